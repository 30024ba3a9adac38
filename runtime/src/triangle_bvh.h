// A bounding-volume hierarchy over the triangles of a deforming mesh: its shape (which
// triangles share a node) is built once from the rest pose, and every evaluation refits the
// node boxes to the triangles' current boxes (a limb that moves keeps its triangles together,
// so a rest-pose hierarchy stays tight under skinning). A box query then visits the nodes
// whose boxes meet it and reports each triangle whose box does, once.
#pragma once

#include "cpu.h"
#include "memory.h"

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif
#if defined(SKELFORM_HAS_AVX2_KERNELS)
#  include <immintrin.h>
#endif

#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>

namespace skelform::runtime {

// A node: a leaf lists `count` triangles from TriangleHierarchy::order[first]; an inner node
// (count == 0) has its children at `first` and `first + 1`. Children follow their parent.
struct HierarchyNode {
  uint32_t first = 0;
  uint32_t count = 0;
};

// Triangles per leaf, at most: the searches cost mostly their descent (docs/tuning.md).
constexpr uint32_t kLeafTriangles = 32;
constexpr uint32_t kMaxHierarchyDepth = 64;
// Surface-area splits down to this depth, median splits below: a surface-area split leaves at
// least a quarter of a node (rounded down) on each side, so at depth 40 a node of 2^32
// triangles holds under 2^16, and median splits finish within the depth limit.
constexpr uint32_t kSurfaceSplitDepth = 40;
// A leaf's lanes as bits of one word.
using LeafLanes = uint64_t;

struct TriangleHierarchy {
  explicit TriangleHierarchy(const AllocatorRef& a)
      : nodes(a), parent(a), order(a), slot(a), leaf(a), corners(a), shared_in_leaf(a) {}
  Array<HierarchyNode> nodes;
  Array<uint32_t> parent;  // per node: its parent (the root's is ~0u)
  Array<uint32_t> order;   // triangle indices, leaf by leaf: position i is "slot" i
  Array<uint32_t> slot;    // per triangle: its slot (order's inverse)
  Array<uint32_t> leaf;    // per slot: the leaf holding it
  // The triangles' corners by slot, three planes of slot_stride() entries (corner k of the
  // triangle in slot i at k·stride + i), so a leaf's corners load as lanes; the padding
  // after the last slot holds ~0u, which names no vertex.
  Array<uint32_t> corners;
  // Per slot: the lanes of its own leaf whose triangles share a corner with it (its own lane
  // too), so that a leaf met against itself needs no corner compares.
  Array<LeafLanes> shared_in_leaf;
  size_t slot_stride() const { return order.size() + kLeafTriangles; }
};

// Triangle boxes by slot for self_pairs_triangle_hierarchy, six planes of slot_stride()
// floats (lo x, y, z, hi x, y, z): a leaf's boxes load as lanes. Padding slots hold empty
// boxes (lo = +max, hi = -max), which meet nothing.
struct SlotBoxes {
  explicit SlotBoxes(const AllocatorRef& a) : planes(CallbackAllocator<float>(a)) {}
  Array<float> planes;
  size_t stride = 0;

