// The fairing's local frames (fair.h fairing_frames) and its rest targets (make_fairing_rest).
// Relative to rest, the flows compare the surface's umbrellas with the rest ones turned by a
// frame per vertex that follows the pose (normal along M − S, tangent fitted to the rest
// one-ring), so an undeformed character is a fixed point of flows (4) and (5).
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

// One vertex of fairing_frames (fair.h), fallbacks included: the reference the four-lane
// path below reproduces, and what it falls back to.
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
// recomputed by vertex_frame. Returns the number of vertices done (a multiple of four).
uint32_t lane_frames(const FairingTopology& topology, const glm::vec3* skeletal, const glm::vec3* positions,
                     glm::mat3* frames, const FairingRest& rest, glm::vec3* umbrellas, float* mean_edges) {
  const uint32_t vertex_count = topology.vertex_count;
  const sse::Vec3Reader read(positions, vertex_count);
  const uint32_t* neighbours = topology.neighbours.data();
  uint32_t v = 0;
  for (; v + 4 <= vertex_count; v += 4) {
    const LaneRings rings = lane_rings(topology.neighbour_offsets.data(), v);
    FrameLanes f = lane_basis(read, skeletal, neighbours, v, rings);
    const RingSums r = ring_sums(read, neighbours, rest.edge_2d.data(), v, rings, f);
    turn_lanes(r, f);
    store_lanes(f, r, rings, v, frames, umbrellas, mean_edges);
    const int fallback = ~_mm_movemask_ps(f.main) & 0xf;
    if (fallback != 0)
      for (uint32_t i = 0; i < 4; ++i)
        if (fallback & (1 << i))
          vertex_frame(topology, skeletal, positions, v + i, frames, &rest, true, umbrellas, mean_edges);
  }
  return v;
}
#endif

}  // namespace

void fairing_frames(const FairingTopology& topology, const glm::vec3* skeletal, const glm::vec3* positions,
                    glm::mat3* frames, const FairingRest* rest, glm::vec3* umbrellas, float* mean_edges) {
  const bool procrustes = rest && rest->edge_2d.size() == topology.neighbours.size();
  uint32_t v = 0;
#if defined(__SSE2__)
  if (procrustes && umbrellas && mean_edges)
    v = lane_frames(topology, skeletal, positions, frames, *rest, umbrellas, mean_edges);
#endif
  for (; v < topology.vertex_count; ++v)
    vertex_frame(topology, skeletal, positions, v, frames, rest, procrustes, umbrellas, mean_edges);
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
