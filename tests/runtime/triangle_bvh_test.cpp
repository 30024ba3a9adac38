// The triangle hierarchy's self-pair search (runtime/src/triangle_bvh.h) against a brute-force
// loop over every pair: the same set of pairs (distinct, sharing no corner, boxes meeting, at
// least one wanted), each once, on a deformed grid folded onto itself and on a random soup
// whose leaves end part-full, with and without wanted flags.
#include "triangle_bvh.h"

#include <doctest/doctest.h>
#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

using skelform::runtime::AllocatorRef;
using skelform::runtime::Array;
using skelform::runtime::build_triangle_hierarchy;
using skelform::runtime::CallbackAllocator;
using skelform::runtime::query_triangle_hierarchy;
using skelform::runtime::refit_triangle_hierarchy;
using skelform::runtime::self_pairs_triangle_hierarchy;
using skelform::runtime::SlotBoxes;

namespace {

using PairSet = std::set<std::pair<uint32_t, uint32_t>>;

void boxes_of(const std::vector<glm::vec3>& p, const std::vector<uint32_t>& tri, std::vector<float>& boxes) {
  const size_t n = tri.size() / 3;
  boxes.resize(6 * n);
  for (size_t t = 0; t < n; ++t)
    for (int k = 0; k < 3; ++k) {
      const float a = p[tri[3 * t]][k], b = p[tri[3 * t + 1]][k], c = p[tri[3 * t + 2]][k];
      boxes[6 * t + size_t(k)] = std::min({a, b, c});
      boxes[6 * t + 3 + size_t(k)] = std::max({a, b, c});
    }
}

PairSet brute_force(const std::vector<uint32_t>& tri, const std::vector<float>& boxes,
                    const std::vector<uint8_t>& wanted) {
  PairSet pairs;
  const size_t n = tri.size() / 3;
  for (size_t s = 0; s < n; ++s)
    for (size_t t = s + 1; t < n; ++t) {
      if (!wanted[s] && !wanted[t]) continue;
      bool shared = false;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) shared |= tri[3 * s + size_t(i)] == tri[3 * t + size_t(j)];
      const float* a = &boxes[6 * s];
      const float* b = &boxes[6 * t];
      const bool meet = a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
      if (!shared && meet) pairs.insert({uint32_t(s), uint32_t(t)});
    }
  return pairs;
}

// The hierarchy built at `rest` with the triangles' boxes at `now` (as the guard does: rest
// shape, posed boxes), refitted: what every search below runs on.
struct Searchable {
  Searchable(const std::vector<glm::vec3>& rest, const std::vector<glm::vec3>& now, const std::vector<uint32_t>& tri)
      : n(uint32_t(tri.size() / 3)),
        h(build_triangle_hierarchy(rest.data(), tri.data(), n, AllocatorRef{})),
        slot_boxes(AllocatorRef{}) {
    boxes_of(now, tri, boxes);
    slot_boxes.resize(h);
    for (uint32_t t = 0; t < n; ++t) slot_boxes.set(h.slot[t], &boxes[6 * size_t(t)]);
    node_boxes.resize(6 * h.nodes.size());
    refit_triangle_hierarchy(h, slot_boxes, node_boxes.data());
  }
  // The self-pair search with `wanted` (by triangle; the search takes them by slot, with
  // padding flags set, which must not count).
  template <class Visit>
  bool self_pairs(const std::vector<uint8_t>& wanted, Visit&& visit) {
    std::vector<uint8_t> by_slot(h.slot_stride(), 1), node_wanted(h.nodes.size());
    for (uint32_t t = 0; t < n; ++t) by_slot[h.slot[t]] = wanted[t];
    std::vector<skelform::runtime::LeafLanes> leaf_wanted(h.nodes.size());
    return self_pairs_triangle_hierarchy(h, node_boxes.data(), slot_boxes, by_slot.data(), node_wanted.data(),
                                         leaf_wanted.data(), visit);
  }
  uint32_t n;
  skelform::runtime::TriangleHierarchy h;
  std::vector<float> boxes;  // by triangle
  SlotBoxes slot_boxes;
  std::vector<float> node_boxes;
};

