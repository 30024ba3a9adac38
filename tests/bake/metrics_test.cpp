// Checks bake/src/metrics.cpp against analytic values and brute force.
#include "skelform/bake/metrics.h"
#include "skelform/bake/procedural.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

using namespace skelform::bake;

namespace {

// Brute-force distance from p to triangle (a, b, c): the minimum of the distance to the plane
// (when the projection falls inside, tested by barycentric signs) and to the three edges.
double brute_force_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  auto segment_distance = [&p](const Vec3& s, const Vec3& e) {
    const Vec3 direction = e - s;
    const double t = std::clamp(glm::dot(p - s, direction) / glm::dot(direction, direction), 0.0, 1.0);
    return glm::length(s + t * direction - p);
  };
  double best = std::min({segment_distance(a, b), segment_distance(b, c), segment_distance(c, a)});
  const Vec3 normal = glm::cross(b - a, c - a);
  const double twice_area = glm::length(normal);
  if (twice_area > 0.0) {
    const Vec3 unit = normal / twice_area;
    const Vec3 projected = p - glm::dot(p - a, unit) * unit;
    const double wa = glm::dot(glm::cross(b - projected, c - projected), unit);
    const double wb = glm::dot(glm::cross(c - projected, a - projected), unit);
    const double wc = glm::dot(glm::cross(a - projected, b - projected), unit);
    if (wa >= 0 && wb >= 0 && wc >= 0) best = std::min(best, std::abs(glm::dot(p - a, unit)));
  }
  return best;
}

}  // namespace

TEST_CASE("metrics: winding number of a closed sphere is 1 inside and 0 outside") {
  const TriangleMesh sphere = make_icosphere(1.0, 3);
  const std::vector<Vec3> inside = {{0, 0, 0}, {0.5, 0.2, -0.3}, {0, 0, 0.95}, {-0.9, 0.1, 0}};
  const std::vector<Vec3> outside = {{2, 0, 0}, {0, 0, 1.05}, {10, -3, 4}, {0.8, 0.8, 0.8}};
  for (double w : winding_numbers(sphere, inside)) CHECK(w == doctest::Approx(1.0).epsilon(1e-9));
  for (double w : winding_numbers(sphere, outside)) CHECK(w == doctest::Approx(0.0).epsilon(1e-9));
  CHECK(inside_fraction(sphere, inside) == 1.0);
  CHECK(inside_fraction(sphere, outside) == 0.0);
  std::vector<Vec3> mixed = inside;
  mixed.insert(mixed.end(), outside.begin(), outside.end());
  CHECK(inside_fraction(sphere, mixed) == doctest::Approx(0.5));
}

TEST_CASE("metrics: winding number flips sign with orientation and is about 1/2 at an open hemisphere's centre") {
  TriangleMesh sphere = make_uv_sphere(1.0, 32, 16);
  TriangleMesh reversed = sphere;
  for (Triangle& t : reversed.triangles) std::swap(t[1], t[2]);
  CHECK(winding_numbers(reversed, {{0.1, 0.2, 0.3}})[0] == doctest::Approx(-1.0).epsilon(1e-9));

  // Upper half of the UV sphere (stacks are symmetric about z = 0): seen from the centre it
  // covers exactly half of the directions.
  TriangleMesh hemisphere;
  hemisphere.positions = sphere.positions;
  for (const Triangle& t : sphere.triangles) {
    const double centroid_z = (sphere.positions[t[0]].z + sphere.positions[t[1]].z + sphere.positions[t[2]].z) / 3;
    if (centroid_z > 0) hemisphere.triangles.push_back(t);
  }
  CHECK(winding_numbers(hemisphere, {{0, 0, 0}})[0] == doctest::Approx(0.5).epsilon(1e-9));
}

