// Vertex adjacency and normals of a triangle mesh, as the flows and the skeleton use them.
#pragma once

#include "skelform/bake/mesh.h"

#include <vector>

namespace skelform::bake {

// One-ring neighbours in compressed rows: the neighbours of vertex v are
// neighbours[offsets[v] .. offsets[v+1]), each once, sorted ascending.
struct VertexAdjacency {
  std::vector<uint32_t> offsets;
  std::vector<uint32_t> neighbours;
  // A vertex on an edge with exactly one incident triangle (an open border). Non-manifold
  // edges (three or more triangles) do not make a vertex a border vertex.
  std::vector<bool> on_border;

  size_t vertex_count() const { return offsets.empty() ? 0 : offsets.size() - 1; }
  size_t degree(uint32_t v) const { return offsets[v + 1] - offsets[v]; }
};

VertexAdjacency build_adjacency(const TriangleMesh& mesh);

// Unit outward normals: normalised area-weighted sum of incident face normals (the paper's
// choice). A vertex with no incident non-degenerate triangle gets (0, 0, 0).
std::vector<Vec3> area_weighted_normals(const TriangleMesh& mesh);

}  // namespace skelform::bake