void check_search(const std::vector<glm::vec3>& rest, const std::vector<glm::vec3>& now,
                  const std::vector<uint32_t>& tri, const std::vector<uint8_t>& wanted) {
  Searchable scene(rest, now, tri);
  PairSet found;
  size_t visits = 0;
  scene.self_pairs(wanted, [&](uint32_t s, uint32_t t) {
    ++visits;
    found.insert({std::min(s, t), std::max(s, t)});
  });
  const PairSet expected = brute_force(tri, scene.boxes, wanted);
  CHECK(visits == found.size());  // each pair once
  CHECK(found == expected);
  CHECK(!expected.empty());  // the scene has pairs to find
}

// A (k+1)² grid in the plane z = 0, two triangles per cell, rolled up around the x axis by
// `turns` (more than one turn lays the sheet onto itself, so far-apart triangles meet).
void grid(uint32_t k, float turns, std::vector<glm::vec3>& rest, std::vector<glm::vec3>& now,
          std::vector<uint32_t>& tri) {
  for (uint32_t j = 0; j <= k; ++j)
    for (uint32_t i = 0; i <= k; ++i) {
      const float x = float(i) / float(k), y = float(j) / float(k);
      rest.emplace_back(x, y, 0.0f);
      const float angle = 6.2831853f * turns * y, radius = 0.15f;
      now.emplace_back(x, radius * std::sin(angle), radius * (1.0f - std::cos(angle)));
    }
  for (uint32_t j = 0; j < k; ++j)
    for (uint32_t i = 0; i < k; ++i) {
      const uint32_t a = j * (k + 1) + i, b = a + 1, c = a + k + 1, d = c + 1;
      tri.insert(tri.end(), {a, b, d, a, d, c});
    }
}

// Queries the scene's hierarchy with the box (`boxes`, by triangle) of every `step`-th triangle
// and compares what each finds with a brute-force loop over `boxes`: the queries that differ
// or report a triangle twice. Adds the triangles found to `found_total`.
size_t query_mismatches(const Searchable& scene, const std::vector<float>& boxes, uint32_t step, size_t& found_total) {
  size_t mismatched = 0;
  for (uint32_t q = 0; q < scene.n; q += step) {
    const float* box = &boxes[6 * size_t(q)];
    std::set<uint32_t> found, expected;
    size_t visits = 0;
    query_triangle_hierarchy(scene.h, scene.node_boxes.data(), scene.slot_boxes, box, [&](uint32_t t) {
      found.insert(t);
      ++visits;
    });
    for (uint32_t t = 0; t < scene.n; ++t) {
      const float* b = &boxes[6 * size_t(t)];
      if (box[0] <= b[3] && b[0] <= box[3] && box[1] <= b[4] && b[1] <= box[4] && box[2] <= b[5] && b[2] <= box[5])
        expected.insert(t);
    }
    mismatched += found != expected || visits != found.size() ? 1 : 0;  // each triangle once
    found_total += found.size();
  }
  return mismatched;
}

}  // namespace

TEST_CASE("triangle hierarchy: the self-pair search finds what a brute-force loop finds") {
  SUBCASE("a sheet rolled onto itself, every triangle wanted") {
    std::vector<glm::vec3> rest, now;
    std::vector<uint32_t> tri;
    grid(23, 1.3f, rest, now, tri);  // 1,058 triangles: leaves end part-full
    check_search(rest, now, tri, std::vector<uint8_t>(tri.size() / 3, 1));
  }
  SUBCASE("the same sheet, a random third wanted") {
    std::vector<glm::vec3> rest, now;
    std::vector<uint32_t> tri;
    grid(23, 1.3f, rest, now, tri);
    std::mt19937 random(7);
    std::vector<uint8_t> wanted(tri.size() / 3);
    for (uint8_t& w : wanted) w = random() % 3 == 0 ? 1 : 0;
    check_search(rest, now, tri, wanted);
  }
  SUBCASE("a random soup of 301 triangles, some sharing corners") {
    std::mt19937 random(11);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::vector<glm::vec3> rest;
    for (int v = 0; v < 400; ++v) rest.emplace_back(unit(random), unit(random), unit(random));
    std::vector<uint32_t> tri;
    for (int t = 0; t < 301; ++t) {
      const uint32_t a = uint32_t(random() % 400);
      uint32_t b = (a + 1 + uint32_t(random() % 20)) % 400, c = (b + 1 + uint32_t(random() % 20)) % 400;
      tri.insert(tri.end(), {a, b, c});
    }
    std::vector<glm::vec3> now = rest;
    for (glm::vec3& p : now) p = 0.5f * p + glm::vec3(0.1f * unit(random));
    std::vector<uint8_t> wanted(tri.size() / 3);
    for (uint8_t& w : wanted) w = random() % 2 == 0 ? 1 : 0;
    check_search(rest, now, tri, wanted);
  }
}

