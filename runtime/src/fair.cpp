// Runtime step 3: the paper's fairing flows (4) and (5) (sec. 3.1, 3.2) on the control mesh —
// the control mesh's connectivity (build_fairing_topology), the per-instance workspace and
// fair_run(), which interleaves one step of each flow per iteration. The flows themselves are
// in fair_fold.cpp (4) and fair_intersection.cpp (5), their operators and stepping in
// fair_operators.cpp, E_T in ball_hull.cpp, the local frames and rest targets in
// fair_frames.cpp; fair_internal.h is what they share.
#include "fair.h"
#include "fair_internal.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace skelform::runtime {

namespace {

// Vertex → triangles (every triangle, degenerate too: F averages over what is incident).
void add_incidence(FairingTopology& topo, const uint32_t* triangle_indices, size_t triangle_count, size_t vertex_count,
                   const AllocatorRef& allocator) {
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
}

// The one-rings (ascending, each neighbour once) and the border flags. Directed half-edges
// (v → w, per triangle corner), sorted per vertex: duplicates are the one-ring; an undirected
// edge seen once (v→w or w→v in one triangle only) is a border.
void add_one_rings(FairingTopology& topo, const uint32_t* triangle_indices, size_t triangle_count, size_t vertex_count,
                   const AllocatorRef& allocator) {
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
}

// ν_v = 1 + (1/n_v) Σ_j 1/n_j, the diagonal of U².
void add_bi_umbrella_diagonal(FairingTopology& topo, size_t vertex_count) {
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
}

}  // namespace

FairingTopology build_fairing_topology(const uint32_t* triangle_indices, size_t triangle_count, size_t vertex_count,
                                       const AllocatorRef& allocator) {
  FairingTopology topo(allocator);
  topo.vertex_count = static_cast<uint32_t>(vertex_count);
  topo.triangle_count = static_cast<uint32_t>(triangle_count);
  topo.triangle_indices.assign(triangle_indices, triangle_indices + 3 * triangle_count);
  add_incidence(topo, triangle_indices, triangle_count, vertex_count, allocator);
  add_one_rings(topo, triangle_indices, triangle_count, vertex_count, allocator);
  add_bi_umbrella_diagonal(topo, vertex_count);
  return topo;
}

FairingWorkspace make_fairing_workspace(const FairingTopology& topology, uint32_t grid_size,
                                        const AllocatorRef& allocator) {
  using fair_detail::kDefaultGridSize;
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
  ws.cell_offsets.assign(cells + 2, 0);
  ws.cell_vertices.assign(n, 0);
  ws.vertex_cell.assign(n, 0);
  ws.cell_x.assign(n + 3, 0.0f);
  ws.cell_y.assign(n + 3, 0.0f);
  ws.cell_z.assign(n + 3, 0.0f);
  ws.cell_rr.assign(n + 3, 0.0f);
  ws.row_rr_max.assign(size_t(ws.grid_size) * ws.grid_size, -std::numeric_limits<float>::infinity());
  ws.layer_rr_max.assign(ws.grid_size, -std::numeric_limits<float>::infinity());
  ws.target_umbrella.assign(n, glm::vec3(0.0f));
  ws.target_bi_umbrella.assign(n, glm::vec3(0.0f));
  ws.iteration_start.assign(n, glm::vec3(0.0f));
  ws.minimiser.assign(n, std::numeric_limits<uint32_t>::max());
  ws.next_minimiser.assign(n, std::numeric_limits<uint32_t>::max());
  ws.reference_bi.assign(n, glm::vec3(0.0f));
  ws.bi_reference.assign(n, glm::vec3(0.0f));
  ws.hull_case.assign(topology.triangle_count, kHullCaseUnknown);
  ws.fixed_mask.assign(n, 2);
  ws.active.assign(n, 0);
  ws.ring.assign(n, 0);
  ws.active_triangles.assign(topology.triangle_count, 0);
  ws.free_triangle.assign(topology.triangle_count, 0);
  ws.ring_mark.assign(n, 0);
  return ws;
}

