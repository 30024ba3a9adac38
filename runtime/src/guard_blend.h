// The LBS guard's output (lbs_guard.cpp guard_and_blend), every dense vertex on every
// evaluation: x = L + s·(K − L) with s = w·λ (the skelform weight of the vertex, λ of its
// welded vertex), and with normals LBS's and skelform's blended the same way and renormalised
// (normalize_or: LBS's where the blend has no length); s = 0 gives LBS's vectors as they are.
//
// blend_output() takes the fastest form this CPU runs: AVX2 eight vertices at a time, each lane
// doing the portable loop's operations in its order (sqrt and division are correctly rounded
// in every lane), so the same bits (tests/runtime/guard_blend_test.cpp). Tangents, which few
// characters carry, take the portable loop.
#pragma once

#include "avx2_lanes.h"
#include "contact.h"
#include "cpu.h"
#include "instance.h"
#include "skin_blend.h"

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstdint>

namespace skelform::runtime {

struct BlendInput {
  const float* weight;   // per dense vertex
  const float* factor;   // λ per welded vertex, or null (λ = 1)
  const uint32_t* weld;  // per dense vertex: its welded vertex (read with factor)
  DenseOutput skelform;  // K
  DenseOutput lbs;       // L
};

// Dense vertices [first, end); `out` may be in.skelform itself (a vertex is written after its
// own K is read).
inline void blend_output_portable(uint32_t first, uint32_t end, const BlendInput& in, bool normals, bool tangents,
                                  const DenseOutput& out) {
  for (uint32_t v = first; v < end; ++v) {
    const float s = in.weight[v] * (in.factor ? in.factor[in.weld[v]] : 1.0f);
    if (s == 0.0f) {
      out.positions[v] = in.lbs.positions[v];
      if (normals) out.normals[v] = in.lbs.normals[v];
      if (tangents) out.tangents[v] = in.lbs.tangents[v];
      continue;
    }
    out.positions[v] = blend_with_lbs(in.lbs.positions[v], in.skelform.positions[v], s);
    if (normals)
      out.normals[v] =
          normalize_or(in.lbs.normals[v] + s * (in.skelform.normals[v] - in.lbs.normals[v]), in.lbs.normals[v]);
    if (tangents) {
      const glm::vec3 t(in.lbs.tangents[v]);
      out.tangents[v] =
          glm::vec4(normalize_or(t + s * (glm::vec3(in.skelform.tangents[v]) - t), t), in.lbs.tangents[v].w);
    }
  }
}

namespace detail {

#if defined(SKELFORM_HAS_AVX2_KERNELS)
// blend_output_portable without tangents over [first, first + 8·⌊(end − first)/8⌋), eight at a
// time; returns where it stopped. The dense arrays must take int32 gather offsets
// (gather_offsets_fit).
__attribute__((target("avx2"))) inline uint32_t blend_output_avx2(uint32_t first, uint32_t end, const BlendInput& in,
                                                                  bool normals, const DenseOutput& out) {
  const __m256 zero = _mm256_setzero_ps();
  const __m256i lane3 = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
  uint32_t v = first;
  for (; v + 8 <= end; v += 8) {
    __m256 s = _mm256_loadu_ps(in.weight + v);
    if (in.factor) {
      const __m256i welded = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(in.weld + v));
      s = _mm256_mul_ps(s, avx2::gather_ps(in.factor, welded));
    } else {
      s = _mm256_mul_ps(s, _mm256_set1_ps(1.0f));
    }
    const __m256 lbs_only = _mm256_cmp_ps(s, zero, _CMP_EQ_OQ);
    const __m256i index3 = _mm256_add_epi32(_mm256_set1_epi32(int(3 * v)), lane3);
    __m256 position[3], normal[3];
    for (int axis = 0; axis < 3; ++axis) {
      const __m256 l = avx2::gather_axis(in.lbs.positions, axis, index3);
      const __m256 k = avx2::gather_axis(in.skelform.positions, axis, index3);
      position[axis] = _mm256_blendv_ps(_mm256_add_ps(l, _mm256_mul_ps(s, _mm256_sub_ps(k, l))), l, lbs_only);
    }
    if (normals) {
      __m256 l[3], n[3];
      for (int axis = 0; axis < 3; ++axis) {
        l[axis] = avx2::gather_axis(in.lbs.normals, axis, index3);
        const __m256 k = avx2::gather_axis(in.skelform.normals, axis, index3);
        n[axis] = _mm256_add_ps(l[axis], _mm256_mul_ps(s, _mm256_sub_ps(k, l[axis])));
      }
      // normalize_or: length √((x² + y²) + z²), used where > 1e-30 and finite.
      const __m256 length = _mm256_sqrt_ps(_mm256_add_ps(
          _mm256_add_ps(_mm256_mul_ps(n[0], n[0]), _mm256_mul_ps(n[1], n[1])), _mm256_mul_ps(n[2], n[2])));
      const __m256 usable = _mm256_andnot_ps(
          lbs_only, _mm256_and_ps(_mm256_cmp_ps(length, _mm256_set1_ps(1e-30f), _CMP_GT_OQ), avx2::finite(length)));
      for (int axis = 0; axis < 3; ++axis)
        normal[axis] = _mm256_blendv_ps(l[axis], _mm256_div_ps(n[axis], length), usable);
    }
    // All eight read before any is written (out may be in.skelform).
    avx2::store_vec3(position, out.positions + v);
    if (normals) avx2::store_vec3(normal, out.normals + v);
  }
  return v;
}
#endif

}  // namespace detail

inline void blend_output(uint32_t first, uint32_t end, const BlendInput& in, bool normals, bool tangents,
                         const DenseOutput& out) {
  uint32_t done = first;
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (!tangents && cpu_has_avx2() && gather_offsets_fit(end))
    done = detail::blend_output_avx2(first, end, in, normals, out);
#endif
  blend_output_portable(done, end, in, normals, tangents, out);
}

}  // namespace skelform::runtime
