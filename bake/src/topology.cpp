// Vertex one-rings, open-border detection and area-weighted vertex normals (paper section 2:
// "the normal at a mesh vertex is computed as the normalized area-weighting mean of the
// normals of the mesh triangles incident to the vertex").
#include "skelform/bake/topology.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <utility>

namespace skelform::bake {

VertexAdjacency build_adjacency(const TriangleMesh& mesh) {
  const size_t vertex_count = mesh.positions.size();
  VertexAdjacency adjacency;
  adjacency.offsets.assign(vertex_count + 1, 0);
  adjacency.on_border.assign(vertex_count, false);

  // Every undirected edge (lo, hi) once per incident triangle; a degenerate triangle with a
  // repeated corner contributes no edge between equal indices. Sorting the list both
  // deduplicates the one-rings and counts the triangles per edge, which decides the border.
  std::vector<std::pair<uint32_t, uint32_t>> edges;
  edges.reserve(mesh.triangles.size() * 3);
  for (const Triangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      if (a == b || a >= vertex_count || b >= vertex_count) continue;
      edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  }
  std::sort(edges.begin(), edges.end());

  std::vector<std::pair<uint32_t, uint32_t>> unique_edges;
  unique_edges.reserve(edges.size() / 2 + 1);
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    // Exactly one incident triangle: an open border. Two or more (manifold or not): interior.
    if (j - i == 1) {
      adjacency.on_border[edges[i].first] = true;
      adjacency.on_border[edges[i].second] = true;
    }
    unique_edges.push_back(edges[i]);
    i = j;
  }

  for (const auto& [lo, hi] : unique_edges) {
    ++adjacency.offsets[lo + 1];
    ++adjacency.offsets[hi + 1];
  }
  for (size_t v = 0; v < vertex_count; ++v) adjacency.offsets[v + 1] += adjacency.offsets[v];
  adjacency.neighbours.resize(adjacency.offsets[vertex_count]);
  std::vector<uint32_t> fill(adjacency.offsets.begin(), adjacency.offsets.end() - 1);
  // unique_edges is sorted by (lo, hi), so the first pass writes each row's smaller
  // neighbours in ascending order and the second pass appends its larger ones, also
  // ascending: every row comes out sorted without a per-row sort.
  for (const auto& [lo, hi] : unique_edges) adjacency.neighbours[fill[hi]++] = lo;
  for (const auto& [lo, hi] : unique_edges) adjacency.neighbours[fill[lo]++] = hi;
  return adjacency;
}

std::vector<Vec3> area_weighted_normals(const TriangleMesh& mesh) {
  std::vector<Vec3> normals(mesh.positions.size(), Vec3(0.0));
  const size_t vertex_count = mesh.positions.size();
  for (const Triangle& t : mesh.triangles) {
    if (t[0] >= vertex_count || t[1] >= vertex_count || t[2] >= vertex_count) continue;
    const Vec3& a = mesh.positions[t[0]];
    // The cross product's length is twice the triangle's area: summing it unnormalised is
    // the area weighting.
    const Vec3 twice_area_normal = glm::cross(mesh.positions[t[1]] - a, mesh.positions[t[2]] - a);
    for (uint32_t corner : t) normals[corner] += twice_area_normal;
  }
  for (Vec3& n : normals) {
    const double length = glm::length(n);
    // Exactly cancelling sums (a face and its reverse) and isolated vertices give zero.
    if (length > 0.0 && std::isfinite(length)) {
      n /= length;
    } else {
      n = Vec3(0.0);
    }
  }
  return normals;
}

}  // namespace skelform::bake
