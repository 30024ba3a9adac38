// The contact pass's triangle test (contact.cpp): do two triangles intersect, in float, by
// separating axes. Two forms that give the same verdict on every input, bit for bit:
// triangles_meet_portable, one axis at a time, and triangles_meet_sse2, four axes at a time
// with the same products, sums and comparisons in each lane. triangles_meet picks the SSE2 form
// where the target has it (x86-64's baseline) and evaluates float in float: x87 arithmetic (a
// 32-bit build's default) keeps excess precision in the scalar code, which the lanes do not.
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>

#if defined(__SSE2__) && defined(__FLT_EVAL_METHOD__) && __FLT_EVAL_METHOD__ == 0
#  define SKELFORM_TRIANGLES_MEET_SSE2 1
#  include "vec3_sse.h"

#  include <emmintrin.h>
#endif

namespace skelform::runtime {
namespace detail {

// Are q0, q1, q2 all further than `margin` (≥ 0) on one side of the plane of p0, p1, p2: every
// ((p1 − p0) × (p2 − p0)) · (q_k − p0) above margin, or every one below −margin? (The guard's
// pre-test takes a margin, exact_triangles.h; sse::corners_beyond_plane is its four-lane form.)
inline bool corners_beyond_plane(const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2, const glm::vec3& q0,
                                 const glm::vec3& q1, const glm::vec3& q2, float margin) {
  const glm::vec3 n = glm::cross(p1 - p0, p2 - p0);
  const float d0 = glm::dot(n, q0 - p0), d1 = glm::dot(n, q1 - p0), d2 = glm::dot(n, q2 - p0);
  return (d0 > margin && d1 > margin && d2 > margin) || (d0 < -margin && d1 < -margin && d2 < -margin);
}

// Möller's early outs: all of one triangle's corners strictly on one side of the other's plane.
inline bool planes_separate(const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2, const glm::vec3& q0,
                            const glm::vec3& q1, const glm::vec3& q2) {
  return corners_beyond_plane(p0, p1, p2, q0, q1, q2, 0.0f) || corners_beyond_plane(q0, q1, q2, p0, p1, p2, 0.0f);
}

// Do the projections of the triangles on `axis` miss each other?
inline bool separated(const glm::vec3& axis, const glm::vec3* a, const glm::vec3* b) {
  const float a0 = glm::dot(axis, a[0]), a1 = glm::dot(axis, a[1]), a2 = glm::dot(axis, a[2]);
  const float b0 = glm::dot(axis, b[0]), b1 = glm::dot(axis, b[1]), b2 = glm::dot(axis, b[2]);
  return std::max(a0, std::max(a1, a2)) < std::min(b0, std::min(b1, b2)) ||
         std::max(b0, std::max(b1, b2)) < std::min(a0, std::min(a1, a2));
}

// The separating axes' inputs, relative to the first triangle's first corner: its corners a
// and edges ea, the second's corners b and edges eb, and the face normals na and nb.
struct SeparatingFrame {
  glm::vec3 a[3], b[3], ea[3], eb[3], na, nb;
  SeparatingFrame(const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2, const glm::vec3& q0,
                  const glm::vec3& q1, const glm::vec3& q2)
      : a{glm::vec3(0.0f), p1 - p0, p2 - p0},
        b{q0 - p0, q1 - p0, q2 - p0},
        ea{a[1] - a[0], a[2] - a[1], a[0] - a[2]},
        eb{b[1] - b[0], b[2] - b[1], b[0] - b[2]},
        na(glm::cross(ea[0], ea[1])),
        nb(glm::cross(eb[0], eb[1])) {}
};

// Separating-axis test of two triangles (face normals, edge × edge, in-plane edge normals),
// relative to the first triangle's first corner, one axis at a time. An axis of length 0
// separates nothing.
inline bool triangles_meet_portable(const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2, const glm::vec3& q0,
                                    const glm::vec3& q1, const glm::vec3& q2) {
  if (planes_separate(p0, p1, p2, q0, q1, q2)) return false;
  const SeparatingFrame f(p0, p1, p2, q0, q1, q2);
  auto splits = [&](const glm::vec3& axis) { return glm::dot(axis, axis) > 0.0f && separated(axis, f.a, f.b); };
  if (splits(f.na) || splits(f.nb)) return false;
  for (const glm::vec3& u : f.ea)
    for (const glm::vec3& w : f.eb)
      if (splits(glm::cross(u, w))) return false;
  for (const glm::vec3& u : f.ea)
    if (splits(glm::cross(f.na, u))) return false;
  for (const glm::vec3& w : f.eb)
    if (splits(glm::cross(f.nb, w))) return false;
  return true;
}

#if defined(SKELFORM_TRIANGLES_MEET_SSE2)
// Four 3-vectors, a component per register.
struct Vec3x4 {
  __m128 x, y, z;
};

inline Vec3x4 gather4(const glm::vec3& v0, const glm::vec3& v1, const glm::vec3& v2, const glm::vec3& v3) {
  return {_mm_setr_ps(v0.x, v1.x, v2.x, v3.x), _mm_setr_ps(v0.y, v1.y, v2.y, v3.y),
          _mm_setr_ps(v0.z, v1.z, v2.z, v3.z)};
}

// glm::cross lane by lane: (u.y w.z − w.y u.z, u.z w.x − w.z u.x, u.x w.y − w.x u.y).
inline Vec3x4 cross4(const Vec3x4& u, const Vec3x4& w) {
  return {_mm_sub_ps(_mm_mul_ps(u.y, w.z), _mm_mul_ps(w.y, u.z)),
          _mm_sub_ps(_mm_mul_ps(u.z, w.x), _mm_mul_ps(w.z, u.x)),
          _mm_sub_ps(_mm_mul_ps(u.x, w.y), _mm_mul_ps(w.x, u.y))};
}

// glm::dot(axis, p) lane by lane: (x·p.x + y·p.y) + z·p.z.
inline __m128 dot4(const Vec3x4& axis, const glm::vec3& p) {
  return _mm_add_ps(_mm_add_ps(_mm_mul_ps(axis.x, _mm_set1_ps(p.x)), _mm_mul_ps(axis.y, _mm_set1_ps(p.y))),
                    _mm_mul_ps(axis.z, _mm_set1_ps(p.z)));
}

// The lanes whose axis splits the triangles (non-zero bits), as separated() and the length
// test decide them. std::max(x, y) is (x < y ? y : x), which is _mm_max_ps(y, x), and
// std::min(x, y) is (y < x ? y : x), which is _mm_min_ps(y, x): so even a NaN lane selects
// what the scalar code selects.
inline int splitting_lanes(const Vec3x4& axis, const SeparatingFrame& f) {
  const __m128 a0 = dot4(axis, f.a[0]), a1 = dot4(axis, f.a[1]), a2 = dot4(axis, f.a[2]);
  const __m128 b0 = dot4(axis, f.b[0]), b1 = dot4(axis, f.b[1]), b2 = dot4(axis, f.b[2]);
  const __m128 a_hi = _mm_max_ps(_mm_max_ps(a2, a1), a0), a_lo = _mm_min_ps(_mm_min_ps(a2, a1), a0);
  const __m128 b_hi = _mm_max_ps(_mm_max_ps(b2, b1), b0), b_lo = _mm_min_ps(_mm_min_ps(b2, b1), b0);
  const __m128 apart = _mm_or_ps(_mm_cmplt_ps(a_hi, b_lo), _mm_cmplt_ps(b_hi, a_lo));
  const __m128 length =
      _mm_add_ps(_mm_add_ps(_mm_mul_ps(axis.x, axis.x), _mm_mul_ps(axis.y, axis.y)), _mm_mul_ps(axis.z, axis.z));
  return _mm_movemask_ps(_mm_and_ps(_mm_cmpgt_ps(length, _mm_setzero_ps()), apart));
}

// triangles_meet_portable: its early outs as planes_separate takes them, then its 17 axes in
// five groups of four (the last lanes of two groups are zero axes, which split nothing). The
// verdict is the same: the triangles meet when no axis splits them, whatever the order the
// axes are tried in.
inline bool triangles_meet_sse2(const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2, const glm::vec3& q0,
                                const glm::vec3& q1, const glm::vec3& q2) {
  {
    const __m128 a0 = sse::load3(p0), a1 = sse::load3(p1), a2 = sse::load3(p2);
    const __m128 b0 = sse::load3(q0), b1 = sse::load3(q1), b2 = sse::load3(q2);
    const __m128 zero = _mm_setzero_ps();  // (−0 is 0: d < −0 is d < 0)
    if (sse::corners_beyond_plane(a0, a1, a2, b0, b1, b2, zero) ||
        sse::corners_beyond_plane(b0, b1, b2, a0, a1, a2, zero))
      return false;
  }
  const SeparatingFrame f(p0, p1, p2, q0, q1, q2);
  const glm::vec3* ea = f.ea;
  const glm::vec3* eb = f.eb;
  const glm::vec3 zero(0.0f);
  // na, nb and the first two edge × edge axes.
  if (splitting_lanes(cross4(gather4(ea[0], eb[0], ea[0], ea[0]), gather4(ea[1], eb[1], eb[0], eb[1])), f))
    return false;
  if (splitting_lanes(cross4(gather4(ea[0], ea[1], ea[1], ea[1]), gather4(eb[2], eb[0], eb[1], eb[2])), f))
    return false;
  if (splitting_lanes(cross4(gather4(ea[2], ea[2], ea[2], zero), gather4(eb[0], eb[1], eb[2], zero)), f)) return false;
  // The in-plane edge normals.
  if (splitting_lanes(cross4(gather4(f.na, f.na, f.na, f.nb), gather4(ea[0], ea[1], ea[2], eb[0])), f)) return false;
  return splitting_lanes(cross4(gather4(f.nb, f.nb, zero, zero), gather4(eb[1], eb[2], zero, zero)), f) == 0;
}
#endif

}  // namespace detail

// Do the triangles (p0, p1, p2) and (q0, q1, q2) intersect (touching counts)?
inline bool triangles_meet(const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2, const glm::vec3& q0,
                           const glm::vec3& q1, const glm::vec3& q2) {
#if defined(SKELFORM_TRIANGLES_MEET_SSE2)
  return detail::triangles_meet_sse2(p0, p1, p2, q0, q1, q2);
#else
  return detail::triangles_meet_portable(p0, p1, p2, q0, q1, q2);
#endif
}

}  // namespace skelform::runtime