  void resize(const TriangleHierarchy& h) {
    stride = h.slot_stride();
    planes.resize(6 * stride);
    for (size_t i = h.order.size(); i < stride; ++i)
      for (size_t k = 0; k < 3; ++k) {
        planes[k * stride + i] = std::numeric_limits<float>::max();
        planes[(3 + k) * stride + i] = -std::numeric_limits<float>::max();
      }
  }
  // Box of the triangle in `slot` from 6 floats (lo xyz, hi xyz), and back.
  void set(size_t slot, const float* box) {
    for (size_t k = 0; k < 6; ++k) planes[k * stride + slot] = box[k];
  }
  void get(size_t slot, float* box) const {
    for (size_t k = 0; k < 6; ++k) box[k] = planes[k * stride + slot];
  }
};

namespace detail {

constexpr int kSplitBins = 16;

// Half the surface area of the box lo..hi (0 when empty).
inline float half_area(const glm::vec3& lo, const glm::vec3& hi) {
  const glm::vec3 e = glm::max(hi - lo, glm::vec3(0.0f));
  return e.x * e.y + e.y * e.z + e.z * e.x;
}

// The bin of coordinate c in a split of lo + [0, kSplitBins / scale) (NaN: bin 0).
inline int split_bin(float c, float lo, float scale) {
  const float f = (c - lo) * scale;
  return f >= float(kSplitBins - 1) ? kSplitBins - 1 : (f > 0.0f ? int(f) : 0);
}

// A binned surface-area split of the `count` triangles in `order` (centroids within lo +
// [0, extent]): the plane between two of kSplitBins bins, on any axis, that minimises
// area(left)·n_left + area(right)·n_right with between a quarter and three quarters of the
// triangles on each side. Partitions `order` and returns n_left; 0 when no plane qualifies
// (`order` then holds the same triangles, maybe reordered).
inline uint32_t surface_area_split(uint32_t* order, uint32_t count, const glm::vec3* centroid, const glm::vec3* box_lo,
                                   const glm::vec3* box_hi, const glm::vec3& lo, const glm::vec3& extent) {
  const uint32_t least = std::max(1u, count / 4);
  float best = std::numeric_limits<float>::infinity();
  int best_axis = -1, best_bin = 0;
  for (int axis = 0; axis < 3; ++axis) {
    if (!(extent[axis] > 0.0f)) continue;
    const float scale = float(kSplitBins) / extent[axis];
    uint32_t bin_count[kSplitBins] = {};
    glm::vec3 bin_lo[kSplitBins], bin_hi[kSplitBins];
    for (int b = 0; b < kSplitBins; ++b)
      bin_lo[b] = glm::vec3(std::numeric_limits<float>::max()),
      bin_hi[b] = glm::vec3(-std::numeric_limits<float>::max());
    for (uint32_t i = 0; i < count; ++i) {
      const uint32_t t = order[i];
      const int b = split_bin(centroid[t][axis], lo[axis], scale);
      ++bin_count[b];
      bin_lo[b] = glm::min(bin_lo[b], box_lo[t]);
      bin_hi[b] = glm::max(bin_hi[b], box_hi[t]);
    }
    float right_area[kSplitBins];
    uint32_t right_count[kSplitBins];
    glm::vec3 rl(std::numeric_limits<float>::max()), rh(-std::numeric_limits<float>::max());
    uint32_t n = 0;
    for (int b = kSplitBins - 1; b > 0; --b) {
      rl = glm::min(rl, bin_lo[b]), rh = glm::max(rh, bin_hi[b]), n += bin_count[b];
      right_area[b] = half_area(rl, rh), right_count[b] = n;
    }
    glm::vec3 ll(std::numeric_limits<float>::max()), lh(-std::numeric_limits<float>::max());
    n = 0;
    for (int b = 0; b + 1 < kSplitBins; ++b) {  // the plane after bin b
      ll = glm::min(ll, bin_lo[b]), lh = glm::max(lh, bin_hi[b]), n += bin_count[b];
      if (n < least || right_count[b + 1] < least) continue;
      const float cost = half_area(ll, lh) * float(n) + right_area[b + 1] * float(right_count[b + 1]);
      if (cost < best) best = cost, best_axis = axis, best_bin = b;
    }
  }
  if (best_axis < 0) return 0;
  const float scale = float(kSplitBins) / extent[best_axis];
  const uint32_t* middle = std::partition(order, order + count, [&](uint32_t t) {
    return split_bin(centroid[t][best_axis], lo[best_axis], scale) <= best_bin;
  });
  const uint32_t left = uint32_t(middle - order);
  return left < count ? left : 0;  // (both sides hold at least `least` > 0, as counted)
}

}  // namespace detail

// Builds the hierarchy of `triangle_count` triangles (3 vertex indices each into `positions`)
// by binned surface-area splits of their centroids (detail::surface_area_split: smaller,
// less overlapping boxes than median splits, so fewer node pairs meet: a warm evaluation costs
// 3.5-6 % fewer instructions), a median split along the longest axis where none qualifies, at
// most kLeafTriangles per leaf. Throws std::bad_alloc.
inline TriangleHierarchy build_triangle_hierarchy(const glm::vec3* positions, const uint32_t* triangles,
                                                  uint32_t triangle_count, const AllocatorRef& allocator) {
  TriangleHierarchy h(allocator);
  if (triangle_count == 0) return h;
  h.order.resize(triangle_count);
  Array<glm::vec3> centroid{CallbackAllocator<glm::vec3>(allocator)};
  centroid.resize(triangle_count);
  for (uint32_t t = 0; t < triangle_count; ++t) {
    h.order[t] = t;
    centroid[t] = (positions[triangles[3 * size_t(t)]] + positions[triangles[3 * size_t(t) + 1]] +
                   positions[triangles[3 * size_t(t) + 2]]) /
                  3.0f;
  }
  Array<glm::vec3> box_lo{CallbackAllocator<glm::vec3>(allocator)}, box_hi{CallbackAllocator<glm::vec3>(allocator)};
  box_lo.resize(triangle_count);
  box_hi.resize(triangle_count);
  for (uint32_t t = 0; t < triangle_count; ++t) {
    const uint32_t* c = triangles + 3 * size_t(t);
    box_lo[t] = glm::min(glm::min(positions[c[0]], positions[c[1]]), positions[c[2]]);
    box_hi[t] = glm::max(glm::max(positions[c[0]], positions[c[1]]), positions[c[2]]);
  }
  h.nodes.reserve(2 * size_t(triangle_count));
  h.nodes.push_back({0, triangle_count});
  struct Pending {
    uint32_t node, depth;
  };
  Pending stack[kMaxHierarchyDepth + 1];
  uint32_t top = 0;
  stack[top++] = {0, 0};
  while (top > 0) {
    const Pending p = stack[--top];
    const uint32_t first = h.nodes[p.node].first, count = h.nodes[p.node].count;
    if (count <= kLeafTriangles || p.depth >= kMaxHierarchyDepth - 1) continue;
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (uint32_t i = first; i < first + count; ++i) {
      lo = glm::min(lo, centroid[h.order[i]]);
      hi = glm::max(hi, centroid[h.order[i]]);
    }
    const glm::vec3 extent = hi - lo;
    uint32_t half = 0;
    if (p.depth < kSurfaceSplitDepth)
      half = detail::surface_area_split(h.order.data() + first, count, centroid.data(), box_lo.data(), box_hi.data(),
                                        lo, extent);
    if (half == 0) {
      const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
      half = count / 2;
      std::nth_element(h.order.begin() + first, h.order.begin() + first + half, h.order.begin() + first + count,
                       [&](uint32_t a, uint32_t b) {
                         return centroid[a][axis] < centroid[b][axis] ||
                                (centroid[a][axis] == centroid[b][axis] && a < b);
                       });
    }
    const uint32_t left = uint32_t(h.nodes.size());
    h.nodes.push_back({first, half});
    h.nodes.push_back({first + half, count - half});
    h.nodes[p.node] = {left, 0};
    stack[top++] = {left, p.depth + 1};
    stack[top++] = {left + 1, p.depth + 1};
  }
  h.parent.assign(h.nodes.size(), ~0u);
  h.leaf.resize(triangle_count);
  for (uint32_t n = 0; n < h.nodes.size(); ++n) {
    const HierarchyNode node = h.nodes[n];
    if (node.count == 0) {
      h.parent[node.first] = h.parent[node.first + 1] = n;
    } else {
      for (uint32_t i = node.first; i < node.first + node.count; ++i) h.leaf[i] = n;
    }
  }
  h.slot.resize(triangle_count);
  const size_t stride = h.slot_stride();
  h.corners.assign(3 * stride, ~0u);
  for (uint32_t i = 0; i < triangle_count; ++i) {
    const uint32_t t = h.order[i];
    h.slot[t] = i;
    for (size_t k = 0; k < 3; ++k) h.corners[k * stride + i] = triangles[3 * size_t(t) + k];
  }
  h.shared_in_leaf.assign(triangle_count, 0);
  for (const HierarchyNode& node : h.nodes)
    for (uint32_t i = 0; i < node.count; ++i)
      for (uint32_t j = 0; j < node.count; ++j) {
        bool shared = false;
        for (size_t k = 0; k < 3; ++k)
          for (size_t l = 0; l < 3; ++l)
            shared |= h.corners[k * stride + node.first + i] == h.corners[l * stride + node.first + j];
        h.shared_in_leaf[node.first + i] |= LeafLanes(shared ? 1 : 0) << j;
      }
  return h;
}

// Box `b` (6 floats: lo xyz, hi xyz) grown to hold `box` too.
inline void grow_box(float* b, const float* box) {
  for (int k = 0; k < 3; ++k) {
    b[k] = std::min(b[k], box[k]);
    b[3 + k] = std::max(b[3 + k], box[3 + k]);
  }
}

namespace detail {

// The smallest (Lowest) or largest of p[0 .. count), count ≥ 1, as std::min or std::max over them
// in order picks it: a NaN after p[0] is passed over, and a NaN p[0] is the result. With SSE2,
// four lanes each start from p[0] and take _mm_min_ps(x, lane) (x < lane ? x : lane, what
// std::min(lane, x) is), so a NaN is passed over or kept as there; of two equal values (0 and
// −0) either may be kept, which no box comparison tells apart.
template <bool Lowest>
inline float plane_extreme(const float* p, uint32_t count) {
#if defined(__SSE2__)
  __m128 acc = _mm_set1_ps(p[0]);
  auto take = [&](__m128 x) { acc = Lowest ? _mm_min_ps(x, acc) : _mm_max_ps(x, acc); };
  uint32_t i = 1;
  for (; i + 4 <= count; i += 4) take(_mm_loadu_ps(p + i));
  for (; i < count; ++i) take(_mm_set1_ps(p[i]));
  take(_mm_shuffle_ps(acc, acc, _MM_SHUFFLE(1, 0, 3, 2)));
  take(_mm_shuffle_ps(acc, acc, _MM_SHUFFLE(2, 3, 0, 1)));
  return _mm_cvtss_f32(acc);
#else
  float e = p[0];
  for (uint32_t i = 1; i < count; ++i) e = Lowest ? std::min(e, p[i]) : std::max(e, p[i]);
  return e;
#endif
}

#if defined(SKELFORM_HAS_AVX2_KERNELS)
// A leaf's box (6 floats) from the `count` slots at `first` of each plane, as plane_extreme
// takes each plane's, eight lanes at a time: every lane starts from the leaf's first value, and
// the lanes past the leaf (the next leaf's slots or the padding: in bounds) take it again,
// which changes nothing. The same value as plane_extreme's (of 0 and −0 either).
__attribute__((target("avx2"))) inline void leaf_box_avx2(const float* planes, size_t stride, uint32_t first,
                                                          uint32_t count, float* box) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (size_t k = 0; k < 6; ++k) {
    const bool lowest = k < 3;
    const float* p = planes + k * stride + first;
    const __m256 start = _mm256_set1_ps(p[0]);
    __m256 acc = start;
    for (uint32_t g = 0; g < count; g += 8) {
      const __m256 live = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(int32_t(count - g)), lane));
      const __m256 x = _mm256_blendv_ps(start, _mm256_loadu_ps(p + g), live);
      acc = lowest ? _mm256_min_ps(x, acc) : _mm256_max_ps(x, acc);
    }
    const __m128 high = _mm256_extractf128_ps(acc, 1);
    __m128 a = _mm256_castps256_ps128(acc);
    a = lowest ? _mm_min_ps(high, a) : _mm_max_ps(high, a);
    const __m128 pair = _mm_shuffle_ps(a, a, _MM_SHUFFLE(1, 0, 3, 2));
    a = lowest ? _mm_min_ps(pair, a) : _mm_max_ps(pair, a);
    const __m128 one = _mm_shuffle_ps(a, a, _MM_SHUFFLE(2, 3, 0, 1));
    a = lowest ? _mm_min_ps(one, a) : _mm_max_ps(one, a);
    box[k] = _mm_cvtss_f32(a);
  }
}
#endif

}  // namespace detail

