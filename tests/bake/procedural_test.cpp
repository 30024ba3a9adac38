// Procedural meshes: the analytic shapes and the project's own test character must be closed,
// consistently outward-oriented genus-0 surfaces, because every later stage (Voronoi
// skeleton, tangent flow, volume metrics) relies on that.
#include "skelform/bake/procedural.h"

#include "mesh_checks.h"
#include "test_support.h"

#include <glm/gtc/constants.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>

using skelform::bake::CharacterJoint;
using skelform::bake::CharacterOptions;
using skelform::bake::TriangleMesh;
using skelform::bake::Vec3;
using skelform::test::analyze_mesh;
using skelform::test::MeshReport;

namespace {

// The properties every closed genus-0 test mesh must have.
MeshReport check_closed_sphere_like(const TriangleMesh& mesh) {
  const MeshReport r = analyze_mesh(mesh);
  INFO("problems: " << r.manifold_problem);
  CHECK(r.manifold_problem.empty());
  CHECK(r.components == 1);
  CHECK(r.euler == 2);
  CHECK(r.degenerate == 0);
  CHECK(r.volume > 0.0);
  return r;
}

void check_character(const CharacterOptions& options) {
  const TriangleMesh mesh = skelform::bake::make_test_character(options);
  const MeshReport r = check_closed_sphere_like(mesh);
  const auto box = skelform::bake::bounds_of(mesh.positions);
  INFO("bounds " << box.min.x << " " << box.min.y << " " << box.min.z << " .. " << box.max.x << " " << box.max.y << " "
                 << box.max.z);
  const double h = options.height;
  CHECK(std::abs((box.max.y - box.min.y) - h) <= 0.02 * h);
  CHECK(std::abs(box.min.y) <= 0.02 * h);
  // Left/right mirror symmetry of the extents (the mesh itself is only approximately
  // symmetric: the tetrahedral split of the grid is not).
  CHECK(std::abs(box.min.x + box.max.x) <= 0.01 * h);
  // Faces +z: the feet point forward, so the front extends farther than the back.
  CHECK(box.max.z > -box.min.z);
  // The A-pose arms span far wider than the body is deep.
  CHECK(box.max.x - box.min.x > 0.6 * h);
  CHECK(box.max.x - box.min.x < 1.0 * h);

  // A human-sized body: a 1.8 m character of roughly 50 to 100 litres (scales with h^3).
  const double litres_at_reference = 1000.0 * r.volume * std::pow(1.8 / h, 3);
  CHECK(litres_at_reference > 50.0);
  CHECK(litres_at_reference < 100.0);
}

// Number of separate pieces of the mesh's cross-section by the plane y = `y`, counted as
// connected groups of triangles that straddle the plane (a cheap slice).
size_t slice_pieces(const TriangleMesh& mesh, double y) {
  std::vector<uint32_t> parent(mesh.positions.size());
  for (uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::set<uint32_t> used;
  for (const auto& t : mesh.triangles) {
    double lo = 1e300, hi = -1e300;
    for (uint32_t v : t) {
      lo = std::min(lo, mesh.positions[v].y);
      hi = std::max(hi, mesh.positions[v].y);
    }
    if (lo > y || hi < y) continue;
    for (uint32_t v : t) used.insert(v);
    parent[find(t[1])] = find(t[0]);
    parent[find(t[2])] = find(t[0]);
  }
  std::set<uint32_t> roots;
  for (uint32_t v : used) roots.insert(find(v));
  return roots.size();
}

}  // namespace

TEST_CASE("mesh_checks: detects open, flipped and non-manifold meshes") {
  // The checker itself must be able to fail, or every test below proves nothing.
  const TriangleMesh sphere = skelform::bake::make_icosphere(1.0, 1);
  REQUIRE(analyze_mesh(sphere).manifold_problem.empty());

  TriangleMesh open = sphere;
  open.triangles.pop_back();
  CHECK_FALSE(analyze_mesh(open).manifold_problem.empty());

  TriangleMesh flipped = sphere;
  std::swap(flipped.triangles[3][1], flipped.triangles[3][2]);
  CHECK_FALSE(analyze_mesh(flipped).manifold_problem.empty());

  TriangleMesh inside_out = sphere;
  for (auto& t : inside_out.triangles) std::swap(t[1], t[2]);
  CHECK(analyze_mesh(inside_out).manifold_problem.empty());
  CHECK(analyze_mesh(inside_out).volume < 0.0);

  // Two spheres sharing one vertex: every edge is fine, but the shared vertex has two fans.
  TriangleMesh pinched = sphere;
  const uint32_t offset = uint32_t(sphere.positions.size()) - 1;
  for (size_t i = 1; i < sphere.positions.size(); ++i)
    pinched.positions.push_back(sphere.positions[i] - 2.0 * sphere.positions[0]);
  for (auto t : sphere.triangles) {
    for (auto& v : t) v = v == 0 ? 0 : v + offset;
    pinched.triangles.push_back(t);
  }
  const MeshReport r = analyze_mesh(pinched);
  CHECK(r.manifold_problem.find("not one fan") != std::string::npos);

  // Two disjoint spheres: manifold, but two components and Euler characteristic 4.
  TriangleMesh two = sphere;
  const uint32_t n = uint32_t(sphere.positions.size());
  for (const Vec3& p : sphere.positions) two.positions.push_back(p + Vec3{3.0, 0.0, 0.0});
  for (auto t : sphere.triangles) two.triangles.push_back({t[0] + n, t[1] + n, t[2] + n});
  const MeshReport r2 = analyze_mesh(two);
  CHECK(r2.manifold_problem.empty());
  CHECK(r2.components == 2);
  CHECK(r2.euler == 4);

  TriangleMesh degenerate = sphere;
  degenerate.positions[degenerate.triangles[0][1]] = degenerate.positions[degenerate.triangles[0][0]];
  CHECK(analyze_mesh(degenerate).degenerate > 0);
}

TEST_CASE("procedural shapes: closed, outward, genus 0, expected sizes") {
  SUBCASE("icosphere") {
    const size_t expected[] = {12, 42, 162, 642};
    for (int level = 0; level < 4; ++level) {
      CAPTURE(level);
      const TriangleMesh mesh = skelform::bake::make_icosphere(2.0, level);
      CHECK(mesh.positions.size() == expected[level]);
      const MeshReport r = check_closed_sphere_like(mesh);
      CHECK(r.volume < 4.0 / 3.0 * glm::pi<double>() * 8.0);  // inscribed polyhedron
      if (level == 3) CHECK(r.volume > 0.97 * 4.0 / 3.0 * glm::pi<double>() * 8.0);
      for (const Vec3& p : mesh.positions) CHECK(std::abs(glm::length(p) - 2.0) < 1e-12);
    }
  }
  SUBCASE("uv sphere") {
    const TriangleMesh mesh = skelform::bake::make_uv_sphere(1.5, 24, 12);
    CHECK(mesh.positions.size() == size_t(2 + 24 * 11));
    const MeshReport r = check_closed_sphere_like(mesh);
    CHECK(r.volume < 4.0 / 3.0 * glm::pi<double>() * 1.5 * 1.5 * 1.5);
    CHECK(r.volume > 0.95 * 4.0 / 3.0 * glm::pi<double>() * 1.5 * 1.5 * 1.5);
  }
  SUBCASE("capsule") {
    const double radius = 0.5, length = 2.0;
    const TriangleMesh mesh = skelform::bake::make_capsule(radius, length, 16, 4, 5);
    CHECK(mesh.positions.size() == size_t(2 + 16 * (5 + 4 + 5 - 1)));
    const MeshReport r = check_closed_sphere_like(mesh);
    const double exact =
        glm::pi<double>() * radius * radius * length + 4.0 / 3.0 * glm::pi<double>() * radius * radius * radius;
    CHECK(r.volume < exact);
    CHECK(r.volume > 0.9 * exact);
    const auto box = skelform::bake::bounds_of(mesh.positions);
    CHECK(box.min.z == doctest::Approx(-1.5));
    CHECK(box.max.z == doctest::Approx(1.5));
  }
}

TEST_CASE("test character: closed genus-0 single surface at the default options") {
  const CharacterOptions options;
  const auto start = std::chrono::steady_clock::now();
  const TriangleMesh mesh = skelform::bake::make_test_character(options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  MESSAGE("test character: " << mesh.positions.size() << " vertices, " << mesh.triangles.size() << " triangles in "
                             << seconds << " s");
  CHECK(mesh.triangles.size() >= 3000);
  CHECK(mesh.triangles.size() <= 20000);
  check_character(options);

  SUBCASE("deterministic") {
    const TriangleMesh again = skelform::bake::make_test_character(options);
    CHECK(again.positions == mesh.positions);
    CHECK(again.triangles == mesh.triangles);
  }
  SUBCASE("separate limbs: two legs below the crotch, arms apart from the torso") {
    // Legs must not touch (a bridge would make a handle): two pieces at knee height.
    CHECK(slice_pieces(mesh, 0.3 * options.height) == 2);
    // At hip height: torso plus the two arms, not touching it.
    CHECK(slice_pieces(mesh, 0.58 * options.height) == 3);
  }
  SUBCASE("vertices lie on the implicit surface between the capsules and their blend") {
    // Every vertex is within the blend radius outside of, and not inside, the union of
    // the joints' capsules (smooth union only adds volume, at most blend/4).
    const auto joints = skelform::bake::test_character_joints(options);
    const double blend = skelform::bake::test_character_blend_radius(options);
    for (const Vec3& p : mesh.positions) {
      double nearest = 1e300;
      for (const CharacterJoint& j : joints) {
        const Vec3 ab = j.tail - j.head;
        const double t = std::clamp(glm::dot(p - j.head, ab) / glm::dot(ab, ab), 0.0, 1.0);
        // The lerp-radius tube around the segment, which over-estimates the hull's distance
        // near tapered ends by far less than the tolerance used here.
        nearest = std::min(nearest,
                           glm::length(p - (j.head + t * ab)) - (j.head_radius + t * (j.tail_radius - j.head_radius)));
      }
      REQUIRE(nearest > -0.01 * blend);
      REQUIRE(nearest < 0.35 * blend);
    }
  }
}

TEST_CASE("test character: same properties at coarser resolutions and another height") {
  for (double resolution : {0.03, 0.04}) {
    CAPTURE(resolution);
    CharacterOptions options;
    options.resolution = resolution;
    const TriangleMesh mesh = skelform::bake::make_test_character(options);
    CHECK(mesh.triangles.size() >= 1000);
    check_character(options);
  }
  CharacterOptions tall;
  tall.height = 18.0;  // a scaled copy: the resolution is in the same unit as the height
  tall.resolution = 0.25;
  check_character(tall);
}

TEST_CASE("test character: rig description") {
  const CharacterOptions options;
  const auto joints = skelform::bake::test_character_joints(options);
  REQUIRE(joints.size() == 19);
  CHECK(joints[0].name == "pelvis");
  CHECK(joints[0].parent == -1);
  std::set<std::string> names;
  for (size_t i = 0; i < joints.size(); ++i) {
    const CharacterJoint& j = joints[i];
    CAPTURE(j.name);
    names.insert(j.name);
    if (i > 0) {
      CHECK(j.parent >= 0);
      CHECK(j.parent < int(i));  // parents first: a single pass computes world transforms
    }
    CHECK(j.head_radius > 0.0);
    CHECK(j.tail_radius > 0.0);
    CHECK(glm::length(j.tail - j.head) > std::abs(j.head_radius - j.tail_radius));
    CHECK(j.head.y >= 0.0);
    CHECK(j.tail.y <= options.height);
  }
  CHECK(names.size() == joints.size());
  for (const char* name : {"spine", "chest", "neck", "head", "shoulder.L", "upper_arm.L", "lower_arm.L", "hand.L",
                           "upper_leg.L", "lower_leg.L", "foot.L", "shoulder.R", "upper_arm.R", "lower_arm.R", "hand.R",
                           "upper_leg.R", "lower_leg.R", "foot.R"})
    CHECK(names.count(name) == 1);

  auto find = [&](const std::string& name) -> const CharacterJoint& {
    for (const auto& j : joints)
      if (j.name == name) return j;
    FAIL("missing joint " << name);
    return joints.front();
  };
  // Chains: each limb bone is the child of the previous one, and the sides mirror in x.
  CHECK(joints[size_t(find("hand.L").parent)].name == "lower_arm.L");
  CHECK(joints[size_t(find("lower_arm.L").parent)].name == "upper_arm.L");
  CHECK(joints[size_t(find("foot.R").parent)].name == "lower_leg.R");
  CHECK(joints[size_t(find("upper_leg.R").parent)].name == "pelvis");
  CHECK(joints[size_t(find("head").parent)].name == "neck");
  for (const char* part : {"shoulder", "upper_arm", "lower_arm", "hand", "upper_leg", "lower_leg", "foot"}) {
    const CharacterJoint& l = find(std::string(part) + ".L");
    const CharacterJoint& r = find(std::string(part) + ".R");
    CAPTURE(part);
    CHECK(l.head.x > 0.0);  // the character's left is +x when it faces +z
    CHECK(r.head.x == doctest::Approx(-l.head.x));
    CHECK(r.tail.x == doctest::Approx(-l.tail.x));
    CHECK(r.head.y == l.head.y);
    CHECK(r.tail.z == l.tail.z);
  }
  // A-pose: the upper arm points 30 to 45 degrees below the horizontal.
  const CharacterJoint& arm = find("upper_arm.L");
  const Vec3 d = glm::normalize(arm.tail - arm.head);
  const double below = std::asin(-d.y) * 180.0 / glm::pi<double>();
  CHECK(below >= 30.0);
  CHECK(below <= 45.0);

  // Scales with the height.
  CharacterOptions half;
  half.height = 0.9;
  const auto small = skelform::bake::test_character_joints(half);
  CHECK(small[8].tail.x == doctest::Approx(0.5 * joints[8].tail.x));
  CHECK(small[8].tail_radius == doctest::Approx(0.5 * joints[8].tail_radius));
}

TEST_CASE("test character: refuses unusable options") {
  CharacterOptions options;
  options.resolution = 0.0;
  CHECK_THROWS_AS(skelform::bake::make_test_character(options), skelform::bake::Error);
  options.resolution = 0.045;  // coarser than height / 45: the wrists are not resolved
  CHECK_THROWS_AS(skelform::bake::make_test_character(options), skelform::bake::Error);
  options.resolution = 1e-4;  // a grid far too large
  CHECK_THROWS_AS(skelform::bake::make_test_character(options), skelform::bake::Error);
  options = CharacterOptions{};
  options.height = -1.0;
  CHECK_THROWS_AS(skelform::bake::make_test_character(options), skelform::bake::Error);
  CHECK_THROWS_AS(skelform::bake::test_character_joints(options), skelform::bake::Error);
}
