// DSS binding (bake/src/dss.cpp) and its shared evaluation (core/include/skelform/core/dss_frame.h): a
// bumpy dense sphere bound to a subdivided coarse one is reproduced at rest within 1e-5 of
// the diagonal when evaluated the runtime's way, seam copies bind identically, vertices the
// normal field cannot reach still reproduce through the residual, and the frame never
// produces NaN.
#include "skelform/bake/decimate.h"
#include "skelform/bake/dss.h"
#include "skelform/bake/input.h"
#include "skelform/bake/procedural.h"
#include "skelform/bake/subdivision.h"
#include "skelform/bake/weld.h"

#include "skelform/core/dss_frame.h"
#include "open_capsule.h"
#include "test_support.h"

#include <doctest/doctest.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

using namespace skelform::bake;
namespace dss = skelform::dss;

namespace {

// r(θ, φ) = 1 + 0.03 sin(5θ) cos(4φ): small-scale detail DSS must carry as displacement.
Vec3 bumpy(const Vec3& p) {
  const Vec3 u = glm::normalize(p);
  const double theta = std::acos(std::clamp(u.z, -1.0, 1.0)), phi = std::atan2(u.y, u.x);
  return u * (1.0 + 0.03 * std::sin(5.0 * theta) * std::cos(4.0 * phi));
}

std::vector<Vec3> bumpy_positions(const TriangleMesh& mesh) {
  std::vector<Vec3> out;
  for (const Vec3& p : mesh.positions) out.push_back(bumpy(p));
  return out;
}

struct Refined {
  SubdivisionStencils stencils;
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;  // refined_normals: what the binding displaces along
};

Refined refine(const TriangleMesh& control, int level) {
  Refined refined;
  refined.stencils = build_loop_stencils(control, level);
  const std::vector<glm::vec3> positions(control.positions.begin(), control.positions.end());
  refined.positions = apply_stencils(refined.stencils, positions);
  refined.normals = refined_normals(refined.stencils, positions, control.triangles);
  return refined;
}

DssBinding bind(const Refined& refined, const std::vector<Vec3>& dense, double diagonal) {
  return bind_dense_vertices(refined.positions, refined.normals, refined.stencils.refined_triangles, dense, diagonal);
}

// Evaluates a binding as the runtime will, independently of the binder's own report:
// frame, displaced point, all in float.
double rest_error(const Refined& refined, const DssBinding& binding, const std::vector<Vec3>& dense, double diagonal) {
  const std::vector<glm::vec3>& normals = refined.normals;
  double worst = 0.0;
  for (size_t v = 0; v < dense.size(); ++v) {
    const Triangle& t = refined.stencils.refined_triangles.at(binding.triangle[v]);
    const dss::SurfaceFrame frame =
        dss::surface_frame(refined.positions[t[0]], refined.positions[t[1]], refined.positions[t[2]], normals[t[0]],
                           normals[t[1]], normals[t[2]], binding.barycentric[v].x, binding.barycentric[v].y);
    const glm::vec3 evaluated = dss::displaced_point(frame, binding.displacement[v], binding.residual[v]);
    worst = std::max(worst, glm::length(Vec3(evaluated) - dense[v]));
  }
  return worst / diagonal;
}

void check_well_formed(const DssBinding& binding, size_t dense_count, size_t refined_triangles) {
  REQUIRE(binding.triangle.size() == dense_count);
  REQUIRE(binding.barycentric.size() == dense_count);
  REQUIRE(binding.displacement.size() == dense_count);
  REQUIRE(binding.residual.size() == dense_count);
  bool valid = true;
  for (size_t v = 0; v < dense_count; ++v) {
    const glm::vec2 b = binding.barycentric[v];
    valid = valid && binding.triangle[v] < refined_triangles && b.x >= 0.0f && b.y >= 0.0f && b.x + b.y <= 1.0f &&
            std::isfinite(binding.displacement[v]) && std::isfinite(binding.residual[v].x) &&
            std::isfinite(binding.residual[v].y);
  }
  CHECK(valid);
}

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

void check_orthonormal(const dss::SurfaceFrame& f) {
  CHECK(finite(f.point));
  CHECK(std::fabs(glm::length(f.normal) - 1.0f) < 1e-5f);
  CHECK(std::fabs(glm::length(f.tangent) - 1.0f) < 1e-5f);
  CHECK(std::fabs(glm::length(f.bitangent) - 1.0f) < 1e-5f);
  CHECK(std::fabs(glm::dot(f.normal, f.tangent)) < 1e-5f);
  CHECK(std::fabs(glm::dot(f.normal, f.bitangent)) < 1e-5f);
  CHECK(std::fabs(glm::dot(f.tangent, f.bitangent)) < 1e-5f);
  // Right-handed: t × s = n.
  CHECK(glm::length(glm::cross(f.tangent, f.bitangent) - f.normal) < 1e-5f);
}

}  // namespace

