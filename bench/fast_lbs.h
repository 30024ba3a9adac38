// The speed baseline skelform is compared with: linear blend skinning as a game engine's
// skinning job does it (ozz-animation's SkinningJob, a hand-written engine loop), not the
// runtime's SF_METHOD_LBS path. Per vertex: the influences' joint matrices blended as 3x4
// column blocks (two 8-float FMA lanes per influence with AVX2, four 4-float lanes with SSE2),
// the position and normal transformed by the blend and the normal renormalised, both stored
// straight into the caller's interleaved vertex buffer (any stride). The kernel is chosen at
// run time: AVX2 + FMA when the CPU has them, else SSE2 (x86-64's baseline), else a portable
// loop.
//
// All memory is allocated in the constructor; skin() does not allocate. Single-threaded.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace skelform::bench {

class FastLbs {
 public:
  // rest_positions, rest_normals: 3 floats per vertex; joints/weights: `influences` entries
  // per vertex (4 per JOINTS_n/WEIGHTS_n set). Throws std::invalid_argument on inconsistent
  // sizes.
  FastLbs(const std::vector<float>& rest_positions, const std::vector<float>& rest_normals,
          const std::vector<uint16_t>& joints, const std::vector<float>& weights, size_t influences);

  // joint_matrices: 16 floats per joint (glTF, column-major), as many as the joints named
  // (the caller checks its data). Writes vertex v's position at out + v·stride_floats and its
  // normal at the 3 floats after it; nothing else of the buffer.
  void skin(const float* joint_matrices, float* out, size_t stride_floats);

  size_t vertex_count() const { return positions_.size() / 4; }
  const char* kernel() const;  // "avx2+fma", "sse2" or "portable"

 private:
  std::vector<float> positions_;  // 4 per vertex (w = 1)
  std::vector<float> normals_;    // 4 per vertex (w = 0)
  std::vector<uint32_t> joints_;  // `influences_` per vertex, offsets in floats into columns_
  std::vector<float> weights_;
  size_t influences_;
  std::vector<float> columns_;  // per joint: its 3x4 matrix as four columns of 4 floats
  int kernel_;                  // 0 portable, 1 sse2, 2 avx2+fma
};

}  // namespace skelform::bench