// Node boxes (6 floats per node: lo xyz, hi xyz) from the triangles' boxes, children before
// parents; a leaf reads its slots' lanes, contiguous in each plane (with AVX2, eight at a time).
inline void refit_triangle_hierarchy(const TriangleHierarchy& h, const SlotBoxes& boxes, float* node_boxes) {
  [[maybe_unused]] const bool avx2 = cpu_has_avx2() && boxes.stride >= h.slot_stride();
  for (size_t n = h.nodes.size(); n-- > 0;) {
    const HierarchyNode node = h.nodes[n];
    float* b = node_boxes + 6 * n;
    if (node.count > 0) {
#if defined(SKELFORM_HAS_AVX2_KERNELS)
      if (avx2) {
        detail::leaf_box_avx2(boxes.planes.data(), boxes.stride, node.first, node.count, b);
        continue;
      }
#endif
      for (size_t k = 0; k < 3; ++k) {
        b[k] = detail::plane_extreme<true>(boxes.planes.data() + k * boxes.stride + node.first, node.count);
        b[3 + k] = detail::plane_extreme<false>(boxes.planes.data() + (3 + k) * boxes.stride + node.first, node.count);
      }
    } else {
      const float* c0 = node_boxes + 6 * size_t(node.first);
      std::copy(c0, c0 + 6, b);
      grow_box(b, c0 + 6);  // the second child follows the first
    }
  }
}

// Grows the node boxes (as refit_triangle_hierarchy left them, or grown since) around `box`, the
// new box of the triangle in `slot`: its leaf and ancestors, up to the first that holds it
// already. The boxes then hold every triangle's box as it is now (and as it was), so queries
// find every pair that meets, at the cost of looser boxes than a refit.
inline void grow_triangle_hierarchy(const TriangleHierarchy& h, size_t slot, const float* box, float* node_boxes) {
  for (uint32_t n = h.leaf[slot]; n != ~0u; n = h.parent[n]) {
    float* b = node_boxes + 6 * size_t(n);
    if (b[0] <= box[0] && b[1] <= box[1] && b[2] <= box[2] && box[3] <= b[3] && box[4] <= b[4] && box[5] <= b[5])
      return;
    grow_box(b, box);
  }
}

