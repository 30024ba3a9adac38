// Checks bake/src/skeleton.cpp on shapes whose medial axis is known (paper section 2,
// DESIGN.md bake step 5): a capsule's is its axis segment, a sphere's its centre.
#include "skelform/bake/metrics.h"
#include "skelform/bake/procedural.h"
#include "skelform/bake/skeleton.h"
#include "skelform/bake/tangent_flow.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

using namespace skelform::bake;

namespace {

bool finite(const Vec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// The paper's eq. (1), M = S + d·N, at every vertex, relative to the bounding-box diagonal;
// plus the invariants every skeletal mesh has (sizes, unit normals, d >= 0, no NaN).
void check_skeleton_invariants(const TriangleMesh& mesh, const SkeletalMesh& skeleton) {
  const size_t n = mesh.positions.size();
  REQUIRE(skeleton.skeletal_positions.size() == n);
  REQUIRE(skeleton.medial_radius.size() == n);
  REQUIRE(skeleton.normals.size() == n);
  REQUIRE(skeleton.voronoi_vertex_count.size() == n);
  const double diagonal = bounds_of(mesh.positions).diagonal();
  double worst_reconstruction = 0.0;
  size_t without_candidates = 0, bad = 0;
  for (size_t v = 0; v < n; ++v) {
    const Vec3 rebuilt = skeleton.skeletal_positions[v] + skeleton.medial_radius[v] * skeleton.normals[v];
    worst_reconstruction = std::max(worst_reconstruction, glm::length(rebuilt - mesh.positions[v]) / diagonal);
    if (!finite(skeleton.skeletal_positions[v]) || !std::isfinite(skeleton.medial_radius[v]) ||
        skeleton.medial_radius[v] < 0.0)
      ++bad;
    // Unit, or zero for a vertex without a non-degenerate incident triangle (then S = M).
    const double normal_length = glm::length(skeleton.normals[v]);
    if (std::abs(normal_length - 1.0) > 1e-12 &&
        !(normal_length == 0.0 && skeleton.skeletal_positions[v] == mesh.positions[v]))
      ++bad;
    if (skeleton.voronoi_vertex_count[v] == 0) ++without_candidates;
  }
  CHECK(worst_reconstruction <= 1e-6);
  CHECK(bad == 0);
  CHECK(without_candidates == skeleton.vertices_without_candidates);
  for (const Vec3& v : skeleton.kept_voronoi_vertices) CHECK(finite(v));
}

void check_capsule(bool with_tangent_flow) {
  const double radius = 1.0, length = 6.0;
  TriangleMesh capsule = make_capsule(radius, length, 32, 24, 8);
  if (with_tangent_flow) apply_tangent_flow(capsule);
  const SkeletalMesh skeleton = extract_skeleton(capsule);
  check_skeleton_invariants(capsule, skeleton);

  double worst_axis_distance = 0.0, worst_radius_error = 0.0;
  size_t cylinder_vertices = 0;
  for (size_t v = 0; v < capsule.positions.size(); ++v) {
    if (std::abs(capsule.positions[v].z) > length / 2) continue;  // caps
    ++cylinder_vertices;
    const Vec3& s = skeleton.skeletal_positions[v];
    worst_axis_distance = std::max(worst_axis_distance, std::hypot(s.x, s.y));
    worst_radius_error = std::max(worst_radius_error, std::abs(skeleton.medial_radius[v] - radius));
  }
  MESSAGE("capsule" << std::string(with_tangent_flow ? " after tangent flow" : "") << ": " << cylinder_vertices
                    << " cylinder vertices, max distance of S to the axis " << worst_axis_distance << ", max |d - r| "
                    << worst_radius_error << ", without candidates " << skeleton.vertices_without_candidates);
  CHECK(cylinder_vertices > 500);
  CHECK(worst_axis_distance <= 0.15 * radius);
  CHECK(worst_radius_error <= 0.15 * radius);
  // Every skeletal vertex, caps included, is inside the capsule.
  CHECK(inside_fraction(capsule, skeleton.skeletal_positions) == 1.0);
}

void check_sphere(TriangleMesh sphere, double radius, const std::string& name, bool with_tangent_flow) {
  if (with_tangent_flow) apply_tangent_flow(sphere);
  const SkeletalMesh skeleton = extract_skeleton(sphere);
  check_skeleton_invariants(sphere, skeleton);
  double worst_centre_distance = 0.0;
  for (const Vec3& s : skeleton.skeletal_positions)
    worst_centre_distance = std::max(worst_centre_distance, glm::length(s));
  MESSAGE(name << std::string(with_tangent_flow ? " after tangent flow" : "") << ": max distance of S to the centre "
               << worst_centre_distance << " (R = " << radius << "), without candidates "
               << skeleton.vertices_without_candidates);
  CHECK(worst_centre_distance <= 0.3 * radius);
}

}  // namespace

TEST_CASE("skeleton: fewer than 4 distinct vertices or coplanar input is invalid input") {
  TriangleMesh triangle;
  triangle.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  triangle.triangles = {{0, 1, 2}};
  CHECK_THROWS_AS(extract_skeleton(triangle), Error);
  // Four vertices, but two coincide.
  triangle.positions.push_back({1, 0, 0});
  CHECK_THROWS_AS(extract_skeleton(triangle), Error);

  TriangleMesh grid;  // a flat 5x5 grid
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) grid.positions.push_back({i * 1.0, j * 1.0, 0.0});
  for (uint32_t i = 0; i < 4; ++i)
    for (uint32_t j = 0; j < 4; ++j) {
      const uint32_t a = i * 5 + j;
      grid.triangles.push_back({a, a + 5, a + 6});
      grid.triangles.push_back({a, a + 6, a + 1});
    }
  try {
    extract_skeleton(grid);
    FAIL("coplanar input was accepted");
  } catch (const Error& error) {
    CHECK(error.kind() == ErrorKind::invalid_input);
  }

