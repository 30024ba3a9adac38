// The LBS guard's triangle test (lbs_guard.cpp check_exact): geometry::triangles_intersect,
// the metric's own definition, and on a CPU with AVX the same test four separating axes at a
// time: the same products, sums and comparisons in each lane, so the same verdict on every
// input. exact_triangle_test() picks the form once. Only where double is evaluated in double:
// x87 arithmetic (a 32-bit build's default) keeps excess precision in the scalar reference.
// Before it, triangles_surely_apart: a float test of the face planes that says "apart" only
// where the exact test must say so, and decides most of the guard's pairs.
#pragma once

#include "skelform/core/triangle_intersection.h"

#include "triangles_meet.h"
#include "vec3_sse.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#if defined(__SSE2__) && (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__)) && \
    defined(__FLT_EVAL_METHOD__) && __FLT_EVAL_METHOD__ == 0
#  define SKELFORM_EXACT_TRIANGLES_AVX 1
#  include <immintrin.h>
#endif

namespace skelform::runtime {

using ExactTriangleTest = bool (*)(const glm::dvec3&, const glm::dvec3&, const glm::dvec3&, const glm::dvec3&,
                                   const glm::dvec3&, const glm::dvec3&);

namespace detail {

#if defined(SKELFORM_EXACT_TRIANGLES_AVX)
// Four double 3-vectors, a component per register.
struct DVec3x4 {
  __m256d x, y, z;
};

__attribute__((target("avx"))) inline DVec3x4 gather_d4(const glm::dvec3& v0, const glm::dvec3& v1,
                                                        const glm::dvec3& v2, const glm::dvec3& v3) {
  return {_mm256_setr_pd(v0.x, v1.x, v2.x, v3.x), _mm256_setr_pd(v0.y, v1.y, v2.y, v3.y),
          _mm256_setr_pd(v0.z, v1.z, v2.z, v3.z)};
}

// glm::cross lane by lane: (u.y w.z − w.y u.z, u.z w.x − w.z u.x, u.x w.y − w.x u.y).
__attribute__((target("avx"))) inline DVec3x4 cross_d4(const DVec3x4& u, const DVec3x4& w) {
  return {_mm256_sub_pd(_mm256_mul_pd(u.y, w.z), _mm256_mul_pd(w.y, u.z)),
          _mm256_sub_pd(_mm256_mul_pd(u.z, w.x), _mm256_mul_pd(w.z, u.x)),
          _mm256_sub_pd(_mm256_mul_pd(u.x, w.y), _mm256_mul_pd(w.x, u.y))};
}

// glm::dot(axis, p) lane by lane: (x·p.x + y·p.y) + z·p.z.
__attribute__((target("avx"))) inline __m256d dot_d4(const DVec3x4& axis, const glm::dvec3& p) {
  return _mm256_add_pd(
      _mm256_add_pd(_mm256_mul_pd(axis.x, _mm256_set1_pd(p.x)), _mm256_mul_pd(axis.y, _mm256_set1_pd(p.y))),
      _mm256_mul_pd(axis.z, _mm256_set1_pd(p.z)));
}

// The lanes whose axis separates the triangles (non-zero bits), as separated_along decides.
// std::min({p0, p1, p2}) keeps the first smallest (p1 < r ? p1 : r, then p2), which is
// _mm256_min_pd(p1, r); std::max keeps the first largest (r < p1 ? p1 : r), _mm256_max_pd(p1, r):
// so a NaN lane selects what the scalar code selects.
__attribute__((target("avx"))) inline int separating_lanes_d4(const DVec3x4& axis, const glm::dvec3* a,
                                                              const glm::dvec3* b) {
  const __m256d pa0 = dot_d4(axis, a[0]), pa1 = dot_d4(axis, a[1]), pa2 = dot_d4(axis, a[2]);
  const __m256d pb0 = dot_d4(axis, b[0]), pb1 = dot_d4(axis, b[1]), pb2 = dot_d4(axis, b[2]);
  const __m256d min_a = _mm256_min_pd(pa2, _mm256_min_pd(pa1, pa0));
  const __m256d max_a = _mm256_max_pd(pa2, _mm256_max_pd(pa1, pa0));
  const __m256d min_b = _mm256_min_pd(pb2, _mm256_min_pd(pb1, pb0));
  const __m256d max_b = _mm256_max_pd(pb2, _mm256_max_pd(pb1, pb0));
  const __m256d apart = _mm256_or_pd(_mm256_cmp_pd(max_a, min_b, _CMP_LT_OQ), _mm256_cmp_pd(max_b, min_a, _CMP_LT_OQ));
  const __m256d length = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(axis.x, axis.x), _mm256_mul_pd(axis.y, axis.y)),
                                       _mm256_mul_pd(axis.z, axis.z));
  return _mm256_movemask_pd(_mm256_and_pd(_mm256_cmp_pd(length, _mm256_setzero_pd(), _CMP_GT_OQ), apart));
}

