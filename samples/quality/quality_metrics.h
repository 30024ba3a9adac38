// The quality metrics of DESIGN.md "Metrics", on a posed dense mesh as the runtime writes it
// (all primitives of a deformable, original vertex order), for skelform-quality and its tests.
//
// Topology is taken once, from the mesh as stored: vertices at bit-equal positions are one
// (glTF splits vertices at seams and between primitives), degenerate and repeated triangles
// are dropped. A posed mesh is read through that welding (each welded vertex at its first
// original vertex's posed position), so pairs of triangles that share a position as modelled
// stay adjacent in every pose.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace skelform::samples {

struct DenseTopology {
  std::vector<uint32_t> welded_of_vertex;          // per original vertex
  std::vector<uint32_t> vertex_of_welded;          // first original vertex of each welded vertex
  std::vector<std::array<uint32_t, 3>> triangles;  // welded corners, non-degenerate, unique
  // Every edge has exactly two triangles that use it in opposite directions: the mesh bounds
  // a volume (it may still intersect itself).
  bool closed = false;
};

// `positions`: 3 floats per original vertex; `triangles`: 3 original indices per triangle.
DenseTopology dense_topology(const std::vector<float>& positions, const std::vector<uint32_t>& triangles);

using TrianglePair = std::pair<uint32_t, uint32_t>;

// Intersecting pairs of non-adjacent triangles (no shared welded vertex) of the posed mesh,
// sorted; triangle indices into topology.triangles. Exact for the float input
// (triangles_intersect in bake/self_intersection.h decides each candidate pair; its broad
// phase misses none, which the tests check against every pair).
std::vector<TrianglePair> intersecting_pairs(const DenseTopology& topology, const std::vector<float>& positions);

// Pairs of `posed` that are not in `reference` (both sorted): the pairs a pose adds.
size_t pairs_added(const std::vector<TrianglePair>& posed, const std::vector<TrianglePair>& reference);

// Parts modelled through each other (a spider's legs pushed into its body, a sword through a
// belt): a part is a connected piece of the welded mesh (triangles sharing a welded vertex),
// and two parts are joined when a pair of their triangles intersects in the reference pose.
// Where joined parts move against each other, the curve where they cross slides over their
// triangles, and the pairs it crosses change: pairs added over the reference that no
// deformation keeping both parts' shapes can avoid. Every added pair between two joined parts
// counts, also one far from where they cross (a leg stuck into the body that later touches
// it elsewhere): the count bounds the unavoidable pairs from above.
struct Junctions {
  std::vector<uint32_t> part;                         // per triangle of the topology
  std::vector<std::pair<uint32_t, uint32_t>> joined;  // (lower, higher) part, sorted, unique
};
Junctions find_junctions(const DenseTopology& topology, const std::vector<TrianglePair>& reference);

// Of the pairs `posed` adds over `reference` (both sorted), those between two joined parts.
size_t pairs_added_at_junctions(const std::vector<TrianglePair>& posed, const std::vector<TrianglePair>& reference,
                                const Junctions& junctions);

// Signed volume bounded by the welded triangles (divergence theorem, double); meaningful
// when topology.closed.
double enclosed_volume(const DenseTopology& topology, const std::vector<float>& positions);

// Bounding-box diagonal of 3-float positions.
double bounding_diagonal(const std::vector<float>& positions);

}  // namespace skelform::samples
