// A bounding-volume hierarchy over the triangles of a deforming mesh: its shape (which
// triangles share a node) is built once from the rest pose, and every evaluation refits the
// node boxes to the triangles' current boxes (a limb that moves keeps its triangles together,
// so a rest-pose hierarchy stays tight under skinning). A box query then visits the nodes
// whose boxes meet it and reports each triangle whose box does, once.
#pragma once

#include "memory.h"

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif

#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cstdint>
#include <limits>

namespace skelform::runtime {

// A node: a leaf lists `count` triangles from TriangleHierarchy::order[first]; an inner node
// (count == 0) has its children at `first` and `first + 1`. Children follow their parent.
struct HierarchyNode {
  uint32_t first = 0;
  uint32_t count = 0;
};

constexpr uint32_t kLeafTriangles = 16;
constexpr uint32_t kMaxHierarchyDepth = 64;

struct TriangleHierarchy {
  explicit TriangleHierarchy(const AllocatorRef& a)
      : nodes(CallbackAllocator<HierarchyNode>(a)),
        order(CallbackAllocator<uint32_t>(a)),
        slot(CallbackAllocator<uint32_t>(a)),
        corners(CallbackAllocator<uint32_t>(a)) {}
  Array<HierarchyNode> nodes;
  Array<uint32_t> order;  // triangle indices, leaf by leaf: position i is "slot" i
  Array<uint32_t> slot;   // per triangle: its slot (order's inverse)
  // The triangles' corners by slot, three planes of slot_stride() entries (corner k of the
  // triangle in slot i at k·stride + i), so a leaf's corners load as lanes; the padding
  // after the last slot holds ~0u, which names no vertex.
  Array<uint32_t> corners;
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

// Builds the hierarchy of `triangle_count` triangles (3 vertex indices each into `positions`)
// by median splits of their centroids along the longest axis, at most kLeafTriangles per leaf
// (a median split halves a node, so 2^32 triangles need 30 of the kMaxHierarchyDepth levels). Throws std::bad_alloc.
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
    const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
    const uint32_t half = count / 2;
    std::nth_element(h.order.begin() + first, h.order.begin() + first + half, h.order.begin() + first + count,
                     [&](uint32_t a, uint32_t b) {
                       return centroid[a][axis] < centroid[b][axis] ||
                              (centroid[a][axis] == centroid[b][axis] && a < b);
                     });
    const uint32_t left = uint32_t(h.nodes.size());
    h.nodes.push_back({first, half});
    h.nodes.push_back({first + half, count - half});
    h.nodes[p.node] = {left, 0};
    stack[top++] = {left, p.depth + 1};
    stack[top++] = {left + 1, p.depth + 1};
  }
  h.slot.resize(triangle_count);
  const size_t stride = h.slot_stride();
  h.corners.assign(3 * stride, ~0u);
  for (uint32_t i = 0; i < triangle_count; ++i) {
    const uint32_t t = h.order[i];
    h.slot[t] = i;
    for (size_t k = 0; k < 3; ++k) h.corners[k * stride + i] = triangles[3 * size_t(t) + k];
  }
  return h;
}

// Node boxes (6 floats per node: lo xyz, hi xyz) from the triangles' boxes, children before
// parents; a leaf reads its slots' lanes, contiguous in each plane.
inline void refit_triangle_hierarchy(const TriangleHierarchy& h, const SlotBoxes& boxes, float* node_boxes) {
  for (size_t n = h.nodes.size(); n-- > 0;) {
    const HierarchyNode node = h.nodes[n];
    float* b = node_boxes + 6 * n;
    if (node.count > 0) {
      for (size_t k = 0; k < 3; ++k) {
        const float* lo = boxes.planes.data() + k * boxes.stride + node.first;
        const float* hi = boxes.planes.data() + (3 + k) * boxes.stride + node.first;
        float l = lo[0], u = hi[0];
        for (uint32_t i = 1; i < node.count; ++i) {
          l = std::min(l, lo[i]);
          u = std::max(u, hi[i]);
        }
        b[k] = l;
        b[3 + k] = u;
      }
    } else {
      const float* c0 = node_boxes + 6 * size_t(node.first);
      const float* c1 = node_boxes + 6 * size_t(node.first + 1);
      for (int k = 0; k < 3; ++k) {
        b[k] = std::min(c0[k], c1[k]);
        b[3 + k] = std::max(c0[3 + k], c1[3 + k]);
      }
    }
  }
}