TEST_CASE("dss_frame: the frame is orthonormal, the tangent follows p1 − p0, the displaced point is exact") {
  const glm::vec3 p0(0, 0, 0), p1(2, 0, 0), p2(0, 1, 0);
  const glm::vec3 n0 = glm::normalize(glm::vec3(0.1f, 0, 1)), n1(0, 0, 1), n2 = glm::normalize(glm::vec3(0, 0.2f, 1));
  const dss::SurfaceFrame frame = dss::surface_frame(p0, p1, p2, n0, n1, n2, 0.25f, 0.5f);
  check_orthonormal(frame);
  CHECK(glm::length(frame.point - glm::vec3(0.5f, 0.5f, 0.0f)) < 1e-6f);
  // Tangent = normalised in-plane part of ∂q/∂b1 = p1 − p0 = +x.
  CHECK(frame.tangent.x > 0.99f);
  const glm::vec3 expected_normal = glm::normalize(0.25f * n0 + 0.25f * n1 + 0.5f * n2);
  CHECK(glm::length(frame.normal - expected_normal) < 1e-6f);
  const glm::vec3 p = dss::displaced_point(frame, 0.3f, glm::vec2(0.1f, -0.2f));
  const glm::vec3 expected = frame.point + 0.3f * frame.normal + 0.1f * frame.tangent - 0.2f * frame.bitangent;
  CHECK(glm::length(p - expected) < 1e-6f);
}

TEST_CASE("dss_frame: degenerate triangles and zero or cancelling normals give a finite orthonormal frame") {
  const glm::vec3 zero(0.0f), z(0, 0, 1);
  SUBCASE("all corners equal, all normals zero") {
    check_orthonormal(dss::surface_frame(glm::vec3(1), glm::vec3(1), glm::vec3(1), zero, zero, zero, 0.3f, 0.3f));
  }
  SUBCASE("collinear corners, normals zero") {
    check_orthonormal(
        dss::surface_frame(glm::vec3(0), glm::vec3(1, 0, 0), glm::vec3(2, 0, 0), zero, zero, zero, 0.3f, 0.3f));
  }
  SUBCASE("normals cancelling at the point fall back to the face normal") {
    const dss::SurfaceFrame f =
        dss::surface_frame(glm::vec3(0), glm::vec3(1, 0, 0), glm::vec3(0, 1, 0), z, -z, z, 0.5f, 0.0f);
    check_orthonormal(f);
    CHECK(f.normal.z > 0.99f);
  }
  SUBCASE("p1 − p0 along the normal: tangent from p2 − p0") {
    const dss::SurfaceFrame f =
        dss::surface_frame(glm::vec3(0), glm::vec3(0, 0, 1), glm::vec3(1, 0, 0), z, z, z, 0.2f, 0.2f);
    check_orthonormal(f);
    CHECK(f.tangent.x > 0.99f);
  }
  SUBCASE("both edges along the normal: any axis orthogonal to it") {
    const dss::SurfaceFrame f =
        dss::surface_frame(glm::vec3(0), glm::vec3(0, 0, 1), glm::vec3(0, 0, 2), z, z, z, 0.2f, 0.2f);
    check_orthonormal(f);
  }
  SUBCASE("displaced_point stays finite on a degenerate frame") {
    const dss::SurfaceFrame f = dss::surface_frame(zero, zero, zero, zero, zero, zero, 0.0f, 0.0f);
    CHECK(finite(dss::displaced_point(f, 1.0f, glm::vec2(1.0f, 1.0f))));
  }
}

