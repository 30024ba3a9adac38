// Loop subdivision stencils (bake/src/subdivision.cpp): counts, partition of unity, the Loop
// rules themselves (against an independent reference implementation), open and
// non-manifold control meshes, and the level choice.
#include "skelform/bake/procedural.h"
#include "skelform/bake/subdivision.h"
#include "skelform/core/dss_frame.h"
#include "open_capsule.h"

#include <doctest/doctest.h>

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

using namespace skelform::bake;

namespace {

std::vector<glm::vec3> to_float(const std::vector<Vec3>& positions) {
  return std::vector<glm::vec3>(positions.begin(), positions.end());
}

// One step of Loop subdivision of a closed manifold triangle mesh, written from Loop's
// 1987 thesis independently of OpenSubdiv: vertex points (1 − nβ)v + βΣ neighbours with
// β = (1/n)(5/8 − (3/8 + 1/4 cos(2π/n))²), edge points 3/8 (a + b) + 1/8 (c + d). The
// first vertices of the result are the vertex points, in the input's order.
TriangleMesh reference_loop_step(const TriangleMesh& mesh) {
  const size_t n = mesh.positions.size();
  std::vector<std::vector<uint32_t>> neighbours(n);
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> edge_opposite;  // edge -> opposite corners
  for (const Triangle& t : mesh.triangles)
    for (int i = 0; i < 3; ++i) {
      const uint32_t a = t[i], b = t[(i + 1) % 3], c = t[(i + 2) % 3];
      edge_opposite[{std::min(a, b), std::max(a, b)}].push_back(c);
      neighbours[a].push_back(b);
    }
  TriangleMesh out;
  out.positions.resize(n);
  for (size_t v = 0; v < n; ++v) {
    const double valence = static_cast<double>(neighbours[v].size());
    const double inner = 3.0 / 8.0 + 0.25 * std::cos(2.0 * glm::pi<double>() / valence);
    const double beta = (5.0 / 8.0 - inner * inner) / valence;
    Vec3 sum(0.0);
    for (uint32_t w : neighbours[v]) sum += mesh.positions[w];
    out.positions[v] = (1.0 - valence * beta) * mesh.positions[v] + beta * sum;
  }
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> edge_vertex;
  for (const auto& [edge, opposite] : edge_opposite) {
    REQUIRE(opposite.size() == 2);  // closed manifold input only
    edge_vertex[edge] = static_cast<uint32_t>(out.positions.size());
    out.positions.push_back(0.375 * (mesh.positions[edge.first] + mesh.positions[edge.second]) +
                            0.125 * (mesh.positions[opposite[0]] + mesh.positions[opposite[1]]));
  }
  for (const Triangle& t : mesh.triangles) {
    uint32_t e[3];
    for (int i = 0; i < 3; ++i) e[i] = edge_vertex[{std::min(t[i], t[(i + 1) % 3]), std::max(t[i], t[(i + 1) % 3])}];
    out.triangles.push_back({t[0], e[0], e[2]});
    out.triangles.push_back({t[1], e[1], e[0]});
    out.triangles.push_back({t[2], e[2], e[1]});
    out.triangles.push_back({e[0], e[1], e[2]});
  }
  return out;
}

double max_stencil_sum_error(const SubdivisionStencils& stencils) {
  double worst = 0.0;
  for (size_t v = 0; v < stencils.refined_vertex_count(); ++v) {
    double sum = 0.0;
    for (uint32_t s = stencils.offsets[v]; s < stencils.offsets[v + 1]; ++s) sum += stencils.weights[s];
    worst = std::max(worst, std::fabs(sum - 1.0));
  }
  return worst;
}

// Structural validity every stencil table must have, whatever the input.
void check_well_formed(const SubdivisionStencils& stencils, size_t control_vertices) {
  REQUIRE(stencils.offsets.size() >= 2);
  CHECK(stencils.offsets.front() == 0);
  CHECK(stencils.offsets.back() == stencils.indices.size());
  CHECK(stencils.indices.size() == stencils.weights.size());
  CHECK(stencils.control_vertex_count == control_vertices);
  CHECK(std::is_sorted(stencils.offsets.begin(), stencils.offsets.end()));
  CHECK(
      std::all_of(stencils.indices.begin(), stencils.indices.end(), [&](uint32_t i) { return i < control_vertices; }));
  CHECK(std::all_of(stencils.refined_triangles.begin(), stencils.refined_triangles.end(), [&](const Triangle& t) {
    return t[0] < stencils.refined_vertex_count() && t[1] < stencils.refined_vertex_count() &&
           t[2] < stencils.refined_vertex_count();
  }));
  CHECK(std::all_of(stencils.weights.begin(), stencils.weights.end(), [](float w) { return std::isfinite(w); }));
}

double signed_volume(const std::vector<glm::vec3>& positions, const std::vector<Triangle>& triangles) {
  double six_volume = 0.0;
  for (const Triangle& t : triangles)
    six_volume += glm::dot(Vec3(positions[t[0]]), glm::cross(Vec3(positions[t[1]]), Vec3(positions[t[2]])));
  return six_volume / 6.0;
}

}  // namespace

