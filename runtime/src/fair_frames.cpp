// The fairing's local frames (fair.h fairing_frames) and its rest targets (make_fairing_rest).
// Relative to rest, the flows compare the surface's umbrellas with the rest ones turned by a
// frame per vertex that follows the pose (normal along M − S, tangent fitted to the rest
// one-ring), so an undeformed character is a fixed point of flows (4) and (5).
#include "avx2_lanes.h"
#include "cpu.h"
#include "fair_internal.h"
#include "vec3_sse.h"

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstddef>

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif

namespace skelform::runtime {
namespace {

// One vertex of fairing_frames (fair.h), fallbacks included: the reference the four- and
// eight-lane paths below reproduce, and what they fall back to.
void vertex_frame(const FairingTopology& topology, const glm::vec3* skeletal, const glm::vec3* positions, uint32_t v,
                  glm::mat3* frames, const FairingRest* rest, bool procrustes, glm::vec3* umbrellas,
                  float* mean_edges) {
  glm::vec3 normal = positions[v] - skeletal[v];
  float length = glm::length(normal);
  if (!(length > 0.0f) || !std::isfinite(length)) {
    // Zero radius: the area-weighted normal of the incident triangles.
    normal = glm::vec3(0.0f);
    for (uint32_t k = topology.incident_offsets[v]; k < topology.incident_offsets[v + 1]; ++k) {
      const uint32_t* c = topology.triangle_indices.data() + 3 * size_t{topology.incident_triangles[k]};
      normal += glm::cross(positions[c[1]] - positions[c[0]], positions[c[2]] - positions[c[0]]);
    }
    length = glm::length(normal);
  }
  normal = length > 0.0f && std::isfinite(length) ? normal * (1.0f / length) : glm::vec3(0.0f, 0.0f, 1.0f);
  // Tangent: the first one-ring edge not parallel to the normal, else a coordinate axis.
  glm::vec3 tangent(0.0f);
  for (uint32_t k = topology.neighbour_offsets[v]; k < topology.neighbour_offsets[v + 1]; ++k) {
    const glm::vec3 edge = positions[topology.neighbours[k]] - positions[v];
    tangent = edge - glm::dot(edge, normal) * normal;
    const float t2 = glm::dot(tangent, tangent);
    if (t2 > 1e-12f * glm::dot(edge, edge) && std::isfinite(t2)) {  // |tangent| > 1e-6 |edge|
      tangent *= 1.0f / std::sqrt(t2);
      break;
    }
    tangent = glm::vec3(0.0f);
  }
  if (tangent == glm::vec3(0.0f)) {
    const glm::vec3 axis = std::fabs(normal.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    tangent = glm::normalize(axis - glm::dot(axis, normal) * normal);
  }
  glm::vec3 bitangent = glm::cross(normal, tangent);
  const uint32_t begin = topology.neighbour_offsets[v], end = topology.neighbour_offsets[v + 1];
  if (procrustes || umbrellas || mean_edges) {
    float dot = 0.0f, cross = 0.0f, edge_sum = 0.0f;
    glm::vec3 sum(0.0f);
    for (uint32_t k = begin; k < end; ++k) {
      const glm::vec3 edge = positions[topology.neighbours[k]] - positions[v];
      if (umbrellas) sum += positions[topology.neighbours[k]];
      if (mean_edges) edge_sum += glm::length(edge);
      if (!procrustes) continue;
      const glm::vec2 now(glm::dot(edge, tangent), glm::dot(edge, bitangent));
      const glm::vec2 then = rest->edge_2d[k];
      dot += glm::dot(then, now);
      cross += then.x * now.y - then.y * now.x;
    }
    const float count = static_cast<float>(end - begin);
    if (umbrellas) umbrellas[v] = begin == end ? glm::vec3(0.0f) : sum / count - positions[v];  // = umbrella_at
    if (mean_edges) mean_edges[v] = begin == end ? 0.0f : edge_sum / count;
    // cos and sin of the best angle, atan2(cross, dot), without trigonometry.
    const float length = std::sqrt(dot * dot + cross * cross);
    if (procrustes && length > 0.0f && std::isfinite(length)) {
      const float inverse = 1.0f / length;
      const float c = dot * inverse, s = cross * inverse;
      const glm::vec3 turned = c * tangent + s * bitangent;
      bitangent = -s * tangent + c * bitangent;
      tangent = turned;
    }
  }
  frames[v] = glm::mat3(tangent, bitangent, normal);
}

// The lanes set in `fallback` (bit i: vertex v + i) recomputed by vertex_frame, fallbacks
// included, with the rest fit, umbrellas and mean edges (the lanes' callers).
void redo_lanes(unsigned fallback, const FairingTopology& topology, const glm::vec3* skeletal,
                const glm::vec3* positions, uint32_t v, glm::mat3* frames, const FairingRest& rest,
                glm::vec3* umbrellas, float* mean_edges) {
  for (; fallback != 0; fallback &= fallback - 1)
    vertex_frame(topology, skeletal, positions, v + uint32_t(__builtin_ctz(fallback)), frames, &rest, true, umbrellas,
                 mean_edges);
}

#if defined(__SSE2__)
// Four vertices v .. v + 3 of lane_frames side by side, lane = vertex.
struct LaneRings {  // their one-rings
  uint32_t begin[4], degree[4], most;
  __m128i degrees;
};
struct FrameLanes {  // their positions and frames
  __m128 px, py, pz, nx, ny, nz, tx, ty, tz, bx, by, bz;
  __m128 main;  // all ones where vertex_frame's main branch holds (no fallback)
};
struct RingSums {  // their one-ring sums: neighbours, edge lengths, the rest fit's terms
  __m128 sum_x, sum_y, sum_z, edge_sum, dot_sum, cross_sum;
};

LaneRings lane_rings(const uint32_t* offsets, uint32_t v) {
  LaneRings rings;
  rings.most = 0;
  for (uint32_t i = 0; i < 4; ++i) {
    rings.begin[i] = offsets[v + i];
    rings.degree[i] = offsets[v + i + 1] - rings.begin[i];
    rings.most = std::max(rings.most, rings.degree[i]);
  }
  rings.degrees = _mm_loadu_si128(reinterpret_cast<const __m128i*>(rings.degree));
  return rings;
}

// vertex_frame's normal (along M − S), tangent (from the first one-ring edge) and bitangent,
// and which lanes need none of its fallbacks.
FrameLanes lane_basis(const sse::Vec3Reader& read, const glm::vec3* skeletal, const uint32_t* neighbours, uint32_t v,
                      const LaneRings& rings) {
  using namespace lane4;
  const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f), largest = _mm_set1_ps(FLT_MAX);
  const __m128 parallel = _mm_set1_ps(1e-12f);
  const uint32_t* begin = rings.begin;
  const uint32_t* degree = rings.degree;
  FrameLanes f;
  __m128 pw = read(v + 3);
  f.px = read(v), f.py = read(v + 1), f.pz = read(v + 2);
  _MM_TRANSPOSE4_PS(f.px, f.py, f.pz, pw);
  __m128 sx = sse::load3(skeletal[v]), sy = sse::load3(skeletal[v + 1]), sz = sse::load3(skeletal[v + 2]),
         sw = sse::load3(skeletal[v + 3]);
  _MM_TRANSPOSE4_PS(sx, sy, sz, sw);
  // The normal: (M − S) · (1 / |M − S|) where that length is > 0 and finite.
  __m128 nx = sub(f.px, sx), ny = sub(f.py, sy), nz = sub(f.pz, sz);
  const __m128 n_length = _mm_sqrt_ps(dot(nx, ny, nz, nx, ny, nz));
  __m128 main = _mm_and_ps(_mm_cmpgt_ps(n_length, zero), _mm_cmple_ps(n_length, largest));
  main = _mm_and_ps(main, _mm_castsi128_ps(_mm_cmpgt_epi32(rings.degrees, _mm_setzero_si128())));
  const __m128 n_inverse = _mm_div_ps(one, n_length);
  nx = mul(nx, n_inverse), ny = mul(ny, n_inverse), nz = mul(nz, n_inverse);
  // The tangent from the first one-ring edge (a lane without neighbours reads its own vertex).
  __m128 qx = read(degree[0] ? neighbours[begin[0]] : v), qy = read(degree[1] ? neighbours[begin[1]] : v + 1),
         qz = read(degree[2] ? neighbours[begin[2]] : v + 2), qw = read(degree[3] ? neighbours[begin[3]] : v + 3);
  _MM_TRANSPOSE4_PS(qx, qy, qz, qw);
  const __m128 ex = sub(qx, f.px), ey = sub(qy, f.py), ez = sub(qz, f.pz);
  const __m128 e_dot_n = dot(ex, ey, ez, nx, ny, nz);
  __m128 tx = sub(ex, mul(e_dot_n, nx)), ty = sub(ey, mul(e_dot_n, ny)), tz = sub(ez, mul(e_dot_n, nz));
  const __m128 t2 = dot(tx, ty, tz, tx, ty, tz);
  main = _mm_and_ps(
      main, _mm_and_ps(_mm_cmpgt_ps(t2, mul(parallel, dot(ex, ey, ez, ex, ey, ez))), _mm_cmple_ps(t2, largest)));
  const __m128 t_inverse = _mm_div_ps(one, _mm_sqrt_ps(t2));
  tx = mul(tx, t_inverse), ty = mul(ty, t_inverse), tz = mul(tz, t_inverse);
  f.nx = nx, f.ny = ny, f.nz = nz, f.tx = tx, f.ty = ty, f.tz = tz;
  // glm::cross(normal, tangent).
  f.bx = sub(mul(ny, tz), mul(ty, nz)), f.by = sub(mul(nz, tx), mul(tz, nx)), f.bz = sub(mul(nx, ty), mul(tx, ny));
  f.main = main;
  return f;
}

// The one-rings side by side, edge j of every lane at step j (a lane whose one-ring is done
// adds +0).
RingSums ring_sums(const sse::Vec3Reader& read, const uint32_t* neighbours, const glm::vec2* then_2d, uint32_t v,
                   const LaneRings& rings, const FrameLanes& f) {
  using namespace lane4;
  const __m128 zero = _mm_setzero_ps();
  RingSums r{zero, zero, zero, zero, zero, zero};
  for (uint32_t j = 0; j < rings.most; ++j) {
    const __m128 live = _mm_castsi128_ps(_mm_cmpgt_epi32(rings.degrees, _mm_set1_epi32(static_cast<int>(j))));
    __m128 q[4], then[4];
    for (uint32_t i = 0; i < 4; ++i) {
      const bool in_ring = j < rings.degree[i];
      const uint32_t k = in_ring ? rings.begin[i] + j : 0;
      q[i] = read(in_ring ? neighbours[k] : v + i);
      then[i] = _mm_loadl_pi(zero, reinterpret_cast<const __m64*>(&then_2d[k].x));
    }
    _MM_TRANSPOSE4_PS(q[0], q[1], q[2], q[3]);
    const __m128 then_01 = _mm_unpacklo_ps(then[0], then[1]), then_23 = _mm_unpacklo_ps(then[2], then[3]);
    const __m128 then_x = _mm_movelh_ps(then_01, then_23), then_y = _mm_movehl_ps(then_23, then_01);
    const __m128 dx = sub(q[0], f.px), dy = sub(q[1], f.py), dz = sub(q[2], f.pz);
    const __m128 now_x = dot(dx, dy, dz, f.tx, f.ty, f.tz), now_y = dot(dx, dy, dz, f.bx, f.by, f.bz);
    r.sum_x = add(r.sum_x, _mm_and_ps(live, q[0]));
    r.sum_y = add(r.sum_y, _mm_and_ps(live, q[1]));
    r.sum_z = add(r.sum_z, _mm_and_ps(live, q[2]));
    r.edge_sum = add(r.edge_sum, _mm_and_ps(live, _mm_sqrt_ps(dot(dx, dy, dz, dx, dy, dz))));
    r.dot_sum = add(r.dot_sum, _mm_and_ps(live, add(mul(then_x, now_x), mul(then_y, now_y))));
    r.cross_sum = add(r.cross_sum, _mm_and_ps(live, sub(mul(then_x, now_y), mul(then_y, now_x))));
  }
  return r;
}

// The rest fit's turn of tangent and bitangent where |(dot, cross)| is > 0 and finite.
void turn_lanes(const RingSums& r, FrameLanes& f) {
  using namespace lane4;
  const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f), largest = _mm_set1_ps(FLT_MAX);
  const __m128 sign = _mm_set1_ps(-0.0f);
  const __m128 fit = _mm_sqrt_ps(add(mul(r.dot_sum, r.dot_sum), mul(r.cross_sum, r.cross_sum)));
  const __m128 turn = _mm_and_ps(_mm_cmpgt_ps(fit, zero), _mm_cmple_ps(fit, largest));
  const __m128 fit_inverse = _mm_div_ps(one, fit);
  const __m128 c = mul(r.dot_sum, fit_inverse), s = mul(r.cross_sum, fit_inverse), minus_s = _mm_xor_ps(s, sign);
  const __m128 turned_x = add(mul(c, f.tx), mul(s, f.bx)), turned_y = add(mul(c, f.ty), mul(s, f.by)),
               turned_z = add(mul(c, f.tz), mul(s, f.bz));
  f.bx = select(turn, add(mul(minus_s, f.tx), mul(c, f.bx)), f.bx);
  f.by = select(turn, add(mul(minus_s, f.ty), mul(c, f.by)), f.by);
  f.bz = select(turn, add(mul(minus_s, f.tz), mul(c, f.bz)), f.bz);
  f.tx = select(turn, turned_x, f.tx), f.ty = select(turn, turned_y, f.ty), f.tz = select(turn, turned_z, f.tz);
}

// Back to one frame (columns tangent, bitangent, normal: 9 floats), one umbrella and one mean
// edge per vertex.
void store_lanes(const FrameLanes& f, const RingSums& r, const LaneRings& rings, uint32_t v, glm::mat3* frames,
                 glm::vec3* umbrellas, float* mean_edges) {
  using namespace lane4;
  const __m128 count = _mm_cvtepi32_ps(rings.degrees);
  __m128 ux = sub(_mm_div_ps(r.sum_x, count), f.px), uy = sub(_mm_div_ps(r.sum_y, count), f.py),
         uz = sub(_mm_div_ps(r.sum_z, count), f.pz), uw = _mm_setzero_ps();
  const __m128 mean_edge = _mm_div_ps(r.edge_sum, count);
  __m128 head_x = f.tx, head_y = f.ty, head_z = f.tz, head_w = f.bx;  // per vertex: t.x t.y t.z b.x
  _MM_TRANSPOSE4_PS(head_x, head_y, head_z, head_w);
  __m128 mid_x = f.by, mid_y = f.bz, mid_z = f.nx, mid_w = f.ny;  // per vertex: b.y b.z n.x n.y
  _MM_TRANSPOSE4_PS(mid_x, mid_y, mid_z, mid_w);
  alignas(16) float last[4];  // n.z
  _mm_store_ps(last, f.nz);
  const __m128 head[4] = {head_x, head_y, head_z, head_w}, mid[4] = {mid_x, mid_y, mid_z, mid_w};
  _MM_TRANSPOSE4_PS(ux, uy, uz, uw);
  const __m128 umbrella[4] = {ux, uy, uz, uw};
  for (uint32_t i = 0; i < 4; ++i) {
    float* frame = &frames[v + i][0].x;
    _mm_storeu_ps(frame, head[i]);
    _mm_storeu_ps(frame + 4, mid[i]);
    frame[8] = last[i];
    sse::store3(umbrellas[v + i], umbrella[i]);
  }
  _mm_storeu_ps(mean_edges + v, mean_edge);
}

// fairing_frames with the rest fit, umbrellas and mean edges (fair_stage's call), four
// vertices at a time, lanes = vertices: the positions and their one-ring neighbours gathered
// as vectors and transposed (structure of arrays), then vertex_frame's main branch evaluated
// lane by lane with its operations in its order (so its bits): normal along M − S, tangent
// from the first one-ring edge, the one-ring walked edge by edge in order (a lane whose
// one-ring is done adds +0, which leaves its sums as they are: they start at +0 and can never
// become −0), the rest fit's turn. A lane whose normal or first edge takes a fallback
// (medial radius 0 or not finite, first edge parallel to the normal, no neighbours) is
// recomputed by vertex_frame. Returns the vertex it stopped at (first plus a multiple of four).
// Starts at vertex `first`.
uint32_t lane_frames(const FairingTopology& topology, const glm::vec3* skeletal, const glm::vec3* positions,
                     glm::mat3* frames, const FairingRest& rest, glm::vec3* umbrellas, float* mean_edges,
                     uint32_t first) {
  const uint32_t vertex_count = topology.vertex_count;
  const sse::Vec3Reader read(positions, vertex_count);
  const uint32_t* neighbours = topology.neighbours.data();
  uint32_t v = first;
  for (; v + 4 <= vertex_count; v += 4) {
    const LaneRings rings = lane_rings(topology.neighbour_offsets.data(), v);
    FrameLanes f = lane_basis(read, skeletal, neighbours, v, rings);
    const RingSums r = ring_sums(read, neighbours, rest.edge_2d.data(), v, rings, f);
    turn_lanes(r, f);
    store_lanes(f, r, rings, v, frames, umbrellas, mean_edges);
    redo_lanes(~unsigned(_mm_movemask_ps(f.main)) & 0xfu, topology, skeletal, positions, v, frames, rest, umbrellas,
               mean_edges);
  }
  return v;
}
#endif

#if defined(SKELFORM_HAS_AVX2_KERNELS)
// lane_frames eight vertices at a time (AVX2 alone: no fused multiply-add, so every lane keeps
// vertex_frame's operations and bits). The same steps as the four lanes above, with gathers in
// place of the transposed loads: a lane whose one-ring is done reads its own vertex and a rest
// edge of 0, and adds +0.
namespace avx8 {

struct Rings {
  __m256i begin, degree, self;  // self: v + lane
  uint32_t most;
};
struct Frames {
  __m256 px, py, pz, nx, ny, nz, tx, ty, tz, bx, by, bz, main;
};
struct Sums {
  __m256 sum_x, sum_y, sum_z, edge_sum, dot_sum, cross_sum;
};

__attribute__((target("avx2"))) inline __m256 add(__m256 a, __m256 b) { return _mm256_add_ps(a, b); }
__attribute__((target("avx2"))) inline __m256 sub(__m256 a, __m256 b) { return _mm256_sub_ps(a, b); }
__attribute__((target("avx2"))) inline __m256 mul(__m256 a, __m256 b) { return _mm256_mul_ps(a, b); }
__attribute__((target("avx2"))) inline __m256 select(__m256 mask, __m256 a, __m256 b) {
  return _mm256_or_ps(_mm256_and_ps(mask, a), _mm256_andnot_ps(mask, b));
}
// neighbours[k] where `live`, else `self`.
__attribute__((target("avx2"))) inline __m256i neighbour(const uint32_t* neighbours, __m256i k, __m256i live,
                                                         __m256i self) {
  return _mm256_mask_i32gather_epi32(self, reinterpret_cast<const int*>(neighbours), k, live, 4);
}

__attribute__((target("avx2"))) Rings rings(const uint32_t* offsets, uint32_t v) {
  Rings r;
  r.begin = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(offsets + v));
  r.degree = _mm256_sub_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(offsets + v + 1)), r.begin);
  r.self = _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(v)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  __m256i most = _mm256_max_epu32(r.degree, _mm256_permute2x128_si256(r.degree, r.degree, 1));
  most = _mm256_max_epu32(most, _mm256_shuffle_epi32(most, _MM_SHUFFLE(1, 0, 3, 2)));
  most = _mm256_max_epu32(most, _mm256_shuffle_epi32(most, _MM_SHUFFLE(2, 3, 0, 1)));
  r.most = static_cast<uint32_t>(_mm256_cvtsi256_si32(most));
  return r;
}