TEST_CASE("triangle hierarchy: every leaf-pair and leaf-self kernel gives the portable loop's masks and rows") {
  std::vector<glm::vec3> rest, now;
  std::vector<uint32_t> tri;
  grid(23, 1.3f, rest, now, tri);
  const Searchable scene(rest, now, tri);
  const auto& h = scene.h;
  const auto& node_boxes = scene.node_boxes;
  namespace detail = skelform::runtime::detail;
  const detail::LeafPairInput input{scene.slot_boxes.planes.data(), scene.slot_boxes.stride, h.corners.data(),
                                    h.slot_stride()};
  std::vector<std::pair<const char*, detail::LeafPairKernel>> kernels;
#if defined(__SSE2__)
  kernels.emplace_back("sse2", &detail::leaf_pair_sse2);
#endif
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (skelform::runtime::cpu_has_avx2()) kernels.emplace_back("avx2", &detail::leaf_pair_avx2);
#endif
  kernels.emplace_back("chosen", detail::leaf_pair_kernel());
  std::vector<std::pair<const char*, detail::LeafSelfKernel>> self_kernels{{"portable", &detail::leaf_self_portable}};
#if defined(__SSE2__)
  self_kernels.emplace_back("sse2", &detail::leaf_self_sse2);
#endif
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (skelform::runtime::cpu_has_avx2()) self_kernels.emplace_back("avx2", &detail::leaf_self_avx2);
#endif
  self_kernels.emplace_back("chosen", detail::leaf_self_kernel());
  std::map<std::string, size_t> mismatches, self_mismatches;
  size_t self_bits = 0;
  size_t pairs = 0, bits = 0, hit_mismatches = 0;  // hit_mismatches: rows the portable loop names wrongly
  for (uint32_t a = 0; a < h.nodes.size(); ++a) {
    if (h.nodes[a].count == 0) continue;
    for (uint32_t b = 0; b < h.nodes.size(); ++b) {
      if (h.nodes[b].count == 0) continue;
      skelform::runtime::LeafLanes expected[skelform::runtime::kLeafTriangles], got[skelform::runtime::kLeafTriangles];
      const skelform::runtime::LeafLanes expected_hit =
          detail::leaf_pair_portable(input, h.nodes[a].first, h.nodes[a].count, h.nodes[b].first, h.nodes[b].count,
                                     node_boxes.data() + 6 * size_t(b), expected);
      for (uint32_t i = 0; i < h.nodes[a].count; ++i)
        hit_mismatches += ((expected_hit >> i) & 1) != (expected[i] != 0 ? 1u : 0u) ? 1 : 0;
      for (const auto& kernel : kernels) {
        const skelform::runtime::LeafLanes hit =
            kernel.second(input, h.nodes[a].first, h.nodes[a].count, h.nodes[b].first, h.nodes[b].count,
                          node_boxes.data() + 6 * size_t(b), got);
        for (uint32_t i = 0; i < h.nodes[a].count; ++i) mismatches[kernel.first] += got[i] != expected[i] ? 1 : 0;
        mismatches[kernel.first] += hit != expected_hit ? 1 : 0;
      }
      if (a == b) {  // a leaf against itself: the self kernels give the lanes after each row
        for (const auto& kernel : self_kernels) {
          const skelform::runtime::LeafLanes hit =
              kernel.second(input, h.nodes[a].first, h.nodes[a].count, node_boxes.data() + 6 * size_t(a),
                            h.shared_in_leaf.data() + h.nodes[a].first, got);
          skelform::runtime::LeafLanes later_hit = 0;
          for (uint32_t i = 0; i < h.nodes[a].count; ++i) {
            const skelform::runtime::LeafLanes later = expected[i] & detail::later_lanes(i, h.nodes[a].count);
            self_mismatches[kernel.first] += got[i] != later ? 1 : 0;
            later_hit |= skelform::runtime::LeafLanes(later != 0 ? 1 : 0) << i;
            self_bits += size_t(__builtin_popcountll(later));
          }
          self_mismatches[kernel.first] += hit != later_hit ? 1 : 0;
          // A node box that is not finite (a NaN position in the leaf) meets no row: nothing.
          const float nan_box[6] = {std::nanf(""), 0.0f, 0.0f, 1.0f, 1.0f, 1.0f};
          const skelform::runtime::LeafLanes nan_hit = kernel.second(input, h.nodes[a].first, h.nodes[a].count, nan_box,
                                                                     h.shared_in_leaf.data() + h.nodes[a].first, got);
          self_mismatches[kernel.first] += nan_hit != 0 ? 1 : 0;
          for (uint32_t i = 0; i < h.nodes[a].count; ++i) self_mismatches[kernel.first] += got[i] != 0 ? 1 : 0;
        }
      }
      ++pairs;
      for (uint32_t i = 0; i < h.nodes[a].count; ++i) bits += size_t(__builtin_popcountll(expected[i]));
    }
  }
  for (const auto& kernel : kernels) {
    INFO(kernel.first);
    CHECK(mismatches[kernel.first] == 0);
  }
  for (const auto& kernel : self_kernels) {
    INFO("self " << kernel.first);
    CHECK(self_mismatches[kernel.first] == 0);
  }
  CHECK(self_bits > 100);
  CHECK(hit_mismatches == 0);  // each kernel returns the rows whose mask is not 0
  CHECK(pairs > 100);
  CHECK(bits > 1000);  // the masks are not all empty
}