TEST_CASE("metrics: the hierarchical winding number stays within 2e-3 of the exact one") {
  // The procedural character (many parts, thin limbs: queries near and far from every node)
  // and an open hemisphere (winding numbers between 0 and 1), at random points in and around
  // their bounding boxes, and at points just off the surface.
  TriangleMesh hemisphere;
  const TriangleMesh sphere = make_uv_sphere(1.0, 48, 24);
  hemisphere.positions = sphere.positions;
  for (const Triangle& t : sphere.triangles)
    if (sphere.positions[t[0]].z + sphere.positions[t[1]].z + sphere.positions[t[2]].z > 0)
      hemisphere.triangles.push_back(t);
  for (const TriangleMesh& mesh : {make_test_character(), hemisphere}) {
    Vec3 lo(std::numeric_limits<double>::max()), hi(std::numeric_limits<double>::lowest());
    for (const Vec3& p : mesh.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
    const Vec3 margin = 0.25 * (hi - lo);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<Vec3> queries;
    for (int i = 0; i < 1500; ++i)
      queries.push_back(lo - margin + Vec3(u(rng), u(rng), u(rng)) * (hi - lo + 2.0 * margin));
    for (size_t t = 0; t < mesh.triangles.size(); t += 7) {
      const Triangle& tri = mesh.triangles[t];
      const Vec3 a = mesh.positions[tri[0]], b = mesh.positions[tri[1]], c = mesh.positions[tri[2]];
      const Vec3 n = glm::cross(b - a, c - a);
      if (glm::length(n) == 0.0) continue;
      const double offset = 1e-3 * glm::length(hi - lo) * (t % 2 == 0 ? 1.0 : -1.0);
      queries.push_back((a + b + c) / 3.0 + offset * glm::normalize(n));
    }
    const std::vector<double> exact = winding_numbers(mesh, queries);
    const std::vector<double> fast = fast_winding_numbers(mesh, queries);
    REQUIRE(fast.size() == exact.size());
    double worst = 0.0;
    size_t disagree = 0;
    for (size_t q = 0; q < queries.size(); ++q) {
      REQUIRE(std::isfinite(fast[q]));
      worst = std::max(worst, std::abs(fast[q] - exact[q]));
      disagree += (fast[q] > 0.5) != (exact[q] > 0.5) ? 1u : 0u;
    }
    CAPTURE(mesh.triangles.size());
    CHECK(worst < 2e-3);
    CHECK(disagree == 0);
  }
}

TEST_CASE("metrics: TriangleTree closest point equals brute force on random queries") {
  TriangleMesh mesh = make_capsule(0.7, 2.0, 17, 5, 6);
  // Jitter the vertices so triangles have all orientations and sizes.
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> jitter(-0.05, 0.05);
  for (Vec3& p : mesh.positions) p += Vec3(jitter(rng), jitter(rng), jitter(rng));
  const TriangleTree tree(mesh);

  std::uniform_real_distribution<double> coordinate(-3.0, 3.0);
  int mismatches = 0;
  for (int q = 0; q < 2000; ++q) {
    const Vec3 query(coordinate(rng), coordinate(rng), coordinate(rng) * 1.5);
    double brute = std::numeric_limits<double>::infinity();
    for (const Triangle& t : mesh.triangles)
      brute = std::min(brute, brute_force_triangle_distance(query, mesh.positions[t[0]], mesh.positions[t[1]],
                                                            mesh.positions[t[2]]));
    const TriangleTree::Hit hit = tree.closest(query);
    if (std::abs(hit.distance - brute) > 1e-12 * (1.0 + brute)) ++mismatches;
    // The reported point is on the reported triangle, at the reported distance.
    const Triangle& t = mesh.triangles[hit.triangle];
    CHECK(brute_force_triangle_distance(hit.point, mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]) <
          1e-12);
    CHECK(glm::length(hit.point - query) == doctest::Approx(hit.distance).epsilon(1e-12));
  }
  CHECK(mismatches == 0);

  const std::vector<double> distances = surface_distances(mesh, {mesh.positions[3], {0, 0, 0}});
  CHECK(distances[0] == 0.0);
  CHECK(distances[1] > 0.6);
}

TEST_CASE("metrics: enclosed volume of an icosphere lies between its inscribed and circumscribed balls") {
  const double radius = 1.5;
  for (int subdivisions = 1; subdivisions <= 4; ++subdivisions) {
    const TriangleMesh sphere = make_icosphere(radius, subdivisions);
    const double volume = enclosed_volume(sphere);
    // Vertices lie on the sphere, so the polyhedron is inside it and contains the ball whose
    // radius is the smallest distance from the centre to a face plane.
    double inner_radius = radius;
    for (const Triangle& t : sphere.triangles) {
      const Vec3& a = sphere.positions[t[0]];
      const Vec3 unit = glm::normalize(glm::cross(sphere.positions[t[1]] - a, sphere.positions[t[2]] - a));
      inner_radius = std::min(inner_radius, glm::dot(a, unit));
    }
    const double ball = 4.0 / 3.0 * glm::pi<double>();
    CHECK(volume < ball * radius * radius * radius);
    CHECK(volume > ball * inner_radius * inner_radius * inner_radius);
    if (subdivisions == 4) CHECK(volume == doctest::Approx(ball * radius * radius * radius).epsilon(5e-3));
  }
  // Inverting the orientation negates the volume; translating does not change it.
  TriangleMesh moved = make_icosphere(radius, 2);
  const double reference = enclosed_volume(moved);
  for (Vec3& p : moved.positions) p += Vec3(1000.0, -2000.0, 3000.0);
  CHECK(enclosed_volume(moved) == doctest::Approx(reference).epsilon(1e-9));
  for (Triangle& t : moved.triangles) std::swap(t[1], t[2]);
  CHECK(enclosed_volume(moved) == doctest::Approx(-reference).epsilon(1e-9));
}