TEST_CASE("dss_frame: vertex_normals are area-weighted unit normals, zero for isolated vertices") {
  // A unit square in z = 0 (two triangles) and an unused vertex.
  const glm::vec3 positions[] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {5, 5, 5}};
  const uint32_t indices[] = {0, 1, 2, 0, 2, 3};
  glm::vec3 normals[5];
  dss::vertex_normals(positions, 5, indices, 2, normals);
  for (int v = 0; v < 4; ++v) CHECK(glm::length(normals[v] - glm::vec3(0, 0, 1)) < 1e-6f);
  CHECK(normals[4] == glm::vec3(0.0f));
  // A big (area 1.5) and a small (area 0.5) triangle folded at 90° around the edge 0-1: the
  // shared normal leans 3:1 toward the bigger one (area weighting, not angle or uniform).
  const glm::vec3 folded[] = {{0, 0, 0}, {1, 0, 0}, {0, 3, 0}, {0, 0, 1}};
  const uint32_t folded_indices[] = {0, 1, 2, 0, 3, 1};
  glm::vec3 folded_normals[4];
  dss::vertex_normals(folded, 4, folded_indices, 2, folded_normals);
  CHECK(glm::length(folded_normals[0] - glm::normalize(glm::vec3(0, 1, 3))) < 1e-6f);
}

TEST_CASE("dss_frame: medial_normal_sums turns each sum halfway onto P - S and keeps its length") {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  // Vertex by vertex: position P, skeletal position S, area-weighted sum A.
  const glm::vec3 positions[] = {{0, 0, 2}, {0, 0, 0},   {1, 0, 0},   {0, 0, 1}, {0, 0, 1},
                                 {0, 0, 1}, {nan, 0, 0}, {0, 0, inf}, {1, 2, 3}};
  const glm::vec3 skeletal[] = {{0, 0, 0}, {-3, 0, 0}, {1, 0, 0}, {0, 0, 0},   {0, 0, 0},
                                {0, 0, 0}, {0, 0, 0},  {0, 0, 0}, {1, 2, 3.5f}};
  glm::vec3 sums[] = {{0, 0, 4},      {0, 0, 2}, {0, 3, 0}, {0, 0, 0},   {0, 0, -5},
                      {1e-31f, 0, 0}, {0, 1, 0}, {0, 1, 0}, {0, 0, 0.5f}};
  const glm::vec3 before[9] = {sums[0], sums[1], sums[2], sums[3], sums[4], sums[5], sums[6], sums[7], sums[8]};
  dss::medial_normal_sums(positions, skeletal, 9, sums);
  // The rest case, A along P − S: the same vector.
  CHECK(glm::length(sums[0] - before[0]) < 1e-6f);
  // P − S along +x, A along +z with length 2: the bisector, at 45°, with A's length.
  CHECK(glm::length(sums[1] - glm::vec3(std::sqrt(2.0f), 0, std::sqrt(2.0f))) < 1e-6f);
  CHECK(std::fabs(glm::length(sums[1]) - 2.0f) < 1e-6f);
  // Left as they are: a zero medial radius (P = S), a zero sum, a sum opposite to P − S (no
  // bisector), a sum below 1e-30, a non-finite position or medial direction.
  for (int v = 2; v < 8; ++v) CHECK(std::memcmp(&sums[v], &before[v], sizeof(glm::vec3)) == 0);
  // A sum pointing into the skeleton (P − S along −z, A along +z): exactly opposite, unchanged.
  CHECK(sums[8] == before[8]);
}

TEST_CASE("DSS binding of a bumpy sphere reproduces every dense vertex at rest within 1e-5 of the diagonal") {
  const TriangleMesh control_sphere = make_icosphere(1.0, 2);  // 320 triangles
  TriangleMesh control = control_sphere;
  control.positions = bumpy_positions(control_sphere);
  TriangleMesh dense = make_icosphere(1.0, 5);  // 20,480 triangles
  dense.positions = bumpy_positions(dense);
  const int level = choose_subdivision_level(control.triangles.size(), dense.triangles.size());
  CHECK(level == 3);
  const Refined refined = refine(control, level);
  const double diagonal = bounds_of(dense.positions).diagonal();
  const DssBinding binding = bind(refined, dense.positions, diagonal);
  check_well_formed(binding, dense.positions.size(), refined.stencils.refined_triangles.size());
  const double error = rest_error(refined, binding, dense.positions, diagonal);
  CHECK(error <= 1e-5);
  CHECK(binding.max_rest_error <= 1e-5);
  // The binder's own report is the same measurement.
  CHECK(std::fabs(binding.max_rest_error - error) <= 1e-9);
  const double share = static_cast<double>(binding.residual_vertices) / static_cast<double>(dense.positions.size());
  MESSAGE("bumpy sphere: rest error " << error << " of the diagonal, " << binding.residual_vertices << " of "
                                      << dense.positions.size() << " vertices (" << 100.0 * share
                                      << " %) need a tangential residual > 1e-3 diag");
  // The normal field reaches a surface this close everywhere: the residual is the exception,
  // and where Newton converged it is rounding noise, not a tangential offset.
  CHECK(share < 0.01);
  size_t not_converged = 0;
  for (const glm::vec2& r : binding.residual)
    if (glm::length(r) > 1e-6 * diagonal) ++not_converged;
  MESSAGE("bumpy sphere: " << not_converged << " vertices with |residual| > 1e-6 diag");
  CHECK(not_converged < dense.positions.size() / 100);
  // Displacements are the bump's size, not the sphere's.
  float max_h = 0.0f;
  for (float h : binding.displacement) max_h = std::max(max_h, std::fabs(h));
  CHECK(max_h < 0.1f);
}

