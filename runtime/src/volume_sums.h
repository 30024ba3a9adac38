// The sums behind the LBS guard's volume test (lbs_guard.cpp volume_within): over the triangles
// (a, b, c) of a closed welded mesh, with a base point a and a direction α per welded vertex,
//   at_zero = Σ det(a, b, c),   at_one = Σ det(a + α, b + β, c + γ),   scale = Σ n_a n_b n_c
// (det(x, y, z) = x·(y × z), six times the signed volume of the tetrahedron on the origin; n a
// per-vertex norm, for the caller's rounding bound). The test runs on every evaluation of a
// closed character and reads every triangle, in double: on a 75K-triangle mesh it was an eighth
// of an evaluation.
//
// volume_sums() picks the fastest form once: with AVX2, four triangles at a time, their corners
// gathered from the interleaved arrays, each lane summing its own triangles and the lanes added
// at the end (the same products per triangle, summed in another order); elsewhere the portable
// loop. The two differ by the rounding of their sums, which the caller's bound covers (any
// order of summing T terms is within (T − 1)·2^-53 of their absolute sum).
//
// Where that test says no, the guard expands the volume of base + μ·delta as a cubic in μ
// (volume_cubic_sums): with AVX2 four triangles' terms at a time, added one triangle after the
// other as the portable loop adds them, so the same bits in either form.
#pragma once

#include "avx2_lanes.h"
#include "cpu.h"
#include "exact_triangles.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>

namespace skelform::runtime {

struct VolumeSums {
  double at_zero = 0.0, at_one = 0.0, scale = 0.0;
};

// The sums over triangles [first, end), added to `sums` in triangle order.
inline void volume_sums_portable(const uint32_t* triangles, uint32_t first, uint32_t end, const glm::dvec3* base,
                                 const glm::dvec3* delta, const double* norm, VolumeSums& sums) {
  double at_zero = sums.at_zero, at_one = sums.at_one, scale = sums.scale;
  for (uint32_t t = first; t < end; ++t) {
    const uint32_t* q = triangles + 3 * size_t(t);
    const glm::dvec3 &a = base[q[0]], &b = base[q[1]], &c = base[q[2]];
    at_zero += glm::dot(a, glm::cross(b, c));
    at_one += glm::dot(a + delta[q[0]], glm::cross(b + delta[q[1]], c + delta[q[2]]));
    scale += norm[q[0]] * norm[q[1]] * norm[q[2]];
  }
  sums = {at_zero, at_one, scale};
}

#if defined(SKELFORM_HAS_AVX2_KERNELS)
namespace detail {

// Four double 3-vectors and their cross product lane by lane: the guard's triangle test's
// (exact_triangles.h, glm::cross's operations).
using D4 = DVec3x4;

// a·b lane by lane, as glm::dot computes it: (x + y) + z.
__attribute__((target("avx2"))) inline __m256d dot_d4(const D4& a, const D4& b) {
  return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(a.x, b.x), _mm256_mul_pd(a.y, b.y)), _mm256_mul_pd(a.z, b.z));
}
// det(a, b, c) = a·(b × c) lane by lane, as glm::dot(a, glm::cross(b, c)) computes it.
__attribute__((target("avx2"))) inline __m256d det_d4(const D4& a, const D4& b, const D4& c) {
  return dot_d4(a, cross_d4(b, c));
}
// The three corners of four consecutive triangles (`triangles` at the first): their vertices,
// base (a) and delta (α) there. Vertex indices must take int32 gather offsets
// (gather_offsets_fit).
__attribute__((target("avx2"))) inline void gather_corners(const uint32_t* triangles, const glm::dvec3* base,
                                                           const glm::dvec3* delta, __m128i vertex[3], D4 a[3],
                                                           D4 alpha[3]) {
  static_assert(sizeof(glm::dvec3) == 3 * sizeof(double), "dvec3 is three packed doubles");
  const int* q = reinterpret_cast<const int*>(triangles);
  const __m128i rows = _mm_setr_epi32(0, 3, 6, 9);  // a corner of four consecutive triangles
  for (int k = 0; k < 3; ++k) {
    const __m128i v = vertex[k] = avx2::gather_epi32(q + k, rows);
    const __m128i v3 = _mm_add_epi32(v, _mm_add_epi32(v, v));  // the vertex's first double
    a[k] = {avx2::gather_pd(&base[0].x, v3), avx2::gather_pd(&base[0].y, v3), avx2::gather_pd(&base[0].z, v3)};
    alpha[k] = {avx2::gather_pd(&delta[0].x, v3), avx2::gather_pd(&delta[0].y, v3), avx2::gather_pd(&delta[0].z, v3)};
  }
}

