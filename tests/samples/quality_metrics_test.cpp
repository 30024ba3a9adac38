// samples/quality/quality_metrics.h: the metrics skelform-quality reports. The pair search
// must miss no intersecting pair: it is checked against testing every pair of triangles, on
// meshes made to intersect and on real characters posed by LBS; welding, closedness, volume
// and the set difference against the bind pose on meshes whose answers are known; junctions
// (parts modelled through each other) on spheres whose parts are known.
#include "brute_force_pairs.h"
#include "gltf_animation.h"
#include "quality_metrics.h"
#include "skelform/bake/metrics.h"
#include "skelform/bake/procedural.h"
#include "skelform/bake/self_intersection.h"
#include "test_support.h"

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

namespace {

using skelform::samples::DenseTopology;
using skelform::samples::TrianglePair;

std::vector<float> flatten(const skelform::bake::TriangleMesh& mesh) {
  std::vector<float> out;
  for (const auto& p : mesh.positions) out.insert(out.end(), {float(p.x), float(p.y), float(p.z)});
  return out;
}

std::vector<uint32_t> corners(const skelform::bake::TriangleMesh& mesh) {
  std::vector<uint32_t> out;
  for (const auto& t : mesh.triangles) out.insert(out.end(), t.begin(), t.end());
  return out;
}

// Every pair of non-adjacent welded triangles, tested one by one.
std::vector<TrianglePair> brute_force_pairs(const DenseTopology& topology, const std::vector<float>& positions) {
  auto at = [&](uint32_t w) {
    const size_t v = topology.vertex_of_welded[w];
    return skelform::bake::Vec3(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
  };
  return skelform::test::brute_force_pairs(topology.triangles, at);
}

}  // namespace

TEST_CASE("quality metrics: the pair search finds exactly the pairs a test of every pair finds (crumpled spheres)") {
  // An icosphere whose vertices are jittered by about two edge lengths folds through itself,
  // with intersections of every size (grazing, crossing, nearly coplanar), at three scales.
  // (Moving them along their radii alone would not: a star-shaped surface stays embedded.)
  const skelform::bake::TriangleMesh sphere = skelform::bake::make_icosphere(1.0, 3);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  size_t checked = 0, found = 0;
  for (double scale : {1e-2, 1.0, 1e3}) {
    for (int trial = 0; trial < 4; ++trial) {
      skelform::bake::TriangleMesh crumpled = sphere;
      for (auto& p : crumpled.positions)
        p = (p + skelform::bake::Vec3(jitter(random), jitter(random), jitter(random))) * scale;
      const std::vector<float> positions = flatten(crumpled);
      const DenseTopology topology = skelform::samples::dense_topology(positions, corners(crumpled));
      const std::vector<TrianglePair> fast = skelform::samples::intersecting_pairs(topology, positions);
      const std::vector<TrianglePair> slow = brute_force_pairs(topology, positions);
      CHECK(fast == slow);
      checked += topology.triangles.size();
      found += slow.size();
    }
  }
  MESSAGE("crumpled spheres: " << found << " intersecting pairs over " << checked << " triangles, every one found");
  CHECK(found > 100);  // the meshes do intersect: the comparison is not vacuous
}

TEST_CASE("quality metrics: the pair search misses no pair of a real character posed by LBS") {
  SKELFORM_REQUIRE_DATA(path, "quaternius/animals_pack/Wolf.glb");
  // The posed mesh itself would need the runtime; the metric only needs positions, so the
  // character is skinned here with the file's own skin at its gallop's middle frame.
  const skelform::samples::GltfAnimation gltf = skelform::samples::GltfAnimation::load_file(path.string());
  std::vector<float> positions = gltf.primitive_positions(0, 0);
  std::vector<uint32_t> triangles = gltf.primitive_triangles(0, 0);
  for (size_t p = 1; p < gltf.primitive_count(0); ++p) {
    const uint32_t offset = uint32_t(positions.size() / 3);
    const std::vector<float> more = gltf.primitive_positions(0, p);
    positions.insert(positions.end(), more.begin(), more.end());
    for (uint32_t i : gltf.primitive_triangles(0, p)) triangles.push_back(offset + i);
  }
  const DenseTopology topology = skelform::samples::dense_topology(positions, triangles);
  // Fold the mesh onto itself: mirror the half with x > 0 through x = 0 and pull it in, so
  // many triangles of the two halves cross.
  float largest = 0;
  for (size_t i = 0; i < positions.size(); i += 3) largest = std::max(largest, std::fabs(positions[i]));
  std::vector<float> folded = positions;
  for (size_t i = 0; i < folded.size(); i += 3)
    if (folded[i] > 0) folded[i] = -0.6f * folded[i] + 0.1f * largest;
  const std::vector<TrianglePair> fast = skelform::samples::intersecting_pairs(topology, folded);
  const std::vector<TrianglePair> slow = brute_force_pairs(topology, folded);
  MESSAGE("Wolf folded onto itself: " << slow.size() << " intersecting pairs over " << topology.triangles.size()
                                      << " triangles");
  CHECK(slow.size() > 50);
  CHECK(fast == slow);
}

TEST_CASE("quality metrics: welding, closedness, volume and pairs added") {
  const skelform::bake::TriangleMesh sphere = skelform::bake::make_icosphere(2.0, 3);
  std::vector<float> positions = flatten(sphere);
  std::vector<uint32_t> triangles = corners(sphere);
  SUBCASE("a closed sphere: its volume, to the polyhedron's") {
    const DenseTopology topology = skelform::samples::dense_topology(positions, triangles);
    CHECK(topology.closed);
    CHECK(topology.triangles.size() == sphere.triangles.size());
    const double volume = skelform::samples::enclosed_volume(topology, positions);
    CHECK(volume == doctest::Approx(skelform::bake::enclosed_volume(sphere)).epsilon(1e-6));  // (its float positions)
    CHECK(volume == doctest::Approx(4.0 / 3.0 * glm::pi<double>() * 8.0).epsilon(0.02));  // the ball it approximates
    CHECK(skelform::samples::bounding_diagonal(positions) == doctest::Approx(4.0 * std::sqrt(3.0)).epsilon(1e-6));
  }
  SUBCASE("split at a seam (duplicated vertices): welded back, still closed") {
    // Give triangle 0 its own copies of its corners, as glTF does at a UV seam.
    const uint32_t base = uint32_t(positions.size() / 3);
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = triangles[size_t(k)];
      positions.insert(positions.end(), {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]});
      triangles[size_t(k)] = base + uint32_t(k);
    }
    const DenseTopology topology = skelform::samples::dense_topology(positions, triangles);
    CHECK(topology.closed);
    CHECK(topology.vertex_of_welded.size() == sphere.positions.size());
    for (int k = 0; k < 3; ++k)  // each copy welds to the vertex it copies
      CHECK(topology.welded_of_vertex[base + uint32_t(k)] == topology.welded_of_vertex[sphere.triangles[0][size_t(k)]]);
  }
  SUBCASE("a hole makes it open; a repeated triangle is dropped") {
    std::vector<uint32_t> holed(triangles.begin() + 3, triangles.end());
    CHECK_FALSE(skelform::samples::dense_topology(positions, holed).closed);
    std::vector<uint32_t> repeated = triangles;
    repeated.insert(repeated.end(), {triangles[2], triangles[1], triangles[0]});  // same corners, reversed
    const DenseTopology topology = skelform::samples::dense_topology(positions, repeated);
    CHECK(topology.triangles.size() == sphere.triangles.size());
    CHECK(topology.closed);
  }
  SUBCASE("pairs added: the pairs of a pose not in the reference") {
    const std::vector<TrianglePair> reference = {{1, 2}, {3, 9}, {4, 5}};
    CHECK(skelform::samples::pairs_added({{1, 2}, {4, 5}}, reference) == 0);
    CHECK(skelform::samples::pairs_added({{0, 7}, {1, 2}, {3, 8}, {3, 9}, {6, 7}}, reference) == 3);
    CHECK(skelform::samples::pairs_added({}, reference) == 0);
    CHECK(skelform::samples::pairs_added({{0, 1}}, {}) == 1);
  }
}