// lane_basis's normal, tangent, bitangent and main-branch lanes.
__attribute__((target("avx2"))) Frames basis(const glm::vec3* positions, const glm::vec3* skeletal,
                                             const uint32_t* neighbours, const Rings& r) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), largest = _mm256_set1_ps(FLT_MAX);
  Frames f;
  avx2::gather_vec3(positions, r.self, f.px, f.py, f.pz);
  __m256 sx, sy, sz;
  avx2::gather_vec3(skeletal, r.self, sx, sy, sz);
  __m256 nx = sub(f.px, sx), ny = sub(f.py, sy), nz = sub(f.pz, sz);
  const __m256 n_length = _mm256_sqrt_ps(avx2::dot3(nx, ny, nz, nx, ny, nz));
  const __m256i has_ring = _mm256_cmpgt_epi32(r.degree, _mm256_setzero_si256());
  __m256 main = _mm256_and_ps(_mm256_cmp_ps(n_length, zero, _CMP_GT_OQ), _mm256_cmp_ps(n_length, largest, _CMP_LE_OQ));
  main = _mm256_and_ps(main, _mm256_castsi256_ps(has_ring));
  const __m256 n_inverse = _mm256_div_ps(one, n_length);
  nx = mul(nx, n_inverse), ny = mul(ny, n_inverse), nz = mul(nz, n_inverse);
  __m256 qx, qy, qz;
  avx2::gather_vec3(positions, neighbour(neighbours, r.begin, has_ring, r.self), qx, qy, qz);
  const __m256 ex = sub(qx, f.px), ey = sub(qy, f.py), ez = sub(qz, f.pz);
  const __m256 e_dot_n = avx2::dot3(ex, ey, ez, nx, ny, nz);
  __m256 tx = sub(ex, mul(e_dot_n, nx)), ty = sub(ey, mul(e_dot_n, ny)), tz = sub(ez, mul(e_dot_n, nz));
  const __m256 t2 = avx2::dot3(tx, ty, tz, tx, ty, tz);
  const __m256 not_parallel =
      _mm256_cmp_ps(t2, mul(_mm256_set1_ps(1e-12f), avx2::dot3(ex, ey, ez, ex, ey, ez)), _CMP_GT_OQ);
  main = _mm256_and_ps(main, _mm256_and_ps(not_parallel, _mm256_cmp_ps(t2, largest, _CMP_LE_OQ)));
  const __m256 t_inverse = _mm256_div_ps(one, _mm256_sqrt_ps(t2));
  tx = mul(tx, t_inverse), ty = mul(ty, t_inverse), tz = mul(tz, t_inverse);
  f.nx = nx, f.ny = ny, f.nz = nz, f.tx = tx, f.ty = ty, f.tz = tz;
  f.bx = sub(mul(ny, tz), mul(ty, nz)), f.by = sub(mul(nz, tx), mul(tz, nx)), f.bz = sub(mul(nx, ty), mul(tx, ny));
  f.main = main;
  return f;
}