// The sums over triangles [0, 4·⌊count/4⌋), four at a time; returns where it stopped. Vertex
// indices must take int32 gather offsets (gather_offsets_fit).
__attribute__((target("avx2"))) inline uint32_t volume_sums_avx2(const uint32_t* triangles, uint32_t count,
                                                                 const glm::dvec3* base, const glm::dvec3* delta,
                                                                 const double* norm, VolumeSums& sums) {
  __m256d at_zero = _mm256_setzero_pd(), at_one = at_zero, scale = at_zero;
  uint32_t t = 0;
  for (; t + 4 <= count; t += 4) {
    __m128i v[3];
    D4 p[3], e[3], m[3];
    gather_corners(triangles + 3 * size_t(t), base, delta, v, p, e);
    __m256d n[3];
    for (int k = 0; k < 3; ++k) {
      n[k] = avx2::gather_pd(norm, v[k]);
      m[k] = {_mm256_add_pd(p[k].x, e[k].x), _mm256_add_pd(p[k].y, e[k].y), _mm256_add_pd(p[k].z, e[k].z)};
    }
    at_zero = _mm256_add_pd(at_zero, det_d4(p[0], p[1], p[2]));
    at_one = _mm256_add_pd(at_one, det_d4(m[0], m[1], m[2]));
    scale = _mm256_add_pd(scale, _mm256_mul_pd(_mm256_mul_pd(n[0], n[1]), n[2]));
  }
  alignas(32) double lanes[3][4];
  _mm256_store_pd(lanes[0], at_zero);
  _mm256_store_pd(lanes[1], at_one);
  _mm256_store_pd(lanes[2], scale);
  sums.at_zero += (lanes[0][0] + lanes[0][1]) + (lanes[0][2] + lanes[0][3]);
  sums.at_one += (lanes[1][0] + lanes[1][1]) + (lanes[1][2] + lanes[1][3]);
  sums.scale += (lanes[2][0] + lanes[2][1]) + (lanes[2][2] + lanes[2][3]);
  return t;
}

}  // namespace detail
#endif

// Per welded vertex w of [first, end), with r = representative[w], s = weight[r]·factor[w]:
// base = L_r − centre, delta = s·(K_r − L_r), in double, and (norm not null) norm = |base|₁ +
// |delta|₁ summed x, y, z of base then of delta.
inline void volume_points_portable(uint32_t first, uint32_t end, const uint32_t* representative, const glm::vec3* lbs,
                                   const glm::vec3* skelform, const float* weight, const float* factor,
                                   const glm::dvec3& centre, glm::dvec3* base, glm::dvec3* delta, double* norm) {
  for (uint32_t w = first; w < end; ++w) {
    const uint32_t r = representative[w];
    const double s = double(weight[r]) * double(factor[w]);
    base[w] = glm::dvec3(lbs[r]) - centre;
    delta[w] = s * (glm::dvec3(skelform[r]) - glm::dvec3(lbs[r]));
    if (!norm) continue;
    // (std::fabs clears the sign bit, as the AVX2 form's mask does, of −0 and NaN too.)
    norm[w] = std::fabs(base[w].x) + std::fabs(base[w].y) + std::fabs(base[w].z) + std::fabs(delta[w].x) +
              std::fabs(delta[w].y) + std::fabs(delta[w].z);
  }
}