// Whether two triangles (three corner indices each) share a corner: the searches pass over such
// pairs (adjacent triangles touch by construction).
inline bool triangles_share_corner(const uint32_t* a, const uint32_t* b) {
  return a[0] == b[0] || a[0] == b[1] || a[0] == b[2] || a[1] == b[0] || a[1] == b[1] || a[1] == b[2] || a[2] == b[0] ||
         a[2] == b[1] || a[2] == b[2];
}

// Whether two boxes (lo xyz, hi xyz) meet: a NaN bound meets nothing. With SSE2 the six
// comparisons at once (each box read as floats 0-3 and 2-5, inside its six), without the
// scalar form's branches, which the walks over neighbouring nodes mispredict.
inline bool hierarchy_boxes_meet(const float* a, const float* b) {
#if defined(__SSE2__)
  const __m128 a_hi = _mm_loadu_ps(a + 2), b_hi = _mm_loadu_ps(b + 2);  // lanes 1-3: hi xyz
  const __m128 a_up = _mm_shuffle_ps(a_hi, a_hi, _MM_SHUFFLE(3, 3, 2, 1));
  const __m128 b_up = _mm_shuffle_ps(b_hi, b_hi, _MM_SHUFFLE(3, 3, 2, 1));
  const __m128 meet = _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(a), b_up), _mm_cmple_ps(_mm_loadu_ps(b), a_up));
  return (_mm_movemask_ps(meet) & 7) == 7;
#else
  return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
#endif
}

// The work bound of a pair search over a mesh of `triangles` (the LBS guard per evaluation, the
// rest pairs at load): candidate pairs visited, kPairVisitsPerTriangle per triangle plus
// kPairVisitsFloor. Real meshes stay far below it (the corpus's worst guard evaluation visits
// 26 per triangle); only a surface tangled over itself, all boxes meeting all boxes, reaches
// it, and the searches are quadratic there: the caller stops and falls back.
constexpr uint64_t kPairVisitsPerTriangle = 64;
constexpr uint64_t kPairVisitsFloor = uint64_t(1) << 16;
inline uint64_t pair_visit_budget(uint32_t triangles) { return kPairVisitsPerTriangle * triangles + kPairVisitsFloor; }

// The allowance of candidate pairs of `searches` such searches: the visitor spends one per pair
// and stops when spend() says the budget is used up.
struct PairBudget {
  uint64_t left = 0;

  PairBudget() = default;
  explicit PairBudget(uint32_t triangles, uint64_t searches = 1) : left(searches * pair_visit_budget(triangles)) {}
  bool spend() {
    if (left == 0) return false;
    --left;
    return true;
  }
};

namespace detail {

// visit(args...), and whether the search goes on: a visitor may return bool (false stops the
// search) or nothing (it never stops).
template <class Visit, class... Args>
inline bool visit_goes_on(Visit& visit, Args... args) {
  if constexpr (std::is_void_v<std::invoke_result_t<Visit&, Args...>>) {
    visit(args...);
    return true;
  } else {
    return bool(visit(args...));
  }
}

}  // namespace detail

// Calls visit(t) for every triangle t whose box (`boxes`, by slot) meets `box`. A visitor that
// returns bool stops the search by returning false; the call returns false when it was stopped.
template <class Visit>
bool query_triangle_hierarchy(const TriangleHierarchy& h, const float* node_boxes, const SlotBoxes& boxes,
                              const float* box, Visit&& visit) {
  if (h.nodes.empty()) return true;
  uint32_t stack[kMaxHierarchyDepth + 1];
  uint32_t top = 0;
  stack[top++] = 0;
  const float* p = boxes.planes.data();
  const size_t bs = boxes.stride;
  while (top > 0) {
    const uint32_t n = stack[--top];
    if (!hierarchy_boxes_meet(box, node_boxes + 6 * size_t(n))) continue;
    const HierarchyNode node = h.nodes[n];
    if (node.count > 0) {
#if defined(__SSE2__)
      // The leaf's lanes four at a time (lanes past the leaf are masked off).
      LeafLanes mask = 0;
      const float* lo_x = p + node.first;
      const __m128 lx = _mm_set1_ps(box[0]), ly = _mm_set1_ps(box[1]), lz = _mm_set1_ps(box[2]);
      const __m128 hx = _mm_set1_ps(box[3]), hy = _mm_set1_ps(box[4]), hz = _mm_set1_ps(box[5]);
      for (uint32_t g = 0; g < node.count; g += 4) {
        __m128 meet =
            _mm_and_ps(_mm_cmple_ps(lx, _mm_loadu_ps(lo_x + 3 * bs + g)), _mm_cmple_ps(_mm_loadu_ps(lo_x + g), hx));
        meet = _mm_and_ps(meet, _mm_cmple_ps(ly, _mm_loadu_ps(lo_x + 4 * bs + g)));
        meet = _mm_and_ps(meet, _mm_cmple_ps(_mm_loadu_ps(lo_x + bs + g), hy));
        meet = _mm_and_ps(meet, _mm_cmple_ps(lz, _mm_loadu_ps(lo_x + 5 * bs + g)));
        meet = _mm_and_ps(meet, _mm_cmple_ps(_mm_loadu_ps(lo_x + 2 * bs + g), hz));
        mask |= LeafLanes(_mm_movemask_ps(meet)) << g;
      }
      mask &= (LeafLanes(1) << node.count) - 1;
      while (mask) {
        const uint32_t j = uint32_t(__builtin_ctzll(mask));
        mask &= mask - 1;
        if (!detail::visit_goes_on(visit, h.order[node.first + j])) return false;
      }
#else
      for (uint32_t i = node.first; i < node.first + node.count; ++i)
        if (box[0] <= p[3 * bs + i] && p[i] <= box[3] && box[1] <= p[4 * bs + i] && p[bs + i] <= box[4] &&
            box[2] <= p[5 * bs + i] && p[2 * bs + i] <= box[5] && !detail::visit_goes_on(visit, h.order[i]))
          return false;
#endif
    } else {
      stack[top++] = node.first + 1;
      stack[top++] = node.first;
    }
  }
  return true;
}