// ring_sums: edge j of every lane at step j.
__attribute__((target("avx2"))) Sums ring_sums(const glm::vec3* positions, const uint32_t* neighbours,
                                               const glm::vec2* then_2d, const Rings& r, const Frames& f) {
  const __m256 zero = _mm256_setzero_ps();
  Sums s{zero, zero, zero, zero, zero, zero};
  const float* then = &then_2d[0].x;
  for (uint32_t j = 0; j < r.most; ++j) {
    const __m256i live_i = _mm256_cmpgt_epi32(r.degree, _mm256_set1_epi32(static_cast<int>(j)));
    const __m256 live = _mm256_castsi256_ps(live_i);
    const __m256i k = _mm256_add_epi32(r.begin, _mm256_set1_epi32(static_cast<int>(j)));
    __m256 qx, qy, qz;
    avx2::gather_vec3(positions, neighbour(neighbours, k, live_i, r.self), qx, qy, qz);
    const __m256i k2 = _mm256_add_epi32(k, k);
    const __m256 then_x = _mm256_mask_i32gather_ps(zero, then, k2, live, 4);
    const __m256 then_y = _mm256_mask_i32gather_ps(zero, then + 1, k2, live, 4);
    const __m256 dx = sub(qx, f.px), dy = sub(qy, f.py), dz = sub(qz, f.pz);
    const __m256 now_x = avx2::dot3(dx, dy, dz, f.tx, f.ty, f.tz), now_y = avx2::dot3(dx, dy, dz, f.bx, f.by, f.bz);
    s.sum_x = add(s.sum_x, _mm256_and_ps(live, qx));
    s.sum_y = add(s.sum_y, _mm256_and_ps(live, qy));
    s.sum_z = add(s.sum_z, _mm256_and_ps(live, qz));
    s.edge_sum = add(s.edge_sum, _mm256_and_ps(live, _mm256_sqrt_ps(avx2::dot3(dx, dy, dz, dx, dy, dz))));
    s.dot_sum = add(s.dot_sum, _mm256_and_ps(live, add(mul(then_x, now_x), mul(then_y, now_y))));
    s.cross_sum = add(s.cross_sum, _mm256_and_ps(live, sub(mul(then_x, now_y), mul(then_y, now_x))));
  }
  return s;
}

