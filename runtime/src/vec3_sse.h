// SSE2 loads and stores of glm::vec3, and four-lane float helpers, for the runtime's hand-
// vectorised kernels (refine.cpp, refine_normals.cpp, fair_operators.cpp, ball_hull.h,
// fair_frames.cpp). SSE2 is part of x86-64 itself, so no ISA flag and no runtime dispatch: the
// kernels compile these under `#if defined(__SSE2__)` and keep their portable loops as the
// fallback. One vec3 sits in the low three lanes of an __m128; its lanes compute exactly what
// the scalar code computes per component (the same IEEE operations in the same order, no fused
// multiply-add), so the results keep the scalar code's bits. What the fourth lane holds is
// never stored.
#pragma once

#if defined(__SSE2__)

#  include <glm/vec3.hpp>

#  include <emmintrin.h>

#  include <cstddef>

namespace skelform::runtime::sse {

// A whole-vector load of vectors[index]: x, y, z and, in the fourth lane, the next vector's x.
// The last vector of the array has no next one, so it is read from `tail` (its copy, zero
// padded) instead: no read past the end (a select, not a branch in the hot loops).
struct Vec3Reader {
  const glm::vec3* vectors;
  size_t last;  // index of the last vector (0 for an empty array: then `tail` is never used)
  alignas(16) float tail[4];

  Vec3Reader(const glm::vec3* v, size_t count)
      : vectors(v), last(count > 0 ? count - 1 : 0), tail{0.0f, 0.0f, 0.0f, 0.0f} {
    if (count > 0) tail[0] = v[last].x, tail[1] = v[last].y, tail[2] = v[last].z;
  }
  __m128 operator()(size_t index) const {
    const float* p = index < last ? &vectors[index].x : tail;
    return _mm_loadu_ps(p);
  }
};

// A whole-vector load of vectors[index] (x, y, z and whatever float follows it) from a buffer
// with kVec3ReadPadding (memory.h) vectors after its last one, so that no load leaves the
// buffer: Vec3Reader's job without its select of the copied tail (a compare and a conditional
// move per load in the stencil walk and in displace's gather).
struct PaddedVec3Reader {
  const glm::vec3* vectors;

  explicit PaddedVec3Reader(const glm::vec3* v) : vectors(v) {}
  __m128 operator()(size_t index) const { return _mm_loadu_ps(&vectors[index].x); }
};

// Exactly the 12 bytes of `v` (x, y in one 8-byte access, z in one 4-byte access: the same
// access sizes as store3's, so a load after a store to the same vector is forwarded).
inline __m128 load3(const glm::vec3& v) {
  const __m128 xy = _mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(&v.x));
  return _mm_movelh_ps(xy, _mm_load_ss(&v.z));
}

// The low three lanes of `a` into `v`, nothing past it.
inline void store3(glm::vec3& v, __m128 a) {
  _mm_storel_pi(reinterpret_cast<__m64*>(&v.x), a);
  _mm_store_ss(&v.z, _mm_movehl_ps(a, a));
}

// Are q0, q1, q2 (x, y, z in the low lanes) all further than `margin` (≥ 0, in every lane) on
// one side of the plane of p0, p1, p2: every d_k = ((p1 − p0) × (p2 − p0)) · (q_k − p0) above
// margin, or every one below −margin? glm::cross's products and differences, and each glm::dot
// as (x + y) + z across the transposed products: with margin 0, the scalar test's bits and
// verdict (the contact pass's and the guard's triangle tests, triangles_meet.h and
// exact_triangles.h).
inline bool corners_beyond_plane(__m128 p0, __m128 p1, __m128 p2, __m128 q0, __m128 q1, __m128 q2, __m128 margin) {
  const __m128 e1 = _mm_sub_ps(p1, p0), e2 = _mm_sub_ps(p2, p0);
  // (e1.y e2.z − e2.y e1.z, e1.z e2.x − e2.z e1.x, e1.x e2.y − e2.x e1.y)
  const __m128 n = _mm_sub_ps(
      _mm_mul_ps(_mm_shuffle_ps(e1, e1, _MM_SHUFFLE(3, 0, 2, 1)), _mm_shuffle_ps(e2, e2, _MM_SHUFFLE(3, 1, 0, 2))),
      _mm_mul_ps(_mm_shuffle_ps(e2, e2, _MM_SHUFFLE(3, 0, 2, 1)), _mm_shuffle_ps(e1, e1, _MM_SHUFFLE(3, 1, 0, 2))));
  __m128 m0 = _mm_mul_ps(n, _mm_sub_ps(q0, p0)), m1 = _mm_mul_ps(n, _mm_sub_ps(q1, p0)),
         m2 = _mm_mul_ps(n, _mm_sub_ps(q2, p0)), m3 = _mm_setzero_ps();
  _MM_TRANSPOSE4_PS(m0, m1, m2, m3);
  const __m128 d = _mm_add_ps(_mm_add_ps(m0, m1), m2);  // d_k in lane k
  const __m128 minus = _mm_sub_ps(_mm_setzero_ps(), margin);
  return (_mm_movemask_ps(_mm_cmpgt_ps(d, margin)) & 7) == 7 || (_mm_movemask_ps(_mm_cmplt_ps(d, minus)) & 7) == 7;
}

}  // namespace skelform::runtime::sse

namespace skelform::runtime {

// Four float lanes for the kernels that evaluate a scalar formula for four triangles, balls,
// edges or rows at once (fair_frames.cpp, refine.cpp): each helper is one IEEE operation per lane (no
// fused multiply-add), so a lane computes what the scalar code computes, in the same order.
namespace lane4 {
inline __m128 load(const float* p) { return _mm_loadu_ps(p); }
inline __m128 add(__m128 a, __m128 b) { return _mm_add_ps(a, b); }
inline __m128 sub(__m128 a, __m128 b) { return _mm_sub_ps(a, b); }
inline __m128 mul(__m128 a, __m128 b) { return _mm_mul_ps(a, b); }
// glm::dot's order: (x0 x1 + y0 y1) + z0 z1.
inline __m128 dot(__m128 x0, __m128 y0, __m128 z0, __m128 x1, __m128 y1, __m128 z1) {
  return add(add(mul(x0, x1), mul(y0, y1)), mul(z0, z1));
}
// mask ? a : b, lane by lane (mask lanes all ones or all zeros, as the comparisons give them).
inline __m128 select(__m128 mask, __m128 a, __m128 b) { return _mm_or_ps(_mm_and_ps(mask, a), _mm_andnot_ps(mask, b)); }
}  // namespace lane4

}  // namespace skelform::runtime

#endif
