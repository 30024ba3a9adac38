// Runtime step 3: fairing flows (4) and (5) of the paper (sec. 3.1, 3.2) on the control mesh.
//
// Discretisation (DESIGN.md math notes):
//   Δ²M ≈ U²(p) = mean_j U(q_j) − U(p), U(p) = mean_j q_j − p (Kobbelt et al. [17]), uniform
//   weights; −U² smooths (it decreases Σ|U|², tested).
//   Flow (4): ∂M/∂t = −αΔ²M − F − V, with α ∈ {0.25, 0} by the obtuse-umbrella rule,
//     F(M) = (1/n) Σ_j E_{T_j}(C_j) ∇E_{T_j}(C_j), V = Δ²M − (Δ²M·F̂) F̂.
//   Flow (5): ∂M/∂t = −f∇f − WΔ²M, g(x, S) = |x − S|² − d_S², f from the voxel grid,
//     W = |f − g| / max|f − g|.
//
// Explicit stepping (the paper's): x ← x + τ·(right-hand side at x).
// Semi-implicit stepping (paper sec. 5 after Desbrun et al. [11]): the forces F and f∇f are
// taken at the old positions, the bilaplacian terms at the new ones:
//   x' + τ B_v U²(x') = x − τ F(x),   B_v = α_v I + (I − F̂F̂ᵀ)  (flow 4: αΔ² and V),
//   x' + τ W_v U²(x') = x − τ G(x),                             (flow 5),
// solved by a few in-place Gauss-Seidel sweeps in fixed vertex order; each vertex's 3×3 block
// (I + τ ν_v B_v) is inverted in closed form (B_v has eigenvalue α along F̂ and α + 1
// across it). No Eigen, no allocation.
#include "fair.h"
#include "vec3_sse.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif

namespace skelform::runtime {
namespace {

constexpr uint32_t kDefaultIterations = 30;
constexpr float kAlphaSmooth = 0.25f;      // α of flow (4) where the umbrellas agree
constexpr float kObtuseFraction = 0.3f;    // the paper's 30 % rule
constexpr uint32_t kDefaultGridSize = 20;  // the paper's 20×20×20 voxels
constexpr int kGaussSeidelSweeps = 3;
// A vertex moves at most this many times its mean incident edge length per step: a safety net
// against a far-off vertex overshooting (scale-free, so scale invariance is kept).
constexpr float kMaxStepPerEdge = 0.5f;
// Relative to rest, flow (4)'s V has its full weight where the medial radius is at least this
// many rest mean edge lengths, and d / (kRestShapeRadius e) below (fold_step).
constexpr float kRestShapeRadius = 3.0f;
// Flow (5) relative to rest keeps a vertex this many rest mean edge lengths (or medial radii,
// if smaller) on its own side of the radical plane with any ball it was farther from at rest
// (intersection_step).
constexpr float kIntersectionMargin = 0.75f;

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// The rest values the flows are measured from (FairingRest), in this evaluation's frames;
// all null for the paper's absolute flows.
struct Targets {
  const glm::vec3* umbrella = nullptr;
  const glm::vec3* bi_umbrella = nullptr;
  const float* triangle_level = nullptr;
  const float* gap = nullptr;
  const glm::vec3* reference_bi_umbrella = nullptr;  // U² of the unfaired reconstruction
  const glm::vec3* rest_positions = nullptr;         // M and S at rest (flow (5)'s margin)
  const glm::vec3* rest_skeletal = nullptr;
};

// Never moved: open-border and isolated vertices, and the caller's FairingParams::fixed.
bool is_fixed(const FairingTopology& topo, const FairingWorkspace& ws, uint32_t v) {
  return topo.fixed[v] || (ws.caller_fixed && ws.caller_fixed[v]);
}

// U(p) = mean of the one-ring − p; 0 for a vertex without neighbours.
glm::vec3 umbrella_at(const FairingTopology& topo, const glm::vec3* x, uint32_t v) {
  const uint32_t begin = topo.neighbour_offsets[v], end = topo.neighbour_offsets[v + 1];
  if (begin == end) return glm::vec3(0.0f);
  glm::vec3 sum(0.0f);
  for (uint32_t k = begin; k < end; ++k) sum += x[topo.neighbours[k]];
  return sum / static_cast<float>(end - begin) - x[v];
}

// U²(p) = mean_j U(q_j) − U(p) evaluated from the positions as they are now (for the
// in-place Gauss-Seidel sweeps, which cannot use a precomputed U).
glm::vec3 bi_umbrella_at(const FairingTopology& topo, const glm::vec3* x, uint32_t v) {
  const uint32_t begin = topo.neighbour_offsets[v], end = topo.neighbour_offsets[v + 1];
  if (begin == end) return glm::vec3(0.0f);
  glm::vec3 sum(0.0f);
  for (uint32_t k = begin; k < end; ++k) sum += umbrella_at(topo, x, topo.neighbours[k]);
  return sum / static_cast<float>(end - begin) - umbrella_at(topo, x, v);
}

// umbrella_at of every vertex into `out` (not aliasing x). With SSE2 a vertex's x, y and z share
// one addition chain and one division (vec3_sse.h: the scalar operations lane by lane in the
// same order, so umbrella_at's bits), where the compiled scalar code divides twice (measured:
// ~1 % of an evaluation on CesiumMan_loop2, with five such passes per frame).
void umbrella_pass(const FairingTopology& topo, const glm::vec3* x, glm::vec3* out) {
#if defined(__SSE2__)
  const sse::Vec3Reader read(x, topo.vertex_count);
  for (uint32_t v = 0; v < topo.vertex_count; ++v) {
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
  for (uint32_t v = 0; v < topo.vertex_count; ++v) out[v] = umbrella_at(topo, x, v);
#endif
}

void compute_umbrellas(const FairingTopology& topo, const glm::vec3* x, const Targets& targets, FairingWorkspace& ws) {
  umbrella_pass(topo, x, ws.umbrella.data());
  umbrella_pass(topo, ws.umbrella.data(), ws.bi_umbrella.data());
  if (!targets.umbrella) return;
  for (uint32_t v = 0; v < topo.vertex_count; ++v) {
    ws.umbrella[v] -= targets.umbrella[v];
    if (targets.reference_bi_umbrella) ws.bi_reference[v] = ws.bi_umbrella[v] - targets.reference_bi_umbrella[v];
    ws.bi_umbrella[v] -= targets.bi_umbrella[v];
  }
}

float mean_edge_length(const FairingTopology& topo, const glm::vec3* x, uint32_t v) {
  const uint32_t begin = topo.neighbour_offsets[v], end = topo.neighbour_offsets[v + 1];
  if (begin == end) return 0.0f;
  float sum = 0.0f;
  for (uint32_t k = begin; k < end; ++k) sum += glm::length(x[topo.neighbours[k]] - x[v]);
  return sum / static_cast<float>(end - begin);
}

// The vertex's mean edge length: at rest when the run has rest values (a constant scale for
// the step limit and the thresholds; scale-covariant like the current one), else now.
float edge_scale(const FairingTopology& topo, const glm::vec3* x, const FairingWorkspace& ws, uint32_t v) {
  return ws.rest_edge ? ws.rest_edge[v] : mean_edge_length(topo, x, v);
}

// Moves every free vertex by ws.displacement, each shortened to kMaxStepPerEdge of its mean
// edge length measured before anything moves (so the result does not depend on vertex
// order). A non-finite displacement moves nothing.
void apply_displacements(const FairingTopology& topo, glm::vec3* x, FairingWorkspace& ws) {
  for (uint32_t v = 0; v < topo.vertex_count; ++v) {
    glm::vec3& step = ws.displacement[v];
    if (is_fixed(topo, ws, v) || !finite(step)) {
      step = glm::vec3(0.0f);
      continue;
    }
    const float squared = glm::dot(step, step);  // (the square root only for steps it shortens)
    const float limit = kMaxStepPerEdge * edge_scale(topo, x, ws, v);
    if (squared > limit * limit) step *= limit / std::sqrt(squared);
  }
  for (uint32_t v = 0; v < topo.vertex_count; ++v) x[v] += ws.displacement[v];
}

// Semi-implicit step: solves x' + τ B_v U²(x') = rhs (rhs in ws.start_positions) in place,
// then turns x' − x into ws.displacement and applies it like an explicit step.
// `tangential_weights`: V's weight b per vertex (null: 0, flow (5) has no V).
void implicit_update(const FairingTopology& topo, glm::vec3* x, float step, const float* tangential_weights,
                     const Targets& targets, FairingWorkspace& ws);

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
  for (int sweep = 0; sweep < kGaussSeidelSweeps; ++sweep) {
    for (uint32_t v = 0; v < topo.vertex_count; ++v) {
      if (is_fixed(topo, ws, v)) continue;
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

// ---- flow (4) ----------------------------------------------------------------------------

// Flow (4)'s triangle terms into ws.triangle_force, a block of triangles at a time (E_T below).
constexpr uint32_t kHullBlock = 64;
void triangle_forces(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, const glm::vec3* x,
                     const float* rest_level, uint32_t first, uint32_t count, FairingWorkspace& ws);

// One step of flow (4).
void fold_step(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, glm::vec3* x, float step,
               bool semi_implicit, const Targets& targets, FairingWorkspace& ws) {
  const uint32_t vertex_count = topo.vertex_count;
  compute_umbrellas(topo, x, targets, ws);

  // E_T(C_j)·∇E_T(C_j) per mesh triangle j against its deformed skeletal triangle T_j.
  for (uint32_t first = 0; first < topo.triangle_count; first += kHullBlock)
    triangle_forces(topo, skeletal, radius, x, targets.triangle_level, first,
                    std::min(kHullBlock, topo.triangle_count - first), ws);

  for (uint32_t v = 0; v < vertex_count; ++v) {
    ws.displacement[v] = glm::vec3(0.0f);
    ws.smoothing_weight[v] = 0.0f;
    ws.force_direction[v] = glm::vec3(0.0f);
    if (is_fixed(topo, ws, v)) continue;
    // α: 0.25 unless 30 % or more of the neighbours' umbrella vectors are obtuse to U(p).
    const uint32_t begin = topo.neighbour_offsets[v], end = topo.neighbour_offsets[v + 1];
    uint32_t obtuse = 0;
    for (uint32_t k = begin; k < end; ++k)
      if (glm::dot(ws.umbrella[topo.neighbours[k]], ws.umbrella[v]) < 0.0f) ++obtuse;
    // An umbrella below a thousandth of the edge length (relative to rest: the pose has not
    // changed the surface here) has no meaningful direction: no fold, α as for a smooth spot.
    const float edge = edge_scale(topo, x, ws, v);
    const bool negligible = glm::length(ws.umbrella[v]) < 1e-3f * edge;
    const float alpha = negligible || static_cast<float>(obtuse) < kObtuseFraction * static_cast<float>(end - begin)
                            ? kAlphaSmooth
                            : 0.0f;

    // F = (1/n) Σ_j E_{T_j}(C_j) ∇E_{T_j}(C_j) over the incident triangles.
    const uint32_t tri_begin = topo.incident_offsets[v], tri_end = topo.incident_offsets[v + 1];
    glm::vec3 force(0.0f);
    for (uint32_t k = tri_begin; k < tri_end; ++k) force += ws.triangle_force[topo.incident_triangles[k]];
    if (tri_end > tri_begin) force /= static_cast<float>(tri_end - tri_begin);
    // F̂, softened: where |F| is below a thousandth of the vertex's edge length its direction is
    // rounding noise, and a V that turned with it would make a held pose jitter; the
    // projection fades out there instead (|direction| < 1).
    const float force_length = glm::length(force);
    const float soft = 1e-3f * edge;
    const glm::vec3 direction = force_length > 0.0f ? force / std::max(force_length, soft) : glm::vec3(0.0f);

    // V = Δ²M − (Δ²M·F̂)F̂ (V = Δ²M where F = 0).
    const glm::vec3& bi = ws.bi_umbrella[v];
    const glm::vec3 tangential = bi - glm::dot(bi, direction) * direction;
    ws.smoothing_weight[v] = alpha;
    ws.force_direction[v] = direction;
    // (4): ∂M/∂t = −αΔ²M − F − V.
    // With a smoothing reference (explicit steps), the α term smooths the correction x − M
    // (measured: rest-shape smoothing there pushes the inner side of tight bends into
    // itself on coarse meshes), V keeps restoring the rest shape along the surface.
    const glm::vec3& smooth = targets.reference_bi_umbrella ? ws.bi_reference[v] : bi;
    // V's weight, relative to rest. V restores the rest shape of the vertex's 2-ring (the
    // bi-umbrella's support) as seen in its local frame. Where the mesh is coarse for the part
    // it covers, a medial radius d below kRestShapeRadius mean edge lengths, the 2-ring spans a
    // good part of a limb's cross-section (RiggedFigure's 130-vertex body everywhere; a dense
    // character's fingers), articulation bends the 2-ring itself, and the rest shape turned by
    // one frame is no longer the shape to restore: there V is weighted by d / (kRestShapeRadius
    // e). Measured, frames of the sample animations above LBS / Fig. 11's pairs: weight 1
    // everywhere 15 / 0; with kRestShapeRadius 2: 10 / 0, 3: 5 / 0, 4: 6 / 0, 6: 8 / 3; a
    // uniform weight of 0.2: 5 / 11 (Fig. 11 needs V where the mesh is fine). The paper's
    // (absolute) V keeps weight 1.
    const float rest_shape_weight =
        targets.umbrella ? std::min(1.0f, std::max(radius[v], 0.0f) / (kRestShapeRadius * edge)) : 1.0f;
    ws.tangential_weight[v] = rest_shape_weight;
    ws.displacement[v] =
        semi_implicit ? -step * force : -step * (alpha * smooth + force + rest_shape_weight * tangential);
  }

  if (!semi_implicit) {
    apply_displacements(topo, x, ws);  // Jacobi: all from one state
    return;
  }
  for (uint32_t v = 0; v < vertex_count; ++v) ws.start_positions[v] = x[v] + ws.displacement[v];  // x − τF
  implicit_update(topo, x, step, ws.tangential_weight.data(), targets, ws);
}

// ---- flow (5) ----------------------------------------------------------------------------

struct Grid {
  glm::vec3 origin{0.0f};
  glm::vec3 cell{1.0f};  // cell size per axis
  glm::vec3 inverse_cell{1.0f};
  int size = 1;             // cells per axis
  int ring[3] = {1, 1, 1};  // ⌈max d / cell⌉ per axis, at least 1 (the paper's 3×3×3)
  float max_radius = 0.0f;  // largest d
};

// The cell of coordinate x along one axis, in [0, size). Clamped while still a float: the
// product is inf when the cell underflows (a mesh collapsed to a point, 1/cell = inf) and
// beyond int's range for a point far outside the box, and converting either to int is
// undefined behaviour (in practice INT_MIN: an index before the grid).
int cell_coordinate(float x, float origin, float inverse_cell, int size) {
  const float c = (x - origin) * inverse_cell;
  if (!(c >= 0.0f)) return 0;  // also NaN
  if (!(c < static_cast<float>(size))) return size - 1;
  return static_cast<int>(c);
}

// Buckets the skeletal vertices into the grid over the bounding box of skeleton and mesh.
Grid build_grid(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, const glm::vec3* x,
                int size, FairingWorkspace& ws) {
  const uint32_t vertex_count = topo.vertex_count;
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  float max_radius = 0.0f;
  for (uint32_t v = 0; v < vertex_count; ++v) {
    if (finite(skeletal[v])) lo = glm::min(lo, skeletal[v]), hi = glm::max(hi, skeletal[v]);
    if (finite(x[v])) lo = glm::min(lo, x[v]), hi = glm::max(hi, x[v]);
    if (std::isfinite(radius[v])) max_radius = std::max(max_radius, radius[v]);
  }
  Grid grid;
  grid.size = size;
  if (!(lo.x <= hi.x)) lo = hi = glm::vec3(0.0f);
  const glm::vec3 extent = hi - lo;
  const float largest = std::max(std::max(extent.x, extent.y), extent.z);
  // Cubic cells (the paper divides a unit box): the largest extent over `size` cells; the
  // box is centred in the grid along its shorter axes.
  const float cell = (largest > 0.0f ? largest : 1.0f) / static_cast<float>(size);
  grid.origin = 0.5f * (lo + hi) - 0.5f * cell * static_cast<float>(size);
  grid.cell = glm::vec3(cell);
  grid.inverse_cell = glm::vec3(1.0f / cell);
  grid.max_radius = max_radius;
  // Clamped while still a float, as in cell_coordinate: a radius of 3e38 over a small cell is
  // far beyond int's range (NaN, from a cell that underflowed to 0, searches everything too).
  const float rings = std::ceil(max_radius / cell);
  const int ring = rings < static_cast<float>(size) ? std::max(1, static_cast<int>(rings)) : size;
  grid.ring[0] = grid.ring[1] = grid.ring[2] = ring;

  const size_t cell_count = size_t(size) * size * size;
  std::fill(ws.cell_offsets.begin(), ws.cell_offsets.begin() + cell_count + 1, 0u);
  const uint32_t none = std::numeric_limits<uint32_t>::max();
  for (uint32_t v = 0; v < vertex_count; ++v) {
    const glm::vec3& s = skeletal[v];
    if (!finite(s) || !std::isfinite(radius[v])) {
      ws.vertex_cell[v] = none;
      continue;
    }
    const size_t c = (size_t(cell_coordinate(s.z, grid.origin.z, grid.inverse_cell.z, size)) * size +
                      size_t(cell_coordinate(s.y, grid.origin.y, grid.inverse_cell.y, size))) *
                         size +
                     size_t(cell_coordinate(s.x, grid.origin.x, grid.inverse_cell.x, size));
    ws.vertex_cell[v] = static_cast<uint32_t>(c);
    ++ws.cell_offsets[c + 1];
  }
  // Counts to offsets. A row of cells (z, y) is then one run of slots: field_at scans a
  // neighbourhood row as cell_offsets[first cell] .. cell_offsets[last cell + 1].
  for (size_t c = 0; c < cell_count; ++c) ws.cell_offsets[c + 1] += ws.cell_offsets[c];
  // Counting sort, stable: each cell lists its vertices in ascending order (determinism of
  // ties in the minimum below).
  for (uint32_t v = 0; v < vertex_count; ++v) {
    if (ws.vertex_cell[v] == none) continue;
    ws.cell_vertices[ws.cell_offsets[ws.vertex_cell[v]]++] = v;
  }
  for (size_t c = cell_count; c > 0; --c) ws.cell_offsets[c] = ws.cell_offsets[c - 1];
  ws.cell_offsets[0] = 0;
  // The balls in cell order, structure of arrays: slot_minimum's candidates side by side.
  for (uint32_t k = 0; k < ws.cell_offsets[cell_count]; ++k) {
    const uint32_t s = ws.cell_vertices[k];
    ws.cell_x[k] = skeletal[s].x;
    ws.cell_y[k] = skeletal[s].y;
    ws.cell_z[k] = skeletal[s].z;
    ws.cell_rr[k] = radius[s] * radius[s];
  }
  return grid;
}

struct FieldValue {
  float f = std::numeric_limits<float>::infinity();
  uint32_t minimiser = std::numeric_limits<uint32_t>::max();  // S* (skeletal vertex index)
};

// The field's order: the smaller g, and of equal g the smaller ball index. A strict total order
// on (g, s), so the minimum does not depend on the order the balls are visited in.
inline bool precedes(float g, uint32_t s, const FieldValue& best) {
  return g < best.f || (g == best.f && s < best.minimiser);
}

// min of g(x, S) = |x − S|² − d_S² over the skeletal vertices in slots [begin, end) of the
// balls' cell-ordered copy (build_grid: S and d² side by side) other than `exclude`, into
// `best`. The slots of consecutive cells are consecutive, so a run of cells along x is one
// range. g is (dx² + dy²) + dz² − d² in either path, the same minimum and the same ties.
void slot_minimum(const glm::vec3& x, const FairingWorkspace& ws, uint32_t begin, uint32_t end, uint32_t exclude,
                  FieldValue& best) {
#if defined(__SSE2__)
  // Four candidates at a time; only a group with some g below the best so far is walked lane by
  // lane, in order, with the portable rule.
  const __m128 px = _mm_set1_ps(x.x), py = _mm_set1_ps(x.y), pz = _mm_set1_ps(x.z);
  for (uint32_t k = begin; k < end; k += 4) {
    const __m128 dx = _mm_sub_ps(px, _mm_loadu_ps(ws.cell_x.data() + k));
    const __m128 dy = _mm_sub_ps(py, _mm_loadu_ps(ws.cell_y.data() + k));
    const __m128 dz = _mm_sub_ps(pz, _mm_loadu_ps(ws.cell_z.data() + k));
    const __m128 g = lane4::sub(lane4::dot(dx, dy, dz, dx, dy, dz), lane4::load(ws.cell_rr.data() + k));
    const uint32_t lanes = std::min(4u, end - k);
    if ((_mm_movemask_ps(_mm_cmple_ps(g, _mm_set1_ps(best.f))) & ((1 << lanes) - 1)) == 0) continue;
    alignas(16) float values[4];
    _mm_store_ps(values, g);
    for (uint32_t lane = 0; lane < lanes; ++lane) {
      const uint32_t s = ws.cell_vertices[k + lane];
      if (s != exclude && precedes(values[lane], s, best)) best = {values[lane], s};
    }
  }
#else
  for (uint32_t k = begin; k < end; ++k) {
    const uint32_t s = ws.cell_vertices[k];
    if (s == exclude) continue;
    const float dx = x.x - ws.cell_x[k], dy = x.y - ws.cell_y[k], dz = x.z - ws.cell_z[k];
    const float g = dx * dx + dy * dy + dz * dz - ws.cell_rr[k];
    if (precedes(g, s, best)) best = {g, s};
  }
#endif
}

// f(x) of (5): h of x's own cell when negative, else the minimum of h over the neighbouring
// cells — the paper's 3×3×3, widened to rings of ⌈max d / cell⌉ (DESIGN.md), and further if
// still no skeletal vertex was found, so f is always defined. Skeletal vertex `exclude` (the
// vertex's own ball, relative to rest; none = no exclusion) is left out of the minimum.
FieldValue field_at(const Grid& grid, const glm::vec3& x, const FairingWorkspace& ws,
                    uint32_t exclude = std::numeric_limits<uint32_t>::max()) {
  const int n = grid.size;
  const int cx = cell_coordinate(x.x, grid.origin.x, grid.inverse_cell.x, n);
  const int cy = cell_coordinate(x.y, grid.origin.y, grid.inverse_cell.y, n);
  const int cz = cell_coordinate(x.z, grid.origin.z, grid.inverse_cell.z, n);
  FieldValue best;
  const uint32_t* offsets = ws.cell_offsets.data();
  const size_t own = (size_t(cz) * n + cy) * n + cx;
  slot_minimum(x, ws, offsets[own], offsets[own + 1], exclude, best);
  // The paper stops here when h of the own cell is negative. That makes f jump where the
  // own cell's minimum crosses 0 (a float rounding away at rest), so the neighbourhood's
  // minimum is always taken: the same f wherever the own cell's value is negative and
  // another cell's is lower, continuous otherwise.
  // The (widened) 3×3×3 neighbourhood at once, each row of it (z, y) one run of slots from its
  // first cell's to past its last cell's: empty cells cost nothing and the balls of a row are
  // read four at a time without a break at every cell boundary (the own row in two runs, the
  // own cell being done above). The neighbourhood spans up to (2 ring + 1)³ cells, most of
  // them empty (CesiumMan_loop2, ring 3: 343 cells). The minimum does not depend on the order
  // (precedes), so it is the shell-by-shell search's minimum. (Row occupancy masks visiting
  // only the occupied cells, one call per cell, were slower on CesiumMan_loop2. No per-cell
  // pruning by dist(x, cell)² − (largest d in the cell)² ≥ best either: a cell that bound
  // excludes cannot lower `best`, so the result is the same without it, and measured, its
  // unpredictable branch cost more than scanning the cell four balls at a time: ~2 % of an
  // evaluation on CesiumMan_loop2.)
  const int last_ring = std::max(std::max(grid.ring[0], grid.ring[1]), grid.ring[2]);
  const int x0 = std::max(0, cx - last_ring), x1 = std::min(n - 1, cx + last_ring);
  for (int z = std::max(0, cz - last_ring); z <= std::min(n - 1, cz + last_ring); ++z)
    for (int y = std::max(0, cy - last_ring); y <= std::min(n - 1, cy + last_ring); ++y) {
      const size_t row = (size_t(z) * n + y) * n;
      if (z == cz && y == cy) {
        slot_minimum(x, ws, offsets[row + x0], offsets[own], exclude, best);
        slot_minimum(x, ws, offsets[own + 1], offsets[row + x1 + 1], exclude, best);
      } else {
        slot_minimum(x, ws, offsets[row + x0], offsets[row + x1 + 1], exclude, best);
      }
    }
  // Shells of Chebyshev radius r around the own cell beyond the neighbourhood, nearest first,
  // only while no ball has been found, up to the first shell holding one. A row on the
  // shell's faces in z or y is one run; any other row of the shell's cube meets its surface in
  // the two cells at x = cx ± r.
  for (int r = last_ring + 1; r <= n && best.minimiser == std::numeric_limits<uint32_t>::max(); ++r) {
    const int shell_x0 = std::max(0, cx - r), shell_x1 = std::min(n - 1, cx + r);
    for (int z = std::max(0, cz - r); z <= std::min(n - 1, cz + r); ++z)
      for (int y = std::max(0, cy - r); y <= std::min(n - 1, cy + r); ++y) {
        const size_t row = (size_t(z) * n + y) * n;
        if (std::abs(z - cz) == r || std::abs(y - cy) == r) {
          slot_minimum(x, ws, offsets[row + shell_x0], offsets[row + shell_x1 + 1], exclude, best);
          continue;
        }
        if (cx - r >= 0) slot_minimum(x, ws, offsets[row + cx - r], offsets[row + cx - r + 1], exclude, best);
        if (cx + r < n) slot_minimum(x, ws, offsets[row + cx + r], offsets[row + cx + r + 1], exclude, best);
      }
  }
  return best;
}

// One step of flow (5).
void intersection_step(const FairingTopology& topo, const Grid& grid, const glm::vec3* skeletal, const float* radius,
                       glm::vec3* x, float step, bool semi_implicit, bool refresh_field, const Targets& targets,
                       FairingWorkspace& ws) {
  const uint32_t vertex_count = topo.vertex_count;
  // No compute_umbrellas here: the semi-implicit solve evaluates U² itself, and the explicit
  // step needs U² only where W > 0 (a third of the vertices on CesiumMan_loop2), from U of all.
  if (!semi_implicit) umbrella_pass(topo, x, ws.umbrella.data());

  // f, its Gauss-Newton step G = f∇f / max(|∇f|², 4 d*²) with ∇f = 2(x − S*), and |f − g|.
  // Relative to rest, f is the minimum over the balls other than the vertex's own (the ball it
  // was reconstructed from): the margin below needs the nearest other ball also where the own
  // ball is nearer.
  const bool relative = targets.rest_positions && targets.rest_skeletal;
  constexpr uint32_t none = std::numeric_limits<uint32_t>::max();
  float largest_gap = 0.0f;
  for (uint32_t v = 0; v < vertex_count; ++v) {
    ws.displacement[v] = glm::vec3(0.0f);
    ws.smoothing_weight[v] = 0.0f;
    ws.force_direction[v] = glm::vec3(0.0f);
    if (is_fixed(topo, ws, v) || !finite(x[v])) continue;
    // The grid search once per fair_run() call; later iterations of the call follow the
    // minimising ball found then (the vertices move a fraction of an edge per iteration).
    FieldValue field;
    const bool search = refresh_field && (ws.search_stride <= 1 || ws.minimiser[v] == none ||
                                          (ws.search_phase + v) % ws.search_stride == 0);
    if (search) {
      field = field_at(grid, x[v], ws, relative ? v : none);
      ws.minimiser[v] = field.minimiser;
    } else if (refresh_field) {
      // Tracking (FairingParams::search_stride): the best of the vertex's own ball (not
      // relative to rest), its last minimiser and its neighbours' last minimisers; a minimum
      // that moves along the surface is followed, a new one is found at the vertex's next full
      // search.
      // The smallest (g, s), lexicographically, over the candidates: the order they come in does
      // not matter. The tests that rarely fail branch (build_grid left vertex_cell at none for
      // a skeletal vertex or radius that is not finite); the comparison, which fails or holds
      // at random, selects without a branch (measured: ~3 % of an evaluation on CesiumMan_loop2).
      auto consider = [&](uint32_t s) {
        if (s == none || (relative && s == v) || ws.vertex_cell[s] == none) return;
        const glm::vec3 d = x[v] - skeletal[s];
        const float g = glm::dot(d, d) - radius[s] * radius[s];
        const bool better = (g < field.f) | ((g == field.f) & (s < field.minimiser));
        field.f = better ? g : field.f;
        field.minimiser = better ? s : field.minimiser;
      };
      consider(v);
      consider(ws.minimiser[v]);
      for (uint32_t k = topo.neighbour_offsets[v]; k < topo.neighbour_offsets[v + 1]; ++k)
        consider(ws.minimiser[topo.neighbours[k]]);
      ws.next_minimiser[v] = field.minimiser;
    } else if (ws.minimiser[v] != none) {
      const uint32_t s = ws.minimiser[v];
      const glm::vec3 d = x[v] - skeletal[s];
      field = {glm::dot(d, d) - radius[s] * radius[s], s};
    }
    if (field.minimiser == none) continue;
    // g(x, S_v) of the vertex's own ball, where another ball is the minimiser (0 is unused).
    const bool foreign = field.minimiser != v && finite(skeletal[v]);
    const glm::vec3 to_own = x[v] - skeletal[v];
    const float own = foreign ? glm::dot(to_own, to_own) - radius[v] * radius[v] : 0.0f;
    if (!relative) {
      // The paper's −f∇f, ∇f = 2(x − S*), as a Gauss-Newton step towards f = 0.
      const glm::vec3 gradient = 2.0f * (x[v] - skeletal[field.minimiser]);
      const float d_star = radius[field.minimiser];
      const float denominator = std::max(glm::dot(gradient, gradient), 4.0f * d_star * d_star);
      if (denominator > 0.0f) ws.displacement[v] = -step * (field.f / denominator) * gradient;
    } else if (foreign) {
      // Relative to rest, flow (5) keeps the vertex on its own side of the radical plane
      // between its own ball (S_v, d_v) and the nearest other ball (S*, d*). The power
      // difference Δ = g(x, S*) − g(x, S_v) = f − g_own is positive on the own side, with
      // ∇Δ = 2(S_v − S*) and Δ / |∇Δ| the distance to the plane. Δ must not fall below the
      // smaller of its rest value (the same two balls, rest M and S) and a margin of
      // kIntersectionMargin times the rest mean edge length e or the medial radius d_v,
      // whichever is smaller (a gap wider than the part is thick would fold a coarse mesh):
      //   - a vertex never sinks deeper into another ball's power cell than it was at rest
      //     (where balls overlap at rest, in a crease or a thin part, that is the rest depth);
      //   - where two parts that were apart at rest come into contact (the inner side of a
      //     bent joint, an arm against the torso), both skins stop a margin short of the plane
      //     between them. Without the margin both settled onto the same plane and touched or
      //     crossed between their vertices. Measured, intersecting pairs with the rest depth
      //     alone (before) / margins of 0.35 / 0.5 / 0.75 edges: CesiumMan's animation 2,915 /
      //     1,301 / 1,239 / 1,182 (LBS 3,769), its frames above LBS 3 / 0 / 0 / 0; the bent
      //     capsule from rest 137 / 119 / 113 / 109; the sample animations' frames above LBS in
      //     all 16 / 16 / 16 / 15. Fig. 11 stays at 0. The price is volume: the capsule's change goes from
      //     −1.7 % to −2.6 %, Fox Survey's mean from 1.12 % to 1.18 % (LBS 1.27 %). Capping
      //     the margin at 0.75 d_v (measured after V's weighting in fold_step) took
      //     RiggedFigure's frames above LBS from 3 to 0, the samples' from 5 to 2 (caps at
      //     0.19 / 0.38 / 0.56 / 1.1 / 1.5 d_v: 10 / 5 / 4 / 4 / 6 frames; the capsule and
      //     Fig. 11 do not change).
      // The step goes along ∇Δ, towards the own side (pushing out of S*'s ball along
      // ∇f = 2(x − S*) instead laid each skin onto the other's surface, over the other's skin).
      // A vertex on its own side beyond the margin is not pulled in: that is flow (4)'s, and
      // pulling towards the union of all balls shrank the animated samples (Fox Survey lost
      // 1.58 % of its volume, LBS 1.27 %).
      const uint32_t other = field.minimiser;
      const glm::vec3 gradient = 2.0f * (skeletal[v] - skeletal[other]);
      const glm::vec3 rest_to_other = targets.rest_positions[v] - targets.rest_skeletal[other];
      const glm::vec3 rest_to_own = targets.rest_positions[v] - targets.rest_skeletal[v];
      const float rest_difference = (glm::dot(rest_to_other, rest_to_other) - radius[other] * radius[other]) -
                                    (glm::dot(rest_to_own, rest_to_own) - radius[v] * radius[v]);
      const float edge = edge_scale(topo, x, ws, v);
      const float margin = kIntersectionMargin * std::min(edge, std::max(radius[v], 0.0f)) * glm::length(gradient);
      const float h = std::min(field.f - own - std::min(rest_difference, margin), 0.0f);
      const float denominator = std::max(glm::dot(gradient, gradient), 4.0f * edge * edge);
      if (denominator > 0.0f) ws.displacement[v] = -step * (h / denominator) * gradient;
    }
    // W's numerator: how deep the vertex lies in another ball's power cell, |f(M) − g(M, S)|
    // where another ball is the minimiser (0 where its own ball is); relative to rest, beyond
    // its rest depth.
    if (foreign) {
      float gap = relative ? std::max(0.0f, own - field.f) : std::fabs(field.f - own);
      if (targets.gap) gap = std::max(0.0f, gap - targets.gap[v]);
      ws.smoothing_weight[v] = std::isfinite(gap) ? gap : 0.0f;
      largest_gap = std::max(largest_gap, ws.smoothing_weight[v]);
    }
  }
  if (refresh_field && ws.search_stride > 1)  // tracked minimisers, read from the old ones above
    for (uint32_t v = 0; v < vertex_count; ++v)
      if (ws.next_minimiser[v] != std::numeric_limits<uint32_t>::max()) {
        ws.minimiser[v] = ws.next_minimiser[v];
        ws.next_minimiser[v] = std::numeric_limits<uint32_t>::max();
      }
  // W(M) = |f(M) − g(M, S)| / max_M |f − g|.
  for (uint32_t v = 0; v < vertex_count; ++v)
    ws.smoothing_weight[v] = largest_gap > 0.0f ? ws.smoothing_weight[v] / largest_gap : 0.0f;

  if (!semi_implicit) {
    // (5): ∂M/∂t = −f∇f − WΔ²M, with U² relative to the reference or to rest as compute_umbrellas
    // gives it (the same bits), where W > 0: elsewhere the term is 0.
    for (uint32_t v = 0; v < vertex_count; ++v) {
      if (!(ws.smoothing_weight[v] > 0.0f)) continue;
      glm::vec3 bi = umbrella_at(topo, ws.umbrella.data(), v);
      if (targets.reference_bi_umbrella)
        bi -= targets.reference_bi_umbrella[v];
      else if (targets.umbrella)
        bi -= targets.bi_umbrella[v];
      ws.displacement[v] -= step * ws.smoothing_weight[v] * bi;
    }
    apply_displacements(topo, x, ws);
    return;
  }
  for (uint32_t v = 0; v < vertex_count; ++v) ws.start_positions[v] = x[v] + ws.displacement[v];  // x − τG
  implicit_update(topo, x, step, nullptr, targets, ws);
}

void implicit_update(const FairingTopology& topo, glm::vec3* x, float step, const float* tangential_weights,
                     const Targets& targets, FairingWorkspace& ws) {
  // ws.umbrella is free now: keep x before the solve there.
  for (uint32_t v = 0; v < topo.vertex_count; ++v) ws.umbrella[v] = x[v];
  gauss_seidel(topo, x, step, tangential_weights, targets, ws);
  for (uint32_t v = 0; v < topo.vertex_count; ++v) {
    ws.displacement[v] = x[v] - ws.umbrella[v];
    x[v] = ws.umbrella[v];
  }
  apply_displacements(topo, x, ws);
}

}  // namespace

// ---- E_T ---------------------------------------------------------------------------------
//
// In float, like the rest of the runtime's per-frame loops (it ran in double before: measured,
// the same intersection pairs, volumes and Fig. 11 result on every test scene, and no
// measurable difference in time). The interior case's degeneracy test is relative,
// |e1 × e2|² > 1e-6 |e1|² |e2|² (the skeletal triangle's angles above ~0.06°): below that the
// Gram determinant is float cancellation noise and the boundary candidates decide.

namespace {

// The foot of the minimum of E_T along the cone frustum of balls i and j = i + 1 (mod 3):
// with s the arc length along the axis, φ(s) = sqrt((a − s)² + h²) − r_i − k s,
// k = (r_j − r_i)/L; φ'(s) = 0 at s* = a + k h / sqrt(1 − k²) when |k| < 1 (else one ball
// contains the other: a vertex wins). False when the edge has no such minimum; `clamped` when
// s* was clamped to an end (a vertex is then the foot).
bool edge_foot(const glm::vec3& p, const glm::vec3* c, const float* r, int i, glm::vec3& foot, float& foot_radius,
               bool& clamped) {
  const int j = (i + 1) % 3;
  const glm::vec3 edge = c[j] - c[i];
  const float length = glm::length(edge);
  if (!(length > 0.0f)) return false;
  const float k = (r[j] - r[i]) / length;
  if (!(std::fabs(k) < 1.0f)) return false;
  const glm::vec3 axis = edge * (1.0f / length);
  const glm::vec3 u = p - c[i];
  const float a = glm::dot(u, axis);
  const float h = glm::length(u - a * axis);
  const float unclamped = a + k * h / std::sqrt(1.0f - k * k);
  const float s = std::clamp(unclamped, 0.0f, length);
  clamped = !(unclamped > 0.0f && unclamped < length);
  foot = c[i] + s * axis;
  foot_radius = r[i] + k * s;
  return true;
}

// Directional derivative of φ(b) = |P − c(b)| − r(b) at a foot (unit n = (P − foot)/|P − foot|)
// towards ball m: moving weight to m moves the foot by c_m − foot and its radius by r_m − r.
float toward(const glm::vec3& n, const glm::vec3& foot, float foot_radius, const glm::vec3& centre, float radius) {
  return -glm::dot(n, centre - foot) - (radius - foot_radius);
}

// Interior (tangent-plane case) of E_T: at a stationary b the unit n = (P − c(b))/|P − c(b)|
// obeys n·c_i + r_i = const, i.e. n·e_1 = −δ_1, n·e_2 = −δ_2 (e_i = c_i − c_0, δ_i = r_i − r_0):
// n = n₀ + σμ m with n₀ in the triangle's plane, m its unit normal, μ = sqrt(1 − |n₀|²), σ the
// side of P. Then E_T = n·(P − c_0) − r_0 (distance to the tangent plane), valid when the
// foot Q = P − t n, t = |(P − c_0)·m| / μ, lies in the triangle. φ is convex in b, so such a
// stationary point is the minimum.
//
// Written once, without branches (guards are selects): the scalar E_T and the block-wise one
// in fold_step evaluate this same function, so both give the same bits; in a block the
// independent triangles overlap their divisions and square roots (measured: ~5 % of the
// fairing; GCC 12 does not vectorise it, not even with -fno-trapping-math, which we would not
// impose on engines that trap floating-point exceptions anyway). With SSE2 the block runs it
// four triangles at a time (interior_lanes4 below: the same operations per lane, so the same
// bits; measured ~3 % off a whole CesiumMan_loop2 evaluation). Inputs: P − c_0 (w0), e_1, e_2,
// r_0, δ_1, δ_2. Returns whether the stationary point exists and lies in the triangle.
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
bool interior_result(float value, float nx, float ny, float nz, HullDistance& result) {
  result.value = value;
  result.gradient = glm::vec3(nx, ny, nz);
  return std::isfinite(result.value) && finite(result.gradient);
}

// E_T where the minimum is not interior: the hint's candidate if the KKT conditions prove it
// the minimum, else the smallest of the three vertices and three edge minima.
HullDistance boundary_distance(const glm::vec3& p, const glm::vec3* c, const float* r, uint8_t* hint) {
  // The hint's candidate first. φ is convex in b and differentiable wherever P is off the
  // foot, so a boundary candidate whose derivatives towards the triangle's other corners are
  // all ≥ 0 (the KKT conditions) is the minimum over the whole triangle: the same foot, with
  // the same arithmetic, as the full search below would pick.
  if (hint && *hint >= kHullCaseVertex && *hint < kHullCaseVertex + 6) {
    const int which = *hint - kHullCaseVertex;  // 0..2 a vertex, 3..5 an edge
    const int i = which % 3;
    glm::vec3 foot;
    float foot_radius = 0.0f;
    bool clamped = false;
    bool valid = true;
    if (which < 3) {
      foot = c[i];
      foot_radius = r[i];
    } else {
      valid = edge_foot(p, c, r, i, foot, foot_radius, clamped) && !clamped;
    }
    if (valid) {
      const glm::vec3 offset = p - foot;
      const float distance = glm::length(offset);
      if (distance > 0.0f) {
        const glm::vec3 n = offset * (1.0f / distance);
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        const bool minimum = which < 3 ? toward(n, foot, foot_radius, c[j], r[j]) >= 0.0f &&
                                             toward(n, foot, foot_radius, c[k], r[k]) >= 0.0f
                                       : toward(n, foot, foot_radius, c[k], r[k]) >= 0.0f;
        if (minimum) {
          HullDistance result;
          result.value = distance - foot_radius;
          result.gradient = n;
          if (std::isfinite(result.value) && finite(result.gradient)) return result;
        }
      }
    }
  }

  float best = std::numeric_limits<float>::infinity();
  glm::vec3 best_gradient(0.0f);
  uint8_t best_case = kHullCaseUnknown;
  // A candidate b on the triangle's boundary with its foot c(b) and value |P − c(b)| − r(b);
  // the function is convex in b, so without an interior minimum the smallest candidate among
  // {each edge's minimum, each vertex} is the minimum.
  auto consider_foot = [&](const glm::vec3& foot, float foot_radius, uint8_t which) {
    const glm::vec3 offset = p - foot;
    const float distance = glm::length(offset);
    const float value = distance - foot_radius;
    if (value < best) {
      best = value;
      best_gradient = distance > 0.0f ? offset * (1.0f / distance) : glm::vec3(0.0f);
      best_case = which;
    }
  };
  for (int i = 0; i < 3; ++i) consider_foot(c[i], r[i], uint8_t(kHullCaseVertex + i));  // the sphere itself
  for (int i = 0; i < 3; ++i) {
    glm::vec3 foot;
    float foot_radius = 0.0f;
    bool clamped = false;
    if (edge_foot(p, c, r, i, foot, foot_radius, clamped))
      consider_foot(foot, foot_radius, uint8_t(kHullCaseVertex + 3 + i));
  }
  if (hint) *hint = best_case;

  HullDistance result;
  result.value = std::isfinite(best) ? best : 0.0f;
  result.gradient = std::isfinite(best) ? best_gradient : glm::vec3(0.0f);
  return result;
}

}  // namespace

HullDistance ball_hull_distance(const glm::vec3& point, const glm::vec3* centres, const float* radii, uint8_t* hint) {
  const glm::vec3& p = point;
  const glm::vec3* c = centres;
  const float* r = radii;
  const glm::vec3 w0 = p - c[0], e1 = c[1] - c[0], e2 = c[2] - c[0];
  float value = 0.0f, nx = 0.0f, ny = 0.0f, nz = 0.0f;
  HullDistance result;
  if (interior_lane(w0.x, w0.y, w0.z, e1.x, e1.y, e1.z, e2.x, e2.y, e2.z, r[0], r[1] - r[0], r[2] - r[0], value, nx, ny,
                    nz) &&
      interior_result(value, nx, ny, nz, result)) {
    if (hint) *hint = kHullCaseInterior;
    return result;
  }
  return boundary_distance(p, c, r, hint);
}

namespace {

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

// E_T(C_j)·∇E_T(C_j) − (rest level) for triangles [first, first + count), count ≤ kHullBlock:
// the interior candidates of the whole block in one pass (interior_lane, four at a time with
// SSE2), then the hinted boundary candidates four at a time (hinted_lanes4, SSE2), the rest one
// by one (boundary_distance). Same results as ball_hull_distance per triangle.
void triangle_forces(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, const glm::vec3* x,
                     const float* rest_level, uint32_t first, uint32_t count, FairingWorkspace& ws) {
  float w0x[kHullBlock], w0y[kHullBlock], w0z[kHullBlock], e1x[kHullBlock], e1y[kHullBlock], e1z[kHullBlock];
  float e2x[kHullBlock], e2y[kHullBlock], e2z[kHullBlock], r0[kHullBlock], d1[kHullBlock], d2[kHullBlock];
  float value[kHullBlock], nx[kHullBlock], ny[kHullBlock], nz[kHullBlock];
  bool inside[kHullBlock];
  glm::vec3 centroid[kHullBlock];
  bool usable[kHullBlock];
  for (uint32_t i = 0; i < count; ++i) {
    const uint32_t* corner = topo.triangle_indices.data() + 3 * size_t{first + i};
    centroid[i] = (x[corner[0]] + x[corner[1]] + x[corner[2]]) / 3.0f;
    const glm::vec3 &s0 = skeletal[corner[0]], &s1 = skeletal[corner[1]], &s2 = skeletal[corner[2]];
    usable[i] = finite(centroid[i]) && finite(s0) && finite(s1) && finite(s2);
    // The same differences as ball_hull_distance.
    const glm::vec3 c0(usable[i] ? s0 : glm::vec3(0.0f)), p(usable[i] ? centroid[i] : glm::vec3(0.0f));
    const glm::vec3 c1(usable[i] ? s1 : glm::vec3(0.0f)), c2(usable[i] ? s2 : glm::vec3(0.0f));
    w0x[i] = p.x - c0.x, w0y[i] = p.y - c0.y, w0z[i] = p.z - c0.z;
    e1x[i] = c1.x - c0.x, e1y[i] = c1.y - c0.y, e1z[i] = c1.z - c0.z;
    e2x[i] = c2.x - c0.x, e2y[i] = c2.y - c0.y, e2z[i] = c2.z - c0.z;
    const float rr0 = radius[corner[0]], rr1 = radius[corner[1]], rr2 = radius[corner[2]];
    r0[i] = rr0, d1[i] = rr1 - rr0, d2[i] = rr2 - rr0;
  }
  uint32_t i = 0;
#if defined(__SSE2__)
  for (; i + 4 <= count; i += 4)
    interior_lanes4(w0x + i, w0y + i, w0z + i, e1x + i, e1y + i, e1z + i, e2x + i, e2y + i, e2z + i, r0 + i, d1 + i,
                    d2 + i, value + i, nx + i, ny + i, nz + i, inside + i);
#endif
  for (; i < count; ++i)
    inside[i] = interior_lane(w0x[i], w0y[i], w0z[i], e1x[i], e1y[i], e1z[i], e2x[i], e2y[i], e2z[i], r0[i], d1[i],
                              d2[i], value[i], nx[i], ny[i], nz[i]);
  // E_T's value and gradient per triangle: the interior candidate where it holds; else, with
  // SSE2, the triangles whose hint names an edge or a vertex try it four at a time
  // (hinted_lanes4), the rest (and those whose hint fails) go through boundary_distance.
  const auto store_force = [&](uint32_t i, const HullDistance& e) {
    const uint32_t t = first + i;
    const glm::vec3 force = (rest_level ? e.value - rest_level[t] : e.value) * e.gradient;
    ws.triangle_force[t] = finite(force) ? force : glm::vec3(0.0f);
  };
  const auto boundary = [&](uint32_t i) {
    const uint32_t t = first + i;
    const uint32_t* corner = topo.triangle_indices.data() + 3 * size_t{t};
    const glm::vec3 c[3] = {skeletal[corner[0]], skeletal[corner[1]], skeletal[corner[2]]};
    const float r[3] = {radius[corner[0]], radius[corner[1]], radius[corner[2]]};
    store_force(i, boundary_distance(centroid[i], c, r, ws.hull_case.data() + t));
  };
  uint32_t hinted[kHullBlock];
  uint32_t hinted_count = 0;
  for (uint32_t i = 0; i < count; ++i) {
    const uint32_t t = first + i;
    if (!usable[i]) {
      ws.triangle_force[t] = glm::vec3(0.0f);
      continue;
    }
    HullDistance e;
    if (inside[i] && interior_result(value[i], nx[i], ny[i], nz[i], e)) {
      ws.hull_case[t] = kHullCaseInterior;
      store_force(i, e);
    } else if (kHintedLanes && ws.hull_case[t] >= kHullCaseVertex && ws.hull_case[t] < kHullCaseVertex + 6) {
      hinted[hinted_count++] = i;
    } else {
      boundary(i);
    }
  }
  uint32_t k = 0;
#if defined(__SSE2__)
  for (; k + 4 <= hinted_count; k += 4) {
    HullLanes lanes;
    for (uint32_t lane = 0; lane < 4; ++lane) {
      const uint32_t i = hinted[k + lane];
      const uint32_t* corner = topo.triangle_indices.data() + 3 * size_t{first + i};
      const int which = ws.hull_case[first + i] - kHullCaseVertex;  // 0..2 a vertex, 3..5 an edge
      const uint32_t a = corner[which % 3], b = corner[(which + 1) % 3], c = corner[(which + 2) % 3];
      lanes.set(lane, centroid[i], skeletal[a], skeletal[b], skeletal[c], radius[a], radius[b], radius[c], which >= 3);
    }
    HullDistance e[4];
    const int accepted = hinted_lanes4(lanes, e);
    for (uint32_t lane = 0; lane < 4; ++lane)
      if ((accepted >> lane) & 1)
        store_force(hinted[k + lane], e[lane]);
      else
        boundary(hinted[k + lane]);
  }
#endif
  for (; k < hinted_count; ++k) boundary(hinted[k]);
}

}  // namespace

// ---- topology, workspace, run ----------------------------------------------------------

FairingTopology build_fairing_topology(const uint32_t* triangle_indices, size_t triangle_count, size_t vertex_count,
                                       const AllocatorRef& allocator) {
  FairingTopology topo(allocator);
  topo.vertex_count = static_cast<uint32_t>(vertex_count);
  topo.triangle_count = static_cast<uint32_t>(triangle_count);
  topo.triangle_indices.assign(triangle_indices, triangle_indices + 3 * triangle_count);

  // Vertex → triangles (every triangle, degenerate too: F averages over what is incident).
  topo.incident_offsets.assign(vertex_count + 1, 0);
  for (size_t i = 0; i < 3 * triangle_count; ++i) ++topo.incident_offsets[triangle_indices[i] + 1];
  for (size_t v = 0; v < vertex_count; ++v) topo.incident_offsets[v + 1] += topo.incident_offsets[v];
  topo.incident_triangles.assign(topo.incident_offsets[vertex_count], 0);
  {
    Array<uint32_t> fill(topo.incident_offsets.begin(), topo.incident_offsets.end() - 1,
                         CallbackAllocator<uint32_t>(allocator));
    for (size_t t = 0; t < triangle_count; ++t)
      for (int k = 0; k < 3; ++k) topo.incident_triangles[fill[triangle_indices[3 * t + k]]++] = uint32_t(t);
  }

  // Directed half-edges (v → w, per triangle corner), sorted per vertex: duplicates are the
  // one-ring; an undirected edge seen once (v→w or w→v in one triangle only) is a border.
  Array<uint32_t> half_offsets(vertex_count + 1, 0, CallbackAllocator<uint32_t>(allocator));
  for (size_t t = 0; t < triangle_count; ++t) {
    const uint32_t* tri = triangle_indices + 3 * t;
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) continue;
    for (int k = 0; k < 3; ++k) half_offsets[tri[k] + 1] += 2;
  }
  for (size_t v = 0; v < vertex_count; ++v) half_offsets[v + 1] += half_offsets[v];
  Array<uint32_t> half_targets(half_offsets[vertex_count], 0, CallbackAllocator<uint32_t>(allocator));
  {
    Array<uint32_t> fill(half_offsets.begin(), half_offsets.end() - 1, CallbackAllocator<uint32_t>(allocator));
    for (size_t t = 0; t < triangle_count; ++t) {
      const uint32_t* tri = triangle_indices + 3 * t;
      if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) continue;
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = tri[k];
        half_targets[fill[v]++] = tri[(k + 1) % 3];
        half_targets[fill[v]++] = tri[(k + 2) % 3];
      }
    }
  }
  topo.fixed.assign(vertex_count, 0);
  topo.neighbour_offsets.assign(vertex_count + 1, 0);
  topo.neighbours.reserve(half_targets.size() / 2);
  for (size_t v = 0; v < vertex_count; ++v) {
    uint32_t* begin = half_targets.data() + half_offsets[v];
    uint32_t* end = half_targets.data() + half_offsets[v + 1];
    std::sort(begin, end);
    // Each neighbour w appears once per triangle containing edge vw: once = border edge.
    for (uint32_t* it = begin; it != end;) {
      uint32_t* run = it;
      while (run != end && *run == *it) ++run;
      if (run - it == 1) topo.fixed[v] = 1;
      topo.neighbours.push_back(*it);
      it = run;
    }
    topo.neighbour_offsets[v + 1] = static_cast<uint32_t>(topo.neighbours.size());
    if (begin == end) topo.fixed[v] = 1;  // isolated
  }

