// What the fairing's source files share (fair.h is their interface): the tuning constants,
// the rest targets of one run, the umbrella operators evaluated inside the flows' per-vertex
// loops (inline here, so every hot loop keeps them inlined), and the steps each file
// provides to fair_run() (fair.cpp).
//
// Discretisation (DESIGN.md math notes):
//   Δ²M ≈ U²(p) = mean_j U(q_j) − U(p), U(p) = mean_j q_j − p (Kobbelt et al. [17]), uniform
//   weights; −U² smooths (it decreases Σ|U|², tested).
//   Flow (4): ∂M/∂t = −αΔ²M − F − V, with α ∈ {0.25, 0} by the obtuse-umbrella rule,
//     F(M) = (1/n) Σ_j E_{T_j}(C_j) ∇E_{T_j}(C_j), V = Δ²M − (Δ²M·F̂) F̂ (fair_fold.cpp).
//   Flow (5): ∂M/∂t = −f∇f − WΔ²M, g(x, S) = |x − S|² − d_S², f from the voxel grid,
//     W = |f − g| / max|f − g| (fair_intersection.cpp).
// Both are stepped explicitly (the paper's scheme) or semi-implicitly (fair_operators.cpp).
#pragma once

#include "fair.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>

namespace skelform::runtime::fair_detail {

constexpr uint32_t kDefaultIterations = 30;
constexpr float kAlphaSmooth = 0.25f;      // α of flow (4) where the umbrellas agree
constexpr float kObtuseFraction = 0.3f;    // the paper's 30 % rule
constexpr uint32_t kDefaultGridSize = 20;  // the paper's 20×20×20 voxels
constexpr int kGaussSeidelSweeps = 3;
// A vertex moves at most this many times its mean incident edge length per step: a safety net
// against a far-off vertex overshooting (scale-free, so scale invariance is kept).
constexpr float kMaxStepPerEdge = 0.5f;
// Relative to rest, flow (4)'s V has its full weight where the medial radius is at least this
// many rest mean edge lengths, and d / (kRestShapeRadius e) below (fair_fold.cpp).
constexpr float kRestShapeRadius = 3.0f;
// Flow (5) relative to rest keeps a vertex this many rest mean edge lengths (or medial radii,
// if smaller) on its own side of the radical plane with any ball it was farther from at rest
// (intersection_step).
constexpr float kIntersectionMargin = 0.75f;

// The forms of fairing_frames' pass (fair_frames.cpp), for the tests that compare them: each
// gives the portable loop's bits. `avx2` runs eight vertices at a time, then four, then one;
// `sse2` four, then one.
enum class FrameKernel { portable, sse2, avx2 };
bool frame_kernel_available(FrameKernel kernel);
// fairing_frames in the given form (one not available on this CPU or build: the portable one).
void fairing_frames_with(FrameKernel kernel, const FairingTopology& topology, const glm::vec3* skeletal,
                         const glm::vec3* positions, glm::mat3* frames, const FairingRest* rest, glm::vec3* umbrellas,
                         float* mean_edges);

inline bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

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
inline bool is_fixed(const FairingTopology& topo, const FairingWorkspace& ws, uint32_t v) {
  return topo.fixed[v] || (ws.caller_fixed && ws.caller_fixed[v]);
}

// The vertices a pass covers: list[0 .. count), or 0 .. count − 1 when list is null (the whole
// mesh).
struct VertexSet {
  const uint32_t* list = nullptr;
  uint32_t count = 0;
  uint32_t operator[](uint32_t i) const { return list ? list[i] : i; }
};
inline VertexSet all_vertices(const FairingTopology& topo) { return {nullptr, topo.vertex_count}; }
// The run's free vertices, and those with their one-rings (FairingWorkspace: the active set).
inline VertexSet free_vertices(const FairingWorkspace& ws) { return {ws.active.data(), ws.active_count}; }
inline VertexSet ring_vertices(const FairingWorkspace& ws) { return {ws.ring.data(), ws.ring_count}; }

// U(p) = mean of the one-ring − p; 0 for a vertex without neighbours.
inline glm::vec3 umbrella_at(const FairingTopology& topo, const glm::vec3* x, uint32_t v) {
  const uint32_t begin = topo.neighbour_offsets[v], end = topo.neighbour_offsets[v + 1];
  if (begin == end) return glm::vec3(0.0f);
  glm::vec3 sum(0.0f);
  for (uint32_t k = begin; k < end; ++k) sum += x[topo.neighbours[k]];
  return sum / static_cast<float>(end - begin) - x[v];
}

// U²(p) = mean_j U(q_j) − U(p) evaluated from the positions as they are now (for the
// in-place Gauss-Seidel sweeps, which cannot use a precomputed U).
inline glm::vec3 bi_umbrella_at(const FairingTopology& topo, const glm::vec3* x, uint32_t v) {
  const uint32_t begin = topo.neighbour_offsets[v], end = topo.neighbour_offsets[v + 1];
  if (begin == end) return glm::vec3(0.0f);
  glm::vec3 sum(0.0f);
  for (uint32_t k = begin; k < end; ++k) sum += umbrella_at(topo, x, topo.neighbours[k]);
  return sum / static_cast<float>(end - begin) - umbrella_at(topo, x, v);
}

inline float mean_edge_length(const FairingTopology& topo, const glm::vec3* x, uint32_t v) {
  const uint32_t begin = topo.neighbour_offsets[v], end = topo.neighbour_offsets[v + 1];
  if (begin == end) return 0.0f;
  float sum = 0.0f;
  for (uint32_t k = begin; k < end; ++k) sum += glm::length(x[topo.neighbours[k]] - x[v]);
  return sum / static_cast<float>(end - begin);
}

// The vertex's mean edge length: at rest when the run has rest values (a constant scale for
// the step limit and the thresholds; scale-covariant like the current one), else now.
inline float edge_scale(const FairingTopology& topo, const glm::vec3* x, const FairingWorkspace& ws, uint32_t v) {
  return ws.rest_edge ? ws.rest_edge[v] : mean_edge_length(topo, x, v);
}

// ---- fair_operators.cpp: the umbrella passes and the two ways of stepping -----------------

// umbrella_at of each vertex of `vertices` into `out` (not aliasing x), with umbrella_at's bits.
void umbrella_pass(const FairingTopology& topo, const glm::vec3* x, glm::vec3* out, VertexSet vertices);

// U of x at `ring` into ws.umbrella and U² at `vertices` into ws.bi_umbrella (`ring` holds
// `vertices` and their one-rings), relative to the targets when there are any (and U²
// relative to the smoothing reference's into ws.bi_reference).
void compute_umbrellas(const FairingTopology& topo, const glm::vec3* x, const Targets& targets, VertexSet vertices,
                       VertexSet ring, FairingWorkspace& ws);

// Moves every free vertex by ws.displacement, each shortened to kMaxStepPerEdge of its mean
// edge length measured before anything moves (so the result does not depend on vertex
// order). A non-finite displacement moves nothing. Reads the run's active set.
void apply_displacements(const FairingTopology& topo, glm::vec3* x, FairingWorkspace& ws);

// Semi-implicit step: solves x' + τ B_v U²(x') = rhs (rhs in ws.start_positions) in place,
// then turns x' − x into ws.displacement and applies it like an explicit step.
// `tangential_weights`: V's weight b per vertex (null: 0, flow (5) has no V).
void implicit_update(const FairingTopology& topo, glm::vec3* x, float step, const float* tangential_weights,
                     const Targets& targets, FairingWorkspace& ws);

// ---- fair_fold.cpp: flow (4) ----------------------------------------------------------------

// One step of flow (4).
void fold_step(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, glm::vec3* x, float step,
               bool semi_implicit, const Targets& targets, FairingWorkspace& ws);

// ---- fair_intersection.cpp: flow (5) ----------------------------------------------------------

// Flow (5)'s voxel grid over the bounding box of skeleton and mesh (its cells' balls are in the
// workspace).
struct Grid {
  glm::vec3 origin{0.0f};
  glm::vec3 cell{1.0f};  // cell size per axis
  glm::vec3 inverse_cell{1.0f};
  int size = 1;             // cells per axis
  int ring[3] = {1, 1, 1};  // ⌈max d / cell⌉ per axis, at least 1 (the paper's 3×3×3)
  float max_radius = 0.0f;  // largest d
  float max_rr = 0.0f;      // largest d² in the grid
};

// Buckets the skeletal vertices into a grid of size³ cells over the bounding box of skeleton
// and mesh.
Grid build_grid(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, const glm::vec3* x,
                int size, FairingWorkspace& ws);

// One step of flow (5). `refresh_field`: search the grid for each vertex's minimising ball
// (the first iteration of a run); otherwise follow the one found then.
void intersection_step(const FairingTopology& topo, const Grid& grid, const glm::vec3* skeletal, const float* radius,
                       glm::vec3* x, float step, bool semi_implicit, bool refresh_field, const Targets& targets,
                       FairingWorkspace& ws);

// f(x) as flow (5)'s grid search finds it (for tests): the smallest g(x, S) = |x − S|² − d_S²
// over the balls in the cells within grid.ring of x's cell (further out only when those hold
// none) other than skeletal vertex `exclude` (UINT32_MAX: none), the smaller index on a tie;
// its ball in `minimiser` (UINT32_MAX and +inf when there is none).
float grid_field(const Grid& grid, const glm::vec3& x, const FairingWorkspace& ws, uint32_t exclude,
                 uint32_t& minimiser);

// FairingRest::gap: |f − g|(M_rest) per vertex into `gap` (zeroed by the caller), on a grid of
// `size` cells per axis; left 0 where the own ball is the minimiser, at fixed vertices and
// where no ball was found.
void rest_gaps(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, const glm::vec3* x,
               int size, FairingWorkspace& ws, float* gap);

}  // namespace skelform::runtime::fair_detail