namespace {

// The bounding-box diagonal of the finite positions (0 if there are none).
float bounding_diagonal(const glm::vec3* positions, size_t vertex_count) {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (size_t v = 0; v < vertex_count; ++v)
    if (fair_detail::finite(positions[v])) lo = glm::min(lo, positions[v]), hi = glm::max(hi, positions[v]);
  return lo.x <= hi.x ? glm::length(hi - lo) : 0.0f;
}

// The run's targets relative to rest: the rest umbrellas turned into this evaluation's frames
// and, with a smoothing reference, its U² (U where the active set needs U, U² at its free
// vertices).
fair_detail::Targets rest_targets(const FairingTopology& topology, const FairingParams& params, const FairingRest& rest,
                                  const glm::mat3* frames, size_t vertex_count, FairingWorkspace& workspace) {
  using fair_detail::umbrella_pass;
  const fair_detail::VertexSet free = fair_detail::free_vertices(workspace),
                               ring = fair_detail::ring_vertices(workspace);
  if (params.smoothing_reference) {
    // U² of the reference surface (the unfaired reconstruction M): smoothing against it
    // smooths the correction x − M itself.
    const glm::vec3* reference_umbrella = params.smoothing_reference_umbrella;
    if (!reference_umbrella) {
      umbrella_pass(topology, params.smoothing_reference, workspace.target_umbrella.data(), ring);
      reference_umbrella = workspace.target_umbrella.data();
    }
    umbrella_pass(topology, reference_umbrella, workspace.reference_bi.data(), free);
  }
  for (uint32_t i = 0; i < ring.count; ++i) {
    const uint32_t v = ring[i];
    workspace.target_umbrella[v] = frames[v] * rest.umbrella[v];
  }
  for (uint32_t i = 0; i < free.count; ++i) {
    const uint32_t v = free[i];
    workspace.target_bi_umbrella[v] = frames[v] * rest.bi_umbrella[v];
  }
  return {workspace.target_umbrella.data(),
          workspace.target_bi_umbrella.data(),
          rest.triangle_level.data(),
          rest.gap.data(),
          params.smoothing_reference ? workspace.reference_bi.data() : nullptr,
          rest.positions.size() == vertex_count ? rest.positions.data() : nullptr,
          rest.skeletal.size() == vertex_count ? rest.skeletal.data() : nullptr};
}

// The run's active set (FairingWorkspace: the free vertices, their one-rings and the triangles
// with a free corner), rebuilt only when which vertices are fixed has changed since the last
// run. Nothing reads a fixed vertex's per-vertex scratch but flow (5)'s tracking, which reads
// the minimisers of a vertex's neighbours: a vertex that becomes fixed forgets its minimiser, so
// that its free neighbours never track a stale one (the result then depends on the input since
// the last fresh start only), and one that becomes free searches the grid afresh. A triangle
// that gains a free corner forgets its E_T hint, which the passes left stale (a stale hint
// that still holds would round as its case rounds, where a fresh search may round otherwise):
// so the active set gives the bits of passes over the whole mesh (whole_passes).
void update_active_set(const FairingTopology& topo, FairingWorkspace& ws) {
  const uint32_t n = topo.vertex_count;
  bool changed = false;
  for (uint32_t v = 0; v < n; ++v) {
    const uint8_t fixed = fair_detail::is_fixed(topo, ws, v) ? 1 : 0;
    if (ws.fixed_mask[v] != fixed) {
      changed = true;
      ws.minimiser[v] = std::numeric_limits<uint32_t>::max();
    }
    ws.fixed_mask[v] = fixed;
  }
  if (!changed) return;
  std::fill(ws.ring_mark.begin(), ws.ring_mark.end(), static_cast<uint8_t>(ws.whole_passes ? 1 : 0));
  ws.active_count = 0;
  for (uint32_t v = 0; v < n; ++v) {
    if (ws.fixed_mask[v]) continue;
    ws.active[ws.active_count++] = v;
    ws.ring_mark[v] = 1;
    for (uint32_t k = topo.neighbour_offsets[v]; k < topo.neighbour_offsets[v + 1]; ++k)
      ws.ring_mark[topo.neighbours[k]] = 1;
  }
  ws.ring_count = 0;
  for (uint32_t v = 0; v < n; ++v)
    if (ws.ring_mark[v]) ws.ring[ws.ring_count++] = v;
  ws.active_triangle_count = 0;
  for (uint32_t t = 0; t < topo.triangle_count; ++t) {
    const uint32_t* corner = topo.triangle_indices.data() + 3 * size_t{t};
    const uint8_t free = !ws.fixed_mask[corner[0]] || !ws.fixed_mask[corner[1]] || !ws.fixed_mask[corner[2]];
    if (free && !ws.free_triangle[t]) ws.hull_case[t] = kHullCaseUnknown;
    ws.free_triangle[t] = free;
    if (ws.whole_passes || free) ws.active_triangles[ws.active_triangle_count++] = t;
  }
}

// The largest squared motion from `start` over the free vertices (non-finite ones ignored; the
// fixed ones do not move): one square root at the end.
float largest_squared_motion(const glm::vec3* positions, const glm::vec3* start, const FairingWorkspace& ws) {
  float moved = 0.0f;
  const fair_detail::VertexSet free = fair_detail::free_vertices(ws);
  for (uint32_t i = 0; i < free.count; ++i) {
    const uint32_t v = free[i];
    const glm::vec3 d = positions[v] - start[v];
    const float squared = glm::dot(d, d);
    if (std::isfinite(squared)) moved = std::max(moved, squared);
  }
  return moved;
}

}  // namespace

float fair_run(const FairingTopology& topology, const glm::vec3* skeletal, const float* radius, glm::vec3* positions,
               size_t vertex_count, const FairingParams& params, FairingWorkspace& workspace, const FairingRest* rest,
               const glm::mat3* frames) {
  using namespace fair_detail;
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

  const float diagonal = bounding_diagonal(positions, vertex_count);

  workspace.caller_fixed = params.fixed;
  workspace.rest_edge = rest && rest->mean_edge.size() == vertex_count ? rest->mean_edge.data() : nullptr;
  workspace.search_stride = params.search_stride;
  if (params.search_stride > 1) workspace.search_phase = (workspace.search_phase + 1) % params.search_stride;
  update_active_set(topology, workspace);
  Targets targets;
  if (rest && frames) {
    if (rest->umbrella.size() != vertex_count || rest->triangle_level.size() != topology.triangle_count) return -1.0f;
    targets = rest_targets(topology, params, *rest, frames, vertex_count, workspace);
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
    const float moved = largest_squared_motion(positions, workspace.iteration_start.data(), workspace);
    residual = diagonal > 0.0f ? std::sqrt(moved) / diagonal : 0.0f;
  }
  return residual;
}

}  // namespace skelform::runtime