inline bool hierarchy_boxes_meet(const float* a, const float* b) {
  return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

// Calls visit(t) for every triangle t whose box (`boxes`, by slot) meets `box`.
template <class Visit>
void query_triangle_hierarchy(const TriangleHierarchy& h, const float* node_boxes, const SlotBoxes& boxes,
                              const float* box, Visit&& visit) {
  if (h.nodes.empty()) return;
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
      for (uint32_t i = node.first; i < node.first + node.count; ++i)
        if (box[0] <= p[3 * bs + i] && p[i] <= box[3] && box[1] <= p[4 * bs + i] && p[bs + i] <= box[4] &&
            box[2] <= p[5 * bs + i] && p[2 * bs + i] <= box[5])
          visit(h.order[i]);
    } else {
      stack[top++] = node.first + 1;
      stack[top++] = node.first;
    }
  }
}

namespace detail {

// Bit j set: lane j of the leaf at `first` (slot space, kLeafTriangles lanes) holds a
// triangle whose box (`boxes`) meets `box` and that shares no corner with `c` (3 vertex
// indices). Lanes past the leaf are not masked here.
inline uint32_t leaf_candidates(const SlotBoxes& boxes, const uint32_t* corners, size_t stride, size_t first,
                                const float* box, const uint32_t* c) {
  const float* lo_x = boxes.planes.data() + first;
  const size_t bs = boxes.stride;
  uint32_t mask = 0;
#if defined(__SSE2__)
  for (size_t g = 0; g < kLeafTriangles; g += 4) {
    __m128 meet = _mm_and_ps(_mm_cmple_ps(_mm_set1_ps(box[0]), _mm_loadu_ps(lo_x + 3 * bs + g)),
                             _mm_cmple_ps(_mm_loadu_ps(lo_x + g), _mm_set1_ps(box[3])));
    meet = _mm_and_ps(meet, _mm_cmple_ps(_mm_set1_ps(box[1]), _mm_loadu_ps(lo_x + 4 * bs + g)));
    meet = _mm_and_ps(meet, _mm_cmple_ps(_mm_loadu_ps(lo_x + bs + g), _mm_set1_ps(box[4])));
    meet = _mm_and_ps(meet, _mm_cmple_ps(_mm_set1_ps(box[2]), _mm_loadu_ps(lo_x + 5 * bs + g)));
    meet = _mm_and_ps(meet, _mm_cmple_ps(_mm_loadu_ps(lo_x + 2 * bs + g), _mm_set1_ps(box[5])));
    __m128i shared = _mm_setzero_si128();
    for (size_t k = 0; k < 3; ++k) {
      const __m128i lane = _mm_loadu_si128(reinterpret_cast<const __m128i*>(corners + k * stride + first + g));
      for (size_t j = 0; j < 3; ++j)
        shared = _mm_or_si128(shared, _mm_cmpeq_epi32(lane, _mm_set1_epi32(int32_t(c[j]))));
    }
    const __m128 keep = _mm_andnot_ps(_mm_castsi128_ps(shared), meet);
    mask |= uint32_t(_mm_movemask_ps(keep)) << g;
  }
#else
  for (size_t g = 0; g < kLeafTriangles; ++g) {
    const bool meet = box[0] <= lo_x[3 * bs + g] && lo_x[g] <= box[3] && box[1] <= lo_x[4 * bs + g] &&
                      lo_x[bs + g] <= box[4] && box[2] <= lo_x[5 * bs + g] && lo_x[2 * bs + g] <= box[5];
    bool shared = false;
    for (size_t k = 0; k < 3; ++k)
      for (size_t j = 0; j < 3; ++j) shared |= corners[k * stride + first + g] == c[j];
    mask |= uint32_t(meet && !shared) << g;
  }
#endif
  return mask;
}

}  // namespace detail