// turn_lanes.
__attribute__((target("avx2"))) void turn(const Sums& s, Frames& f) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), largest = _mm256_set1_ps(FLT_MAX);
  const __m256 fit = _mm256_sqrt_ps(add(mul(s.dot_sum, s.dot_sum), mul(s.cross_sum, s.cross_sum)));
  const __m256 turned = _mm256_and_ps(_mm256_cmp_ps(fit, zero, _CMP_GT_OQ), _mm256_cmp_ps(fit, largest, _CMP_LE_OQ));
  const __m256 fit_inverse = _mm256_div_ps(one, fit);
  const __m256 c = mul(s.dot_sum, fit_inverse), sn = mul(s.cross_sum, fit_inverse);
  const __m256 minus_s = _mm256_xor_ps(sn, _mm256_set1_ps(-0.0f));
  const __m256 turned_x = add(mul(c, f.tx), mul(sn, f.bx)), turned_y = add(mul(c, f.ty), mul(sn, f.by)),
               turned_z = add(mul(c, f.tz), mul(sn, f.bz));
  f.bx = select(turned, add(mul(minus_s, f.tx), mul(c, f.bx)), f.bx);
  f.by = select(turned, add(mul(minus_s, f.ty), mul(c, f.by)), f.by);
  f.bz = select(turned, add(mul(minus_s, f.tz), mul(c, f.bz)), f.bz);
  f.tx = select(turned, turned_x, f.tx), f.ty = select(turned, turned_y, f.ty), f.tz = select(turned, turned_z, f.tz);
}