TEST_CASE("Loop stencils of the icosahedron: level 3 has 642 vertices and 1280 triangles, each stencil sums to 1") {
  const TriangleMesh icosahedron = make_icosphere(1.0, 0);
  REQUIRE(icosahedron.positions.size() == 12);
  const SubdivisionStencils stencils = build_loop_stencils(icosahedron, 3);
  check_well_formed(stencils, 12);
  CHECK(stencils.level == 3);
  CHECK(stencils.refined_vertex_count() == 642);
  CHECK(stencils.refined_triangles.size() == 1280);
  CHECK(max_stencil_sum_error(stencils) <= 1e-5);
  // Loop's weights are non-negative for valence 5 and 6: the surface is a convex
  // combination of control points, so it lies inside their convex hull, within radius 1,
  // and (the sphere being approximated, not interpolated) clearly inside it.
  CHECK(*std::min_element(stencils.weights.begin(), stencils.weights.end()) >= 0.0f);
  const std::vector<glm::vec3> refined = apply_stencils(stencils, to_float(icosahedron.positions));
  double max_radius = 0.0, min_radius = 2.0;
  for (const glm::vec3& p : refined) {
    max_radius = std::max(max_radius, static_cast<double>(glm::length(p)));
    min_radius = std::min(min_radius, static_cast<double>(glm::length(p)));
  }
  CHECK(max_radius < 1.0);
  CHECK(min_radius > 0.7);
  // Parents' orientation is kept: outward triangles enclose a positive volume.
  CHECK(signed_volume(refined, stencils.refined_triangles) > 0.0);
}

TEST_CASE("Loop stencils reproduce an independent Loop implementation at levels 1 and 3") {
  const TriangleMesh icosahedron = make_icosphere(1.0, 0);
  for (int level : {1, 3}) {
    CAPTURE(level);
    TriangleMesh reference = icosahedron;
    for (int i = 0; i < level; ++i) reference = reference_loop_step(reference);
    const SubdivisionStencils stencils = build_loop_stencils(icosahedron, level);
    const std::vector<glm::vec3> refined = apply_stencils(stencils, to_float(icosahedron.positions));
    REQUIRE(refined.size() == reference.positions.size());
    // The control vertices' descendants: vertex 0 at level 1 is (1 − 5β)v0 + βΣ neighbours
    // (valence 5), and so on down the levels. OpenSubdiv numbers them first, as the
    // reference does.
    double vertex_rule_error = 0.0;
    for (size_t v = 0; v < icosahedron.positions.size(); ++v)
      vertex_rule_error = std::max(vertex_rule_error, glm::length(Vec3(refined[v]) - reference.positions[v]));
    CHECK(vertex_rule_error < 1e-6);
    // Every refined point (edge points included) is a reference point, whatever the order.
    double set_error = 0.0;
    for (const glm::vec3& p : refined) {
      double nearest = 1e300;
      for (const Vec3& r : reference.positions) nearest = std::min(nearest, glm::length(Vec3(p) - r));
      set_error = std::max(set_error, nearest);
    }
    CHECK(set_error < 1e-6);
  }
}

TEST_CASE("Loop stencils at level 0 are the identity on the control mesh") {
  const TriangleMesh icosahedron = make_icosphere(1.0, 0);
  const SubdivisionStencils stencils = build_loop_stencils(icosahedron, 0);
  check_well_formed(stencils, 12);
  CHECK(stencils.refined_vertex_count() == 12);
  CHECK(stencils.refined_triangles == icosahedron.triangles);
  const std::vector<glm::vec3> control = to_float(icosahedron.positions);
  CHECK(apply_stencils(stencils, control) == control);
}