TEST_CASE("triangle hierarchy: a box query finds what a brute-force loop finds") {
  std::vector<glm::vec3> rest, now;
  std::vector<uint32_t> tri;
  grid(23, 1.3f, rest, now, tri);
  const Searchable scene(rest, now, tri);
  size_t found_total = 0;
  const size_t mismatched = query_mismatches(scene, scene.boxes, 7, found_total);
  CHECK(mismatched == 0);
  CHECK(found_total > 1000);
}

TEST_CASE("triangle hierarchy: node boxes grown around moved triangles find what a brute-force loop finds") {
  // The guard's later rounds: boxes refitted at one pose, then some triangles move (here a band
  // of the rolled grid unrolls back towards the plane) and the node boxes only grow around them.
  std::vector<glm::vec3> rest, now;
  std::vector<uint32_t> tri;
  grid(23, 1.3f, rest, now, tri);
  Searchable scene(rest, now, tri);
  const uint32_t n = scene.n;
  std::vector<glm::vec3> moved = now;
  for (size_t v = 0; v < moved.size(); ++v)
    if (rest[v].y > 0.3f && rest[v].y < 0.6f) moved[v] = glm::mix(now[v], rest[v] + glm::vec3(0.0f, 0.0f, 0.2f), 0.7f);
  std::vector<float> boxes;
  boxes_of(moved, tri, boxes);
  size_t changed = 0;
  for (uint32_t t = 0; t < n; ++t) {
    if (std::equal(boxes.begin() + 6 * t, boxes.begin() + 6 * t + 6, scene.boxes.begin() + 6 * t)) continue;
    scene.slot_boxes.set(scene.h.slot[t], &boxes[6 * size_t(t)]);
    skelform::runtime::grow_triangle_hierarchy(scene.h, scene.h.slot[t], &boxes[6 * size_t(t)],
                                               scene.node_boxes.data());
    ++changed;
  }
  REQUIRE(changed > 50);
  // Every node box holds its children's (grown, a node box still bounds its subtree).
  for (uint32_t m = 1; m < scene.h.nodes.size(); ++m) {
    const float* child = &scene.node_boxes[6 * size_t(m)];
    const float* parent = &scene.node_boxes[6 * size_t(scene.h.parent[m])];
    for (int k = 0; k < 3; ++k) {
      CHECK(parent[k] <= child[k]);
      CHECK(child[3 + k] <= parent[3 + k]);
    }
  }
  size_t found_total = 0;
  const size_t mismatched = query_mismatches(scene, boxes, 5, found_total);
  CHECK(mismatched == 0);
  CHECK(found_total > 1000);
}

