// E_T, the three-ball hull distance of flow (4) (fair.h ball_hull_distance), in pieces the
// fold flow evaluates a block of triangles at a time (fair_fold.cpp triangle_forces): the
// interior (tangent-plane) candidate, one triangle or four SSE2 lanes at a time, and the
// hinted boundary candidate four lanes at a time. Inline here because they run inside that
// block loop; each lane path computes its scalar counterpart's operations in the same order,
// so the block and ball_hull_distance (ball_hull.cpp) give the same bits.
#pragma once

#include "fair.h"
#include "fair_internal.h"
#include "vec3_sse.h"

#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif

namespace skelform::runtime::fair_detail {

// Interior (tangent-plane case) of E_T: at a stationary b the unit n = (P − c(b))/|P − c(b)|
// obeys n·c_i + r_i = const, i.e. n·e_1 = −δ_1, n·e_2 = −δ_2 (e_i = c_i − c_0, δ_i = r_i − r_0):
// n = n₀ + σμ m with n₀ in the triangle's plane, m its unit normal, μ = sqrt(1 − |n₀|²), σ the
// side of P. Then E_T = n·(P − c_0) − r_0 (distance to the tangent plane), valid when the
// foot Q = P − t n, t = |(P − c_0)·m| / μ, lies in the triangle. φ is convex in b, so such a
// stationary point is the minimum.
//
// Written once, without branches (guards are selects): the scalar E_T and the block-wise one
// in triangle_forces evaluate this same function, so both give the same bits, and in a block the
// independent triangles overlap their divisions and square roots. With SSE2 the block runs it
// four triangles at a time (interior_lanes4 below: the same operations per lane, so the same
// bits). Inputs: P − c_0 (w0), e_1, e_2, r_0, δ_1, δ_2. Returns whether the stationary point
// exists and lies in the triangle.
inline bool interior_lane(float w0x, float w0y, float w0z, float e1x, float e1y, float e1z, float e2x, float e2y,
                          float e2z, float r0, float d1, float d2, float& value, float& nx, float& ny, float& nz) {
  const float g11 = e1x * e1x + e1y * e1y + e1z * e1z;
  const float g12 = e1x * e2x + e1y * e2y + e1z * e2z;
  const float g22 = e2x * e2x + e2y * e2y + e2z * e2z;
  const float det = g11 * g22 - g12 * g12;  // |e1 × e2|²
  const bool det_ok = (det > 1e-6f * g11 * g22) & (det > 0.0f);
  const float safe_det = det_ok ? det : 1.0f;
  const float inverse_det = 1.0f / safe_det;  // (reciprocals: one division each, not one per use)
  const float a = (-d1 * g22 + d2 * g12) * inverse_det;
  const float b = (-d2 * g11 + d1 * g12) * inverse_det;
  const float n0x = a * e1x + b * e2x, n0y = a * e1y + b * e2y, n0z = a * e1z + b * e2z;
  const float q = 1.0f - (n0x * n0x + n0y * n0y + n0z * n0z);
  const bool q_ok = q > 0.0f;
  const float mu = std::sqrt(q_ok ? q : 1.0f);
  const float inverse_area = 1.0f / std::sqrt(safe_det);
  const float mx = (e1y * e2z - e1z * e2y) * inverse_area;
  const float my = (e1z * e2x - e1x * e2z) * inverse_area;
  const float mz = (e1x * e2y - e1y * e2x) * inverse_area;
  const float w = w0x * mx + w0y * my + w0z * mz;
  const float sigma_mu = mu * (w >= 0.0f ? 1.0f : -1.0f);
  nx = n0x + sigma_mu * mx;
  ny = n0y + sigma_mu * my;
  nz = n0z + sigma_mu * mz;
  const float t = std::fabs(w) / mu;
  const float fx = w0x - t * nx, fy = w0y - t * ny, fz = w0z - t * nz;  // Q − c_0
  const float f1 = fx * e1x + fy * e1y + fz * e1z, f2 = fx * e2x + fy * e2y + fz * e2z;
  const float beta1 = (f1 * g22 - f2 * g12) * inverse_det;
  const float beta2 = (f2 * g11 - f1 * g12) * inverse_det;
  value = t - (r0 + beta1 * d1 + beta2 * d2);
  return det_ok & q_ok & (beta1 >= 0.0f) & (beta2 >= 0.0f) & (beta1 + beta2 <= 1.0f);
}

#if defined(__SSE2__)
// interior_lane for four triangles at once, in SSE2 (x86-64's baseline: no ISA flag, no
// dispatch): lane by lane the same IEEE operations in the same order (selects as and/andnot/or,
// ±1 and |w| as in the scalar code), so every lane has interior_lane's bits. Reads and writes
// elements [i, i + 4) of the block's arrays; inside[k] as interior_lane's return value.
inline void interior_lanes4(const float* w0x, const float* w0y, const float* w0z, const float* e1x, const float* e1y,
                            const float* e1z, const float* e2x, const float* e2y, const float* e2z, const float* r0,
                            const float* d1, const float* d2, float* value, float* nx, float* ny, float* nz,
                            bool* inside) {
  using namespace lane4;
  const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
  const __m128 sign = _mm_set1_ps(-0.0f);
  const __m128 ax = load(e1x), ay = load(e1y), az = load(e1z), bx = load(e2x), by = load(e2y), bz = load(e2z);
  const __m128 px = load(w0x), py = load(w0y), pz = load(w0z);
  const __m128 delta1 = load(d1), delta2 = load(d2);
  const __m128 g11 = add(add(mul(ax, ax), mul(ay, ay)), mul(az, az));
  const __m128 g12 = add(add(mul(ax, bx), mul(ay, by)), mul(az, bz));
  const __m128 g22 = add(add(mul(bx, bx), mul(by, by)), mul(bz, bz));
  const __m128 det = sub(mul(g11, g22), mul(g12, g12));
  const __m128 det_ok = _mm_and_ps(_mm_cmpgt_ps(det, mul(mul(_mm_set1_ps(1e-6f), g11), g22)), _mm_cmpgt_ps(det, zero));
  const __m128 safe_det = select(det_ok, det, one);
  const __m128 inverse_det = _mm_div_ps(one, safe_det);
  const __m128 a = mul(add(mul(_mm_xor_ps(delta1, sign), g22), mul(delta2, g12)), inverse_det);
  const __m128 b = mul(add(mul(_mm_xor_ps(delta2, sign), g11), mul(delta1, g12)), inverse_det);
  const __m128 n0x = add(mul(a, ax), mul(b, bx)), n0y = add(mul(a, ay), mul(b, by)), n0z = add(mul(a, az), mul(b, bz));
  const __m128 q = sub(one, add(add(mul(n0x, n0x), mul(n0y, n0y)), mul(n0z, n0z)));
  const __m128 q_ok = _mm_cmpgt_ps(q, zero);
  const __m128 mu = _mm_sqrt_ps(select(q_ok, q, one));
  const __m128 inverse_area = _mm_div_ps(one, _mm_sqrt_ps(safe_det));
  const __m128 mx = mul(sub(mul(ay, bz), mul(az, by)), inverse_area);
  const __m128 my = mul(sub(mul(az, bx), mul(ax, bz)), inverse_area);
  const __m128 mz = mul(sub(mul(ax, by), mul(ay, bx)), inverse_area);
  const __m128 w = add(add(mul(px, mx), mul(py, my)), mul(pz, mz));
  const __m128 sigma_mu = mul(mu, select(_mm_cmpge_ps(w, zero), one, _mm_set1_ps(-1.0f)));
  const __m128 normal_x = add(n0x, mul(sigma_mu, mx)), normal_y = add(n0y, mul(sigma_mu, my));
  const __m128 normal_z = add(n0z, mul(sigma_mu, mz));
  const __m128 t = _mm_div_ps(_mm_andnot_ps(sign, w), mu);
  const __m128 fx = sub(px, mul(t, normal_x)), fy = sub(py, mul(t, normal_y)), fz = sub(pz, mul(t, normal_z));
  const __m128 f1 = add(add(mul(fx, ax), mul(fy, ay)), mul(fz, az));
  const __m128 f2 = add(add(mul(fx, bx), mul(fy, by)), mul(fz, bz));
  const __m128 beta1 = mul(sub(mul(f1, g22), mul(f2, g12)), inverse_det);
  const __m128 beta2 = mul(sub(mul(f2, g11), mul(f1, g12)), inverse_det);
  _mm_storeu_ps(value, sub(t, add(add(load(r0), mul(beta1, delta1)), mul(beta2, delta2))));
  _mm_storeu_ps(nx, normal_x);
  _mm_storeu_ps(ny, normal_y);
  _mm_storeu_ps(nz, normal_z);
  const __m128 ok =
      _mm_and_ps(_mm_and_ps(_mm_and_ps(det_ok, q_ok), _mm_and_ps(_mm_cmpge_ps(beta1, zero), _mm_cmpge_ps(beta2, zero))),
                 _mm_cmple_ps(add(beta1, beta2), one));
  const int bits = _mm_movemask_ps(ok);
  for (int k = 0; k < 4; ++k) inside[k] = (bits >> k) & 1;
}
#endif

// The interior candidate as a HullDistance, if it is the minimum and finite.
inline bool interior_result(float value, float nx, float ny, float nz, HullDistance& result) {
  result.value = value;
  result.gradient = glm::vec3(nx, ny, nz);
  return std::isfinite(result.value) && finite(result.gradient);
}

#if defined(__SSE2__)
constexpr bool kHintedLanes = true;

// Four triangles' hinted candidates (boundary_distance's first part), structure of arrays:
// the centroid P, the balls (a, b, c) ordered from the hint's (vertex a, or edge a → b; c the
// remaining corner) and whether the hint is an edge.
struct HullLanes {
  float px[4], py[4], pz[4], ax[4], ay[4], az[4], bx[4], by[4], bz[4], cx[4], cy[4], cz[4];
  float ra[4], rb[4], rc[4];
  uint32_t edge[4];
  void set(uint32_t lane, const glm::vec3& p, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, float r_a,
           float r_b, float r_c, bool is_edge) {
    px[lane] = p.x, py[lane] = p.y, pz[lane] = p.z;
    ax[lane] = a.x, ay[lane] = a.y, az[lane] = a.z;
    bx[lane] = b.x, by[lane] = b.y, bz[lane] = b.z;
    cx[lane] = c.x, cy[lane] = c.y, cz[lane] = c.z;
    ra[lane] = r_a, rb[lane] = r_b, rc[lane] = r_c;
    edge[lane] = is_edge ? ~0u : 0u;
  }
};

// boundary_distance's hint test for four triangles at once, in SSE2: edge_foot, the foot's
// distance and the KKT tests (toward) with the same operations per lane in the same order, so
// an accepted lane has boundary_distance's bits. Branch-free: where the scalar code returns
// early (a zero-length edge, |k| ≥ 1, a clamped foot, a zero distance) the lane computes on a
// stand-in value (never dividing by zero or taking the root of a negative number) and is
// rejected. Returns a bit per lane: 1 = the hinted candidate is the minimum and finite, its
// result in e[lane] (the hint stays); 0 = the caller runs boundary_distance.
inline int hinted_lanes4(const HullLanes& l, HullDistance e[4]) {
  using namespace lane4;
  const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f), sign = _mm_set1_ps(-0.0f);
  const __m128 px = load(l.px), py = load(l.py), pz = load(l.pz);
  const __m128 ax = load(l.ax), ay = load(l.ay), az = load(l.az);
  const __m128 cx = load(l.cx), cy = load(l.cy), cz = load(l.cz);
  const __m128 ra = load(l.ra), rc = load(l.rc);
  const __m128 edge = _mm_castsi128_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(l.edge)));
  // edge_foot(p, c, r, i): the minimum along the frustum of balls a and b.
  const __m128 ex = sub(load(l.bx), ax), ey = sub(load(l.by), ay), ez = sub(load(l.bz), az);
  const __m128 length = _mm_sqrt_ps(dot(ex, ey, ez, ex, ey, ez));
  const __m128 length_ok = _mm_cmpgt_ps(length, zero);
  const __m128 safe_length = select(length_ok, length, one);
  const __m128 slope = _mm_div_ps(sub(load(l.rb), ra), safe_length);
  const __m128 k_ok = _mm_cmplt_ps(_mm_andnot_ps(sign, slope), one);
  const __m128 k = _mm_and_ps(k_ok, slope);  // (0 in the rejected lanes: no overflow below)
  const __m128 inverse_length = _mm_div_ps(one, safe_length);
  const __m128 axis_x = mul(ex, inverse_length), axis_y = mul(ey, inverse_length), axis_z = mul(ez, inverse_length);
  const __m128 ux = sub(px, ax), uy = sub(py, ay), uz = sub(pz, az);
  const __m128 a = dot(ux, uy, uz, axis_x, axis_y, axis_z);
  const __m128 wx = sub(ux, mul(a, axis_x)), wy = sub(uy, mul(a, axis_y)), wz = sub(uz, mul(a, axis_z));
  const __m128 h = _mm_sqrt_ps(dot(wx, wy, wz, wx, wy, wz));
  const __m128 root = _mm_sqrt_ps(sub(one, mul(k, k)));
  const __m128 unclamped = add(a, _mm_div_ps(mul(k, h), root));
  // std::clamp(unclamped, 0, length): (v < 0 ? 0 : length < v ? length : v).
  const __m128 s =
      select(_mm_cmplt_ps(unclamped, zero), zero, select(_mm_cmplt_ps(safe_length, unclamped), safe_length, unclamped));
  const __m128 inside_edge = _mm_and_ps(_mm_cmpgt_ps(unclamped, zero), _mm_cmplt_ps(unclamped, safe_length));
  const __m128 edge_ok = _mm_and_ps(_mm_and_ps(length_ok, k_ok), inside_edge);
  // The foot: on the edge, or ball a itself.
  const __m128 fx = select(edge, add(ax, mul(s, axis_x)), ax);
  const __m128 fy = select(edge, add(ay, mul(s, axis_y)), ay);
  const __m128 fz = select(edge, add(az, mul(s, axis_z)), az);
  const __m128 foot_radius = select(edge, add(ra, mul(k, s)), ra);
  const __m128 ox = sub(px, fx), oy = sub(py, fy), oz = sub(pz, fz);
  const __m128 distance = _mm_sqrt_ps(dot(ox, oy, oz, ox, oy, oz));
  const __m128 distance_ok = _mm_cmpgt_ps(distance, zero);
  const __m128 inverse_distance = _mm_div_ps(one, select(distance_ok, distance, one));
  const __m128 nx = mul(ox, inverse_distance), ny = mul(oy, inverse_distance), nz = mul(oz, inverse_distance);
  // toward(n, foot, foot_radius, centre, radius) = −n·(centre − foot) − (radius − foot_radius).
  const auto toward4 = [&](__m128 x, __m128 y, __m128 z, __m128 r) {
    return sub(_mm_xor_ps(dot(nx, ny, nz, sub(x, fx), sub(y, fy), sub(z, fz)), sign), sub(r, foot_radius));
  };
  const __m128 toward_c = _mm_cmpge_ps(toward4(cx, cy, cz, rc), zero);
  const __m128 toward_b = _mm_cmpge_ps(toward4(load(l.bx), load(l.by), load(l.bz), load(l.rb)), zero);
  const __m128 minimum = _mm_and_ps(toward_c, select(edge, edge_ok, toward_b));
  alignas(16) float value[4], gx[4], gy[4], gz[4];
  _mm_store_ps(value, sub(distance, foot_radius));
  _mm_store_ps(gx, nx);
  _mm_store_ps(gy, ny);
  _mm_store_ps(gz, nz);
  int accepted = _mm_movemask_ps(_mm_and_ps(minimum, distance_ok));
  for (int lane = 0; lane < 4; ++lane) {
    e[lane].value = value[lane];
    e[lane].gradient = glm::vec3(gx[lane], gy[lane], gz[lane]);
    if (!std::isfinite(e[lane].value) || !finite(e[lane].gradient)) accepted &= ~(1 << lane);
  }
  return accepted;
}
#else
constexpr bool kHintedLanes = false;
#endif

// E_T where the minimum is not interior: the hint's candidate if the KKT conditions prove it
// the minimum, else the smallest of the three vertices and three edge minima. Updates `hint`
// (optional) as ball_hull_distance does.
HullDistance boundary_distance(const glm::vec3& p, const glm::vec3* c, const float* r, uint8_t* hint);

}  // namespace skelform::runtime::fair_detail
