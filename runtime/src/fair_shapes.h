// fair_stage's record of the control vertices' local shapes (fair_stage.cpp
// record_local_shapes), which the pose-jump and quiet tests read: every evaluation, every
// control vertex, the umbrella turned into the vertex's frame and compared with the last
// evaluation's and with rest's.
//
// record_shapes() takes the fastest form this CPU runs: AVX2 eight vertices at a time (frames
// and vectors gathered), then the portable loop for the rest. Each lane does the portable
// loop's operations in its order (glm's mat3 product, divisions and lengths, no fused
// multiply-add), so both forms give the same bits and the same count
// (tests/runtime/fair_shapes_test.cpp). (The warm start's two passes in the same frames,
// x += F·c and c = Fᵀ·(x − x₀), stay scalar in fair_stage.cpp: with only a product each, their
// AVX2 form's gathers took longer than the loops, 3.0 against 2.0 µs on CesiumMan's control
// mesh.)
#pragma once

#include "avx2_lanes.h"
#include "cpu.h"

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cstdint>

namespace skelform::runtime {

// The inputs and outputs of record_shapes, per control vertex.
struct ShapeRecord {
  const uint32_t* neighbour_offsets;  // vertex_count + 1 (fair.h FairingTopology)
  const glm::mat3* frames;            // this evaluation's (fair.h fairing_frames)
  const glm::vec3* umbrella;          // U(M) per vertex
  const float* mean_edge;             // M's mean one-ring edge per vertex
  const glm::vec3* rest_umbrella;     // U(M_rest) in the rest frame (FairingRest::umbrella)
  glm::vec3* shape;                   // in: the last evaluation's; out: this one's
  float* rest_change;                 // out: |shape − rest shape|
};

// Vertices [first, end) with a one-ring: the shape (the umbrella in the vertex's frame, in mean
// edges, the edge at least 1e-30), its change since the last evaluation and from rest.
// Returns how many changed by more than `jump` (a NaN counts as changed).
inline uint32_t record_shapes_portable(const ShapeRecord& r, uint32_t first, uint32_t end, float jump) {
  uint32_t changed = 0;
  for (uint32_t v = first; v < end; ++v) {
    if (r.neighbour_offsets[v] == r.neighbour_offsets[v + 1]) continue;
    const float edge = std::max(r.mean_edge[v], 1e-30f);
    const glm::vec3 shape = glm::transpose(r.frames[v]) * r.umbrella[v] / edge;
    const float change = glm::length(shape - r.shape[v]);
    if (!(change <= jump)) ++changed;
    r.shape[v] = shape;
    r.rest_change[v] = glm::length(shape - r.rest_umbrella[v] / edge);
  }
  return changed;
}

#if defined(SKELFORM_HAS_AVX2_KERNELS)
namespace detail {

// Eight vertices' frames as nine lanes, column-major as glm stores them (index9 = 9·(v + lane)).
__attribute__((target("avx2"))) inline void gather_mat3(const glm::mat3* frames, __m256i index9, __m256 (&out)[9]) {
  static_assert(sizeof(glm::mat3) == 9 * sizeof(float), "mat3 is nine packed floats");
  for (int k = 0; k < 9; ++k) out[k] = avx2::gather_ps(&frames[0][0].x + k, index9);
}

// glm::transpose(m) · u, lane by lane: row i is (m[i][0] u.x + m[i][1] u.y) + m[i][2] u.z.
__attribute__((target("avx2"))) inline void transposed_times(const __m256 (&m)[9], const __m256 (&u)[3],
                                                             __m256 (&out)[3]) {
  for (int i = 0; i < 3; ++i)
    out[i] = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(m[3 * i], u[0]), _mm256_mul_ps(m[3 * i + 1], u[1])),
                           _mm256_mul_ps(m[3 * i + 2], u[2]));
}

