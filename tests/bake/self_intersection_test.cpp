// Checks bake/src/self_intersection.cpp: the narrow phase on analytic cases, the count on
// closed and folded meshes, and the grid broad phase against brute force.
#include "skelform/bake/self_intersection.h"
#include "brute_force_pairs.h"
#include "skelform/bake/procedural.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

#include <chrono>
#include <cmath>
#include <random>

using namespace skelform::bake;

namespace {

size_t brute_force_count(const TriangleMesh& mesh) {
  return skelform::test::brute_force_pairs(mesh.triangles, [&](uint32_t v) { return mesh.positions[v]; }).size();
}

}  // namespace

TEST_CASE("self_intersection: the triangle test on crossing / separate / touching and coplanar pairs") {
  // Two triangles piercing each other (one in z = 0, one in x = 0.2 crossing it).
  CHECK(triangles_intersect({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.2, -1}, {0.2, 0.2, 1}, {0.2, -1, 0}));
  // The same pair with the second moved off to x = 2: disjoint.
  CHECK_FALSE(triangles_intersect({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0.2, -1}, {2, 0.2, 1}, {2, -1, 0}));
  // Parallel planes.
  CHECK_FALSE(triangles_intersect({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1e-9}, {1, 0, 1e-9}, {0, 1, 1e-9}));
  // Coplanar overlap and coplanar disjoint (only the in-plane edge normals separate these).
  CHECK(triangles_intersect({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.2, 0}, {1.2, 0.2, 0}, {0.2, 1.2, 0}));
  CHECK_FALSE(triangles_intersect({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.6, 0.6, 0}, {1.6, 0.6, 0}, {0.6, 1.6, 0}));
  // Edge-edge crossing without any vertex inside the other triangle (needs the cross axes).
  CHECK(triangles_intersect({-1, 0, 0}, {1, 0, 0}, {0, 0, 1}, {0, -1, 0.5}, {0, 1, 0.5}, {0, 0, -1}));
  // Each crosses the other's plane, yet they miss: at x = 0.8 the first spans z ∈ [0, 0.2], the
  // second z ∈ [0.3, 1.8]; moved to x = 0 they meet.
  CHECK_FALSE(triangles_intersect({-1, 0, 0}, {1, 0, 0}, {0, 0, 1}, {0.8, -1, 1.8}, {0.8, 1, 1.8}, {0.8, 0, 0.3}));
  CHECK(triangles_intersect({-1, 0, 0}, {1, 0, 0}, {0, 0, 1}, {0, -1, 1.8}, {0, 1, 1.8}, {0, 0, 0.3}));
}

TEST_CASE("self_intersection: two separate crossing triangles count 1 / moved apart 0") {
  TriangleMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.2, -1}, {0.2, 0.2, 1}, {0.2, -1, 0}};
  mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
  CHECK(count_self_intersections(mesh) == 1);
  for (int i = 3; i < 6; ++i) mesh.positions[i].x += 2.0;
  CHECK(count_self_intersections(mesh) == 0);
}

TEST_CASE("self_intersection: adjacent triangles are never counted / even folded onto each other") {
  // Two triangles sharing an edge, the second folded flat onto the first (coplanar overlap),
  // and a third sharing only a vertex, crossing the first.
  TriangleMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5, 0.5, 0}, {0.3, 0.3, -1}, {0.3, 0.3, 1}};
  mesh.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 4, 5}};
  CHECK(count_self_intersections(mesh) == 0);
  // The same third triangle detached from vertex 0 (own copy of it) is counted against both.
  mesh.positions.push_back({0, 0, 0});
  mesh.triangles[2] = {6, 4, 5};
  CHECK(count_self_intersections(mesh) == brute_force_count(mesh));
  CHECK(count_self_intersections(mesh) >= 1);
}

TEST_CASE("self_intersection: closed shapes have none - a mesh folded through itself has some") {
  CHECK(count_self_intersections(make_icosphere(1.0, 4)) == 0);
  CHECK(count_self_intersections(make_capsule(0.2, 1.6, 24, 32, 6)) == 0);

  // Fold a long capsule: rotate its upper half by 170° about the x axis at z = 0: the halves
  // pass through each other.
  TriangleMesh folded = make_capsule(0.2, 1.6, 24, 32, 6);
  const double angle = 170.0 * glm::pi<double>() / 180.0;
  for (Vec3& p : folded.positions) {
    if (p.z <= 0.0) continue;
    const double y = p.y * std::cos(angle) - p.z * std::sin(angle);
    const double z = p.y * std::sin(angle) + p.z * std::cos(angle);
    p = {p.x, y, z};
  }
  const size_t count = count_self_intersections(folded);
  MESSAGE("capsule folded by 170 degrees: " << count << " intersecting pairs");
  CHECK(count > 0);
  CHECK(count == brute_force_count(folded));
}

TEST_CASE("self_intersection: random triangle soup agrees with brute force") {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int round = 0; round < 4; ++round) {
    TriangleMesh soup;
    const int triangles = 300;
    const double size = 0.02 + 0.05 * round;  // denser overlap every round
    for (int t = 0; t < triangles; ++t) {
      const Vec3 centre(unit(random), unit(random), unit(random));
      for (int k = 0; k < 3; ++k)
        soup.positions.push_back(centre + size * Vec3(unit(random) - 0.5, unit(random) - 0.5, unit(random) - 0.5));
      // Every 10th triangle shares a vertex with its predecessor (adjacency must be skipped).
      const uint32_t base = static_cast<uint32_t>(3 * t);
      soup.triangles.push_back({(t % 10 == 9) ? base - 1 : base, base + 1, base + 2});
    }
    const size_t expected = brute_force_count(soup);
    CHECK(count_self_intersections(soup) == expected);
    MESSAGE("soup round " << round << ": " << expected << " pairs");
  }
}

TEST_CASE("self_intersection: 100K triangles of an icosphere pair set well under a second") {
  // Two interpenetrating icospheres (2 × 81,920 triangles): many candidate pairs near the
  // crossing circle. Timing is printed, not asserted (unit tests carry no wall-clock checks).
  TriangleMesh a = make_icosphere(1.0, 6);
  const TriangleMesh b = make_icosphere(1.0, 6);
  const uint32_t offset = static_cast<uint32_t>(a.positions.size());
  for (const Vec3& p : b.positions) a.positions.push_back(p + Vec3(1.0, 0.0, 0.0));
  for (const Triangle& t : b.triangles) a.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  const auto start = std::chrono::steady_clock::now();
  const size_t count = count_self_intersections(a);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  MESSAGE(a.triangles.size() << " triangles: " << count << " intersecting pairs in " << seconds << " s");
  CHECK(count > 0);
}