TEST_CASE("triangle hierarchy: a visitor that returns false stops either search there") {
  // The guard's work budget: the search must end at the visit that says so, and say it ended.
  std::vector<glm::vec3> rest, now;
  std::vector<uint32_t> tri;
  grid(23, 1.3f, rest, now, tri);
  Searchable scene(rest, now, tri);
  const std::vector<uint8_t> all(scene.n, 1);
  size_t pairs = 0;
  CHECK(scene.self_pairs(all, [&](uint32_t, uint32_t) { return ++pairs > 0; }));  // never stops: all of them
  REQUIRE(pairs > 100);
  for (size_t stop_at : {size_t(1), size_t(17), pairs / 2, pairs}) {
    size_t visits = 0;
    const bool complete = scene.self_pairs(all, [&](uint32_t, uint32_t) { return ++visits < stop_at; });
    INFO("stop at visit " << stop_at << " of " << pairs);
    CHECK(!complete);
    CHECK(visits == stop_at);
  }
  const float* box = &scene.boxes[0];
  size_t found = 0;
  CHECK(query_triangle_hierarchy(scene.h, scene.node_boxes.data(), scene.slot_boxes, box,
                                 [&](uint32_t) { return ++found > 0; }));
  REQUIRE(found >= 2);
  size_t visits = 0;
  CHECK(!query_triangle_hierarchy(scene.h, scene.node_boxes.data(), scene.slot_boxes, box,
                                  [&](uint32_t) { return ++visits < 2; }));
  CHECK(visits == 2);
}

TEST_CASE("triangle hierarchy: a surface-area split parts two clusters where they are apart") {
  namespace detail = skelform::runtime::detail;
  // 60 small triangles' centroids along x: 20 near 0, 40 near 10, so a median split would cut
  // the second cluster; the cheapest plane (each side at least a quarter) lies in the gap.
  std::vector<glm::vec3> centroid, lo, hi;
  for (int i = 0; i < 60; ++i) {
    const float x = i < 20 ? 0.01f * float(i) : 10.0f + 0.01f * float(i);
    centroid.emplace_back(x, 0.3f * float(i % 3), 0.0f);
    lo.push_back(centroid.back() - glm::vec3(0.05f));
    hi.push_back(centroid.back() + glm::vec3(0.05f));
  }
  std::vector<uint32_t> order(60);
  for (uint32_t i = 0; i < 60; ++i) order[i] = 59 - i;  // any order
  glm::vec3 c_lo(1e30f), c_hi(-1e30f);
  for (const glm::vec3& c : centroid) c_lo = glm::min(c_lo, c), c_hi = glm::max(c_hi, c);
  const uint32_t left =
      detail::surface_area_split(order.data(), 60, centroid.data(), lo.data(), hi.data(), c_lo, c_hi - c_lo);
  CHECK(left == 20);
  for (uint32_t i = 0; i < 60; ++i) CHECK((order[i] < 20) == (i < left));  // the near cluster first
  std::vector<uint32_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (uint32_t i = 0; i < 60; ++i) CHECK(sorted[i] == i);  // a permutation

  // Every centroid at one point: no plane has triangles on both sides, so none qualifies.
  std::vector<glm::vec3> same(60, glm::vec3(1.0f));
  CHECK(detail::surface_area_split(order.data(), 60, same.data(), lo.data(), hi.data(), glm::vec3(1.0f),
                                   glm::vec3(0.0f)) == 0);
  // A cluster of 5 at x = 0 and 55 spread over x = 10..20, all at one y and z: a side of 5 is
  // under a quarter (15), so the plane moves into the larger cluster, each side holding at least
  // 15, every centroid on the left before every one on the right.
  for (int i = 0; i < 60; ++i) {
    centroid[size_t(i)] = glm::vec3(i < 5 ? 0.0f : 10.0f + 10.0f * float(i - 5) / 54.0f, 0.0f, 0.0f);
    lo[size_t(i)] = centroid[size_t(i)] - glm::vec3(0.05f);
    hi[size_t(i)] = centroid[size_t(i)] + glm::vec3(0.05f);
  }
  const uint32_t part = detail::surface_area_split(order.data(), 60, centroid.data(), lo.data(), hi.data(),
                                                   glm::vec3(0.0f), glm::vec3(20.0f, 0.0f, 0.0f));
  CHECK(part >= 15);
  CHECK(part <= 45);
  float left_max = -1e30f, right_min = 1e30f;
  for (uint32_t i = 0; i < 60; ++i) {
    if (i < part)
      left_max = std::max(left_max, centroid[order[i]].x);
    else
      right_min = std::min(right_min, centroid[order[i]].x);
  }
  CHECK(left_max < right_min);
  CHECK(left_max >= 10.0f);  // inside the larger cluster
}