namespace detail {

// The lanes of the leaf of `count` slots at `wanted` whose flag is not 0. With SSE2 it reads
// kLeafTriangles flags (the slots after the leaf are the next leaf's or padding: in bounds).
inline LeafLanes wanted_lanes(const uint8_t* wanted, uint32_t count) {
  static_assert(kLeafTriangles == 32, "two loads of sixteen flags");
  const LeafLanes lanes = (LeafLanes(1) << count) - 1;
#if defined(__SSE2__)
  const __m128i zero = _mm_setzero_si128();
  const uint32_t low =
      uint32_t(_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(wanted)), zero)));
  const uint32_t high =
      uint32_t(_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(wanted + 16)), zero)));
  return ~(LeafLanes(low) | LeafLanes(high) << 16) & lanes;
#else
  LeafLanes found = 0;
  for (uint32_t i = 0; i < count; ++i) found |= LeafLanes(wanted[i] ? 1 : 0) << i;
  return found & lanes;
#endif
}

// Per node, whether it holds a wanted triangle (children before parents: nodes are stored
// parents first), and per leaf its wanted lanes.
inline void mark_wanted(const TriangleHierarchy& h, const uint8_t* wanted, uint8_t* node_wanted,
                        LeafLanes* leaf_wanted) {
  for (size_t n = h.nodes.size(); n-- > 0;) {
    const HierarchyNode node = h.nodes[n];
    LeafLanes lanes = 0;
    if (node.count > 0) {
      lanes = wanted_lanes(wanted + node.first, node.count);
      node_wanted[n] = lanes ? 1 : 0;
    } else {
      node_wanted[n] = node_wanted[node.first] | node_wanted[node.first + 1];
    }
    leaf_wanted[n] = lanes;
  }
}

// The leaf-pair kernel: for each of the `count_a` triangles in slots first_a.. (leaf A),
// masks[i] gets bit j when lane j < count_b of the leaf at first_b (B) holds a triangle whose
// box meets triangle i's and that shares no corner with it; masks[i] is 0 when triangle i's box
// misses B's node box. Returns the rows whose mask is not 0 (bit i), so that the caller visits
// only those. The SIMD kernels compare B's lanes a group at a time up to the group holding its
// last (the slots after it are the next leaf's or padding: in bounds), then mask them off.
struct LeafPairInput {
  const float* planes;      // SlotBoxes::planes
  size_t box_stride;        // SlotBoxes::stride
  const uint32_t* corners;  // TriangleHierarchy::corners
  size_t corner_stride;     // TriangleHierarchy::slot_stride()
};
using LeafPairKernel = LeafLanes (*)(const LeafPairInput& in, uint32_t first_a, uint32_t count_a, uint32_t first_b,
                                     uint32_t count_b, const float* node_box_b, LeafLanes* masks);

inline bool box_meets_node(const LeafPairInput& in, uint32_t i, const float* node) {
  const float* p = in.planes + i;
  const size_t bs = in.box_stride;
  return p[0] <= node[3] && node[0] <= p[3 * bs] && p[bs] <= node[4] && node[1] <= p[4 * bs] && p[2 * bs] <= node[5] &&
         node[2] <= p[5 * bs];
}

#if defined(__SSE2__)
inline LeafLanes leaf_pair_sse2(const LeafPairInput& in, uint32_t first_a, uint32_t count_a, uint32_t first_b,
                                uint32_t count_b, const float* node_box_b, LeafLanes* masks) {
  LeafLanes hit = 0;
  const LeafLanes lanes_b = (LeafLanes(1) << count_b) - 1;  // count_b ≤ kLeafTriangles < 64
  const size_t bs = in.box_stride, cs = in.corner_stride;
  const float* lo_x = in.planes + first_b;
  for (uint32_t i = 0; i < count_a; ++i) {
    const uint32_t a = first_a + i;
    masks[i] = 0;
    if (!box_meets_node(in, a, node_box_b)) continue;
    const float* pa = in.planes + a;
    const __m128 lx = _mm_set1_ps(pa[0]), ly = _mm_set1_ps(pa[bs]), lz = _mm_set1_ps(pa[2 * bs]);
    const __m128 hx = _mm_set1_ps(pa[3 * bs]), hy = _mm_set1_ps(pa[4 * bs]), hz = _mm_set1_ps(pa[5 * bs]);
    const __m128i c0 = _mm_set1_epi32(int32_t(in.corners[a])), c1 = _mm_set1_epi32(int32_t(in.corners[cs + a])),
                  c2 = _mm_set1_epi32(int32_t(in.corners[2 * cs + a]));
    LeafLanes mask = 0;
    for (size_t g = 0; g < count_b; g += 4) {
      __m128 meet =
          _mm_and_ps(_mm_cmple_ps(lx, _mm_loadu_ps(lo_x + 3 * bs + g)), _mm_cmple_ps(_mm_loadu_ps(lo_x + g), hx));
      meet = _mm_and_ps(meet, _mm_cmple_ps(ly, _mm_loadu_ps(lo_x + 4 * bs + g)));
      meet = _mm_and_ps(meet, _mm_cmple_ps(_mm_loadu_ps(lo_x + bs + g), hy));
      meet = _mm_and_ps(meet, _mm_cmple_ps(lz, _mm_loadu_ps(lo_x + 5 * bs + g)));
      meet = _mm_and_ps(meet, _mm_cmple_ps(_mm_loadu_ps(lo_x + 2 * bs + g), hz));
      if (_mm_movemask_ps(meet) == 0) continue;  // most lanes miss: no corners to compare
      __m128i shared = _mm_setzero_si128();
      for (size_t k = 0; k < 3; ++k) {
        const __m128i lane = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in.corners + k * cs + first_b + g));
        shared = _mm_or_si128(shared, _mm_or_si128(_mm_cmpeq_epi32(lane, c0),
                                                   _mm_or_si128(_mm_cmpeq_epi32(lane, c1), _mm_cmpeq_epi32(lane, c2))));
      }
      mask |= LeafLanes(_mm_movemask_ps(_mm_andnot_ps(_mm_castsi128_ps(shared), meet))) << g;
    }
    masks[i] = mask & lanes_b;
    hit |= LeafLanes(masks[i] != 0) << i;
  }
  return hit;
}
#endif