// Calls visit(s, t) once for every unordered pair of distinct triangles that share no corner
// and whose boxes (`boxes`, by slot) meet, at least one of them marked in `wanted` (per
// triangle, non-zero), by a simultaneous descent of the hierarchy against itself: node pairs
// whose boxes (`node_boxes`) miss each other, or that hold no wanted triangle, are pruned as
// wholes (`node_wanted` per node and `leaf_wanted`, a leaf's wanted lanes, are filled here);
// at two leaves, a triangle meets all lanes of the other leaf at once.
template <class Visit>
void self_pairs_triangle_hierarchy(const TriangleHierarchy& h, const float* node_boxes, const SlotBoxes& boxes,
                                   const uint8_t* wanted, uint8_t* node_wanted, uint32_t* leaf_wanted, Visit&& visit) {
  static_assert(kLeafTriangles % 4 == 0 && kLeafTriangles < 32, "a leaf: groups of four lanes, its lanes one word");
  if (h.nodes.empty()) return;
  for (size_t n = h.nodes.size(); n-- > 0;) {
    const HierarchyNode node = h.nodes[n];
    uint32_t lanes = 0;
    if (node.count > 0) {
      for (uint32_t i = 0; i < node.count; ++i) lanes |= (wanted[h.order[node.first + i]] ? 1u : 0u) << i;
      node_wanted[n] = lanes ? 1 : 0;
    } else {
      node_wanted[n] = node_wanted[node.first] | node_wanted[node.first + 1];
    }
    leaf_wanted[n] = lanes;
  }
  const size_t stride = h.slot_stride();
  const uint32_t* corners = h.corners.data();
  // The triangle in slot i against the lanes of leaf node b set in `allowed`.
  auto against_leaf = [&](uint32_t i, uint32_t b, uint32_t allowed) {
    float box[6];
    uint32_t c[3];
    boxes.get(i, box);
    for (size_t k = 0; k < 3; ++k) c[k] = corners[k * stride + i];
    if (!hierarchy_boxes_meet(box, node_boxes + 6 * size_t(b))) return;
    const uint32_t first = h.nodes[b].first;
    uint32_t mask = detail::leaf_candidates(boxes, corners, stride, first, box, c) & allowed;
    const uint32_t s = h.order[i];
    while (mask) {
      const uint32_t j = uint32_t(__builtin_ctz(mask));
      mask &= mask - 1;
      visit(s, h.order[first + j]);
    }
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
        const uint32_t lanes = (1u << na.count) - 1u;
        for (uint32_t i = 0; i + 1 < na.count; ++i) {
          const uint32_t later = lanes & ~((2u << i) - 1u);  // the lanes after i: each pair once
          against_leaf(na.first + i, p.a, (leaf_wanted[p.a] >> i) & 1u ? later : later & leaf_wanted[p.a]);
        }
      } else {
        stack[top++] = {na.first, na.first + 1};
        stack[top++] = {na.first + 1, na.first + 1};
        stack[top++] = {na.first, na.first};
      }
      continue;
    }
    if (!hierarchy_boxes_meet(node_boxes + 6 * size_t(p.a), node_boxes + 6 * size_t(p.b))) continue;
    if (na.count > 0 && nb.count > 0) {
      const uint32_t lanes = (1u << nb.count) - 1u;
      for (uint32_t i = 0; i < na.count; ++i)
        against_leaf(na.first + i, p.b, (leaf_wanted[p.a] >> i) & 1u ? lanes : lanes & leaf_wanted[p.b]);
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
}

}  // namespace skelform::runtime
