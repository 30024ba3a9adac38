// The self-intersection metric (DESIGN.md "Metrics"): the number of intersecting pairs of
// non-adjacent triangles of a triangle mesh. Used by tests, benchmarks and tool summaries to
// compare skelform's fairing (paper sec. 3.2, flow (5)) with LBS, DQS and Delta Mush.
#pragma once

#include "skelform/bake/mesh.h"

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace skelform::bake {

// True when the closed triangles (a0, a1, a2) and (b0, b1, b2) share at least one point
// (touching counts). Separating-axis test in double precision over the 17 candidate axes
// (two face normals, nine edge-edge cross products, six in-plane edge normals for the
// coplanar case), so crossing, touching and coplanar overlaps are all found. A degenerate
// triangle (a segment or a point) is handled by the same axes as far as they exist.
bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0, const Vec3& b1,
                         const Vec3& b2);

// Number of unordered pairs {s, t} of triangles of `mesh` that share no vertex index and
// intersect (triangles_intersect). Pairs of triangles sharing a vertex or an edge are never
// tested: their contact is the mesh's own connectivity. Welded meshes are expected; two
// triangles touching only through distinct vertices at the same position do count.
//
// Broad phase: a uniform grid over the mesh bounds with a cell about the mean triangle size;
// each pair is tested once, in the first grid cell shared by both triangles' boxes. Cost
// about linear in the triangle count for meshes of even triangle size (100K triangles in
// well under a second). Deterministic; indices must be in range (unchecked).
size_t count_self_intersections(const TriangleMesh& mesh);

// The same pairs themselves, as (smaller, larger) triangle indices in increasing order, so
// the pairs of two poses of one mesh can be compared (pairs added over the bind pose).
std::vector<std::pair<uint32_t, uint32_t>> self_intersecting_pairs(const TriangleMesh& mesh);

}  // namespace skelform::bake
