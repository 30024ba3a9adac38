// Delta Mush (Mancewicz, Derksen, Rijpkema, Joe 2014), the per-frame baseline DESIGN.md's
// "per-frame cost" metric compares skelform with, as Maya ships it: 10 smoothing iterations.
//
// Bake (once, at rest): on the welded dense mesh, smooth the rest positions with `iterations`
// uniform Laplacian steps p <- p + factor·(mean(neighbours) − p); store each vertex's rest
// delta (rest − smoothed rest) in a local frame at its smoothed position: the smoothed
// vertex normal n (area-weighted), a tangent t from its first neighbour's edge made
// orthogonal to n, and b = n × t.
// Per frame: linear blend skinning of the welded vertices, the same smoothing, the frame at
// each smoothed deformed vertex, and the delta added back in that frame. Results go out in
// the original (unwelded) vertex order; vertices that share a position share the result.
//
// All memory is allocated in the constructor; deform() does not allocate. Single-threaded.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace skelform::bench {

struct DeltaMushOptions {
  int iterations = 10;  // Maya's default
  float factor = 0.5f;  // step of each uniform Laplacian iteration
};

class DeltaMush {
 public:
  // rest_positions: 3 floats per original vertex; triangles: 3 indices per triangle into
  // them; joints/weights: `influences_per_vertex` entries per original vertex (any count,
  // e.g. 4 per JOINTS_n/WEIGHTS_n set), weights summing to 1. Vertices with equal positions
  // are welded. Throws std::invalid_argument on inconsistent sizes or indices.
  DeltaMush(const std::vector<float>& rest_positions, const std::vector<uint32_t>& triangles,
            const std::vector<uint16_t>& joints, const std::vector<float>& weights, size_t influences_per_vertex,
            const DeltaMushOptions& options = {});

  size_t vertex_count() const { return original_to_welded_.size(); }
  size_t welded_vertex_count() const { return welded_rest_.size() / 3; }

  // Deforms with `joint_count` column-major joint matrices (jointWorld × inverseBind) and
  // writes 3 floats per original vertex into out_positions.
  void deform(const float* joint_matrices, size_t joint_count, float* out_positions);

 private:
  void smooth(std::vector<float>& positions);  // `iterations` steps in place (uses scratch_)
  // Local frame (t, b, n) at every welded vertex of `positions`, into frames_.
  void compute_frames(const std::vector<float>& positions);

  DeltaMushOptions options_;
  std::vector<uint32_t> original_to_welded_;
  std::vector<float> welded_rest_;           // 3 per welded vertex
  std::vector<uint32_t> welded_triangles_;   // 3 per triangle, welded indices
  std::vector<uint32_t> neighbour_offsets_;  // CSR adjacency of the welded mesh
  std::vector<uint32_t> neighbours_;
  std::vector<uint16_t> joints_;  // influences_ per welded vertex
  std::vector<float> weights_;
  size_t influences_ = 0;
  std::vector<float> local_delta_;  // 3 per welded vertex: (t, b, n) components
  // Per-frame scratch, sized once.
  std::vector<float> skinned_, scratch_, frames_;  // frames_: 9 per vertex (t, b, n)
};

}  // namespace skelform::bench