  // ν_v = 1 + (1/n_v) Σ_j 1/n_j, the diagonal of U².
  topo.bi_umbrella_diagonal.assign(vertex_count, 0.0f);
  for (size_t v = 0; v < vertex_count; ++v) {
    const uint32_t begin = topo.neighbour_offsets[v], end = topo.neighbour_offsets[v + 1];
    if (topo.fixed[v] || begin == end) continue;
    float inverse_degree_sum = 0.0f;
    for (uint32_t k = begin; k < end; ++k) {
      const uint32_t w = topo.neighbours[k];
      inverse_degree_sum += 1.0f / static_cast<float>(topo.neighbour_offsets[w + 1] - topo.neighbour_offsets[w]);
    }
    topo.bi_umbrella_diagonal[v] = 1.0f + inverse_degree_sum / static_cast<float>(end - begin);
  }
  return topo;
}

FairingWorkspace make_fairing_workspace(const FairingTopology& topology, uint32_t grid_size,
                                        const AllocatorRef& allocator) {
  FairingWorkspace ws(allocator);
  const size_t n = topology.vertex_count;
  ws.vertex_count = topology.vertex_count;
  ws.triangle_count = topology.triangle_count;
  ws.grid_size = grid_size == 0 ? kDefaultGridSize : grid_size;
  const size_t cells = size_t(ws.grid_size) * ws.grid_size * ws.grid_size;
  ws.umbrella.assign(n, glm::vec3(0.0f));
  ws.bi_umbrella.assign(n, glm::vec3(0.0f));
  ws.triangle_force.assign(topology.triangle_count, glm::vec3(0.0f));
  ws.displacement.assign(n, glm::vec3(0.0f));
  ws.start_positions.assign(n, glm::vec3(0.0f));
  ws.smoothing_weight.assign(n, 0.0f);
  ws.tangential_weight.assign(n, 0.0f);
  ws.force_direction.assign(n, glm::vec3(0.0f));
  ws.cell_offsets.assign(cells + 1, 0);
  ws.cell_vertices.assign(n, 0);
  ws.vertex_cell.assign(n, 0);
  ws.cell_x.assign(n + 3, 0.0f);
  ws.cell_y.assign(n + 3, 0.0f);
  ws.cell_z.assign(n + 3, 0.0f);
  ws.cell_rr.assign(n + 3, 0.0f);
  ws.target_umbrella.assign(n, glm::vec3(0.0f));
  ws.target_bi_umbrella.assign(n, glm::vec3(0.0f));
  ws.iteration_start.assign(n, glm::vec3(0.0f));
  ws.minimiser.assign(n, std::numeric_limits<uint32_t>::max());
  ws.next_minimiser.assign(n, std::numeric_limits<uint32_t>::max());
  ws.reference_bi.assign(n, glm::vec3(0.0f));
  ws.bi_reference.assign(n, glm::vec3(0.0f));
  ws.hull_case.assign(topology.triangle_count, kHullCaseUnknown);
  return ws;
}

float fair_run(const FairingTopology& topology, const glm::vec3* skeletal, const float* radius, glm::vec3* positions,
               size_t vertex_count, const FairingParams& params, FairingWorkspace& workspace, const FairingRest* rest,
               const glm::mat3* frames) {
  const uint32_t grid_size = params.grid_size == 0 ? kDefaultGridSize : params.grid_size;
  if (vertex_count != topology.vertex_count || workspace.vertex_count != topology.vertex_count ||
      workspace.triangle_count != topology.triangle_count || grid_size > workspace.grid_size)
    return -1.0f;
  if (vertex_count == 0) return 0.0f;
  const uint32_t iterations = params.iterations == 0 ? kDefaultIterations : params.iterations;
  const float fold = params.fold_step > 0.0f
                         ? params.fold_step
                         : (params.semi_implicit ? kDefaultFoldStepSemiImplicit : kDefaultFoldStepExplicit);
  const float intersect = params.intersection_step > 0.0f ? params.intersection_step : kDefaultIntersectionStep;

  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (size_t v = 0; v < vertex_count; ++v)
    if (finite(positions[v])) lo = glm::min(lo, positions[v]), hi = glm::max(hi, positions[v]);
  const float diagonal = lo.x <= hi.x ? glm::length(hi - lo) : 0.0f;

  workspace.caller_fixed = params.fixed;
  workspace.rest_edge = rest && rest->mean_edge.size() == vertex_count ? rest->mean_edge.data() : nullptr;
  workspace.search_stride = params.search_stride;
  if (params.search_stride > 1) workspace.search_phase = (workspace.search_phase + 1) % params.search_stride;
  Targets targets;
  if (rest && frames) {
    if (rest->umbrella.size() != vertex_count || rest->triangle_level.size() != topology.triangle_count) return -1.0f;
    if (params.smoothing_reference) {
      // U² of the reference surface (the unfaired reconstruction M): smoothing against it
      // smooths the correction x − M itself.
      const glm::vec3* reference_umbrella = params.smoothing_reference_umbrella;
      if (!reference_umbrella) {
        umbrella_pass(topology, params.smoothing_reference, workspace.target_umbrella.data());
        reference_umbrella = workspace.target_umbrella.data();
      }
      umbrella_pass(topology, reference_umbrella, workspace.reference_bi.data());
    }
    for (size_t v = 0; v < vertex_count; ++v) {
      workspace.target_umbrella[v] = frames[v] * rest->umbrella[v];
      workspace.target_bi_umbrella[v] = frames[v] * rest->bi_umbrella[v];
    }
    targets = {workspace.target_umbrella.data(),
               workspace.target_bi_umbrella.data(),
               rest->triangle_level.data(),
               rest->gap.data(),
               params.smoothing_reference ? workspace.reference_bi.data() : nullptr,
               rest->positions.size() == vertex_count ? rest->positions.data() : nullptr,
               rest->skeletal.size() == vertex_count ? rest->skeletal.data() : nullptr};
  }

  Grid grid;
  if (params.intersection_flow)
    grid = build_grid(topology, skeletal, radius, positions, static_cast<int>(grid_size), workspace);

  float residual = 0.0f;
  for (uint32_t iteration = 0; iteration < iterations; ++iteration) {
    std::copy(positions, positions + vertex_count, workspace.iteration_start.begin());
    if (params.fold_flow)
      fold_step(topology, skeletal, radius, positions, fold, params.semi_implicit, targets, workspace);
    if (params.intersection_flow)
      intersection_step(topology, grid, skeletal, radius, positions, intersect, params.semi_implicit, iteration == 0,
                        targets, workspace);
    float moved = 0.0f;  // largest squared motion: one square root at the end
    for (size_t v = 0; v < vertex_count; ++v) {
      const glm::vec3 d = positions[v] - workspace.iteration_start[v];
      const float squared = glm::dot(d, d);
      if (std::isfinite(squared)) moved = std::max(moved, squared);
    }
    residual = diagonal > 0.0f ? std::sqrt(moved) / diagonal : 0.0f;
  }
  return residual;
}

}  // namespace skelform::runtime

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
// fairing_frames with the rest fit, umbrellas and mean edges (fair_stage's call), four
// vertices at a time, lanes = vertices: the positions and their one-ring neighbours gathered
// as vectors and transposed (structure of arrays), then vertex_frame's main branch evaluated
// lane by lane with its operations in its order (so its bits): normal along M − S, tangent
// from the first one-ring edge, the one-ring walked edge by edge in order (a lane whose
// one-ring is done adds +0, which leaves its sums as they are: they start at +0 and can never
// become −0), the rest fit's turn. A lane whose normal or first edge takes a fallback
// (medial radius 0 or not finite, first edge parallel to the normal, no neighbours) is
// recomputed by vertex_frame. Returns the number of vertices done (a multiple of four).
// Measured on CesiumMan_loop2, against one vertex at a time with four of its edges per vector
// (scalar normal, tangent and fit, the edges' terms summed out of the vector one by one):
// ~1.5-3 % less per whole evaluation.
uint32_t lane_frames(const FairingTopology& topology, const glm::vec3* skeletal, const glm::vec3* positions,
                     glm::mat3* frames, const FairingRest& rest, glm::vec3* umbrellas, float* mean_edges) {
  using namespace lane4;
  const uint32_t vertex_count = topology.vertex_count;
  const sse::Vec3Reader read(positions, vertex_count);
  const uint32_t* offsets = topology.neighbour_offsets.data();
  const uint32_t* neighbours = topology.neighbours.data();
  const glm::vec2* then_2d = rest.edge_2d.data();
  const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f), largest = _mm_set1_ps(FLT_MAX);
  const __m128 parallel = _mm_set1_ps(1e-12f), sign = _mm_set1_ps(-0.0f);
  uint32_t v = 0;
  for (; v + 4 <= vertex_count; v += 4) {
    uint32_t begin[4], degree[4], most = 0;
    for (uint32_t i = 0; i < 4; ++i) {
      begin[i] = offsets[v + i];
      degree[i] = offsets[v + i + 1] - begin[i];
      most = std::max(most, degree[i]);
    }
    const __m128i degrees = _mm_loadu_si128(reinterpret_cast<const __m128i*>(degree));
    __m128 px = read(v), py = read(v + 1), pz = read(v + 2), pw = read(v + 3);
    _MM_TRANSPOSE4_PS(px, py, pz, pw);
    __m128 sx = sse::load3(skeletal[v]), sy = sse::load3(skeletal[v + 1]), sz = sse::load3(skeletal[v + 2]),
           sw = sse::load3(skeletal[v + 3]);
    _MM_TRANSPOSE4_PS(sx, sy, sz, sw);
    // The normal: (M − S) · (1 / |M − S|) where that length is > 0 and finite.
    __m128 nx = sub(px, sx), ny = sub(py, sy), nz = sub(pz, sz);
    const __m128 n_length = _mm_sqrt_ps(dot(nx, ny, nz, nx, ny, nz));
    __m128 main = _mm_and_ps(_mm_cmpgt_ps(n_length, zero), _mm_cmple_ps(n_length, largest));
    main = _mm_and_ps(main, _mm_castsi128_ps(_mm_cmpgt_epi32(degrees, _mm_setzero_si128())));
    const __m128 n_inverse = _mm_div_ps(one, n_length);
    nx = mul(nx, n_inverse), ny = mul(ny, n_inverse), nz = mul(nz, n_inverse);
    // The tangent from the first one-ring edge (a lane without neighbours reads its own vertex).
    __m128 qx = read(degree[0] ? neighbours[begin[0]] : v), qy = read(degree[1] ? neighbours[begin[1]] : v + 1),
           qz = read(degree[2] ? neighbours[begin[2]] : v + 2), qw = read(degree[3] ? neighbours[begin[3]] : v + 3);
    _MM_TRANSPOSE4_PS(qx, qy, qz, qw);
    const __m128 ex = sub(qx, px), ey = sub(qy, py), ez = sub(qz, pz);
    const __m128 e_dot_n = dot(ex, ey, ez, nx, ny, nz);
    __m128 tx = sub(ex, mul(e_dot_n, nx)), ty = sub(ey, mul(e_dot_n, ny)), tz = sub(ez, mul(e_dot_n, nz));
    const __m128 t2 = dot(tx, ty, tz, tx, ty, tz);
    main = _mm_and_ps(
        main, _mm_and_ps(_mm_cmpgt_ps(t2, mul(parallel, dot(ex, ey, ez, ex, ey, ez))), _mm_cmple_ps(t2, largest)));
    const __m128 t_inverse = _mm_div_ps(one, _mm_sqrt_ps(t2));
    tx = mul(tx, t_inverse), ty = mul(ty, t_inverse), tz = mul(tz, t_inverse);
    // glm::cross(normal, tangent).
    __m128 bx = sub(mul(ny, tz), mul(ty, nz)), by = sub(mul(nz, tx), mul(tz, nx)), bz = sub(mul(nx, ty), mul(tx, ny));
    // The one-rings side by side, edge j of every lane at step j.
    __m128 sum_x = zero, sum_y = zero, sum_z = zero, edge_sum = zero, dot_sum = zero, cross_sum = zero;
    for (uint32_t j = 0; j < most; ++j) {
      const __m128 live = _mm_castsi128_ps(_mm_cmpgt_epi32(degrees, _mm_set1_epi32(static_cast<int>(j))));
      __m128 q[4], then[4];
      for (uint32_t i = 0; i < 4; ++i) {
        const bool in_ring = j < degree[i];
        const uint32_t k = in_ring ? begin[i] + j : 0;
        q[i] = read(in_ring ? neighbours[k] : v + i);
        then[i] = _mm_loadl_pi(zero, reinterpret_cast<const __m64*>(&then_2d[k].x));
      }
      _MM_TRANSPOSE4_PS(q[0], q[1], q[2], q[3]);
      const __m128 then_01 = _mm_unpacklo_ps(then[0], then[1]), then_23 = _mm_unpacklo_ps(then[2], then[3]);
      const __m128 then_x = _mm_movelh_ps(then_01, then_23), then_y = _mm_movehl_ps(then_23, then_01);
      const __m128 dx = sub(q[0], px), dy = sub(q[1], py), dz = sub(q[2], pz);
      const __m128 now_x = dot(dx, dy, dz, tx, ty, tz), now_y = dot(dx, dy, dz, bx, by, bz);
      sum_x = add(sum_x, _mm_and_ps(live, q[0]));
      sum_y = add(sum_y, _mm_and_ps(live, q[1]));
      sum_z = add(sum_z, _mm_and_ps(live, q[2]));
      edge_sum = add(edge_sum, _mm_and_ps(live, _mm_sqrt_ps(dot(dx, dy, dz, dx, dy, dz))));
      dot_sum = add(dot_sum, _mm_and_ps(live, add(mul(then_x, now_x), mul(then_y, now_y))));
      cross_sum = add(cross_sum, _mm_and_ps(live, sub(mul(then_x, now_y), mul(then_y, now_x))));
    }
    const __m128 count = _mm_cvtepi32_ps(degrees);
    __m128 ux = sub(_mm_div_ps(sum_x, count), px), uy = sub(_mm_div_ps(sum_y, count), py),
           uz = sub(_mm_div_ps(sum_z, count), pz), uw = zero;
    const __m128 mean_edge = _mm_div_ps(edge_sum, count);
    // The rest fit's turn of tangent and bitangent where |(dot, cross)| is > 0 and finite.
    const __m128 fit = _mm_sqrt_ps(add(mul(dot_sum, dot_sum), mul(cross_sum, cross_sum)));
    const __m128 turn = _mm_and_ps(_mm_cmpgt_ps(fit, zero), _mm_cmple_ps(fit, largest));
    const __m128 fit_inverse = _mm_div_ps(one, fit);
    const __m128 c = mul(dot_sum, fit_inverse), s = mul(cross_sum, fit_inverse), minus_s = _mm_xor_ps(s, sign);
    const __m128 turned_x = add(mul(c, tx), mul(s, bx)), turned_y = add(mul(c, ty), mul(s, by)),
                 turned_z = add(mul(c, tz), mul(s, bz));
    bx = select(turn, add(mul(minus_s, tx), mul(c, bx)), bx);
    by = select(turn, add(mul(minus_s, ty), mul(c, by)), by);
    bz = select(turn, add(mul(minus_s, tz), mul(c, bz)), bz);
    tx = select(turn, turned_x, tx), ty = select(turn, turned_y, ty), tz = select(turn, turned_z, tz);
    // Back to one frame (columns tangent, bitangent, normal: 9 floats), one umbrella and one
    // mean edge per vertex.
    __m128 head_x = tx, head_y = ty, head_z = tz, head_w = bx;  // per vertex: t.x t.y t.z b.x
    _MM_TRANSPOSE4_PS(head_x, head_y, head_z, head_w);
    __m128 mid_x = by, mid_y = bz, mid_z = nx, mid_w = ny;  // per vertex: b.y b.z n.x n.y
    _MM_TRANSPOSE4_PS(mid_x, mid_y, mid_z, mid_w);
    alignas(16) float last[4];  // n.z
    _mm_store_ps(last, nz);
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
    const int fallback = ~_mm_movemask_ps(main) & 0xf;
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
  FairingRest rest(allocator);
  const uint32_t n = topology.vertex_count;
  Array<glm::mat3> frames(n, glm::mat3(1.0f), CallbackAllocator<glm::mat3>(allocator));
  fairing_frames(topology, skeletal, positions, frames.data());
  compute_umbrellas(topology, positions, Targets{}, ws);
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
  const int size = static_cast<int>(grid_size == 0 ? kDefaultGridSize : std::min(grid_size, ws.grid_size));
  const Grid grid = build_grid(topology, skeletal, radius, positions, size, ws);
  for (uint32_t v = 0; v < n; ++v) {
    if (topology.fixed[v]) continue;
    const FieldValue field = field_at(grid, positions[v], ws);
    if (field.minimiser == std::numeric_limits<uint32_t>::max()) continue;
    if (field.minimiser != v) {
      const glm::vec3 d = positions[v] - skeletal[v];
      rest.gap[v] = std::fabs(field.f - (glm::dot(d, d) - radius[v] * radius[v]));
    }
  }
  return rest;
}

}  // namespace skelform::runtime
