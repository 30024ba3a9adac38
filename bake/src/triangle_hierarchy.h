// Internal to the baker's metrics: a binary bounding-volume hierarchy over a mesh's triangles,
// shared by the closest-point tree (metrics.cpp) and the fast winding number
// (winding_number.cpp), so both group triangles the same way.
#pragma once

#include "skelform/bake/mesh.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <cstdint>
#include <limits>
#include <vector>

namespace skelform::bake::detail {

// An axis-aligned box; the default one is empty (min > max) and grows to what it is given.
struct Box {
  Vec3 min{std::numeric_limits<double>::max()};
  Vec3 max{std::numeric_limits<double>::lowest()};
  void grow(const Vec3& p) {
    min = glm::min(min, p);
    max = glm::max(max, p);
  }
  void grow(const Box& other) {
    min = glm::min(min, other.min);
    max = glm::max(max, other.max);
  }
  double squared_distance(const Vec3& p) const {
    const Vec3 outside = glm::max(glm::max(min - p, p - max), Vec3(0.0));
    return glm::dot(outside, outside);
  }
};

// The root is node 0. A leaf lists `count` triangles from triangle_order[first]; an inner
// node (count == 0) has its children at `first` and `first + 1`, after itself. Median splits of the triangle centroids along their widest axis keep the
// depth near log2(triangles / kLeafSize); a node whose centroids all coincide stays a leaf,
// however many triangles it holds.
struct TriangleHierarchy {
  static constexpr uint32_t kLeafSize = 4;
  struct Node {
    Box box;             // bounds of the node's triangles
    uint32_t first = 0;  // leaf: first entry in triangle_order; inner: index of the left child
    uint32_t count = 0;  // leaf: number of triangles; inner: 0
  };
  std::vector<uint32_t> triangle_order;
  std::vector<Node> nodes;  // empty for a mesh without triangles
};

TriangleHierarchy build_triangle_hierarchy(const TriangleMesh& mesh);

}  // namespace skelform::bake::detail
