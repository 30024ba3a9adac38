// Flow (4)'s triangle terms are computed a block of triangles at a time (fair_fold.cpp
// triangle_forces): the block's structure-of-arrays scratch and its gather, the centroids and
// the differences E_T takes (ball_hull.h interior_lanes4 reads them). The gather reads three
// corners, their positions and balls per triangle, one coordinate at a time; with AVX2 it
// gathers eight triangles' at a time, each lane doing the portable loop's operations, so the
// same bits (hull_block_test).
#pragma once

#include "avx2_lanes.h"
#include "cpu.h"
#include "fair_internal.h"

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>

namespace skelform::runtime::fair_detail {

constexpr uint32_t kHullBlock = 64;

// One block of triangles [first, first + count), count ≤ kHullBlock: E_T's inputs per triangle
// and its interior candidate, side by side (structure of arrays, as interior_lanes4 reads them).
struct HullBlock {
  float w0x[kHullBlock], w0y[kHullBlock], w0z[kHullBlock], e1x[kHullBlock], e1y[kHullBlock], e1z[kHullBlock];
  float e2x[kHullBlock], e2y[kHullBlock], e2z[kHullBlock], r0[kHullBlock], d1[kHullBlock], d2[kHullBlock];
  float value[kHullBlock], nx[kHullBlock], ny[kHullBlock], nz[kHullBlock];
  bool inside[kHullBlock];
  glm::vec3 centroid[kHullBlock];
  bool usable[kHullBlock];
};

// What the gather reads: the control triangles (3 corner indices each), and per control vertex
// the skeletal position, the medial radius and the position.
struct HullSources {
  const uint32_t* corners;
  const glm::vec3* skeletal;
  const float* radius;
  const glm::vec3* x;
};

// Block entries [begin, end) of the triangles `triangles` (the block's, from its first): the
// centroid and the differences ball_hull_distance takes (zeros where a centroid or a ball centre
// is not finite: such a triangle is not usable).
inline void gather_block_portable(const HullSources& in, const uint32_t* triangles, uint32_t begin, uint32_t end,
                                  HullBlock& b) {
  for (uint32_t i = begin; i < end; ++i) {
    const uint32_t* corner = in.corners + 3 * size_t{triangles[i]};
    b.centroid[i] = (in.x[corner[0]] + in.x[corner[1]] + in.x[corner[2]]) / 3.0f;
    const glm::vec3 &s0 = in.skeletal[corner[0]], &s1 = in.skeletal[corner[1]], &s2 = in.skeletal[corner[2]];
    b.usable[i] = finite(b.centroid[i]) && finite(s0) && finite(s1) && finite(s2);
    // The same differences as ball_hull_distance.
    const glm::vec3 c0(b.usable[i] ? s0 : glm::vec3(0.0f)), p(b.usable[i] ? b.centroid[i] : glm::vec3(0.0f));
    const glm::vec3 c1(b.usable[i] ? s1 : glm::vec3(0.0f)), c2(b.usable[i] ? s2 : glm::vec3(0.0f));
    b.w0x[i] = p.x - c0.x, b.w0y[i] = p.y - c0.y, b.w0z[i] = p.z - c0.z;
    b.e1x[i] = c1.x - c0.x, b.e1y[i] = c1.y - c0.y, b.e1z[i] = c1.z - c0.z;
    b.e2x[i] = c2.x - c0.x, b.e2y[i] = c2.y - c0.y, b.e2z[i] = c2.z - c0.z;
    const float rr0 = in.radius[corner[0]], rr1 = in.radius[corner[1]], rr2 = in.radius[corner[2]];
    b.r0[i] = rr0, b.d1[i] = rr1 - rr0, b.d2[i] = rr2 - rr0;
  }
}

#if defined(SKELFORM_HAS_AVX2_KERNELS)
// gather_block_portable over entries [0, 8·⌊count/8⌋), eight triangles at a time; returns where
// it stopped. Per lane the same operations: the centroid's sums in glm's order and its division
// by 3, finiteness (avx2::finite), the unusable lanes' inputs +0 as glm::vec3(0.0f). The control
// triangles and vertices must take int32 gather offsets (gather_offsets_fit).
__attribute__((target("avx2"))) inline uint32_t gather_block_avx2(const HullSources& in, const uint32_t* triangles,
                                                                  uint32_t count, HullBlock& b) {
  const __m256 three = _mm256_set1_ps(3.0f);
  uint32_t i = 0;
  for (; i + 8 <= count; i += 8) {
    const __m256i t = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(triangles + i));
    const __m256i t3 = _mm256_add_epi32(t, _mm256_add_epi32(t, t));
    __m256i vertex[3], vertex3[3];
    for (int k = 0; k < 3; ++k) {
      vertex[k] = avx2::gather_epi32(reinterpret_cast<const int*>(in.corners) + k, t3);
      vertex3[k] = _mm256_add_epi32(vertex[k], _mm256_add_epi32(vertex[k], vertex[k]));
    }
    __m256 centroid[3], ball[3][3];
    __m256 usable = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    for (int axis = 0; axis < 3; ++axis) {
      const __m256 sum = _mm256_add_ps(
          _mm256_add_ps(avx2::gather_axis(in.x, axis, vertex3[0]), avx2::gather_axis(in.x, axis, vertex3[1])),
          avx2::gather_axis(in.x, axis, vertex3[2]));
      centroid[axis] = _mm256_div_ps(sum, three);
      usable = _mm256_and_ps(usable, avx2::finite(centroid[axis]));
      for (int k = 0; k < 3; ++k) {
        ball[k][axis] = avx2::gather_axis(in.skeletal, axis, vertex3[k]);
        usable = _mm256_and_ps(usable, avx2::finite(ball[k][axis]));
      }
    }
    avx2::store_vec3(centroid, b.centroid + i);
    float* w0[3] = {b.w0x, b.w0y, b.w0z};
    float* e1[3] = {b.e1x, b.e1y, b.e1z};
    float* e2[3] = {b.e2x, b.e2y, b.e2z};
    for (int axis = 0; axis < 3; ++axis) {
      const __m256 c0 = _mm256_and_ps(usable, ball[0][axis]);
      _mm256_storeu_ps(w0[axis] + i, _mm256_sub_ps(_mm256_and_ps(usable, centroid[axis]), c0));
      _mm256_storeu_ps(e1[axis] + i, _mm256_sub_ps(_mm256_and_ps(usable, ball[1][axis]), c0));
      _mm256_storeu_ps(e2[axis] + i, _mm256_sub_ps(_mm256_and_ps(usable, ball[2][axis]), c0));
    }
    const __m256 rr0 = avx2::gather_ps(in.radius, vertex[0]);
    _mm256_storeu_ps(b.r0 + i, rr0);
    _mm256_storeu_ps(b.d1 + i, _mm256_sub_ps(avx2::gather_ps(in.radius, vertex[1]), rr0));
    _mm256_storeu_ps(b.d2 + i, _mm256_sub_ps(avx2::gather_ps(in.radius, vertex[2]), rr0));
    const int bits = _mm256_movemask_ps(usable);
    for (int j = 0; j < 8; ++j) b.usable[i + j] = (bits >> j) & 1;
  }
  return i;
}
#endif

// The block's entries [0, count), in the fastest form this CPU runs. `vertex_count`,
// `triangle_count`: the control mesh's (the gathers' reach).
inline void gather_block(const HullSources& in, uint32_t vertex_count, uint32_t triangle_count,
                         const uint32_t* triangles, uint32_t count, HullBlock& b) {
  uint32_t done = 0;
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (cpu_has_avx2() && gather_offsets_fit(vertex_count) && gather_offsets_fit(triangle_count))
    done = gather_block_avx2(in, triangles, count, b);
#else
  (void)vertex_count, (void)triangle_count;
#endif
  gather_block_portable(in, triangles, done, count, b);
}

}  // namespace skelform::runtime::fair_detail