  TriangleMesh with_nan = make_icosphere(1.0, 1);
  with_nan.positions[3].y = std::nan("");
  CHECK_THROWS_AS(extract_skeleton(with_nan), Error);
}

TEST_CASE("skeleton: a capsule's skeletal vertices lie on its axis with d = r (without tangent flow)") {
  check_capsule(false);
}

TEST_CASE("skeleton: a capsule's skeletal vertices lie on its axis with d = r (after the tangent flow)") {
  check_capsule(true);
}

TEST_CASE("skeleton: cospherical input (UV sphere, icosphere) gives the centre") {
  for (bool flow : {false, true}) {
    check_sphere(make_uv_sphere(2.0, 32, 16), 2.0, "UV sphere", flow);
    check_sphere(make_icosphere(2.0, 3), 2.0, "icosphere", flow);
  }
}

TEST_CASE("skeleton: a scaled and translated shape gives the scaled and translated skeleton") {
  const TriangleMesh capsule = make_capsule(1.0, 3.0, 24, 10, 6);
  TriangleMesh moved = capsule;
  const Vec3 offset(100.0, -50.0, 20.0);
  for (Vec3& p : moved.positions) p = 3.0 * p + offset;
  const SkeletalMesh reference = extract_skeleton(capsule);
  const SkeletalMesh transformed = extract_skeleton(moved);
  double worst = 0.0;
  for (size_t v = 0; v < capsule.positions.size(); ++v) {
    worst = std::max(worst,
                     glm::length(transformed.skeletal_positions[v] - (3.0 * reference.skeletal_positions[v] + offset)));
    CHECK(transformed.medial_radius[v] == doctest::Approx(3.0 * reference.medial_radius[v]).epsilon(1e-6));
  }
  CHECK(worst < 1e-6 * 3.0 * bounds_of(capsule.positions).diagonal());
}

TEST_CASE("skeleton: duplicate vertices, degenerate triangles and an isolated vertex are handled") {
  TriangleMesh mesh = make_capsule(1.0, 4.0, 24, 12, 6);
  // A coincident copy of vertex 40 (on the cylinder) that takes over one of its triangles:
  // Qhull sees one point, both mesh vertices must get its Voronoi vertices.
  const uint32_t original = 40;
  const uint32_t copy = static_cast<uint32_t>(mesh.positions.size());
  mesh.positions.push_back(mesh.positions[original]);
  for (Triangle& t : mesh.triangles) {
    auto corner = std::find(t.begin(), t.end(), original);
    if (corner != t.end()) {
      *corner = copy;
      break;
    }
  }
  mesh.triangles.push_back({0, 0, 1});        // degenerate
  mesh.positions.push_back({3.0, 0.0, 0.0});  // isolated, outside: no normal
  const SkeletalMesh skeleton = extract_skeleton(mesh);
  check_skeleton_invariants(mesh, skeleton);
  CHECK(skeleton.voronoi_vertex_count[copy] > 0);
  // The copy's normal is one face's, a few degrees off the radial direction: its skeletal
  // vertex is still near the axis, like the original's.
  const Vec3& s_copy = skeleton.skeletal_positions[copy];
  CHECK(std::hypot(s_copy.x, s_copy.y) < 0.15);
  CHECK(skeleton.medial_radius[copy] == doctest::Approx(skeleton.medial_radius[original]).epsilon(0.15));
  CHECK(skeleton.skeletal_positions.back() == mesh.positions.back());  // no normal: S = M
  CHECK(skeleton.voronoi_vertex_count.back() == 0);
}

