// Runtime step 3 (DESIGN.md "Fair"): the paper's mesh evolutions on the reconstructed control
// mesh M — flow (4) removes folds and protrusions (sec. 3.1), flow (5) removes global and local
// self-intersections (sec. 3.2).
//
// Usage: once per asset, build_fairing_topology() from the control triangles; once per
// instance, make_fairing_workspace(); every evaluation, fair_run() between reconstruction and
// refinement. fair_run() allocates nothing, throws nothing and touches no global state; the
// topology is read-only (shareable across threads), the workspace is the instance's own.
// Deterministic: the same input gives bit-identical output (single thread, fixed order).
//
// Units: whatever the asset's positions are in. Every step is dimensionless or normalised so
// that scaling the input by s scales the output by s (up to float rounding): flow (4) is a
// length per unit time already; flow (5)'s f∇f (length³) is divided per vertex by |∇f|²
// (see FairingParams::intersection_step).
//
// Open borders: vertices on an edge with one incident triangle (and vertices no triangle
// uses) are kept fixed by both flows.
#pragma once

#include "memory.h"

#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>

namespace skelform::runtime {

// Connectivity of the control mesh, built once per asset; immutable afterwards.
struct FairingTopology {
  explicit FairingTopology(const AllocatorRef& a)
      : triangle_indices(a),
        neighbour_offsets(a),
        neighbours(a),
        incident_offsets(a),
        incident_triangles(a),
        fixed(a),
        bi_umbrella_diagonal(a) {}

  uint32_t vertex_count = 0;
  uint32_t triangle_count = 0;
  Array<uint32_t> triangle_indices;    // 3 per triangle, copied from the asset
  Array<uint32_t> neighbour_offsets;   // vertex_count + 1: one-ring of v is neighbours[o[v] .. o[v+1])
  Array<uint32_t> neighbours;          // each neighbour once, ascending
  Array<uint32_t> incident_offsets;    // vertex_count + 1: triangles around v (CSR)
  Array<uint32_t> incident_triangles;  // ascending triangle indices
  Array<uint8_t> fixed;                // 1 = open-border or isolated vertex: never moved
  // ν_v = 1 + (1/n_v) Σ_j 1/n_j: the diagonal of the bi-umbrella U² (Kobbelt et al. 1998),
  // the semi-implicit solve's pivot. 0 for fixed vertices.
  Array<float> bi_umbrella_diagonal;
};

// CSR one-rings, vertex→triangle incidence and border flags of the triangles
// `triangle_indices` (3 × triangle_count, each < vertex_count; unchecked: the asset loader
// validated them). Degenerate triangles (a repeated index) are ignored for the one-rings.
// Allocates through `allocator`; throws std::bad_alloc when it fails (callers at the C API
// catch it).
FairingTopology build_fairing_topology(const uint32_t* triangle_indices, size_t triangle_count, size_t vertex_count,
                                       const AllocatorRef& allocator);

// Default dimensionless steps (FairingParams: 0 = these).
constexpr float kDefaultFoldStepExplicit = 0.2f;
constexpr float kDefaultFoldStepSemiImplicit = 0.5f;
constexpr float kDefaultIntersectionStep = 0.15f;

// Parameters of one fair_run(). Zero means the documented default (so a zero-initialised
// struct is the recommended setting), except the two booleans.
struct FairingParams {
  bool fold_flow = true;          // run flow (4) (sec. 3.1)
  bool intersection_flow = true;  // run flow (5) (sec. 3.2)
  // Explicit (false, the paper's scheme) or semi-implicit bilaplacian (true: the paper's sec. 5
  // suggestion after Desbrun et al. [11]). See fair_operators.cpp for what each solves.
  bool semi_implicit = false;
  // Iterations; each is one step of flow (4) followed by one step of flow (5). 0 = 30.
  uint32_t iterations = 0;
  // τ₄, the dimensionless time step of flow (4). The bilaplacian part is stable for
  // τ₄ (α + 1) λ_max(U²) < 2 with λ_max(U²) ≤ 4; F alone moves a vertex τ₄·E toward the
  // envelope. 0 = 0.2 (explicit) / 0.5 (semi-implicit).
  float fold_step = 0.0f;
  // τ₅, the dimensionless time step of flow (5): each step moves a vertex by
  // τ₅ · f∇f / max(|∇f|², 4 d*²) (a Gauss-Newton step toward f = 0, which a plain f∇f step
  // with length³ units is not) plus τ₅ · W U²; relative to rest (FairingRest), h∇h / max(|∇h|²,
  // 4 e²) with the penetration h of fair_intersection.cpp and e the rest edge length. 0 = 0.15.
  float intersection_step = 0.0f;
  // Cells per axis of flow (5)'s grid over the bounding box of skeleton and mesh. 0 = 20
  // (the paper's 20×20×20). Must not exceed the workspace's grid_size.
  uint32_t grid_size = 0;
  // Flow (5)'s grid search per vertex: 0 or 1 = every call (the paper); K > 1 = each vertex
  // searches the grid at one call in K (staggered by vertex index) and otherwise tracks its
  // minimiser among its own, its last and its neighbours' last minimising balls. For
  // warm-started runs, where the field changes little between calls.
  uint32_t search_stride = 0;
  // With FairingRest and explicit steps: a surface indexed like the positions (normally the
  // unfaired reconstruction M). Flow (4)'s α term and flow (5)'s W term then smooth the
  // correction x − M (their bilaplacian is taken relative to the reference's), while V keeps
  // restoring the rest shape along the surface. Null: every bilaplacian relative to the rest
  // shape turned by the local frames.
  const glm::vec3* smoothing_reference = nullptr;
  // Optional: U(smoothing_reference) per vertex, when the caller has it already (saves a pass).
  const glm::vec3* smoothing_reference_umbrella = nullptr;
  // Optional, per vertex: non-zero = keep this vertex where it is (e.g. the handle driver's
  // pinned vertices), in addition to open borders. Null = none.
  const uint8_t* fixed = nullptr;
};

// Every buffer fair_run() needs, sized once for a topology and a grid resolution. Per instance.
struct FairingWorkspace {
  explicit FairingWorkspace(const AllocatorRef& a)
      : umbrella(a),
        bi_umbrella(a),
        triangle_force(a),
        displacement(a),
        start_positions(a),
        smoothing_weight(a),
        tangential_weight(a),
        force_direction(a),
        cell_offsets(a),
        cell_vertices(a),
        vertex_cell(a),
        cell_x(a),
        cell_y(a),
        cell_z(a),
        cell_rr(a),
        row_rr_max(a),
        layer_rr_max(a),
        target_umbrella(a),
        target_bi_umbrella(a),
        iteration_start(a),
        minimiser(a),
        next_minimiser(a),
        reference_bi(a),
        bi_reference(a),
        hull_case(a),
        fixed_mask(a),
        active(a),
        ring(a),
        active_triangles(a),
        free_triangle(a),
        ring_mark(a) {}

