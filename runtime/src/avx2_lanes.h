// Lane helpers of the runtime's AVX2 kernels (guard_seed.h, hull_block.h, fair_shapes.h,
// rest_clearance.cpp, fair_frames.cpp): gathers with every lane enabled and a zero source (GCC
// 12 warns that the unmasked forms read an uninitialised one), vec3s gathered into lanes and
// glm::dot's order across them, std::isfinite lane by lane, and eight vec3 lanes stored back as
// vectors. Only where cpu.h compiles AVX2 kernels.
#pragma once

#include "cpu.h"

#if defined(SKELFORM_HAS_AVX2_KERNELS)
#  include <glm/vec3.hpp>
#  include <immintrin.h>

#  include <cfloat>
#  include <cstdint>

namespace skelform::runtime::avx2 {

__attribute__((target("avx2"))) inline __m256 gather_ps(const float* p, __m256i index) {
  return _mm256_mask_i32gather_ps(_mm256_setzero_ps(), p, index, _mm256_castsi256_ps(_mm256_set1_epi32(-1)), 4);
}

__attribute__((target("avx2"))) inline __m128 gather_ps(const float* p, __m128i index) {
  return _mm_mask_i32gather_ps(_mm_setzero_ps(), p, index, _mm_castsi128_ps(_mm_set1_epi32(-1)), 4);
}

__attribute__((target("avx2"))) inline __m256d gather_pd(const double* p, __m128i index) {
  return _mm256_mask_i32gather_pd(_mm256_setzero_pd(), p, index, _mm256_castsi256_pd(_mm256_set1_epi64x(-1)), 8);
}

__attribute__((target("avx2"))) inline __m128i gather_epi32(const int* p, __m128i index) {
  return _mm_mask_i32gather_epi32(_mm_setzero_si128(), p, index, _mm_set1_epi32(-1), 4);
}

__attribute__((target("avx2"))) inline __m256i gather_epi32(const int* p, __m256i index) {
  return _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), p, index, _mm256_set1_epi32(-1), 4);
}

// The byte at p + index, per lane (the gather reads four: p needs three readable bytes after
// its last).
__attribute__((target("avx2"))) inline __m256i gather_bytes(const uint8_t* p, __m256i index) {
  const __m256i four = _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), reinterpret_cast<const int*>(p), index,
                                                   _mm256_set1_epi32(-1), 1);
  return _mm256_and_si256(four, _mm256_set1_epi32(0xff));
}

// std::isfinite lane by lane: all ones where |v| ≤ FLT_MAX (none for ±inf and NaN).
__attribute__((target("avx2"))) inline __m256 finite(__m256 v) {
  const __m256 magnitude = _mm256_and_ps(v, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff)));
  return _mm256_cmp_ps(magnitude, _mm256_set1_ps(FLT_MAX), _CMP_LE_OQ);
}

// Coordinate `axis` of the vec3s p[i] at offsets index3 = 3·i.
__attribute__((target("avx2"))) inline __m256 gather_axis(const glm::vec3* p, int axis, __m256i index3) {
  static_assert(sizeof(glm::vec3) == 3 * sizeof(float), "vec3 is three packed floats");
  return gather_ps(&p[0].x + axis, index3);
}

// The vec3s p[index] as lanes of x, y and z (vector indices, whose offsets 3·index + 2 take
// int32: gather_offsets_fit).
__attribute__((target("avx2"))) inline void gather_vec3(const glm::vec3* p, __m256i index, __m256& x, __m256& y,
                                                        __m256& z) {
  const __m256i index3 = _mm256_add_epi32(_mm256_add_epi32(index, index), index);
  x = gather_axis(p, 0, index3), y = gather_axis(p, 1, index3), z = gather_axis(p, 2, index3);
}

// glm::dot's order, lane by lane: (x0 x1 + y0 y1) + z0 z1.
__attribute__((target("avx2"))) inline __m256 dot3(__m256 x0, __m256 y0, __m256 z0, __m256 x1, __m256 y1, __m256 z1) {
  return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(x0, x1), _mm256_mul_ps(y0, y1)), _mm256_mul_ps(z0, z1));
}

// Eight lanes of x, y and z into out[0 .. 8).
__attribute__((target("avx2"))) inline void store_vec3(const __m256 (&lanes)[3], glm::vec3* out) {
  alignas(32) float values[3][8];
  for (int axis = 0; axis < 3; ++axis) _mm256_store_ps(values[axis], lanes[axis]);
  for (int j = 0; j < 8; ++j) out[j] = glm::vec3(values[0][j], values[1][j], values[2][j]);
}

}  // namespace skelform::runtime::avx2
#endif
