// A bounding-volume hierarchy over the triangles of a deforming mesh: its shape (which
// triangles share a node) is built once from the rest pose, and every evaluation refits the
// node boxes to the triangles' current boxes (a limb that moves keeps its triangles together,
// so a rest-pose hierarchy stays tight under skinning). A box query then visits the nodes
// whose boxes meet it and reports each triangle whose box does, once.
#pragma once

#include "memory.h"

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

constexpr uint32_t kLeafTriangles = 8;
constexpr uint32_t kMaxHierarchyDepth = 64;

struct TriangleHierarchy {
  explicit TriangleHierarchy(const AllocatorRef& a)
      : nodes(CallbackAllocator<HierarchyNode>(a)), order(CallbackAllocator<uint32_t>(a)) {}
  Array<HierarchyNode> nodes;
  Array<uint32_t> order;  // triangle indices, leaf by leaf
};

// Builds the hierarchy of `triangle_count` triangles (3 vertex indices each into `positions`)
// by median splits of their centroids along the longest axis, at most kLeafTriangles per leaf
// and kMaxHierarchyDepth levels. Throws std::bad_alloc.
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
                   positions[triangles[3 * size_t(t) + 2]]) / 3.0f;
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
                       return centroid[a][axis] < centroid[b][axis] || (centroid[a][axis] == centroid[b][axis] && a < b);
                     });
    const uint32_t left = uint32_t(h.nodes.size());
    h.nodes.push_back({first, half});
    h.nodes.push_back({first + half, count - half});
    h.nodes[p.node] = {left, 0};
    stack[top++] = {left, p.depth + 1};
    stack[top++] = {left + 1, p.depth + 1};
  }
  return h;
}

// Node boxes (6 floats per node: lo xyz, hi xyz) from the triangles' boxes (6 floats per
// triangle), children before parents.
inline void refit_triangle_hierarchy(const TriangleHierarchy& h, const float* triangle_boxes, float* node_boxes) {
  for (size_t n = h.nodes.size(); n-- > 0;) {
    const HierarchyNode node = h.nodes[n];
    float* b = node_boxes + 6 * n;
    for (int k = 0; k < 3; ++k) {
      b[k] = std::numeric_limits<float>::max();
      b[3 + k] = -std::numeric_limits<float>::max();
    }
    auto grow = [&](const float* c) {
      for (int k = 0; k < 3; ++k) {
        b[k] = std::min(b[k], c[k]);
        b[3 + k] = std::max(b[3 + k], c[3 + k]);
      }
    };
    if (node.count > 0) {
      for (uint32_t i = node.first; i < node.first + node.count; ++i) grow(triangle_boxes + 6 * size_t(h.order[i]));
    } else {
      grow(node_boxes + 6 * size_t(node.first));
      grow(node_boxes + 6 * size_t(node.first + 1));
    }
  }
}

inline bool hierarchy_boxes_meet(const float* a, const float* b) {
  return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

// Calls visit(t) for every triangle t whose box (triangle_boxes) meets `box`.
template <class Visit>
void query_triangle_hierarchy(const TriangleHierarchy& h, const float* node_boxes, const float* triangle_boxes,
                              const float* box, Visit&& visit) {
  if (h.nodes.empty()) return;
  uint32_t stack[kMaxHierarchyDepth + 1];
  uint32_t top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const uint32_t n = stack[--top];
    if (!hierarchy_boxes_meet(box, node_boxes + 6 * size_t(n))) continue;
    const HierarchyNode node = h.nodes[n];
    if (node.count > 0) {
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        const uint32_t t = h.order[i];
        if (hierarchy_boxes_meet(box, triangle_boxes + 6 * size_t(t))) visit(t);
      }
    } else {
      stack[top++] = node.first + 1;
      stack[top++] = node.first;
    }
  }
}

// Calls visit(s, t) once for every unordered pair of distinct triangles whose boxes meet, at
// least one of them marked in `wanted` (per triangle, non-zero), by a simultaneous descent of
// the hierarchy against itself: node pairs whose boxes miss each other, or that hold no wanted
// triangle (`node_wanted`, per node, filled here), are pruned as wholes.
template <class Visit>
void self_pairs_triangle_hierarchy(const TriangleHierarchy& h, const float* node_boxes, const float* triangle_boxes,
                                   const uint8_t* wanted, uint8_t* node_wanted, Visit&& visit) {
  if (h.nodes.empty()) return;
  for (size_t n = h.nodes.size(); n-- > 0;) {
    const HierarchyNode node = h.nodes[n];
    uint8_t any = 0;
    if (node.count > 0) {
      for (uint32_t i = node.first; i < node.first + node.count && !any; ++i) any = wanted[h.order[i]] ? 1 : 0;
    } else {
      any = node_wanted[node.first] | node_wanted[node.first + 1];
    }
    node_wanted[n] = any;
  }
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
        for (uint32_t i = na.first; i < na.first + na.count; ++i)
          for (uint32_t j = i + 1; j < na.first + na.count; ++j) {
            const uint32_t s = h.order[i], t = h.order[j];
            if ((wanted[s] | wanted[t]) &&
                hierarchy_boxes_meet(triangle_boxes + 6 * size_t(s), triangle_boxes + 6 * size_t(t)))
              visit(s, t);
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
      for (uint32_t i = na.first; i < na.first + na.count; ++i) {
        const uint32_t s = h.order[i];
        const float* bs = triangle_boxes + 6 * size_t(s);
        if (!hierarchy_boxes_meet(bs, node_boxes + 6 * size_t(p.b))) continue;
        for (uint32_t j = nb.first; j < nb.first + nb.count; ++j) {
          const uint32_t t = h.order[j];
          if ((wanted[s] | wanted[t]) && hierarchy_boxes_meet(bs, triangle_boxes + 6 * size_t(t))) visit(s, t);
        }
      }
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
