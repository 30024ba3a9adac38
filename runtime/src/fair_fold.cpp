// Flow (4) of the paper (sec. 3.1), which removes folds and protrusions of the control mesh:
// ∂M/∂t = −αΔ²M − F − V. F pulls each triangle's centroid onto the envelope of its skeletal
// triangle's three medial balls (E_T, ball_hull.h), α smooths where the umbrellas agree and V,
// the bilaplacian across F, restores the shape along the surface.
#include "ball_hull.h"
#include "fair_internal.h"
#include "hull_block.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif

namespace skelform::runtime::fair_detail {
namespace {

// The interior candidates of the whole block in one pass: interior_lane, four at a time with
// SSE2.
void interior_candidates(uint32_t count, HullBlock& b) {
  uint32_t i = 0;
#if defined(__SSE2__)
  for (; i + 4 <= count; i += 4)
    interior_lanes4(b.w0x + i, b.w0y + i, b.w0z + i, b.e1x + i, b.e1y + i, b.e1z + i, b.e2x + i, b.e2y + i, b.e2z + i,
                    b.r0 + i, b.d1 + i, b.d2 + i, b.value + i, b.nx + i, b.ny + i, b.nz + i, b.inside + i);
#endif
  for (; i < count; ++i)
    b.inside[i] = interior_lane(b.w0x[i], b.w0y[i], b.w0z[i], b.e1x[i], b.e1y[i], b.e1z[i], b.e2x[i], b.e2y[i],
                                b.e2z[i], b.r0[i], b.d1[i], b.d2[i], b.value[i], b.nx[i], b.ny[i], b.nz[i]);
}

// Where a block's triangle forces go: E_T(C_j)·∇E_T(C_j) − (rest level), for the block's
// triangle i (triangles[i]).
struct BlockForces {
  const FairingTopology& topo;
  const glm::vec3* skeletal;
  const float* radius;
  const float* rest_level;
  const uint32_t* triangles;
  const HullBlock& block;
  FairingWorkspace& ws;