// glm::length(a − b) lane by lane: sqrt((x² + y²) + z²).
__attribute__((target("avx2"))) inline __m256 distance(const __m256 (&a)[3], const __m256 (&b)[3]) {
  const __m256 x = _mm256_sub_ps(a[0], b[0]), y = _mm256_sub_ps(a[1], b[1]), z = _mm256_sub_ps(a[2], b[2]);
  return _mm256_sqrt_ps(avx2::dot3(x, y, z, x, y, z));
}

// The lanes' vertex indices v .. v + 7.
__attribute__((target("avx2"))) inline __m256i lane_vertices(uint32_t v) {
  return _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(v)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
}

// record_shapes_portable over vertices [0, 8·⌊end/8⌋); returns where it stopped and adds the
// changed count to `changed`. A lane without a one-ring stores nothing: its values are blended
// back to those it read. Vertex indices must take int32 gather offsets for 9·v
// (gather_offsets_fit(3·end)).
__attribute__((target("avx2"))) inline uint32_t record_shapes_avx2(const ShapeRecord& r, uint32_t end, float jump,
                                                                   uint32_t& changed) {
  const __m256 tiny = _mm256_set1_ps(1e-30f), limit = _mm256_set1_ps(jump);
  uint32_t v = 0;
  for (; v + 8 <= end; v += 8) {
    const __m256i begin = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(r.neighbour_offsets + v));
    const __m256i stop = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(r.neighbour_offsets + v + 1));
    const __m256 ring = _mm256_castsi256_ps(_mm256_xor_si256(_mm256_cmpeq_epi32(begin, stop), _mm256_set1_epi32(-1)));
    const int rings = _mm256_movemask_ps(ring);
    if (rings == 0) continue;
    const __m256i vertex = lane_vertices(v), index9 = _mm256_mullo_epi32(vertex, _mm256_set1_epi32(9));
    // std::max(e, 1e-30): (e < 1e-30) ? 1e-30 : e, which _mm256_max_ps(1e-30, e) is (NaN: e).
    const __m256 edge = _mm256_max_ps(tiny, _mm256_loadu_ps(r.mean_edge + v));
    __m256 frame[9], umbrella[3], turned[3], shape[3], old[3], rest[3];
    gather_mat3(r.frames, index9, frame);
    avx2::gather_vec3(r.umbrella, vertex, umbrella[0], umbrella[1], umbrella[2]);
    transposed_times(frame, umbrella, turned);
    for (int axis = 0; axis < 3; ++axis) shape[axis] = _mm256_div_ps(turned[axis], edge);
    avx2::gather_vec3(r.shape, vertex, old[0], old[1], old[2]);
    avx2::gather_vec3(r.rest_umbrella, vertex, rest[0], rest[1], rest[2]);
    for (__m256& axis : rest) axis = _mm256_div_ps(axis, edge);
    const __m256 change = distance(shape, old);
    const int within = _mm256_movemask_ps(_mm256_cmp_ps(change, limit, _CMP_LE_OQ));
    changed += uint32_t(__builtin_popcount(unsigned(rings & ~within)));
    for (int axis = 0; axis < 3; ++axis) shape[axis] = _mm256_blendv_ps(old[axis], shape[axis], ring);
    const __m256 rest_change = _mm256_blendv_ps(_mm256_loadu_ps(r.rest_change + v), distance(shape, rest), ring);
    avx2::store_vec3(shape, r.shape + v);
    _mm256_storeu_ps(r.rest_change + v, rest_change);
  }
  return v;
}

}  // namespace detail
#endif

// record_shapes_portable over `count` control vertices in the fastest form.
inline uint32_t record_shapes(const ShapeRecord& r, uint32_t count, float jump) {
  uint32_t changed = 0, done = 0;
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (cpu_has_avx2() && gather_offsets_fit(3 * uint64_t(count)))
    done = detail::record_shapes_avx2(r, count, jump, changed);
#endif
  return changed + record_shapes_portable(r, done, count, jump);
}

}  // namespace skelform::runtime