// store_lanes: each frame's first eight floats (t, b, n.x, n.y) by an 8×8 transpose, then n.z,
// the umbrellas and the mean edges.
__attribute__((target("avx2"))) void store(const Frames& f, const Sums& s, const Rings& r, uint32_t v,
                                           glm::mat3* frames, glm::vec3* umbrellas, float* mean_edges) {
  const __m256 count = _mm256_cvtepi32_ps(r.degree);
  const __m256 u[3] = {sub(_mm256_div_ps(s.sum_x, count), f.px), sub(_mm256_div_ps(s.sum_y, count), f.py),
                       sub(_mm256_div_ps(s.sum_z, count), f.pz)};
  _mm256_storeu_ps(mean_edges + v, _mm256_div_ps(s.edge_sum, count));
  const __m256 a0 = _mm256_unpacklo_ps(f.tx, f.ty), a1 = _mm256_unpackhi_ps(f.tx, f.ty);
  const __m256 a2 = _mm256_unpacklo_ps(f.tz, f.bx), a3 = _mm256_unpackhi_ps(f.tz, f.bx);
  const __m256 a4 = _mm256_unpacklo_ps(f.by, f.bz), a5 = _mm256_unpackhi_ps(f.by, f.bz);
  const __m256 a6 = _mm256_unpacklo_ps(f.nx, f.ny), a7 = _mm256_unpackhi_ps(f.nx, f.ny);
  const __m256 b0 = _mm256_shuffle_ps(a0, a2, _MM_SHUFFLE(1, 0, 1, 0)),
               b1 = _mm256_shuffle_ps(a0, a2, _MM_SHUFFLE(3, 2, 3, 2));
  const __m256 b2 = _mm256_shuffle_ps(a1, a3, _MM_SHUFFLE(1, 0, 1, 0)),
               b3 = _mm256_shuffle_ps(a1, a3, _MM_SHUFFLE(3, 2, 3, 2));
  const __m256 b4 = _mm256_shuffle_ps(a4, a6, _MM_SHUFFLE(1, 0, 1, 0)),
               b5 = _mm256_shuffle_ps(a4, a6, _MM_SHUFFLE(3, 2, 3, 2));
  const __m256 b6 = _mm256_shuffle_ps(a5, a7, _MM_SHUFFLE(1, 0, 1, 0)),
               b7 = _mm256_shuffle_ps(a5, a7, _MM_SHUFFLE(3, 2, 3, 2));
  // Row i: vertex i's eight floats (b_k holds lanes k' and k' + 4 in its halves).
  const __m256 row[8] = {_mm256_permute2f128_ps(b0, b4, 0x20), _mm256_permute2f128_ps(b1, b5, 0x20),
                         _mm256_permute2f128_ps(b2, b6, 0x20), _mm256_permute2f128_ps(b3, b7, 0x20),
                         _mm256_permute2f128_ps(b0, b4, 0x31), _mm256_permute2f128_ps(b1, b5, 0x31),
                         _mm256_permute2f128_ps(b2, b6, 0x31), _mm256_permute2f128_ps(b3, b7, 0x31)};
  alignas(32) float last[8];
  _mm256_store_ps(last, f.nz);
  for (uint32_t i = 0; i < 8; ++i) {
    float* frame = &frames[v + i][0].x;
    _mm256_storeu_ps(frame, row[i]);
    frame[8] = last[i];
  }
  avx2::store_vec3(u, umbrellas + v);
}

}  // namespace avx8