// geometry::triangles_intersect with its 17 axes in four groups of four and one alone, in the
// order it tries them (face normals and in-plane edge normals first: they separate the
// near-coplanar neighbours a broad phase yields most). Any separating axis decides, so the
// verdict does not depend on the grouping.
__attribute__((target("avx"))) inline bool triangles_intersect_avx(const glm::dvec3& a0, const glm::dvec3& a1,
                                                                   const glm::dvec3& a2, const glm::dvec3& b0,
                                                                   const glm::dvec3& b1, const glm::dvec3& b2) {
  const glm::dvec3 origin = a0;
  const glm::dvec3 a[3] = {glm::dvec3(0.0), a1 - origin, a2 - origin};
  const glm::dvec3 b[3] = {b0 - origin, b1 - origin, b2 - origin};
  const glm::dvec3 ea[3] = {a[1] - a[0], a[2] - a[1], a[0] - a[2]};
  const glm::dvec3 eb[3] = {b[1] - b[0], b[2] - b[1], b[0] - b[2]};
  const glm::dvec3 na = glm::cross(ea[0], ea[1]), nb = glm::cross(eb[0], eb[1]);
  // The face normals (computed again in their lanes, the same way) and two in-plane normals.
  if (separating_lanes_d4(cross_d4(gather_d4(ea[0], eb[0], na, na), gather_d4(ea[1], eb[1], ea[0], ea[1])), a, b))
    return false;
  if (separating_lanes_d4(cross_d4(gather_d4(na, nb, nb, nb), gather_d4(ea[2], eb[0], eb[1], eb[2])), a, b))
    return false;
  if (separating_lanes_d4(cross_d4(gather_d4(ea[0], ea[0], ea[0], ea[1]), gather_d4(eb[0], eb[1], eb[2], eb[0])), a, b))
    return false;
  if (separating_lanes_d4(cross_d4(gather_d4(ea[1], ea[1], ea[2], ea[2]), gather_d4(eb[1], eb[2], eb[0], eb[1])), a, b))
    return false;
  return !geometry::detail::separated_along(glm::cross(ea[2], eb[2]), a, b);
}
#endif

}  // namespace detail

// A sure "apart" for geometry::triangles_intersect from the float corners it would widen (the
// LBS guard's pre-test): all three corners of one triangle strictly on one side of the other's
// plane, by far more than rounding. With R the largest extent of the two triangles' box, every
// coordinate of e1 = p1 − p0, e2 = p2 − p0 and w_k = q_k − p0 is within R, so d_k = (e1 × e2)·w_k
// computed in float (each difference, product and sum rounded once, in any order) is within
// 8.1·2^-24·(3R)³ < 1.4e-5·R³ of its exact value, and the exact test's projections on its face
// normal ((a1 − a0) × (a2 − a1): the same normal exactly) within about 10·2^-53·(3R)³ of theirs,
// 0 for the plane's own corners. So every d_k beyond kSureMargin·R³ on one side means that the
// face normal separates the triangles in the exact test too: it says they do not meet (the
// margin is about seven times the float bound). R³ must lie in [kSureScaleMin, kSureScaleMax]:
// each |n_i| ≤ 2R², so every partial sum of a d_k is within 6R³ and stays finite below
// FLT_MAX / 8, and above 1e-30 the products' underflow (at most 2^-149 each) is far below the
// margin. Outside it, and where a coordinate is NaN, this says nothing (false). False says
// nothing either: the exact test decides. On the guard's broad-phase pairs, neighbours on one
// surface, about four in five are decided here, without the 17 axes in double.
constexpr float kSureMargin = 1e-4f;
constexpr float kSureScaleMin = 1e-30f;
constexpr float kSureScaleMax = std::numeric_limits<float>::max() / 8.0f;