TEST_CASE("skeleton: a vertex no triangle uses does not change the skeleton of the others") {
  const TriangleMesh capsule = make_capsule(1.0, 4.0, 24, 12, 6);
  TriangleMesh with_stray = capsule;
  with_stray.positions.push_back({0.2, 0.1, 0.3});  // inside, where it would carve Voronoi cells
  const SkeletalMesh reference = extract_skeleton(capsule);
  const SkeletalMesh skeleton = extract_skeleton(with_stray);
  for (size_t v = 0; v < capsule.positions.size(); ++v) {
    CHECK(skeleton.skeletal_positions[v] == reference.skeletal_positions[v]);
    CHECK(skeleton.medial_radius[v] == reference.medial_radius[v]);
  }
  CHECK(skeleton.skeletal_positions.back() == with_stray.positions.back());
}

TEST_CASE("skeleton: vertices without candidates get d from their neighbours; a component without any keeps d = 0") {
  // The dome z > 0.4 of a jittered sphere, cut off from the rest: the bounding box
  // (margin 0) excludes the region around the sphere's centre, so only some vertices keep
  // inner Voronoi vertices (those of thin cells near the surface) and the others are filled.
  TriangleMesh sphere = make_icosphere(1.0, 3);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-0.02, 0.02);
  for (Vec3& p : sphere.positions) p = glm::normalize(p + Vec3(jitter(rng), jitter(rng), jitter(rng)));
  TriangleMesh dome;
  std::vector<int> new_index(sphere.positions.size(), -1);
  for (Triangle t : sphere.triangles) {
    if (!(sphere.positions[t[0]].z > 0.4 && sphere.positions[t[1]].z > 0.4 && sphere.positions[t[2]].z > 0.4)) continue;
    for (uint32_t& corner : t) {
      if (new_index[corner] < 0) {
        new_index[corner] = static_cast<int>(dome.positions.size());
        dome.positions.push_back(sphere.positions[corner]);
      }
      corner = static_cast<uint32_t>(new_index[corner]);
    }
    dome.triangles.push_back(t);
  }
  // A second component whose normals cancel exactly (a triangle and its reverse): it has
  // no inner side, so no candidate anywhere in it.
  const uint32_t first_flat = static_cast<uint32_t>(dome.positions.size());
  dome.positions.insert(dome.positions.end(), {{0.0, 0.0, 0.6}, {0.1, 0.0, 0.6}, {0.0, 0.1, 0.6}});
  dome.triangles.push_back({first_flat, first_flat + 1, first_flat + 2});
  dome.triangles.push_back({first_flat, first_flat + 2, first_flat + 1});

  SkeletonOptions no_margin;
  no_margin.bounding_box_margin = 0.0;
  const SkeletalMesh skeleton = extract_skeleton(dome, no_margin);
  check_skeleton_invariants(dome, skeleton);
  double measured_min = 1e300, measured_max = -1e300;
  size_t measured = 0;
  for (uint32_t v = 0; v < first_flat; ++v) {
    if (skeleton.voronoi_vertex_count[v] == 0) continue;
    ++measured;
    measured_min = std::min(measured_min, skeleton.medial_radius[v]);
    measured_max = std::max(measured_max, skeleton.medial_radius[v]);
  }
  const size_t filled = first_flat - measured;
  MESSAGE("dome: " << measured << " vertices measured, " << filled << " filled from neighbours");
  REQUIRE(measured > 0);
  REQUIRE(filled > 0);
  // A mean of means stays within the range of the measured values, and is positive.
  for (uint32_t v = 0; v < first_flat; ++v) {
    if (skeleton.voronoi_vertex_count[v] > 0) continue;
    CHECK(skeleton.medial_radius[v] >= measured_min);
    CHECK(skeleton.medial_radius[v] <= measured_max);
  }
  for (uint32_t v = first_flat; v < first_flat + 3; ++v) {
    CHECK(skeleton.voronoi_vertex_count[v] == 0);
    CHECK(skeleton.medial_radius[v] == 0.0);
    CHECK(skeleton.skeletal_positions[v] == dome.positions[v]);
  }
  CHECK(skeleton.vertices_without_candidates == filled + 3);
}