#if defined(SKELFORM_HAS_AVX2_KERNELS)
__attribute__((target("avx2"))) inline LeafLanes leaf_pair_avx2(const LeafPairInput& in, uint32_t first_a,
                                                                uint32_t count_a, uint32_t first_b, uint32_t count_b,
                                                                const float* node_box_b, LeafLanes* masks) {
  const size_t bs = in.box_stride, cs = in.corner_stride;
  const LeafLanes lanes_b = (LeafLanes(1) << count_b) - 1;
  const float* lo_x = in.planes + first_b;
  // The rows whose box meets B's node box, eight at a time (the slots after A's last are the
  // next leaf's or padding: in bounds, and masked off).
  LeafLanes rows = 0;
  {
    const float* la = in.planes + first_a;
    const __m256 nlx = _mm256_set1_ps(node_box_b[0]), nly = _mm256_set1_ps(node_box_b[1]),
                 nlz = _mm256_set1_ps(node_box_b[2]);
    const __m256 nhx = _mm256_set1_ps(node_box_b[3]), nhy = _mm256_set1_ps(node_box_b[4]),
                 nhz = _mm256_set1_ps(node_box_b[5]);
    for (uint32_t g = 0; g < count_a; g += 8) {
      __m256 meet = _mm256_and_ps(_mm256_cmp_ps(_mm256_loadu_ps(la + g), nhx, _CMP_LE_OQ),
                                  _mm256_cmp_ps(nlx, _mm256_loadu_ps(la + 3 * bs + g), _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(_mm256_loadu_ps(la + bs + g), nhy, _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(nly, _mm256_loadu_ps(la + 4 * bs + g), _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(_mm256_loadu_ps(la + 2 * bs + g), nhz, _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(nlz, _mm256_loadu_ps(la + 5 * bs + g), _CMP_LE_OQ));
      rows |= LeafLanes(_mm256_movemask_ps(meet)) << g;
    }
    rows &= (LeafLanes(1) << count_a) - 1;  // count_a ≤ kLeafTriangles < 64
  }
  for (uint32_t i = 0; i < count_a; ++i) masks[i] = 0;
  LeafLanes hit = 0;
  while (rows) {
    const uint32_t i = uint32_t(__builtin_ctzll(rows));
    rows &= rows - 1;
    const uint32_t a = first_a + i;
    const float* pa = in.planes + a;
    const __m256 lx = _mm256_set1_ps(pa[0]), ly = _mm256_set1_ps(pa[bs]), lz = _mm256_set1_ps(pa[2 * bs]);
    const __m256 hx = _mm256_set1_ps(pa[3 * bs]), hy = _mm256_set1_ps(pa[4 * bs]), hz = _mm256_set1_ps(pa[5 * bs]);
    const __m256i c0 = _mm256_set1_epi32(int32_t(in.corners[a])), c1 = _mm256_set1_epi32(int32_t(in.corners[cs + a])),
                  c2 = _mm256_set1_epi32(int32_t(in.corners[2 * cs + a]));
    LeafLanes mask = 0;
    for (size_t g = 0; g < count_b; g += 8) {
      __m256 meet = _mm256_and_ps(_mm256_cmp_ps(lx, _mm256_loadu_ps(lo_x + 3 * bs + g), _CMP_LE_OQ),
                                  _mm256_cmp_ps(_mm256_loadu_ps(lo_x + g), hx, _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(ly, _mm256_loadu_ps(lo_x + 4 * bs + g), _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(_mm256_loadu_ps(lo_x + bs + g), hy, _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(lz, _mm256_loadu_ps(lo_x + 5 * bs + g), _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(_mm256_loadu_ps(lo_x + 2 * bs + g), hz, _CMP_LE_OQ));
      if (_mm256_movemask_ps(meet) == 0) continue;  // most lanes miss: no corners to compare
      __m256i shared = _mm256_setzero_si256();
      for (size_t k = 0; k < 3; ++k) {
        const __m256i lane = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(in.corners + k * cs + first_b + g));
        shared = _mm256_or_si256(
            shared, _mm256_or_si256(_mm256_cmpeq_epi32(lane, c0),
                                    _mm256_or_si256(_mm256_cmpeq_epi32(lane, c1), _mm256_cmpeq_epi32(lane, c2))));
      }
      mask |= LeafLanes(_mm256_movemask_ps(_mm256_andnot_ps(_mm256_castsi256_ps(shared), meet))) << g;
    }
    masks[i] = mask & lanes_b;
    hit |= LeafLanes(masks[i] != 0) << i;
  }
  return hit;
}
#endif

inline LeafLanes leaf_pair_portable(const LeafPairInput& in, uint32_t first_a, uint32_t count_a, uint32_t first_b,
                                    uint32_t count_b, const float* node_box_b, LeafLanes* masks) {
  LeafLanes hit = 0;
  const size_t bs = in.box_stride, cs = in.corner_stride;
  const float* p = in.planes;
  for (uint32_t i = 0; i < count_a; ++i) {
    const uint32_t a = first_a + i;
    masks[i] = 0;
    if (!box_meets_node(in, a, node_box_b)) continue;
    for (uint32_t g = 0; g < count_b; ++g) {
      const size_t b = first_b + g;
      const bool meet = p[a] <= p[3 * bs + b] && p[b] <= p[3 * bs + a] && p[bs + a] <= p[4 * bs + b] &&
                        p[bs + b] <= p[4 * bs + a] && p[2 * bs + a] <= p[5 * bs + b] && p[2 * bs + b] <= p[5 * bs + a];
      bool shared = false;
      for (size_t k = 0; k < 3; ++k)
        for (size_t j = 0; j < 3; ++j) shared |= in.corners[k * cs + b] == in.corners[j * cs + a];
      masks[i] |= LeafLanes(meet && !shared) << g;
    }
    hit |= LeafLanes(masks[i] != 0) << i;
  }
  return hit;
}

// The self kernel: the leaf of `count` triangles from slot `first` against itself. masks[i] gets
// bit j for each lane j in (i, count) whose triangle's box meets triangle i's and shares no
// corner with it (`shared`: TriangleHierarchy::shared_in_leaf from `first`), so each pair once
// and no corner compares; every mask is 0 when the leaf's node box (`node_box`, holding its
// triangles' boxes) has a NaN. Returns the rows whose mask is not 0. These are the pair
// kernel's masks with the leaf as B, restricted to the lanes after each row.
using LeafSelfKernel = LeafLanes (*)(const LeafPairInput& in, uint32_t first, uint32_t count, const float* node_box,
                                     const LeafLanes* shared, LeafLanes* masks);

// The lanes after lane i of a leaf of `count` (≤ kLeafTriangles < 64).
inline LeafLanes later_lanes(uint32_t i, uint32_t count) {
  return ((LeafLanes(1) << count) - 1) & ~((LeafLanes(2) << i) - 1);
}

// Whether a node box has no NaN. Holding its leaf's boxes, it then meets every row whose box is
// a box (one with a NaN meets nothing anyway); with a NaN it meets none, as in the pair kernels.
inline bool node_box_usable(const float* b) {
  return b[0] == b[0] && b[1] == b[1] && b[2] == b[2] && b[3] == b[3] && b[4] == b[4] && b[5] == b[5];
}

inline LeafLanes leaf_self_portable(const LeafPairInput& in, uint32_t first, uint32_t count, const float* node_box,
                                    const LeafLanes* shared, LeafLanes* masks) {
  LeafLanes hit = 0;
  const size_t bs = in.box_stride;
  const float* p = in.planes + first;
  if (!node_box_usable(node_box)) {
    for (uint32_t i = 0; i < count; ++i) masks[i] = 0;
    return 0;
  }
  for (uint32_t i = 0; i < count; ++i) {
    LeafLanes mask = 0;
    for (uint32_t j = i + 1; j < count; ++j) {
      const bool meet = p[i] <= p[3 * bs + j] && p[j] <= p[3 * bs + i] && p[bs + i] <= p[4 * bs + j] &&
                        p[bs + j] <= p[4 * bs + i] && p[2 * bs + i] <= p[5 * bs + j] && p[2 * bs + j] <= p[5 * bs + i];
      mask |= LeafLanes(meet ? 1 : 0) << j;
    }
    masks[i] = mask & ~shared[i];
    hit |= LeafLanes(masks[i] != 0) << i;
  }
  return hit;
}

#if defined(__SSE2__)
inline LeafLanes leaf_self_sse2(const LeafPairInput& in, uint32_t first, uint32_t count, const float* node_box,
                                const LeafLanes* shared, LeafLanes* masks) {
  LeafLanes hit = 0;
  const size_t bs = in.box_stride;
  const float* lo_x = in.planes + first;
  if (!node_box_usable(node_box)) {
    for (uint32_t i = 0; i < count; ++i) masks[i] = 0;
    return 0;
  }
  for (uint32_t i = 0; i < count; ++i) {
    const float* pa = lo_x + i;
    const __m128 lx = _mm_set1_ps(pa[0]), ly = _mm_set1_ps(pa[bs]), lz = _mm_set1_ps(pa[2 * bs]);
    const __m128 hx = _mm_set1_ps(pa[3 * bs]), hy = _mm_set1_ps(pa[4 * bs]), hz = _mm_set1_ps(pa[5 * bs]);
    LeafLanes mask = 0;
    // From the group holding lane i + 1; the lanes after the leaf are the next leaf's or
    // padding (in bounds) and are masked off.
    for (uint32_t g = (i + 1) & ~3u; g < count; g += 4) {
      __m128 meet =
          _mm_and_ps(_mm_cmple_ps(lx, _mm_loadu_ps(lo_x + 3 * bs + g)), _mm_cmple_ps(_mm_loadu_ps(lo_x + g), hx));
      meet = _mm_and_ps(meet, _mm_cmple_ps(ly, _mm_loadu_ps(lo_x + 4 * bs + g)));
      meet = _mm_and_ps(meet, _mm_cmple_ps(_mm_loadu_ps(lo_x + bs + g), hy));
      meet = _mm_and_ps(meet, _mm_cmple_ps(lz, _mm_loadu_ps(lo_x + 5 * bs + g)));
      meet = _mm_and_ps(meet, _mm_cmple_ps(_mm_loadu_ps(lo_x + 2 * bs + g), hz));
      mask |= LeafLanes(_mm_movemask_ps(meet)) << g;
    }
    masks[i] = mask & later_lanes(i, count) & ~shared[i];
    hit |= LeafLanes(masks[i] != 0) << i;
  }
  return hit;
}
#endif

#if defined(SKELFORM_HAS_AVX2_KERNELS)
__attribute__((target("avx2"))) inline LeafLanes leaf_self_avx2(const LeafPairInput& in, uint32_t first, uint32_t count,
                                                                const float* node_box, const LeafLanes* shared,
                                                                LeafLanes* masks) {
  LeafLanes hit = 0;
  const size_t bs = in.box_stride;
  const float* lo_x = in.planes + first;
  if (!node_box_usable(node_box)) {
    for (uint32_t i = 0; i < count; ++i) masks[i] = 0;
    return 0;
  }
  for (uint32_t i = 0; i < count; ++i) {
    const float* pa = lo_x + i;
    const __m256 lx = _mm256_set1_ps(pa[0]), ly = _mm256_set1_ps(pa[bs]), lz = _mm256_set1_ps(pa[2 * bs]);
    const __m256 hx = _mm256_set1_ps(pa[3 * bs]), hy = _mm256_set1_ps(pa[4 * bs]), hz = _mm256_set1_ps(pa[5 * bs]);
    LeafLanes mask = 0;
    for (uint32_t g = (i + 1) & ~7u; g < count; g += 8) {  // as in leaf_self_sse2
      __m256 meet = _mm256_and_ps(_mm256_cmp_ps(lx, _mm256_loadu_ps(lo_x + 3 * bs + g), _CMP_LE_OQ),
                                  _mm256_cmp_ps(_mm256_loadu_ps(lo_x + g), hx, _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(ly, _mm256_loadu_ps(lo_x + 4 * bs + g), _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(_mm256_loadu_ps(lo_x + bs + g), hy, _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(lz, _mm256_loadu_ps(lo_x + 5 * bs + g), _CMP_LE_OQ));
      meet = _mm256_and_ps(meet, _mm256_cmp_ps(_mm256_loadu_ps(lo_x + 2 * bs + g), hz, _CMP_LE_OQ));
      mask |= LeafLanes(_mm256_movemask_ps(meet)) << g;
    }
    masks[i] = mask & later_lanes(i, count) & ~shared[i];
    hit |= LeafLanes(masks[i] != 0) << i;
  }
  return hit;
}
#endif

// The fastest kernel this CPU runs: AVX2 where the CPU has it (checked once), else SSE2
// (x86-64's baseline), else the portable loop. All give the same masks.
inline LeafPairKernel leaf_pair_kernel() {
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  return cpu_has_avx2() ? LeafPairKernel(&leaf_pair_avx2) : LeafPairKernel(&leaf_pair_sse2);
#elif defined(__SSE2__)
  return &leaf_pair_sse2;
#else
  return &leaf_pair_portable;
#endif
}

inline LeafSelfKernel leaf_self_kernel() {  // as leaf_pair_kernel()
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  return cpu_has_avx2() ? LeafSelfKernel(&leaf_self_avx2) : LeafSelfKernel(&leaf_self_sse2);
#elif defined(__SSE2__)
  return &leaf_self_sse2;
#else
  return &leaf_self_portable;
#endif
}

}  // namespace detail

// Calls visit(s, t) once for every unordered pair of distinct triangles that share no corner
// and whose boxes (`boxes`, by slot) meet, at least one of them marked in `wanted` (by slot,
// non-zero; slot_stride() flags, read a leaf's kLeafTriangles at a time), by a simultaneous
// descent of the hierarchy against itself: node pairs whose boxes (`node_boxes`) miss each
// other, or that hold no wanted triangle, are pruned as wholes (`node_wanted` per node and
// `leaf_wanted`, a leaf's wanted lanes, are filled here);
// at two leaves, a triangle meets all lanes of the other leaf at once. A visitor that returns
// bool stops the search by returning false (a work budget); the call then returns false.
// `apart(a, b)`, for two leaves (a = b: a leaf against itself), may tell that none of their
// triangles meet: their pairs are then passed over.
template <class Visit, class Apart>
bool self_pairs_triangle_hierarchy(const TriangleHierarchy& h, const float* node_boxes, const SlotBoxes& boxes,
                                   const uint8_t* wanted, uint8_t* node_wanted, LeafLanes* leaf_wanted, Visit&& visit,
                                   Apart&& apart) {
  static_assert(kLeafTriangles % 8 == 0 && kLeafTriangles < 64, "a leaf: groups of eight lanes, its lanes one word");
  if (h.nodes.empty()) return true;
  detail::mark_wanted(h, wanted, node_wanted, leaf_wanted);
  const detail::LeafPairInput input{boxes.planes.data(), boxes.stride, h.corners.data(), h.slot_stride()};
  const detail::LeafPairKernel kernel = detail::leaf_pair_kernel();
  const detail::LeafSelfKernel self_kernel = detail::leaf_self_kernel();
  LeafLanes masks[kLeafTriangles];
  // Leaf a's triangles against the lanes of leaf b (a leaf against itself: the lanes after each
  // row, as the self kernel gives them): all the kernel's lanes of a wanted row, the wanted ones
  // of another. False when the visitor stopped.
  auto leaves = [&](uint32_t a, uint32_t b) {
    if (apart(a, b)) return true;
    const LeafLanes want_a = leaf_wanted[a], want_b = leaf_wanted[b];
    const HierarchyNode na = h.nodes[a], nb = h.nodes[b];
    LeafLanes hit = a == b ? self_kernel(input, na.first, na.count, node_boxes + 6 * size_t(a),
                                         h.shared_in_leaf.data() + na.first, masks)
                           : kernel(input, na.first, na.count, nb.first, nb.count, node_boxes + 6 * size_t(b), masks);
    while (hit) {
      const uint32_t i = uint32_t(__builtin_ctzll(hit));
      hit &= hit - 1;
      LeafLanes mask = (want_a >> i) & 1 ? masks[i] : masks[i] & want_b;
      const uint32_t s = h.order[na.first + i];
      while (mask) {
        const uint32_t j = uint32_t(__builtin_ctzll(mask));
        mask &= mask - 1;
        if (!detail::visit_goes_on(visit, s, h.order[nb.first + j])) return false;
      }
    }
    return true;
  };
  // A pair of nodes to compare; a == b: a node against itself.
  struct Pair {
    uint32_t a, b;
  };
  Pair stack[8 * kMaxHierarchyDepth];  // a descent holds at most ~4 pending pairs per level
  uint32_t top = 0;
  stack[top++] = {0, 0};
  while (top > 0) {
    const Pair p = stack[--top];
    if (!(node_wanted[p.a] | node_wanted[p.b])) continue;
    const HierarchyNode na = h.nodes[p.a], nb = h.nodes[p.b];
    if (p.a == p.b) {
      if (na.count > 0) {
        if (!leaves(p.a, p.a)) return false;
      } else {
        stack[top++] = {na.first, na.first + 1};
        stack[top++] = {na.first + 1, na.first + 1};
        stack[top++] = {na.first, na.first};
      }
      continue;
    }
    if (!hierarchy_boxes_meet(node_boxes + 6 * size_t(p.a), node_boxes + 6 * size_t(p.b))) continue;
    if (na.count > 0 && nb.count > 0) {
      if (!leaves(p.a, p.b)) return false;
      continue;
    }
    // Descend the inner node; when both are, the one with the larger box.
    auto size = [&](uint32_t n) {
      const float* b = node_boxes + 6 * size_t(n);
      return (b[3] - b[0]) + (b[4] - b[1]) + (b[5] - b[2]);
    };
    const bool split_a = nb.count > 0 || (na.count == 0 && size(p.a) >= size(p.b));
    if (split_a) {
      stack[top++] = {na.first, p.b};
      stack[top++] = {na.first + 1, p.b};
    } else {
      stack[top++] = {p.a, nb.first};
      stack[top++] = {p.a, nb.first + 1};
    }
  }
  return true;
}

template <class Visit>
bool self_pairs_triangle_hierarchy(const TriangleHierarchy& h, const float* node_boxes, const SlotBoxes& boxes,
                                   const uint8_t* wanted, uint8_t* node_wanted, LeafLanes* leaf_wanted, Visit&& visit) {
  return self_pairs_triangle_hierarchy(h, node_boxes, boxes, wanted, node_wanted, leaf_wanted,
                                       std::forward<Visit>(visit), [](uint32_t, uint32_t) { return false; });
}

}  // namespace skelform::runtime
