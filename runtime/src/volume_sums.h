// The sums behind the LBS guard's volume test (lbs_guard.cpp volume_within): over the triangles
// (a, b, c) of a closed welded mesh, with a base point a and a direction α per welded vertex,
//   at_zero = Σ det(a, b, c),   at_one = Σ det(a + α, b + β, c + γ),   scale = Σ n_a n_b n_c
// (det(x, y, z) = x·(y × z), six times the signed volume of the tetrahedron on the origin; n a
// per-vertex norm, for the caller's rounding bound). The test runs on every evaluation of a
// closed character and reads every triangle, in double: on a 75K-triangle mesh it was an eighth
// of an evaluation.
//
// Where that test says no, the guard expands the volume of base + μ·delta as a cubic in μ
// (volume_cubic_sums).
//
// Plain loops: AVX2 forms that gathered four triangles' corners at a time ran fewer
// instructions but took longer (on the 75K-triangle CesiumMan_loop2: the sums 0.72 against
// 0.29 ms, the cubic 0.79 against 0.49 ms, the points 0.14 against 0.13 ms; docs/results.md
// "Speed").
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace skelform::runtime {

struct VolumeSums {
  double at_zero = 0.0, at_one = 0.0, scale = 0.0;
};

// The sums over the triangles, in triangle order.
inline VolumeSums volume_sums(const uint32_t* triangles, uint32_t triangle_count, const glm::dvec3* base,
                              const glm::dvec3* delta, const double* norm) {
  double at_zero = 0.0, at_one = 0.0, scale = 0.0;
  for (uint32_t t = 0; t < triangle_count; ++t) {
    const uint32_t* q = triangles + 3 * size_t(t);
    const glm::dvec3 &a = base[q[0]], &b = base[q[1]], &c = base[q[2]];
    at_zero += glm::dot(a, glm::cross(b, c));
    at_one += glm::dot(a + delta[q[0]], glm::cross(b + delta[q[1]], c + delta[q[2]]));
    scale += norm[q[0]] * norm[q[1]] * norm[q[2]];
  }
  return {at_zero, at_one, scale};
}

// Per welded vertex w < count, with r = representative[w], s = weight[r]·factor[w]: base = L_r −
// centre, delta = s·(K_r − L_r), in double, and (norm not null) norm = |base|₁ + |delta|₁ summed
// x, y, z of base then of delta.
inline void volume_points(uint32_t count, const uint32_t* representative, const glm::vec3* lbs,
                          const glm::vec3* skelform, const float* weight, const float* factor, const glm::dvec3& centre,
                          glm::dvec3* base, glm::dvec3* delta, double* norm) {
  for (uint32_t w = 0; w < count; ++w) {
    const uint32_t r = representative[w];
    const double s = double(weight[r]) * double(factor[w]);
    base[w] = glm::dvec3(lbs[r]) - centre;
    delta[w] = s * (glm::dvec3(skelform[r]) - glm::dvec3(lbs[r]));
    if (!norm) continue;
    norm[w] = std::fabs(base[w].x) + std::fabs(base[w].y) + std::fabs(base[w].z) + std::fabs(delta[w].x) +
              std::fabs(delta[w].y) + std::fabs(delta[w].z);
  }
}

// The cubic the guard solves where the test above says no (lbs_guard.cpp volume_polynomial):
// Σ det(a + μα, b + μβ, c + μγ) = v[0] + v[1]·μ + v[2]·μ² + v[3]·μ³ over the triangles, each
// triangle's terms added in triangle order. Its four cross products are computed once: the sums
// of eight determinants, in four cross and eight dot products. v[0] is volume_sums' at_zero
// bit for bit.
inline void volume_cubic_sums(const uint32_t* triangles, uint32_t triangle_count, const glm::dvec3* base,
                              const glm::dvec3* delta, double v[4]) {
  double v0 = 0.0, v1 = 0.0, v2 = 0.0, v3 = 0.0;
  for (uint32_t t = 0; t < triangle_count; ++t) {
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

}  // namespace skelform::runtime