TEST_CASE("DSS binding: split copies of a vertex bind identically, and the others do not change") {
  const TriangleMesh control = make_icosphere(1.0, 1);
  TriangleMesh dense = make_icosphere(1.0, 3);
  dense.positions = bumpy_positions(dense);
  const Refined refined = refine(control, 2);
  const double diagonal = bounds_of(dense.positions).diagonal();
  const DssBinding plain = bind(refined, dense.positions, diagonal);
  // Copies interleaved and appended, as a glTF exporter splits vertices at seams.
  std::vector<Vec3> split = dense.positions;
  std::vector<uint32_t> source(dense.positions.size());
  for (uint32_t v = 0; v < source.size(); ++v) source[v] = v;
  for (uint32_t v = 0; v < dense.positions.size(); v += 7) {
    split.push_back(dense.positions[v]);
    source.push_back(v);
    split.insert(split.begin() + v / 2, dense.positions[v]);
    source.insert(source.begin() + v / 2, v);
  }
  const DssBinding copies = bind(refined, split, diagonal);
  check_well_formed(copies, split.size(), refined.stencils.refined_triangles.size());
  bool identical = true;
  for (size_t v = 0; v < split.size(); ++v) {
    const uint32_t s = source[v];
    identical = identical && copies.triangle[v] == plain.triangle[s] && copies.barycentric[v] == plain.barycentric[s] &&
                copies.displacement[v] == plain.displacement[s] && copies.residual[v] == plain.residual[s];
  }
  CHECK(identical);
  CHECK(copies.max_rest_error == plain.max_rest_error);
}

TEST_CASE("DSS binding: separate components the control mesh lacks still bind and reproduce") {
  const TriangleMesh control = make_icosphere(1.0, 2);
  TriangleMesh dense = make_icosphere(1.0, 4);
  dense.positions = bumpy_positions(dense);
  const size_t body_vertices = dense.positions.size();
  // A small ball floating beside the sphere (an eye, a button), and a tiny one around the
  // sphere's centre, where every normal line of the surface meets (the focal point: Newton's
  // Jacobian is singular there and the binding must fall back to the residual).
  const TriangleMesh ball = make_icosphere(0.1, 2);
  for (const Vec3& p : ball.positions) dense.positions.push_back(p + Vec3(1.6, 0.3, 0.0));
  const TriangleMesh core = make_icosphere(0.01, 1);
  for (const Vec3& p : core.positions) dense.positions.push_back(p);
  dense.positions.push_back(Vec3(0.0));
  const Refined refined = refine(control, 2);
  const double diagonal = bounds_of(dense.positions).diagonal();
  const DssBinding binding = bind(refined, dense.positions, diagonal);
  check_well_formed(binding, dense.positions.size(), refined.stencils.refined_triangles.size());
  const double error = rest_error(refined, binding, dense.positions, diagonal);
  CHECK(error <= 1e-5);
  size_t body_residuals = 0;
  for (size_t v = 0; v < body_vertices; ++v)
    if (glm::length(binding.residual[v]) > 1e-3 * diagonal) ++body_residuals;
  MESSAGE("separate components: rest error " << error << ", residual vertices " << binding.residual_vertices << " ("
                                             << body_residuals << " of " << body_vertices << " on the body, "
                                             << binding.residual_vertices - body_residuals << " of "
                                             << dense.positions.size() - body_vertices << " off it)");
  CHECK(body_residuals < body_vertices / 100);
  // The exact centre is on every normal line at once (h = −1 from anywhere): whatever point
  // the binder keeps, the displacement must carry the whole radius.
  CHECK(std::fabs(std::fabs(binding.displacement.back()) - 0.9f) < 0.1f);
}