// lane_frames in eight lanes, from `first`. Returns the vertex it stopped at.
__attribute__((target("avx2"))) uint32_t lane_frames_avx2(const FairingTopology& topology, const glm::vec3* skeletal,
                                                          const glm::vec3* positions, glm::mat3* frames,
                                                          const FairingRest& rest, glm::vec3* umbrellas,
                                                          float* mean_edges, uint32_t first) {
  const uint32_t vertex_count = topology.vertex_count;
  const uint32_t* neighbours = topology.neighbours.data();
  uint32_t v = first;
  for (; v + 8 <= vertex_count; v += 8) {
    const avx8::Rings r = avx8::rings(topology.neighbour_offsets.data(), v);
    avx8::Frames f = avx8::basis(positions, skeletal, neighbours, r);
    const avx8::Sums s = avx8::ring_sums(positions, neighbours, rest.edge_2d.data(), r, f);
    avx8::turn(s, f);
    avx8::store(f, s, r, v, frames, umbrellas, mean_edges);
    redo_lanes(~unsigned(_mm256_movemask_ps(f.main)) & 0xffu, topology, skeletal, positions, v, frames, rest, umbrellas,
               mean_edges);
  }
  return v;
}
#endif

}  // namespace

namespace fair_detail {

bool frame_kernel_available(FrameKernel kernel) {
  switch (kernel) {
    case FrameKernel::portable:
      return true;
    case FrameKernel::sse2:
#if defined(__SSE2__)
      return true;
#else
      return false;
#endif
    case FrameKernel::avx2:
      return cpu_has_avx2();
  }
  return false;
}

void fairing_frames_with(FrameKernel kernel, const FairingTopology& topology, const glm::vec3* skeletal,
                         const glm::vec3* positions, glm::mat3* frames, const FairingRest* rest, glm::vec3* umbrellas,
                         float* mean_edges) {
  const bool procrustes = rest && rest->edge_2d.size() == topology.neighbours.size();
  // The lanes compute the frames with the rest fit, the umbrellas and the mean edges together.
  const bool lanes = procrustes && umbrellas && mean_edges && frame_kernel_available(kernel);
  uint32_t v = 0;
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (lanes && kernel == FrameKernel::avx2 && gather_offsets_fit(topology.vertex_count) &&
      gather_offsets_fit(topology.neighbours.size()))
    v = lane_frames_avx2(topology, skeletal, positions, frames, *rest, umbrellas, mean_edges, v);
#endif
#if defined(__SSE2__)
  if (lanes && kernel != FrameKernel::portable)
    v = lane_frames(topology, skeletal, positions, frames, *rest, umbrellas, mean_edges, v);
#endif
  (void)lanes;
  for (; v < topology.vertex_count; ++v)
    vertex_frame(topology, skeletal, positions, v, frames, rest, procrustes, umbrellas, mean_edges);
}

}  // namespace fair_detail