TEST_CASE("triangle hierarchy: every triangle in one leaf of 1 to kLeafTriangles, whatever the centroids") {
  const uint32_t leaf_max = skelform::runtime::kLeafTriangles;
  auto check_structure = [&](const std::vector<glm::vec3>& p, const std::vector<uint32_t>& tri) {
    const uint32_t n = uint32_t(tri.size() / 3);
    const auto h = build_triangle_hierarchy(p.data(), tri.data(), n, AllocatorRef{});
    std::vector<int> seen(n, 0);
    size_t leaves = 0, bad = 0;
    for (size_t k = 0; k < h.nodes.size(); ++k) {
      const auto node = h.nodes[k];
      if (node.count == 0) {  // inner: two children after it
        bad += node.first <= k || node.first + 1 >= h.nodes.size() ? 1 : 0;
        continue;
      }
      ++leaves;
      bad += node.count > leaf_max ? 1 : 0;
      for (uint32_t i = node.first; i < node.first + node.count; ++i) ++seen[h.order[i]];
    }
    CHECK(bad == 0);
    CHECK(std::count(seen.begin(), seen.end(), 1) == std::ptrdiff_t(n));
    CHECK(leaves >= (n + leaf_max - 1) / leaf_max);
  };
  std::vector<glm::vec3> rest, now;
  std::vector<uint32_t> tri;
  grid(23, 1.3f, rest, now, tri);
  check_structure(rest, tri);
  // Every triangle at one place (the bins cannot split them): median splits.
  check_structure(std::vector<glm::vec3>(rest.size(), glm::vec3(2.0f)), tri);
  // A few vertices thrown far out: two clusters of very different sizes, huge coordinates.
  std::vector<glm::vec3> far = rest;
  for (size_t v = 0; v < far.size(); v += 50) far[v] *= 1e30f;
  check_structure(far, tri);
}

TEST_CASE("triangle hierarchy: a leaf's refit takes the extremes std::min and std::max take in order") {
  // plane_extreme, and the AVX2 leaf box where the CPU has it, against the loop they replaced,
  // on every count a leaf can have: random values,
  // a NaN first (the result is NaN), NaNs later (passed over), infinities, and signed zeros
  // (either zero may be kept: equal as floats).
  std::mt19937 random(20261128);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  auto same = [](float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; };
  uint32_t compared = 0;
  for (int kind = 0; kind < 5; ++kind)
    for (uint32_t count = 1; count <= skelform::runtime::kLeafTriangles; ++count)
      for (int trial = 0; trial < 50; ++trial) {
        std::vector<float> p(count);
        for (float& x : p) x = unit(random);
        if (kind == 1) p[0] = nan;
        if (kind == 2)
          for (size_t i = 1; i < count; i += 3) p[i] = nan;
        if (kind == 3) p[size_t(trial) % count] = trial % 2 ? inf : -inf;
        if (kind == 4)
          for (float& x : p) x = x < 0.0f ? -0.0f : 0.0f;
        float lowest = p[0], highest = p[0];
        for (uint32_t i = 1; i < count; ++i) {
          lowest = std::min(lowest, p[i]);
          highest = std::max(highest, p[i]);
        }
        const float got_lowest = skelform::runtime::detail::plane_extreme<true>(p.data(), count);
        const float got_highest = skelform::runtime::detail::plane_extreme<false>(p.data(), count);
        if (!same(got_lowest, lowest) || !same(got_highest, highest)) {
          FAIL_CHECK("kind " << kind << ", count " << count << ": " << got_lowest << " / " << got_highest << " against "
                             << lowest << " / " << highest);
          return;
        }
#if defined(SKELFORM_HAS_AVX2_KERNELS)
        if (skelform::runtime::cpu_has_avx2()) {
          // The AVX2 leaf box reads whole groups of eight past the leaf: slots holding values
          // that would win the minimum or the maximum (and NaNs), which it must leave out.
          const size_t stride = count + skelform::runtime::kLeafTriangles;
          std::vector<float> planes(6 * stride);
          for (size_t k = 0; k < 6; ++k)
            for (size_t i = 0; i < stride; ++i)
              planes[k * stride + i] = i < count ? p[i] : (i % 3 == 0 ? -1e30f : (i % 3 == 1 ? 1e30f : nan));
          float box[6];
          skelform::runtime::detail::leaf_box_avx2(planes.data(), stride, 0, count, box);
          for (int k = 0; k < 6; ++k)
            if (!same(box[k], k < 3 ? lowest : highest)) {
              FAIL_CHECK("AVX2, kind " << kind << ", count " << count << ", plane " << k << ": " << box[k]);
              return;
            }
        }
#endif
        ++compared;
      }
  CHECK(compared == 5u * skelform::runtime::kLeafTriangles * 50u);
}