#if defined(SKELFORM_HAS_AVX2_KERNELS)
namespace detail {

// volume_points_portable over welded vertices [0, 4·⌊count/4⌋), four at a time: the same
// operations in double on the same widened floats (weight·factor is exact in double), so the
// same bits. Returns where it stopped. The representatives' arrays must take int32 gather
// offsets (gather_offsets_fit).
__attribute__((target("avx2"))) inline uint32_t volume_points_avx2(uint32_t count, const uint32_t* representative,
                                                                   const glm::vec3* lbs, const glm::vec3* skelform,
                                                                   const float* weight, const float* factor,
                                                                   const glm::dvec3& centre, glm::dvec3* base,
                                                                   glm::dvec3* delta, double* norm) {
  static_assert(sizeof(glm::vec3) == 3 * sizeof(float), "vec3 is three packed floats");
  const __m256d sign = _mm256_set1_pd(-0.0);
  const __m256d centre_axis[3] = {_mm256_set1_pd(centre.x), _mm256_set1_pd(centre.y), _mm256_set1_pd(centre.z)};
  uint32_t w = 0;
  for (; w + 4 <= count; w += 4) {
    const __m128i r = _mm_loadu_si128(reinterpret_cast<const __m128i*>(representative + w));
    const __m128i r3 = _mm_add_epi32(r, _mm_add_epi32(r, r));
    const __m256d s =
        _mm256_mul_pd(_mm256_cvtps_pd(avx2::gather_ps(weight, r)), _mm256_cvtps_pd(_mm_loadu_ps(factor + w)));
    alignas(32) double b[3][4], d[3][4];
    __m256d sum = _mm256_setzero_pd();
    for (int axis = 0; axis < 3; ++axis) {
      const __m256d l = _mm256_cvtps_pd(avx2::gather_ps(&lbs[0].x + axis, r3));  // 4 lanes
      const __m256d k = _mm256_cvtps_pd(avx2::gather_ps(&skelform[0].x + axis, r3));
      const __m256d bx = _mm256_sub_pd(l, centre_axis[axis]);
      _mm256_store_pd(b[axis], bx);
      _mm256_store_pd(d[axis], _mm256_mul_pd(s, _mm256_sub_pd(k, l)));
      sum = axis == 0 ? _mm256_andnot_pd(sign, bx) : _mm256_add_pd(sum, _mm256_andnot_pd(sign, bx));
    }
    for (int axis = 0; axis < 3; ++axis) sum = _mm256_add_pd(sum, _mm256_andnot_pd(sign, _mm256_load_pd(d[axis])));
    if (norm) _mm256_storeu_pd(norm + w, sum);
    for (int i = 0; i < 4; ++i) {
      base[w + i] = glm::dvec3(b[0][i], b[1][i], b[2][i]);
      delta[w + i] = glm::dvec3(d[0][i], d[1][i], d[2][i]);
    }
  }
  return w;
}

}  // namespace detail
#endif

// volume_points_portable over every welded vertex, in the fastest form this CPU runs.
// `dense_count`: the length of the arrays the representatives index.
inline void volume_points(uint32_t count, uint32_t dense_count, const uint32_t* representative, const glm::vec3* lbs,
                          const glm::vec3* skelform, const float* weight, const float* factor, const glm::dvec3& centre,
                          glm::dvec3* base, glm::dvec3* delta, double* norm) {
  uint32_t done = 0;
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (cpu_has_avx2() && gather_offsets_fit(dense_count))
    done = detail::volume_points_avx2(count, representative, lbs, skelform, weight, factor, centre, base, delta, norm);
#else
  (void)dense_count;
#endif
  volume_points_portable(done, count, representative, lbs, skelform, weight, factor, centre, base, delta, norm);
}

// The sums over every triangle, in the fastest form this CPU runs (checked once).
inline VolumeSums volume_sums(const uint32_t* triangles, uint32_t triangle_count, uint32_t vertex_count,
                              const glm::dvec3* base, const glm::dvec3* delta, const double* norm) {
  VolumeSums sums;
  uint32_t done = 0;
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (cpu_has_avx2() && gather_offsets_fit(vertex_count))
    done = detail::volume_sums_avx2(triangles, triangle_count, base, delta, norm, sums);
#else
  (void)vertex_count;
#endif
  volume_sums_portable(triangles, done, triangle_count, base, delta, norm, sums);
  return sums;
}