void fairing_frames(const FairingTopology& topology, const glm::vec3* skeletal, const glm::vec3* positions,
                    glm::mat3* frames, const FairingRest* rest, glm::vec3* umbrellas, float* mean_edges) {
  using fair_detail::FrameKernel;
  fair_detail::fairing_frames_with(cpu_has_avx2() ? FrameKernel::avx2 : FrameKernel::sse2, topology, skeletal,
                                   positions, frames, rest, umbrellas, mean_edges);
}

FairingRest make_fairing_rest(const FairingTopology& topology, const glm::vec3* skeletal, const float* radius,
                              const glm::vec3* positions, uint32_t grid_size, FairingWorkspace& ws,
                              const AllocatorRef& allocator) {
  using namespace fair_detail;
  FairingRest rest(allocator);
  const uint32_t n = topology.vertex_count;
  Array<glm::mat3> frames(n, glm::mat3(1.0f), CallbackAllocator<glm::mat3>(allocator));
  fairing_frames(topology, skeletal, positions, frames.data());
  compute_umbrellas(topology, positions, Targets{}, all_vertices(topology), all_vertices(topology), ws);
  rest.edge_2d.resize(topology.neighbours.size());
  for (uint32_t v = 0; v < n; ++v)
    for (uint32_t k = topology.neighbour_offsets[v]; k < topology.neighbour_offsets[v + 1]; ++k) {
      const glm::vec3 edge = positions[topology.neighbours[k]] - positions[v];
      rest.edge_2d[k] = glm::vec2(glm::dot(edge, frames[v][0]), glm::dot(edge, frames[v][1]));
    }
  rest.mean_edge.resize(n);
  for (uint32_t v = 0; v < n; ++v) rest.mean_edge[v] = mean_edge_length(topology, positions, v);
  rest.umbrella.resize(n);
  rest.bi_umbrella.resize(n);
  for (uint32_t v = 0; v < n; ++v) {
    // Frames are orthonormal: the transpose is the inverse.
    rest.umbrella[v] = glm::transpose(frames[v]) * ws.umbrella[v];
    rest.bi_umbrella[v] = glm::transpose(frames[v]) * ws.bi_umbrella[v];
  }
  rest.triangle_level.resize(topology.triangle_count);
  for (uint32_t t = 0; t < topology.triangle_count; ++t) {
    const uint32_t* corner = topology.triangle_indices.data() + 3 * size_t{t};
    const glm::vec3 centroid = (positions[corner[0]] + positions[corner[1]] + positions[corner[2]]) / 3.0f;
    const glm::vec3 centres[3] = {skeletal[corner[0]], skeletal[corner[1]], skeletal[corner[2]]};
    const float radii[3] = {radius[corner[0]], radius[corner[1]], radius[corner[2]]};
    rest.triangle_level[t] = ball_hull_distance(centroid, centres, radii).value;
  }
  rest.gap.assign(n, 0.0f);
  rest.positions.assign(positions, positions + n);
  rest.skeletal.assign(skeletal, skeletal + n);
  // (The default too is cut to the workspace's grid: a smaller one has fewer cells.)
  const int size = static_cast<int>(std::min(grid_size == 0 ? kDefaultGridSize : grid_size, ws.grid_size));
  rest_gaps(topology, skeletal, radius, positions, size, ws, rest.gap.data());
  return rest;
}

}  // namespace skelform::runtime