  void store(uint32_t i, const HullDistance& e) const {
    const uint32_t t = triangles[i];
    const glm::vec3 force = (rest_level ? e.value - rest_level[t] : e.value) * e.gradient;
    ws.triangle_force[t] = finite(force) ? force : glm::vec3(0.0f);
  }
  // E_T by the boundary search (boundary_distance, with the triangle's hint).
  void boundary(uint32_t i) const {
    const uint32_t t = triangles[i];
    const uint32_t* corner = topo.triangle_indices.data() + 3 * size_t{t};
    const glm::vec3 c[3] = {skeletal[corner[0]], skeletal[corner[1]], skeletal[corner[2]]};
    const float r[3] = {radius[corner[0]], radius[corner[1]], radius[corner[2]]};
    store(i, boundary_distance(block.centroid[i], c, r, ws.hull_case.data() + t));
  }
};

// The block's triangles `hinted` (indices in the block) whose hint names an edge or a vertex:
// with SSE2 four at a time (hinted_lanes4), those whose hint fails and the remainder through
// boundary_distance.
void hinted_forces(const BlockForces& forces, const uint32_t* hinted, uint32_t hinted_count) {
  const FairingTopology& topo = forces.topo;
  const FairingWorkspace& ws = forces.ws;
  uint32_t k = 0;
#if defined(__SSE2__)
  for (; k + 4 <= hinted_count; k += 4) {
    HullLanes lanes;
    for (uint32_t lane = 0; lane < 4; ++lane) {
      const uint32_t i = hinted[k + lane];
      const uint32_t t = forces.triangles[i];
      const uint32_t* corner = topo.triangle_indices.data() + 3 * size_t{t};
      const int which = ws.hull_case[t] - kHullCaseVertex;  // 0..2 a vertex, 3..5 an edge
      const uint32_t a = corner[which % 3], b = corner[(which + 1) % 3], c = corner[(which + 2) % 3];
      lanes.set(lane, forces.block.centroid[i], forces.skeletal[a], forces.skeletal[b], forces.skeletal[c],
                forces.radius[a], forces.radius[b], forces.radius[c], which >= 3);
    }
    HullDistance e[4];
    const int accepted = hinted_lanes4(lanes, e);
    for (uint32_t lane = 0; lane < 4; ++lane)
      if ((accepted >> lane) & 1)
        forces.store(hinted[k + lane], e[lane]);
      else
        forces.boundary(hinted[k + lane]);
  }
#endif
  for (; k < hinted_count; ++k) forces.boundary(hinted[k]);
}

// E_T(C_j)·∇E_T(C_j) − (rest level) for the triangles triangles[0 .. count), count ≤
// kHullBlock: the interior candidates of the whole block in one pass, then the hinted boundary
// candidates four at a time, the rest one by one (boundary_distance). Same results as
// ball_hull_distance per triangle, whichever triangles share its block.
void triangle_forces(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, const glm::vec3* x,
                     const float* rest_level, const uint32_t* triangles, uint32_t count, FairingWorkspace& ws) {
  HullBlock block;
  gather_block({topo.triangle_indices.data(), skeletal, radius, x}, topo.vertex_count, topo.triangle_count, triangles,
               count, block);
  interior_candidates(count, block);
  // E_T's value and gradient per triangle: the interior candidate where it holds; else, with
  // SSE2, the triangles whose hint names an edge or a vertex try it (hinted_forces), the rest
  // go through boundary_distance.
  const BlockForces forces{topo, skeletal, radius, rest_level, triangles, block, ws};
  uint32_t hinted[kHullBlock];
  uint32_t hinted_count = 0;
  for (uint32_t i = 0; i < count; ++i) {
    const uint32_t t = triangles[i];
    if (!block.usable[i]) {
      ws.triangle_force[t] = glm::vec3(0.0f);
      continue;
    }
    HullDistance e;
    if (block.inside[i] && interior_result(block.value[i], block.nx[i], block.ny[i], block.nz[i], e)) {
      ws.hull_case[t] = kHullCaseInterior;
      forces.store(i, e);
    } else if (kHintedLanes && ws.hull_case[t] >= kHullCaseVertex && ws.hull_case[t] < kHullCaseVertex + 6) {
      hinted[hinted_count++] = i;
    } else {
      forces.boundary(i);
    }
  }
  hinted_forces(forces, hinted, hinted_count);
}

// α of vertex v: kAlphaSmooth unless kObtuseFraction or more of the neighbours' umbrella
// vectors are obtuse to U(p). An umbrella below a thousandth of the edge length `edge`
// (relative to rest: the pose has not changed the surface here) has no meaningful direction:
// no fold, α as for a smooth spot.
float fold_alpha(const FairingTopology& topo, const FairingWorkspace& ws, uint32_t v, float edge) {
  const uint32_t begin = topo.neighbour_offsets[v], end = topo.neighbour_offsets[v + 1];
  uint32_t obtuse = 0;
  for (uint32_t k = begin; k < end; ++k)
    if (glm::dot(ws.umbrella[topo.neighbours[k]], ws.umbrella[v]) < 0.0f) ++obtuse;
  const bool negligible = glm::length(ws.umbrella[v]) < 1e-3f * edge;
  return negligible || static_cast<float>(obtuse) < kObtuseFraction * static_cast<float>(end - begin) ? kAlphaSmooth
                                                                                                      : 0.0f;
}

// F = (1/n) Σ_j E_{T_j}(C_j) ∇E_{T_j}(C_j) over the triangles incident to v.
glm::vec3 vertex_force(const FairingTopology& topo, const FairingWorkspace& ws, uint32_t v) {
  const uint32_t tri_begin = topo.incident_offsets[v], tri_end = topo.incident_offsets[v + 1];
  glm::vec3 force(0.0f);
  for (uint32_t k = tri_begin; k < tri_end; ++k) force += ws.triangle_force[topo.incident_triangles[k]];
  if (tri_end > tri_begin) force /= static_cast<float>(tri_end - tri_begin);
  return force;
}

// F̂, softened: where |F| is below a thousandth of the vertex's edge length its direction is
// rounding noise, and a V that turned with it would make a held pose jitter; the projection
// fades out there instead (|direction| < 1).
glm::vec3 soft_direction(const glm::vec3& force, float edge) {
  const float force_length = glm::length(force);
  const float soft = 1e-3f * edge;
  return force_length > 0.0f ? force / std::max(force_length, soft) : glm::vec3(0.0f);
}

// V's weight at vertex v, relative to rest. V restores the rest shape of the vertex's 2-ring
// (the bi-umbrella's support) as seen in its local frame. Where the mesh is coarse for the part
// it covers, a medial radius d below kRestShapeRadius mean edge lengths, the 2-ring spans a
// good part of a limb's cross-section (RiggedFigure's 130-vertex body everywhere; a dense
// character's fingers), articulation bends the 2-ring itself, and the rest shape turned by one
// frame is no longer the shape to restore: there V is weighted by d / (kRestShapeRadius e). A
// uniformly lower weight would not do: Fig. 11 needs V where the mesh is fine. The paper's
// (absolute) V keeps weight 1.
float rest_shape_weight(const float* radius, uint32_t v, float edge, const Targets& targets) {
  return targets.umbrella ? std::min(1.0f, std::max(radius[v], 0.0f) / (kRestShapeRadius * edge)) : 1.0f;
}

}  // namespace

// One step of flow (4), on the run's active set: the free vertices move, from U at their
// one-rings and F's terms at their triangles.
void fold_step(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, glm::vec3* x, float step,
               bool semi_implicit, const Targets& targets, FairingWorkspace& ws) {
  const VertexSet free = free_vertices(ws);
  compute_umbrellas(topo, x, targets, free, ring_vertices(ws), ws);

  // E_T(C_j)·∇E_T(C_j) per mesh triangle j with a free corner, against its deformed skeletal
  // triangle T_j.
  for (uint32_t first = 0; first < ws.active_triangle_count; first += kHullBlock)
    triangle_forces(topo, skeletal, radius, x, targets.triangle_level, ws.active_triangles.data() + first,
                    std::min(kHullBlock, ws.active_triangle_count - first), ws);

  for (uint32_t i = 0; i < free.count; ++i) {
    const uint32_t v = free[i];
    const float edge = edge_scale(topo, x, ws, v);
    const float alpha = fold_alpha(topo, ws, v, edge);
    const glm::vec3 force = vertex_force(topo, ws, v);
    const glm::vec3 direction = soft_direction(force, edge);
    // V = Δ²M − (Δ²M·F̂)F̂ (V = Δ²M where F = 0).
    const glm::vec3& bi = ws.bi_umbrella[v];
    const glm::vec3 tangential = bi - glm::dot(bi, direction) * direction;
    ws.smoothing_weight[v] = alpha;
    ws.force_direction[v] = direction;
    // (4): ∂M/∂t = −αΔ²M − F − V.
    // With a smoothing reference (explicit steps), the α term smooths the correction x − M
    // (rest-shape smoothing there pushes the inner side of tight bends into itself on coarse
    // meshes), V keeps restoring the rest shape along the surface.
    const glm::vec3& smooth = targets.reference_bi_umbrella ? ws.bi_reference[v] : bi;
    const float tangential_weight = rest_shape_weight(radius, v, edge, targets);
    ws.tangential_weight[v] = tangential_weight;
    ws.displacement[v] =
        semi_implicit ? -step * force : -step * (alpha * smooth + force + tangential_weight * tangential);
  }

  if (!semi_implicit) {
    apply_displacements(topo, x, ws);  // Jacobi: all from one state
    return;
  }
  for (uint32_t i = 0; i < free.count; ++i) {
    const uint32_t v = free[i];
    ws.start_positions[v] = x[v] + ws.displacement[v];  // x − τF
  }
  implicit_update(topo, x, step, ws.tangential_weight.data(), targets, ws);
}

}  // namespace skelform::runtime::fair_detail