TEST_CASE("triangle hierarchy: a leaf's wanted lanes are its own slots' flags") {
  // wanted_lanes reads a leaf's flags a group at a time past its count (the next leaf's, or the
  // padding's): those must not count, or a leaf with none wanted would not be pruned.
  std::vector<glm::vec3> rest, now;
  std::vector<uint32_t> tri;
  grid(23, 1.3f, rest, now, tri);
  const Searchable scene(rest, now, tri);
  const auto& h = scene.h;
  std::mt19937 random(7);
  std::vector<uint8_t> by_slot(h.slot_stride(), 1);
  for (uint32_t i = 0; i < h.order.size(); ++i) by_slot[i] = random() % 4 == 0 ? uint8_t(1 + random() % 255) : 0;
  size_t leaves = 0, part_full = 0;
  for (const auto& node : h.nodes) {
    if (node.count == 0) continue;
    skelform::runtime::LeafLanes expected = 0;
    for (uint32_t i = 0; i < node.count; ++i)
      expected |= skelform::runtime::LeafLanes(by_slot[node.first + i] != 0) << i;
    CHECK(skelform::runtime::detail::wanted_lanes(by_slot.data() + node.first, node.count) == expected);
    ++leaves;
    part_full += node.count < skelform::runtime::kLeafTriangles ? 1 : 0;
  }
  CHECK(part_full > 0);  // some leaves have lanes past their count to ignore
  CHECK(leaves > 10);
}

TEST_CASE("triangle hierarchy: two boxes meet as the six comparisons say, NaN bounds meeting nothing") {
  // Random boxes on a coarse lattice (so that bounds often touch), some 0 bounds −0, some NaN.
  std::mt19937 random(41);
  std::uniform_int_distribution<int> lattice(-3, 3), extent(0, 3), pick(0, 31);
  size_t met = 0, apart = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    std::vector<float> boxes(12);  // two boxes, ending the allocation: AddressSanitizer sees a read past
    for (int box = 0; box < 2; ++box)
      for (int axis = 0; axis < 3; ++axis) {
        const int lo = lattice(random);
        boxes[6 * box + axis] = float(lo), boxes[6 * box + 3 + axis] = float(lo + extent(random));
      }
    for (float& b : boxes) {
      const int k = pick(random);
      if (k == 0) b = std::numeric_limits<float>::quiet_NaN();
      if (k < 8 && b == 0.0f) b = -0.0f;
    }
    const float* a = boxes.data();
    const float* b = boxes.data() + 6;
    const bool expected = a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
    CHECK(skelform::runtime::hierarchy_boxes_meet(a, b) == expected);
    CHECK(skelform::runtime::hierarchy_boxes_meet(b, a) == expected);
    (expected ? met : apart) += 1;
  }
  CHECK(met > 1000);
  CHECK(apart > 1000);
}