TEST_CASE("Loop stencils of an open capsule keep the open rim on its plane (boundary curve rule)") {
  const double length = 2.0;
  const TriangleMesh capsule = make_capsule(0.5, length, 12, 4, 4);
  // The rim is the cylinder's top loop at z = L/2.
  const TriangleMesh open = skelform::test::without_top_cap(capsule, length);
  REQUIRE(open.triangles.size() < capsule.triangles.size());
  // Unreferenced cap vertices stay in the vertex list: they must not disturb anything.
  const SubdivisionStencils stencils = build_loop_stencils(open, 2);
  check_well_formed(stencils, open.positions.size());
  CHECK(max_stencil_sum_error(stencils) <= 1e-5);
  CHECK(stencils.refined_triangles.size() == open.triangles.size() * 16);
  const std::vector<glm::vec3> refined = apply_stencils(stencils, to_float(open.positions));
  // Border edges of the refined mesh: used by exactly one refined triangle.
  std::map<std::pair<uint32_t, uint32_t>, int> edge_use;
  for (const Triangle& t : stencils.refined_triangles)
    for (int i = 0; i < 3; ++i) ++edge_use[{std::min(t[i], t[(i + 1) % 3]), std::max(t[i], t[(i + 1) % 3])}];
  size_t border_edges = 0;
  double rim_off_plane = 0.0;
  for (const auto& [edge, uses] : edge_use) {
    if (uses != 1) continue;
    ++border_edges;
    for (uint32_t v : {edge.first, edge.second})
      rim_off_plane = std::max(rim_off_plane, std::fabs(static_cast<double>(refined[v].z) - length / 2));
  }
  CHECK(border_edges == 12 * 4);  // 12 rim edges, each split twice
  CHECK(rim_off_plane < 1e-5);
}

TEST_CASE("Loop stencils of non-manifold control meshes either work or throw Error, never crash") {
  // Three triangles around one edge (a "book"), plus a bowtie vertex shared by two fans.
  TriangleMesh book;
  book.positions = {Vec3(0, 0, 0),   Vec3(1, 0, 0), Vec3(0.5, 1, 0), Vec3(0.5, -1, 0),
                    Vec3(0.5, 0, 1), Vec3(2, 1, 0), Vec3(2, -1, 0)};
  book.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}, {1, 5, 6}};
  TriangleMesh tetra_pair = make_icosphere(1.0, 0);
  // Glue a second icosahedron at vertex 0 of the first one (non-manifold vertex).
  const TriangleMesh second = make_icosphere(1.0, 0);
  const uint32_t base = static_cast<uint32_t>(tetra_pair.positions.size());
  for (size_t v = 1; v < second.positions.size(); ++v)
    tetra_pair.positions.push_back(second.positions[v] + 2.0 * second.positions[0]);
  for (Triangle t : second.triangles) {
    for (uint32_t& v : t) v = v == 0 ? 0 : base + v - 1;
    tetra_pair.triangles.push_back(t);
  }
  for (const TriangleMesh* mesh : {&book, &tetra_pair}) {
    for (int level : {1, 3}) {
      try {
        const SubdivisionStencils stencils = build_loop_stencils(*mesh, level);
        check_well_formed(stencils, mesh->positions.size());
        CHECK(max_stencil_sum_error(stencils) <= 1e-5);
        const std::vector<glm::vec3> refined = apply_stencils(stencils, to_float(mesh->positions));
        CHECK(std::all_of(refined.begin(), refined.end(), [](const glm::vec3& p) {
          return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
        }));
      } catch (const Error& error) {
        MESSAGE("non-manifold control mesh refused: " << error.what());
      }
    }
  }
}