// The cubic the guard solves where the test above says no (lbs_guard.cpp volume_polynomial):
// Σ det(a + μα, b + μβ, c + μγ) = v[0] + v[1]·μ + v[2]·μ² + v[3]·μ³ over the triangles [first,
// end), each triangle's terms added to v in triangle order. Its four cross products are computed
// once: the sums of eight determinants, in four cross and eight dot products.
inline void volume_cubic_portable(const uint32_t* triangles, uint32_t first, uint32_t end, const glm::dvec3* base,
                                  const glm::dvec3* delta, double v[4]) {
  double v0 = v[0], v1 = v[1], v2 = v[2], v3 = v[3];
  for (uint32_t t = first; t < end; ++t) {
    const uint32_t* q = triangles + 3 * size_t(t);
    const glm::dvec3 &a = base[q[0]], &b = base[q[1]], &c = base[q[2]];
    const glm::dvec3 &da = delta[q[0]], &db = delta[q[1]], &dc = delta[q[2]];
    const glm::dvec3 k0 = glm::cross(b, c), c1 = glm::cross(db, c), c2 = glm::cross(b, dc), k2 = glm::cross(db, dc);
    v0 += glm::dot(a, k0);
    v1 += glm::dot(da, k0) + glm::dot(a, c1) + glm::dot(a, c2);
    v2 += glm::dot(da, c1) + glm::dot(da, c2) + glm::dot(a, k2);
    v3 += glm::dot(da, k2);
  }
  v[0] = v0, v[1] = v1, v[2] = v2, v[3] = v3;
}

#if defined(SKELFORM_HAS_AVX2_KERNELS)
namespace detail {

// volume_cubic_portable over triangles [0, 4·⌊count/4⌋): four triangles' terms at a time, each
// lane the portable loop's products and sums for its triangle, then added to v one triangle
// after the other; so the same bits. Returns where it stopped. Vertex indices must take int32
// gather offsets (gather_offsets_fit).
__attribute__((target("avx2"))) inline uint32_t volume_cubic_avx2(const uint32_t* triangles, uint32_t count,
                                                                  const glm::dvec3* base, const glm::dvec3* delta,
                                                                  double v[4]) {
  double v0 = v[0], v1 = v[1], v2 = v[2], v3 = v[3];
  uint32_t t = 0;
  for (; t + 4 <= count; t += 4) {
    __m128i vertex[3];
    D4 a[3], alpha[3];
    gather_corners(triangles + 3 * size_t(t), base, delta, vertex, a, alpha);
    const D4 k0 = cross_d4(a[1], a[2]), c1 = cross_d4(alpha[1], a[2]), c2 = cross_d4(a[1], alpha[2]),
             k2 = cross_d4(alpha[1], alpha[2]);
    alignas(32) double terms[4][4];
    _mm256_store_pd(terms[0], dot_d4(a[0], k0));
    _mm256_store_pd(terms[1], _mm256_add_pd(_mm256_add_pd(dot_d4(alpha[0], k0), dot_d4(a[0], c1)), dot_d4(a[0], c2)));
    _mm256_store_pd(terms[2],
                    _mm256_add_pd(_mm256_add_pd(dot_d4(alpha[0], c1), dot_d4(alpha[0], c2)), dot_d4(a[0], k2)));
    _mm256_store_pd(terms[3], dot_d4(alpha[0], k2));
    for (int i = 0; i < 4; ++i) v0 += terms[0][i], v1 += terms[1][i], v2 += terms[2][i], v3 += terms[3][i];
  }
  v[0] = v0, v[1] = v1, v[2] = v2, v[3] = v3;
  return t;
}

}  // namespace detail
#endif

// The cubic's coefficients over every triangle (volume_cubic_portable from zero), in the fastest
// form this CPU runs: the same bits in either.
inline void volume_cubic_sums(const uint32_t* triangles, uint32_t triangle_count, uint32_t vertex_count,
                              const glm::dvec3* base, const glm::dvec3* delta, double v[4]) {
  v[0] = v[1] = v[2] = v[3] = 0.0;
  uint32_t done = 0;
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (cpu_has_avx2() && gather_offsets_fit(vertex_count))
    done = detail::volume_cubic_avx2(triangles, triangle_count, base, delta, v);
#else
  (void)vertex_count;
#endif
  volume_cubic_portable(triangles, done, triangle_count, base, delta, v);
}

}  // namespace skelform::runtime
