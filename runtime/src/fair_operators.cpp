// The fairing's discrete operators and its two ways of stepping a flow: the umbrella passes
// U and U² (fair_internal.h), the explicit update with its step limit, and the semi-implicit
// update (paper sec. 5 after Desbrun et al. [11]). Both flows, (4) and (5), step through here.
//
// Explicit stepping (the paper's): x ← x + τ·(right-hand side at x).
// Semi-implicit stepping: the forces F and f∇f are taken at the old positions, the bilaplacian
// terms at the new ones:
//   x' + τ B_v U²(x') = x − τ F(x),   B_v = α_v I + (I − F̂F̂ᵀ)  (flow 4: αΔ² and V),
//   x' + τ W_v U²(x') = x − τ G(x),                             (flow 5),
// solved by a few in-place Gauss-Seidel sweeps in fixed vertex order; each vertex's 3×3 block
// (I + τ ν_v B_v) is inverted in closed form (B_v has eigenvalue α along F̂ and α + 1
// across it). No Eigen, no allocation.
#include "fair_internal.h"
#include "vec3_sse.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif

namespace skelform::runtime::fair_detail {
namespace {

// (I + c B)⁻¹ z for B = a I + b (I − n nᵀ), |n| ≤ 1 (Sherman-Morrison on k I − c b n nᵀ,
// k = 1 + c (a + b); k − c b |n|² ≥ 1 + c a > 0).
glm::vec3 solve_block(const glm::vec3& z, const glm::vec3& n, float c, float a, float b) {
  const float k = 1.0f + c * (a + b);
  const float cb = c * b;
  return (z + (cb * glm::dot(n, z) / (k - cb * glm::dot(n, n))) * n) / k;
}

// Gauss-Seidel sweeps for x' + τ B_v U²(x') = rhs (rhs in ws.start_positions), in place.
void gauss_seidel(const FairingTopology& topo, glm::vec3* x, float step, const float* tangential_weights,
                  const Targets& targets, FairingWorkspace& ws) {
  const VertexSet free = free_vertices(ws);
  for (int sweep = 0; sweep < kGaussSeidelSweeps; ++sweep) {
    for (uint32_t i = 0; i < free.count; ++i) {
      const uint32_t v = free[i];
      const float nu = topo.bi_umbrella_diagonal[v];
      glm::vec3 off_diagonal = bi_umbrella_at(topo, x, v) - nu * x[v];  // U²x − ν x_v
      if (targets.bi_umbrella) off_diagonal -= targets.bi_umbrella[v];  // relative to rest
      const float a = ws.smoothing_weight[v];
      const glm::vec3& n = ws.force_direction[v];
      const float tangential_weight = tangential_weights ? tangential_weights[v] : 0.0f;
      // B_v applied to the off-diagonal part: a·r + b·(r − (r·n)n).
      const glm::vec3 b_off = a * off_diagonal + tangential_weight * (off_diagonal - glm::dot(off_diagonal, n) * n);
      const glm::vec3 solved = solve_block(ws.start_positions[v] - step * b_off, n, step * nu, a, tangential_weight);
      if (finite(solved)) x[v] = solved;
    }
  }
}

}  // namespace

// With SSE2 a vertex's x, y and z share one addition chain and one division (vec3_sse.h: the
// scalar operations lane by lane in the same order, so umbrella_at's bits), where the compiled
// scalar code divides twice.
void umbrella_pass(const FairingTopology& topo, const glm::vec3* x, glm::vec3* out, VertexSet vertices) {
#if defined(__SSE2__)
  const sse::Vec3Reader read(x, topo.vertex_count);
  for (uint32_t i = 0; i < vertices.count; ++i) {
    const uint32_t v = vertices[i];
    const uint32_t begin = topo.neighbour_offsets[v], end = topo.neighbour_offsets[v + 1];
    if (begin == end) {
      out[v] = glm::vec3(0.0f);
      continue;
    }
    __m128 sum = _mm_setzero_ps();
    for (uint32_t k = begin; k < end; ++k) sum = _mm_add_ps(sum, read(topo.neighbours[k]));
    sse::store3(out[v], _mm_sub_ps(_mm_div_ps(sum, _mm_set1_ps(static_cast<float>(end - begin))), read(v)));
  }
#else
  for (uint32_t i = 0; i < vertices.count; ++i) out[vertices[i]] = umbrella_at(topo, x, vertices[i]);
#endif
}

void compute_umbrellas(const FairingTopology& topo, const glm::vec3* x, const Targets& targets, VertexSet vertices,
                       VertexSet ring, FairingWorkspace& ws) {
  umbrella_pass(topo, x, ws.umbrella.data(), ring);
  umbrella_pass(topo, ws.umbrella.data(), ws.bi_umbrella.data(), vertices);
  if (!targets.umbrella) return;
  for (uint32_t i = 0; i < vertices.count; ++i) {
    const uint32_t v = vertices[i];
    if (targets.reference_bi_umbrella) ws.bi_reference[v] = ws.bi_umbrella[v] - targets.reference_bi_umbrella[v];
    ws.bi_umbrella[v] -= targets.bi_umbrella[v];
  }
  for (uint32_t i = 0; i < ring.count; ++i) ws.umbrella[ring[i]] -= targets.umbrella[ring[i]];
}

void apply_displacements(const FairingTopology& topo, glm::vec3* x, FairingWorkspace& ws) {
  const VertexSet free = free_vertices(ws);
  for (uint32_t i = 0; i < free.count; ++i) {
    const uint32_t v = free[i];
    glm::vec3& step = ws.displacement[v];
    if (!finite(step)) {
      step = glm::vec3(0.0f);
      continue;
    }
    const float squared = glm::dot(step, step);  // (the square root only for steps it shortens)
    const float limit = kMaxStepPerEdge * edge_scale(topo, x, ws, v);
    if (squared > limit * limit) step *= limit / std::sqrt(squared);
  }
  for (uint32_t i = 0; i < free.count; ++i) x[free[i]] += ws.displacement[free[i]];
}

void implicit_update(const FairingTopology& topo, glm::vec3* x, float step, const float* tangential_weights,
                     const Targets& targets, FairingWorkspace& ws) {
  // ws.umbrella is free now: keep x before the solve there (the solve moves only free vertices).
  const VertexSet free = free_vertices(ws);
  for (uint32_t i = 0; i < free.count; ++i) ws.umbrella[free[i]] = x[free[i]];
  gauss_seidel(topo, x, step, tangential_weights, targets, ws);
  for (uint32_t i = 0; i < free.count; ++i) {
    const uint32_t v = free[i];
    ws.displacement[v] = x[v] - ws.umbrella[v];
    x[v] = ws.umbrella[v];
  }
  apply_displacements(topo, x, ws);
}

}  // namespace skelform::runtime::fair_detail