TEST_CASE("Loop stencils refuse invalid input with Error") {
  const TriangleMesh icosahedron = make_icosphere(1.0, 0);
  CHECK_THROWS_AS(build_loop_stencils(TriangleMesh{}, 1), Error);
  CHECK_THROWS_AS(build_loop_stencils(icosahedron, -1), Error);
  CHECK_THROWS_AS(build_loop_stencils(icosahedron, 9), Error);
  TriangleMesh bad_index = icosahedron;
  bad_index.triangles[3][1] = 12;
  CHECK_THROWS_AS(build_loop_stencils(bad_index, 1), Error);
  TriangleMesh only_degenerate;
  only_degenerate.positions = {Vec3(0), Vec3(1, 0, 0)};
  only_degenerate.triangles = {{0, 1, 1}};
  CHECK_THROWS_AS(build_loop_stencils(only_degenerate, 1), Error);
  // A degenerate face among good ones is skipped, not an error.
  TriangleMesh with_degenerate = icosahedron;
  with_degenerate.triangles.push_back({0, 0, 1});
  CHECK(build_loop_stencils(with_degenerate, 1).refined_triangles.size() == 80);
  const SubdivisionStencils stencils = build_loop_stencils(icosahedron, 1);
  CHECK_THROWS_AS(apply_stencils(stencils, std::vector<glm::vec3>(11)), Error);
}

TEST_CASE("choose_subdivision_level picks the level whose triangle count is closest in log scale") {
  CHECK(choose_subdivision_level(4000, 16000) == 1);
  CHECK(choose_subdivision_level(4000, 4000) == 0);
  CHECK(choose_subdivision_level(4000, 100000) == 2);  // 64K is closer than 256K in log scale
  CHECK(choose_subdivision_level(4000, 3000) == 0);
  CHECK(choose_subdivision_level(4000, 8000) == 0);      // a tie goes to the cheaper level
  CHECK(choose_subdivision_level(100, 100000000) == 4);  // capped
  CHECK(choose_subdivision_level(0, 1000) == 0);
  CHECK(choose_subdivision_level(1000, 0) == 0);
}

TEST_CASE("refined_normals: the control mesh's normal sums refined by the stencils, unit; level 0 is vertex_normals") {
  const TriangleMesh icosahedron = make_icosphere(1.0, 0);
  const std::vector<glm::vec3> control = to_float(icosahedron.positions);
  // On a regular icosahedron centred at the origin every control vertex's area-weighted normal
  // sum is radial and of the same length, c·p: the stencils then combine the sums exactly as
  // they combine the positions, and every refined normal points along its refined position
  // (to float rounding of the sums and the stencils). The refined triangles' own normals
  // (the extension's version 1 rule) are off by 1.3° at level 2.
  for (int level : {1, 2, 3}) {
    CAPTURE(level);
    const SubdivisionStencils stencils = build_loop_stencils(icosahedron, level);
    const std::vector<glm::vec3> refined = apply_stencils(stencils, control);
    const std::vector<glm::vec3> normals = refined_normals(stencils, control, icosahedron.triangles);
    REQUIRE(normals.size() == refined.size());
    double worst_angle = 0.0, worst_length = 0.0;
    for (size_t v = 0; v < refined.size(); ++v) {
      const double cosine =
          glm::dot(glm::normalize(Vec3(refined[v])), Vec3(normals[v])) / glm::length(Vec3(normals[v]));
      worst_angle = std::max(worst_angle, std::acos(std::min(1.0, cosine)) * 180.0 / glm::pi<double>());
      worst_length = std::max(worst_length, std::fabs(glm::length(Vec3(normals[v])) - 1.0));
    }
    CHECK(worst_angle < 0.1);
    CHECK(worst_length < 1e-6);
  }
  // Level 0: the identity stencils give the control mesh's unit area-weighted normals, bit for bit.
  const TriangleMesh capsule = make_capsule(0.5, 2.0, 12, 4, 4);
  const std::vector<glm::vec3> capsule_control = to_float(capsule.positions);
  std::vector<uint32_t> indices;
  for (const Triangle& t : capsule.triangles) indices.insert(indices.end(), t.begin(), t.end());
  std::vector<glm::vec3> expected(capsule_control.size());
  skelform::dss::vertex_normals(capsule_control.data(), expected.size(), indices.data(), capsule.triangles.size(),
                                expected.data());
  CHECK(refined_normals(build_loop_stencils(capsule, 0), capsule_control, capsule.triangles) == expected);
  // Input that does not match the stencils is refused.
  const SubdivisionStencils stencils = build_loop_stencils(icosahedron, 1);
  CHECK_THROWS_AS(refined_normals(stencils, std::vector<glm::vec3>(11), {}), Error);
  std::vector<Triangle> bad = icosahedron.triangles;
  bad[0][2] = 12;
  CHECK_THROWS_AS(refined_normals(stencils, control, bad), Error);
}