TEST_CASE("DSS binding of an open surface: vertices beyond the border clamp to it and reproduce") {
  // A capsule with its top cap removed from the control mesh, bound to the full dense one.
  const double length = 2.0;
  const TriangleMesh full = make_capsule(0.5, length, 24, 8, 6);
  const TriangleMesh open = skelform::test::without_top_cap(full, length);
  const TriangleMesh dense = make_capsule(0.5, length, 64, 24, 16);
  const Refined refined = refine(open, 1);
  const double diagonal = bounds_of(dense.positions).diagonal();
  const DssBinding binding = bind(refined, dense.positions, diagonal);
  check_well_formed(binding, dense.positions.size(), refined.stencils.refined_triangles.size());
  const double error = rest_error(refined, binding, dense.positions, diagonal);
  CHECK(error <= 1e-5);
  CHECK(binding.residual_vertices > 0);  // the cap has nothing under it
  MESSAGE("open capsule: rest error " << error << ", residual vertices " << binding.residual_vertices << " of "
                                      << dense.positions.size());
}

TEST_CASE("DSS binding refuses invalid input with Error") {
  const std::vector<glm::vec3> positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const std::vector<Triangle> triangles = {{0, 1, 2}};
  const std::vector<glm::vec3> normals(3, glm::vec3(0, 0, 1));
  CHECK_THROWS_AS(bind_dense_vertices({}, {}, {}, {Vec3(0)}, 1.0), Error);
  CHECK_THROWS_AS(bind_dense_vertices(positions, normals, {{0, 1, 3}}, {Vec3(0)}, 1.0), Error);
  CHECK_THROWS_AS(bind_dense_vertices(positions, normals, triangles, {Vec3(std::nan(""), 0, 0)}, 1.0), Error);
  CHECK_THROWS_AS(bind_dense_vertices(positions, {glm::vec3(0, 0, 1)}, triangles, {Vec3(0)}, 1.0), Error);
  // No dense vertex: an empty, valid binding.
  const DssBinding empty = bind_dense_vertices(positions, normals, triangles, {}, 1.0);
  CHECK(empty.triangle.empty());
  CHECK(empty.max_rest_error == 0.0);
}

TEST_CASE("DSS binding at level 4 reproduces a dense bumpy sphere at rest") {
  // Speed is measured in bench/ (skelform-bench-bake), not here.
  const TriangleMesh control_sphere = make_icosphere(1.0, 1);
  TriangleMesh dense = make_uv_sphere(1.0, 100, 62);
  TriangleMesh control = control_sphere;
  control.positions = bumpy_positions(control_sphere);
  dense.positions = bumpy_positions(dense);
  const Refined refined = refine(control, 4);
  const double diagonal = bounds_of(dense.positions).diagonal();
  const DssBinding binding = bind(refined, dense.positions, diagonal);
  MESSAGE("rest error " << binding.max_rest_error << ", residual vertices " << binding.residual_vertices);
  CHECK(binding.max_rest_error <= 1e-5);
}

TEST_CASE("DSS binding of CesiumMan's original vertices to its decimated, subdivided control mesh") {
  SKELFORM_REQUIRE_DATA(path, "CesiumMan/CesiumMan.glb");
  InputMesh input;
  try {
    input = load_mesh(path.string());
  } catch (const Error& error) {
    MESSAGE("skipped: CesiumMan does not load yet: " << error.what());
    return;
  }
  const WeldedMesh welded = weld(input);
  const DecimatedMesh control = decimate(welded.mesh, 1200);
  const int level = choose_subdivision_level(control.mesh.triangles.size(), input.triangles.size());
  const Refined refined = refine(control.mesh, level);
  const double diagonal = bounds_of(input.positions).diagonal();
  const DssBinding binding = bind(refined, input.positions, diagonal);
  check_well_formed(binding, input.positions.size(), refined.stencils.refined_triangles.size());
  const double error = rest_error(refined, binding, input.positions, diagonal);
  CHECK(input.positions.size() == 3273);
  CHECK(error <= 1e-5);
  MESSAGE("CesiumMan: " << input.positions.size() << " original vertices, control " << control.mesh.triangles.size()
                        << " triangles, level " << level << " (" << refined.stencils.refined_triangles.size()
                        << " refined), rest error " << error << ", residual vertices " << binding.residual_vertices
                        << " (" << 100.0 * binding.residual_vertices / input.positions.size() << " %)");
}
