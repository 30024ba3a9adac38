// Median-split bounding-volume hierarchy over triangles (triangle_hierarchy.h).
#include "triangle_hierarchy.h"

#include <algorithm>
#include <numeric>

namespace skelform::bake::detail {
namespace {

struct Builder {
  const std::vector<Vec3>& centroids;
  const std::vector<Box>& boxes;
  TriangleHierarchy& tree;

  void build(uint32_t node_index, uint32_t first, uint32_t count) {
    Box node_box, centroid_box;
    for (uint32_t i = first; i < first + count; ++i) {
      node_box.grow(boxes[tree.triangle_order[i]]);
      centroid_box.grow(centroids[tree.triangle_order[i]]);
    }
    tree.nodes[node_index].box = node_box;
    const Vec3 extent = centroid_box.max - centroid_box.min;
    const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
    if (count <= TriangleHierarchy::kLeafSize || !(extent[axis] > 0.0)) {
      tree.nodes[node_index].first = first;
      tree.nodes[node_index].count = count;
      return;
    }
    // Median split along the widest centroid axis: balanced depth, O(n log n) build.
    const uint32_t half = count / 2;
    auto begin = tree.triangle_order.begin() + first;
    std::nth_element(begin, begin + half, begin + count,
                     [&](uint32_t l, uint32_t r) { return centroids[l][axis] < centroids[r][axis]; });
    const uint32_t left = static_cast<uint32_t>(tree.nodes.size());
    tree.nodes.emplace_back();
    tree.nodes.emplace_back();
    tree.nodes[node_index].first = left;
    tree.nodes[node_index].count = 0;
    build(left, first, half);
    build(left + 1, first + half, count - half);
  }
};

}  // namespace

TriangleHierarchy build_triangle_hierarchy(const TriangleMesh& mesh) {
  TriangleHierarchy tree;
  const size_t triangle_count = mesh.triangles.size();
  if (triangle_count == 0) return tree;
  std::vector<Vec3> centroids(triangle_count);
  std::vector<Box> boxes(triangle_count);
  for (size_t t = 0; t < triangle_count; ++t) {
    for (uint32_t corner : mesh.triangles[t]) boxes[t].grow(mesh.positions[corner]);
    centroids[t] = (mesh.positions[mesh.triangles[t][0]] + mesh.positions[mesh.triangles[t][1]] +
                    mesh.positions[mesh.triangles[t][2]]) /
                   3.0;
  }
  tree.triangle_order.resize(triangle_count);
  std::iota(tree.triangle_order.begin(), tree.triangle_order.end(), 0u);
  tree.nodes.reserve(2 * triangle_count);
  tree.nodes.emplace_back();
  Builder{centroids, boxes, tree}.build(0, 0, static_cast<uint32_t>(triangle_count));
  return tree;
}

}  // namespace skelform::bake::detail