  uint32_t vertex_count = 0;
  uint32_t triangle_count = 0;
  uint32_t grid_size = 0;            // largest FairingParams::grid_size this workspace serves
  Array<glm::vec3> umbrella;         // U(p) per vertex
  Array<glm::vec3> bi_umbrella;      // U²(p) per vertex
  Array<glm::vec3> triangle_force;   // E_T(C)·∇E_T(C) per triangle (flow (4)'s F terms)
  Array<glm::vec3> displacement;     // explicit part of one step, per vertex
  Array<glm::vec3> start_positions;  // positions before the step (semi-implicit right side)
  Array<float> smoothing_weight;     // α (flow 4) or W (flow 5) per vertex
  Array<float> tangential_weight;    // flow (4)'s weight of V per vertex
  Array<glm::vec3> force_direction;  // F/|F| per vertex (flow 4), 0 where F = 0
  Array<uint32_t> cell_offsets;      // grid_size³ + 2: skeletal vertices per cell (CSR in the
                                     // first grid_size³ + 1; a row of cells along x is one run
                                     // of slots; the last is build_grid's scratch)
  Array<uint32_t> cell_vertices;     // vertex_count
  Array<uint32_t> vertex_cell;       // vertex_count: scratch for the bucket sort
  // S and d² of cell_vertices[k] at k (vertex_count + 3: flow (5)'s search reads 4 at a time)
  Array<float> cell_x, cell_y, cell_z, cell_rr;
  Array<float> row_rr_max;                // grid_size²: the largest d² per row of cells along x (-inf where empty)
  Array<float> layer_rr_max;              // grid_size: the largest d² per layer of cells in z (-inf where empty)
  Array<glm::vec3> target_umbrella;       // rest U turned into this evaluation's frames (FairingRest)
  Array<glm::vec3> target_bi_umbrella;    // rest U², likewise
  Array<glm::vec3> iteration_start;       // positions before the last iteration (its net motion)
  const uint8_t* caller_fixed = nullptr;  // FairingParams::fixed of the current run
  Array<uint32_t> minimiser;              // flow (5)'s minimising skeletal vertex per vertex
  Array<uint32_t> next_minimiser;         // tracked minimisers of this call (then moved to minimiser)
  uint32_t search_stride = 0;             // FairingParams::search_stride of the current run
  uint32_t search_phase = 0;              // which vertices search the grid at this call
  Array<glm::vec3> reference_bi;          // U² of FairingParams::smoothing_reference
  Array<glm::vec3> bi_reference;          // U²(x) − reference_bi
  const float* rest_edge = nullptr;       // FairingRest::mean_edge of the current run, or null
  Array<uint8_t> hull_case;               // per triangle: ball_hull_distance's hint (kHullCase*)
  // The run's active set (fair_run: update_active_set). Only free vertices move, and a free
  // vertex's step reads U at its one-ring and E_T at its triangles, so each pass covers only
  // what the free vertices need: `active` the free vertices, `ring` those and their one-rings
  // (where U is needed), `active_triangles` the triangles with a free corner (F's terms), each
  // ascending; nothing reads the scratch of a fixed vertex but flow (5)'s tracking, which reads
  // the minimisers of a free vertex's neighbours (a fixed vertex's is forgotten). Rebuilt when
  // the fixed vertices change (the handle driver's pinned region, the skin driver's quiet
  // vertices: at every evaluation), which also clears the E_T hints of the triangles that gain
  // a free corner (hull_case: the passes skipped them, so their hints are stale).
  Array<uint8_t> fixed_mask;                       // vertex_count: is_fixed() of the lists' run; 2 = not built yet
  Array<uint32_t> active, ring, active_triangles;  // vertex_count, vertex_count, triangle_count
  Array<uint8_t> free_triangle;                    // triangle_count: has a free corner in the lists' run
  uint32_t active_count = 0, ring_count = 0, active_triangle_count = 0;
  Array<uint8_t> ring_mark;  // vertex_count: scratch of the rebuild
  // For tests: `ring` and `active_triangles` cover the whole mesh, as every pass did before the
  // active set. The result must be the same bits.
  bool whole_passes = false;
};

// The flows measured from the rest pose (a departure from the paper, DESIGN.md notes): on a
// real control mesh the rest surface is not a fixed point of (4) and (5) — its umbrellas are
// not zero, its triangle centroids are not on the envelope of the medial balls and its
// vertices sit slightly inside neighbouring balls — so the plain flows would reshape an
// undeformed character. Each term is therefore taken relative to its rest value: the
// bilaplacian and umbrella vectors minus the rest ones carried by the vertex's local frame
// (V weighted down where the medial radius is below 3 mean edge lengths: fair_fold.cpp fold_step),
// E_T minus the centroid's rest E_T, the power difference to the nearest other ball never
// below its rest value for that ball, nor below a margin of 0.75 rest edge lengths (or medial
// radii, if smaller) where it was farther at rest (flow (5) then pushes towards the own side of
// the radical plane: fair_intersection.cpp), |f − g| less its rest value. At rest every force is zero; away
// from rest the flows act as the paper's on what the pose changed. Built once per asset by make_fairing_rest().
struct FairingRest {
  explicit FairingRest(const AllocatorRef& a)
      : umbrella(a), bi_umbrella(a), triangle_level(a), gap(a), edge_2d(a), mean_edge(a), positions(a), skeletal(a) {}
  Array<glm::vec3> umbrella;     // U(M_rest) per vertex, in its rest local frame (fairing_frames)
  Array<glm::vec3> bi_umbrella;  // U²(M_rest) per vertex, in its rest local frame
  Array<float> triangle_level;   // E_T(C) of every triangle at rest
  Array<float> gap;              // |f − g|(M_rest) per vertex (flow (5)'s W numerator)
  Array<glm::vec2> edge_2d;      // per one-ring entry (topology.neighbours): the rest edge in its
                                 // vertex's rest frame (tangent, bitangent components)
  Array<float> mean_edge;        // mean one-ring edge length per vertex at rest
  Array<glm::vec3> positions;    // M_rest and S_rest: flow (5) compares a vertex's power
  Array<glm::vec3> skeletal;     // difference to any ball with its rest value
};

// Orthonormal frame (columns: tangent, bitangent, normal) per vertex of the control mesh: the
// normal along M − S (the reconstruction direction; the area-weighted normal where the
// medial radius is 0), the tangent along the first one-ring edge made orthogonal to it. It
// turns with the surface, so rest vectors stored in it follow a pose. With `rest`, the
// tangent is then turned about the normal by the angle that best aligns the one-ring's
// edges with their rest directions (a 2D Procrustes fit), so a sheared one-ring (a blend
// zone) does not turn the frame with its first edge alone.
// Optionally, from the same pass over the one-rings: `umbrellas` U(positions) per vertex
// (mean of the one-ring − p, exactly as the fairing computes it) and `mean_edges` the mean
// one-ring edge length per vertex (0 without neighbours); either may be null.
void fairing_frames(const FairingTopology& topology, const glm::vec3* skeletal, const glm::vec3* positions,
                    glm::mat3* frames, const struct FairingRest* rest = nullptr, glm::vec3* umbrellas = nullptr,
                    float* mean_edges = nullptr);

// Rest targets of `topology` from the rest control mesh, skeletal mesh and radii. Allocates
// (std::bad_alloc on failure); `workspace` is scratch.
FairingRest make_fairing_rest(const FairingTopology& topology, const glm::vec3* skeletal, const float* radius,
                              const glm::vec3* positions, uint32_t grid_size, FairingWorkspace& workspace,
                              const AllocatorRef& allocator);

// Allocates a workspace for `topology` and grids of up to `grid_size` cells per axis
// (0 = 20). Throws std::bad_alloc when the allocator fails.
FairingWorkspace make_fairing_workspace(const FairingTopology& topology, uint32_t grid_size,
                                        const AllocatorRef& allocator);

// Runs params.iterations fairing iterations on the control mesh `positions` (in/out), each
// one step of flow (4) then one step of flow (5) — interleaved rather than (4) to convergence
// then (5), because the runtime warm-starts from the previous frame with a small per-frame
// budget: a budget spent on (4) alone would never reach (5) while a pose keeps moving.
// `skeletal` (S', the deformed skeletal mesh) and `radius` (d, the medial radii) are indexed
// like `positions`; vertex_count must equal topology.vertex_count and the workspace must have
// been made for this topology (otherwise nothing moves and the result is -1).
// Returns the residual of the last iteration: the largest net vertex motion over it (flow
// (4)'s step and flow (5)'s together: where they balance, nothing moves) divided by the
// bounding-box diagonal of the mesh; a caller may stop iterating once it is below ~1e-4.
// Non-finite input vertices are left where they are and never spread NaN to their neighbours'
// results beyond their own one-ring (their forces are skipped).
// With `rest` and `frames` (this evaluation's fairing_frames of the reconstruction), every
// term is relative to the rest pose (FairingRest); without them (null), the paper's flows.
float fair_run(const FairingTopology& topology, const glm::vec3* skeletal, const float* radius, glm::vec3* positions,
               size_t vertex_count, const FairingParams& params, FairingWorkspace& workspace,
               const FairingRest* rest = nullptr, const glm::mat3* frames = nullptr);

// E_T(P) of flow (4) and its gradient: the signed distance from `point` to the convex hull of
// the three balls (centres[i], radii[i]) — E_T(P) = min over barycentric b of
// |P − c(b)| − r(b), with c(b) = Σ b_i c_i, r(b) = Σ b_i r_i (DESIGN.md math notes) — and
// ∇E_T = (P − c(b*)) / |P − c(b*)| by the envelope theorem. Negative inside the hull.
// Finite for every finite input (degenerate triangle, coincident centres, one ball containing
// the others). In the tangent-plane case the gradient is that plane's unit normal (also for P
// in the skeletal triangle); on an edge or a vertex it is 0 where P = c(b*) exactly.
// Evaluated in float, with a relative degeneracy test for thin triangles (ball_hull.cpp).
struct HullDistance {
  float value = 0.0f;
  glm::vec3 gradient{0.0f};
};
//
// `hint` (optional, one byte per triangle kept across calls): which candidate won last time
// (kHullCase*). When the tangent-plane (interior) case does not hold, that edge or vertex is
// tried before the full boundary search and accepted only if it satisfies the KKT conditions
// of the convex minimisation, i.e. only if it is the minimum; otherwise the full search runs.
// Either way the result is the minimum, but reached through the hint it can differ from the
// full search's in the last bits, so a run's bits depend on its hints (fair_stage clears them
// at a fresh start, fair_run when the fixed vertices change); the hint saves time when the
// foot stays on the same edge or vertex from call to call. Updated on return.
constexpr uint8_t kHullCaseUnknown = 0;
constexpr uint8_t kHullCaseInterior = 1;
constexpr uint8_t kHullCaseVertex = 2;  // + i for ball i; kHullCaseVertex + 3 + i for edge (i, i+1)
HullDistance ball_hull_distance(const glm::vec3& point, const glm::vec3* centres, const float* radii,
                                uint8_t* hint = nullptr);

}  // namespace skelform::runtime