namespace detail {

inline bool triangles_surely_apart_portable(const glm::vec3& a0, const glm::vec3& a1, const glm::vec3& a2,
                                            const glm::vec3& b0, const glm::vec3& b1, const glm::vec3& b2) {
  const glm::vec3 lo = glm::min(glm::min(glm::min(a0, a1), glm::min(a2, b0)), glm::min(b1, b2));
  const glm::vec3 hi = glm::max(glm::max(glm::max(a0, a1), glm::max(a2, b0)), glm::max(b1, b2));
  const glm::vec3 extent = hi - lo;
  const float r = std::max(extent.x, std::max(extent.y, extent.z));
  const float cube = r * r * r;
  if (!(cube >= kSureScaleMin && cube <= kSureScaleMax)) return false;
  const float margin = kSureMargin * cube;
  return corners_beyond_plane(a0, a1, a2, b0, b1, b2, margin) || corners_beyond_plane(b0, b1, b2, a0, a1, a2, margin);
}

#if defined(__SSE2__)
inline bool triangles_surely_apart_sse2(const glm::vec3& a0, const glm::vec3& a1, const glm::vec3& a2,
                                        const glm::vec3& b0, const glm::vec3& b1, const glm::vec3& b2) {
  const __m128 pa0 = sse::load3(a0), pa1 = sse::load3(a1), pa2 = sse::load3(a2);
  const __m128 pb0 = sse::load3(b0), pb1 = sse::load3(b1), pb2 = sse::load3(b2);
  // (A NaN may drop out of the box; the plane tests' comparisons are then false.)
  const __m128 lo = _mm_min_ps(_mm_min_ps(_mm_min_ps(pa0, pa1), _mm_min_ps(pa2, pb0)), _mm_min_ps(pb1, pb2));
  const __m128 hi = _mm_max_ps(_mm_max_ps(_mm_max_ps(pa0, pa1), _mm_max_ps(pa2, pb0)), _mm_max_ps(pb1, pb2));
  const __m128 extent = _mm_sub_ps(hi, lo);
  const __m128 r = _mm_max_ps(extent, _mm_max_ps(_mm_shuffle_ps(extent, extent, _MM_SHUFFLE(3, 0, 2, 1)),
                                                 _mm_shuffle_ps(extent, extent, _MM_SHUFFLE(3, 1, 0, 2))));
  const float cube = _mm_cvtss_f32(_mm_mul_ps(_mm_mul_ps(r, r), r));
  if (!(cube >= kSureScaleMin && cube <= kSureScaleMax)) return false;
  const __m128 margin = _mm_set1_ps(kSureMargin * cube);
  return sse::corners_beyond_plane(pa0, pa1, pa2, pb0, pb1, pb2, margin) ||
         sse::corners_beyond_plane(pb0, pb1, pb2, pa0, pa1, pa2, margin);
}
#endif

}  // namespace detail

inline bool triangles_surely_apart(const glm::vec3& a0, const glm::vec3& a1, const glm::vec3& a2, const glm::vec3& b0,
                                   const glm::vec3& b1, const glm::vec3& b2) {
#if defined(__SSE2__)
  return detail::triangles_surely_apart_sse2(a0, a1, a2, b0, b1, b2);
#else
  return detail::triangles_surely_apart_portable(a0, a1, a2, b0, b1, b2);
#endif
}

// The fastest form of geometry::triangles_intersect this CPU runs (checked once): all give
// the same verdict.
inline ExactTriangleTest exact_triangle_test() {
#if defined(SKELFORM_EXACT_TRIANGLES_AVX)
  static const ExactTriangleTest chosen = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx") ? ExactTriangleTest(&detail::triangles_intersect_avx)
                                         : ExactTriangleTest(&geometry::triangles_intersect);
  }();
  return chosen;
#else
  return &geometry::triangles_intersect;
#endif
}

}  // namespace skelform::runtime