TEST_CASE("quality metrics: junctions - pairs between parts modelled through each other") {
  // Three unit spheres: A at the origin, B through A (centre at x = 1.5), C apart (x = 5). Posed,
  // B slides to x = 1.2 (the curve where it crosses A moves over both) and C comes into A from
  // the other side (x = -1.5). Only A and B are joined; C's pairs with A are a new contact.
  const skelform::bake::TriangleMesh sphere = skelform::bake::make_icosphere(1.0, 2);
  const uint32_t n = uint32_t(sphere.triangles.size());
  auto scene = [&](double b, double c) {
    std::vector<float> positions;
    std::vector<uint32_t> triangles;
    for (double x : {0.0, b, c}) {
      const uint32_t base = uint32_t(positions.size() / 3);
      for (const auto& p : sphere.positions)
        positions.insert(positions.end(), {float(p.x + x), float(p.y), float(p.z)});
      for (const auto& t : sphere.triangles)
        for (uint32_t v : t) triangles.push_back(base + v);
    }
    return std::make_pair(positions, triangles);
  };
  const auto [rest, triangles] = scene(1.5, 5.0);
  const DenseTopology topology = skelform::samples::dense_topology(rest, triangles);
  REQUIRE(topology.triangles.size() == 3 * size_t(n));
  const std::vector<TrianglePair> reference = skelform::samples::intersecting_pairs(topology, rest);
  REQUIRE(!reference.empty());
  const skelform::samples::Junctions junctions = skelform::samples::find_junctions(topology, reference);
  REQUIRE(junctions.part.size() == topology.triangles.size());
  // Three parts, each the triangles of one sphere (dense_topology keeps their order).
  for (uint32_t t = 0; t < 3 * n; ++t) {
    CHECK(junctions.part[t] == junctions.part[(t / n) * n]);
    if (t % n == 0 && t > 0) CHECK(junctions.part[t] != junctions.part[t - 1]);
  }
  const uint32_t a = junctions.part[0], b = junctions.part[n];
  REQUIRE(junctions.joined.size() == 1);
  CHECK(junctions.joined[0] == std::make_pair(std::min(a, b), std::max(a, b)));

  const std::vector<float> posed = scene(1.2, -1.5).first;
  const std::vector<TrianglePair> pairs = brute_force_pairs(topology, posed);
  size_t between_a_and_b = 0, between_a_and_c = 0;
  for (const TrianglePair& pair : pairs) {
    if (std::binary_search(reference.begin(), reference.end(), pair)) continue;
    const uint32_t s = pair.first / n, t = pair.second / n;
    between_a_and_b += (s == 0 && t == 1) || (s == 1 && t == 0);
    between_a_and_c += (s == 0 && t == 2) || (s == 2 && t == 0);
  }
  MESSAGE("pairs added between A and B " << between_a_and_b << ", between A and C " << between_a_and_c);
  REQUIRE(between_a_and_b > 0);
  REQUIRE(between_a_and_c > 0);
  CHECK(skelform::samples::pairs_added(pairs, reference) == between_a_and_b + between_a_and_c);
  CHECK(skelform::samples::pairs_added_at_junctions(pairs, reference, junctions) == between_a_and_b);
  // The reference itself adds nothing, at junctions or elsewhere.
  CHECK(skelform::samples::pairs_added_at_junctions(reference, reference, junctions) == 0);
}
