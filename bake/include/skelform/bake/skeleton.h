// Voronoi-based skeletal mesh (paper section 2, DESIGN.md bake step 5).
#pragma once

#include "skelform/bake/mesh.h"

#include <cstddef>
#include <vector>

namespace skelform::bake {

// The most vertices extract_skeleton accepts: 2^19 = 524,288, a closed mesh of about a
// million triangles. The Delaunay tetrahedralization (Qhull) dominates the extraction's time
// and memory, both growing slightly faster than linearly; the limit bounds them. Decimate
// larger meshes first, as the bake does.
inline constexpr size_t kMaxSkeletonVertices = size_t{1} << 19;

struct SkeletonOptions {
  // Inner Voronoi vertices outside the mesh bounding box grown by this fraction of its
  // diagonal are dropped.
  double bounding_box_margin = 0.05;
};

struct SkeletalMesh {
  // Same connectivity as the input mesh: one skeletal vertex per mesh vertex, and
  // M = S + d·N at every vertex.
  std::vector<Vec3> skeletal_positions;  // S
  std::vector<double> medial_radius;     // d >= 0
  std::vector<Vec3> normals;             // N: unit outward area-weighted normals of M
  // Per vertex: how many inner Voronoi vertices were averaged (0 = d came from neighbours).
  std::vector<uint32_t> voronoi_vertex_count;
  // The inner Voronoi vertices kept (after the inner/bounding-box/pole filters), each once,
  // for display (the paper's Fig. 6 left).
  std::vector<Vec3> kept_voronoi_vertices;
  size_t vertices_without_candidates = 0;
};

// Throws Error(unsupported) for a mesh of more than kMaxSkeletonVertices vertices, and
// Error(invalid_input) when the mesh has fewer than 4 distinct vertices used by triangles,
// when those are all coplanar, when a position is not finite or an index is out of range, and
// when Qhull fails (its message in the Error; Qhull never prints).
// Rules beyond the paper: the mesh must be outward-oriented (N is the outward normal and
// candidates are taken on its negative side). A vertex whose only inner Voronoi vertex is its
// pole keeps it (exactly cospherical input, e.g. a sphere, has one merged Delaunay cell whose
// circumcentre is the centre). A vertex with no candidate gets d as the mean over the one-ring
// neighbours that have a d, spreading front by front; in a connected component where no
// vertex has a candidate, d = 0 (S = M). Vertices no triangle uses stay out of the Voronoi
// diagram and have N = 0, so S = M; exactly coincident vertices share one Voronoi cell.
SkeletalMesh extract_skeleton(const TriangleMesh& mesh, const SkeletonOptions& options = {});

}  // namespace skelform::bake
