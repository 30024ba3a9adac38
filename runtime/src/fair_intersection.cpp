// Flow (5) of the paper (sec. 3.2), which removes global and local self-intersections of the
// control mesh: ∂M/∂t = −f∇f − WΔ²M, with f(x) the minimum over nearby skeletal vertices S of
// the power g(x, S) = |x − S|² − d_S² (how deep x lies in another medial ball), looked up in a
// voxel grid over skeleton and mesh (the paper's 20×20×20) that is built once per fair_run().
#include "fair_internal.h"
#include "vec3_sse.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <limits>

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif

namespace skelform::runtime::fair_detail {
namespace {

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

}  // namespace

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

  // Counting sort, stable (each cell lists its vertices in ascending order: determinism of ties
  // in the minimum below), with no pass over the cells after the placement: counts at c + 2,
  // their running sum puts the start of cell c at c + 1, and placing the vertices moves each to
  // the start of c + 1. The grid has several cells per vertex, so the passes over the cells (the
  // fill and the running sum) are much of the work.
  const size_t cell_count = size_t(size) * size * size;
  uint32_t* offsets = ws.cell_offsets.data();
  std::fill(offsets, offsets + cell_count + 2, 0u);
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
    ++offsets[c + 2];
  }
  uint32_t run = 0;
  for (size_t c = 2; c < cell_count + 2; ++c) {
    run += offsets[c];
    offsets[c] = run;
  }
  for (uint32_t v = 0; v < vertex_count; ++v) {
    if (ws.vertex_cell[v] == none) continue;
    ws.cell_vertices[offsets[ws.vertex_cell[v] + 1]++] = v;
  }
  // Now cell c holds slots offsets[c] .. offsets[c + 1], and a row of cells (z, y) is one run of
  // slots: field_at scans a neighbourhood row as offsets[first cell] .. offsets[last cell + 1].
  // The balls in cell order, structure of arrays: slot_minimum's candidates side by side; and
  // per row of cells along x and per layer of rows the largest d² (field_at's bounds on what a
  // row or a layer can hold).
  std::fill(ws.row_rr_max.begin(), ws.row_rr_max.begin() + size_t(size) * size,
            -std::numeric_limits<float>::infinity());
  for (uint32_t k = 0; k < ws.cell_offsets[cell_count]; ++k) {
    const uint32_t s = ws.cell_vertices[k];
    ws.cell_x[k] = skeletal[s].x;
    ws.cell_y[k] = skeletal[s].y;
    ws.cell_z[k] = skeletal[s].z;
    ws.cell_rr[k] = radius[s] * radius[s];
    float& largest = ws.row_rr_max[ws.vertex_cell[s] / uint32_t(size)];
    largest = std::max(largest, ws.cell_rr[k]);
    grid.max_rr = std::max(grid.max_rr, ws.cell_rr[k]);
  }
  // Per layer of rows (z), the largest of its rows'.
  for (int z = 0; z < size; ++z) {
    float largest = -std::numeric_limits<float>::infinity();
    for (int y = 0; y < size; ++y) largest = std::max(largest, ws.row_rr_max[size_t(z) * size + y]);
    ws.layer_rr_max[size_t(z)] = largest;
  }
  return grid;
}

namespace {

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

// field_at's bound. A ball that build_grid put in cell k of an axis lies within that cell's
// span, in cells from the origin [k, k + 1), widened by kCellSlack cells for the rounding of
// cell_coordinate (the first and last cells reach to infinity: they hold what it clamps). Its g
// from x is then at least cell²·(gap_x² + gap_y² + gap_z²) − (the largest d² of its row of
// cells), each gap the distance in cells from x to the widened span along that axis.
constexpr float kCellSlack = 1e-3f;
// The bound and g are both computed in float: a cell is skipped only where its bound exceeds
// the best g by more than this fraction of (the farthest squared distance in the neighbourhood
// plus the largest d²), far above their rounding (a few units of 2^-24 of those magnitudes).
constexpr float kBoundRounding = 4e-6f;

// The gap, in cells, from coordinate p (in cells from the origin) to cell k of an axis of n.
inline float cell_gap(float p, int k, int n) {
  float gap = 0.0f;
  if (k > 0) gap = std::max(gap, (static_cast<float>(k) - kCellSlack) - p);
  if (k < n - 1) gap = std::max(gap, p - (static_cast<float>(k + 1) + kCellSlack));
  return gap;
}

// kBoundRounding's allowance for the neighbourhood of cells [x0, x1] × [y0, y1] × [z0, z1]
// around p (in cells): a cell beyond the farthest corner, squared, plus the largest d².
inline float bound_tolerance(float px, int x0, int x1, float py, int y0, int y1, float pz, int z0, int z1,
                             float cell_squared, float max_rr) {
  auto farthest = [](float p, int first, int last) {
    return std::max(std::fabs(p - static_cast<float>(first)), std::fabs(p - static_cast<float>(last + 1))) + 1.0f;
  };
  const float fx = farthest(px, x0, x1), fy = farthest(py, y0, y1), fz = farthest(pz, z0, z1);
  return kBoundRounding * (cell_squared * (fx * fx + fy * fy + fz * fz) + max_rr);
}

// The cells [first, last] of a row, within [x0, x1], whose gap along x from p may be at most
// reach = sqrt(allowed) cells (allowed: the squared gap in cells that a ball of the row may
// have and still lower the best g): from ⌊p − reach⌋ − 1 to ⌊p + reach⌋ + 1, which holds every
// cell k with k + 1 + kCellSlack ≥ p − reach and k − kCellSlack ≤ p + reach. Empty (first >
// last) when allowed < 0; the whole [x0, x1] when it is not finite or spans the axis.
inline void row_span(float p, float allowed, int x0, int x1, int n, int& first, int& last) {
  first = x0, last = x1;
  if (!(allowed >= 0.0f)) {
    if (allowed < 0.0f) first = 1, last = 0;
    return;
  }
  const float reach = std::sqrt(allowed);
  if (!(reach < static_cast<float>(n))) return;
  // Beyond the axis's ends the end cells hold what is there: p clamped to [0, n] has no larger gaps.
  const float q = std::min(std::max(p, 0.0f), static_cast<float>(n));
  first = std::max(x0, static_cast<int>(std::floor(q - reach)) - 1);
  last = std::min(x1, static_cast<int>(std::floor(q + reach)) + 1);
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
  // The (widened) 3×3×3 neighbourhood, layer by layer (z) from the own one outwards (the best g
  // so far falls fastest near x), each layer cut to the rows whose bound with the layer's
  // largest d² may beat the best so far, each row one run of slots from its first cell's to
  // past its last cell's (empty cells cost nothing, the balls are read four at a time; the own
  // row in two runs, the own cell being done above) cut down likewise with the row's largest d²
  // (row_span): the ring is sized for the largest ball, so the neighbourhood spans a good part
  // of the character, most of which cannot lower `best`. The minimum does not depend on the
  // order (precedes), so it is the shell-by-shell search's minimum.
  const int last_ring = std::max(std::max(grid.ring[0], grid.ring[1]), grid.ring[2]);
  const int x0 = std::max(0, cx - last_ring), x1 = std::min(n - 1, cx + last_ring);
  const int y0 = std::max(0, cy - last_ring), y1 = std::min(n - 1, cy + last_ring);
  const int z0 = std::max(0, cz - last_ring), z1 = std::min(n - 1, cz + last_ring);
  // x in cells from the origin (cell_coordinate's c), and the bound's rounding allowance.
  const float px = (x.x - grid.origin.x) * grid.inverse_cell.x, py = (x.y - grid.origin.y) * grid.inverse_cell.y;
  const float pz = (x.z - grid.origin.z) * grid.inverse_cell.z;
  const float cell_squared = grid.cell.x * grid.cell.x;
  // A cell² below FLT_MIN is rounded to the subnormals' absolute grid, far beyond the bound's
  // relative allowance: there no row is cut (an infinite tolerance leaves every span whole).
  const float tolerance = cell_squared >= std::numeric_limits<float>::min()
                              ? bound_tolerance(px, x0, x1, py, y0, y1, pz, z0, z1, cell_squared, grid.max_rr)
                              : std::numeric_limits<float>::infinity();
  for (int step = 0; step <= 2 * last_ring; ++step) {
    const int z = step % 2 ? cz - (step + 1) / 2 : cz + step / 2;  // cz, cz + 1, cz − 1, cz + 2, ...
    if (z < z0 || z > z1) continue;
    const float layer_rr = ws.layer_rr_max[size_t(z)];
    if (layer_rr == -std::numeric_limits<float>::infinity()) continue;  // no ball in the layer
    const float gz = cell_gap(pz, z, n);
    int first_y = 0, last_y = 0;
    row_span(py, (best.f + tolerance + layer_rr) / cell_squared - gz * gz, y0, y1, n, first_y, last_y);
    for (int y = first_y; y <= last_y; ++y) {
      const float rr = ws.row_rr_max[size_t(z) * n + y];
      if (rr == -std::numeric_limits<float>::infinity()) continue;  // no ball in the row
      const float gy = cell_gap(py, y, n);
      int first = 0, last = 0;
      row_span(px, (best.f + tolerance + rr) / cell_squared - (gz * gz + gy * gy), x0, x1, n, first, last);
      if (first > last) continue;
      const size_t row = (size_t(z) * n + y) * n;
      if (z == cz && y == cy) {
        if (first < cx) slot_minimum(x, ws, offsets[row + first], offsets[own], exclude, best);
        if (last > cx) slot_minimum(x, ws, offsets[own + 1], offsets[row + last + 1], exclude, best);
      } else {
        slot_minimum(x, ws, offsets[row + first], offsets[row + last + 1], exclude, best);
      }
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

constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

// Tracking (FairingParams::search_stride): f at vertex v as the best of its own ball (not
// relative to rest), its last minimiser and its neighbours' last minimisers; a minimum that
// moves along the surface is followed, a new one is found at the vertex's next full search.
// The smallest (g, s), lexicographically, over the candidates: the order they come in does not
// matter. The tests that rarely fail branch (build_grid left vertex_cell at none for a skeletal
// vertex or radius that is not finite); the comparison, which fails or holds at random, selects
// without a branch.
FieldValue tracked_field(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius,
                         const glm::vec3* x, uint32_t v, bool relative, const FairingWorkspace& ws) {
  FieldValue field;
  auto consider = [&](uint32_t s) {
    if (s == kNone || (relative && s == v) || ws.vertex_cell[s] == kNone) return;
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
  return field;
}

// f at vertex v and its minimising ball. The grid search once per fair_run() call; later
// iterations of the call follow the minimising ball found then (the vertices move a fraction
// of an edge per iteration). Relative to rest, the vertex's own ball is left out.
FieldValue vertex_field(const FairingTopology& topo, const Grid& grid, const glm::vec3* skeletal, const float* radius,
                        const glm::vec3* x, uint32_t v, bool refresh_field, bool relative, FairingWorkspace& ws) {
  FieldValue field;
  const bool search = refresh_field && (ws.search_stride <= 1 || ws.minimiser[v] == kNone ||
                                        (ws.search_phase + v) % ws.search_stride == 0);
  if (search) {
    field = field_at(grid, x[v], ws, relative ? v : kNone);
    ws.minimiser[v] = field.minimiser;
  } else if (refresh_field) {
    field = tracked_field(topo, skeletal, radius, x, v, relative, ws);
    ws.next_minimiser[v] = field.minimiser;
  } else if (ws.minimiser[v] != kNone) {
    const uint32_t s = ws.minimiser[v];
    const glm::vec3 d = x[v] - skeletal[s];
    field = {glm::dot(d, d) - radius[s] * radius[s], s};
  }
  return field;
}

// The paper's −f∇f, ∇f = 2(x − S*), as a Gauss-Newton step towards f = 0, into
// ws.displacement[v].
void paper_step(const glm::vec3* skeletal, const float* radius, const glm::vec3* x, uint32_t v, const FieldValue& field,
                float step, FairingWorkspace& ws) {
  const glm::vec3 gradient = 2.0f * (x[v] - skeletal[field.minimiser]);
  const float d_star = radius[field.minimiser];
  const float denominator = std::max(glm::dot(gradient, gradient), 4.0f * d_star * d_star);
  if (denominator > 0.0f) ws.displacement[v] = -step * (field.f / denominator) * gradient;
}

// Relative to rest, flow (5) keeps the vertex on its own side of the radical plane between its
// own ball (S_v, d_v) and the nearest other ball (S*, d*). The power difference
// Δ = g(x, S*) − g(x, S_v) = f − g_own (`own` = g_own) is positive on the own side, with
// ∇Δ = 2(S_v − S*) and Δ / |∇Δ| the distance to the plane. Δ must not fall below the smaller of
// its rest value (the same two balls, rest M and S) and a margin of kIntersectionMargin times
// the rest mean edge length e or the medial radius d_v, whichever is smaller (a gap wider than
// the part is thick would fold a coarse mesh):
//   - a vertex never sinks deeper into another ball's power cell than it was at rest (where
//     balls overlap at rest, in a crease or a thin part, that is the rest depth);
//   - where two parts that were apart at rest come into contact (the inner side of a bent
//     joint, an arm against the torso), both skins stop a margin short of the plane between
//     them; without it both settle onto the same plane and touch or cross between their
//     vertices. The margin costs a little volume; its cap at d_v keeps thin parts of coarse
//     meshes from folding.
// The step goes along ∇Δ, towards the own side (pushing out of S*'s ball along ∇f = 2(x − S*)
// instead lays each skin onto the other's surface, over the other's skin). A vertex on its own
// side beyond the margin is not pulled in: that is flow (4)'s, and pulling towards the union of
// all balls shrinks the animated characters. Into ws.displacement[v].
void radical_plane_step(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, const glm::vec3* x,
                        uint32_t v, const FieldValue& field, float own, float step, const Targets& targets,
                        FairingWorkspace& ws) {
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

// The tracked minimisers of this call (read from the old ones while the step ran) become the
// current ones.
void adopt_tracked_minimisers(FairingWorkspace& ws) {
  const VertexSet free = free_vertices(ws);
  for (uint32_t i = 0; i < free.count; ++i)
    if (const uint32_t v = free[i]; ws.next_minimiser[v] != kNone) {
      ws.minimiser[v] = ws.next_minimiser[v];
      ws.next_minimiser[v] = kNone;
    }
}

// The explicit step's −WΔ²M, with U² relative to the reference or to rest as compute_umbrellas
// gives it (the same bits), where W > 0: elsewhere the term is 0. Needs U of x in ws.umbrella.
void add_explicit_smoothing(const FairingTopology& topo, float step, const Targets& targets, FairingWorkspace& ws) {
  const VertexSet free = free_vertices(ws);
  for (uint32_t i = 0; i < free.count; ++i) {
    const uint32_t v = free[i];
    if (!(ws.smoothing_weight[v] > 0.0f)) continue;
    glm::vec3 bi = umbrella_at(topo, ws.umbrella.data(), v);
    if (targets.reference_bi_umbrella)
      bi -= targets.reference_bi_umbrella[v];
    else if (targets.umbrella)
      bi -= targets.bi_umbrella[v];
    ws.displacement[v] -= step * ws.smoothing_weight[v] * bi;
  }
}

}  // namespace

// One step of flow (5), on the run's active set (the free vertices move).
void intersection_step(const FairingTopology& topo, const Grid& grid, const glm::vec3* skeletal, const float* radius,
                       glm::vec3* x, float step, bool semi_implicit, bool refresh_field, const Targets& targets,
                       FairingWorkspace& ws) {
  const VertexSet free = free_vertices(ws);
  // No compute_umbrellas here: the semi-implicit solve evaluates U² itself, and the explicit
  // step needs U² only where W > 0 (typically a minority of the vertices), from U at their
  // one-rings.
  if (!semi_implicit) umbrella_pass(topo, x, ws.umbrella.data(), ring_vertices(ws));

  // f, its Gauss-Newton step G = f∇f / max(|∇f|², 4 d*²) with ∇f = 2(x − S*), and |f − g|.
  // Relative to rest, f is the minimum over the balls other than the vertex's own (the ball it
  // was reconstructed from): the margin needs the nearest other ball also where the own ball
  // is nearer.
  const bool relative = targets.rest_positions && targets.rest_skeletal;
  float largest_gap = 0.0f;
  for (uint32_t i = 0; i < free.count; ++i) {
    const uint32_t v = free[i];
    ws.displacement[v] = glm::vec3(0.0f);
    ws.smoothing_weight[v] = 0.0f;
    ws.force_direction[v] = glm::vec3(0.0f);
    if (!finite(x[v])) continue;
    const FieldValue field = vertex_field(topo, grid, skeletal, radius, x, v, refresh_field, relative, ws);
    if (field.minimiser == kNone) continue;
    // g(x, S_v) of the vertex's own ball, where another ball is the minimiser (0 is unused).
    const bool foreign = field.minimiser != v && finite(skeletal[v]);
    const glm::vec3 to_own = x[v] - skeletal[v];
    const float own = foreign ? glm::dot(to_own, to_own) - radius[v] * radius[v] : 0.0f;
    if (!relative)
      paper_step(skeletal, radius, x, v, field, step, ws);
    else if (foreign)
      radical_plane_step(topo, skeletal, radius, x, v, field, own, step, targets, ws);
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
  if (refresh_field && ws.search_stride > 1) adopt_tracked_minimisers(ws);
  // W(M) = |f(M) − g(M, S)| / max_M |f − g| (0 at the fixed vertices).
  for (uint32_t i = 0; i < free.count; ++i) {
    float& weight = ws.smoothing_weight[free[i]];
    weight = largest_gap > 0.0f ? weight / largest_gap : 0.0f;
  }

  if (!semi_implicit) {
    // (5): ∂M/∂t = −f∇f − WΔ²M.
    add_explicit_smoothing(topo, step, targets, ws);
    apply_displacements(topo, x, ws);
    return;
  }
  for (uint32_t i = 0; i < free.count; ++i) {
    const uint32_t v = free[i];
    ws.start_positions[v] = x[v] + ws.displacement[v];  // x − τG
  }
  implicit_update(topo, x, step, nullptr, targets, ws);
}

float grid_field(const Grid& grid, const glm::vec3& x, const FairingWorkspace& ws, uint32_t exclude,
                 uint32_t& minimiser) {
  const FieldValue field = field_at(grid, x, ws, exclude);
  minimiser = field.minimiser;
  return field.f;
}

void rest_gaps(const FairingTopology& topo, const glm::vec3* skeletal, const float* radius, const glm::vec3* x,
               int size, FairingWorkspace& ws, float* gap) {
  const Grid grid = build_grid(topo, skeletal, radius, x, size, ws);
  for (uint32_t v = 0; v < topo.vertex_count; ++v) {
    if (topo.fixed[v]) continue;
    const FieldValue field = field_at(grid, x[v], ws);
    if (field.minimiser == std::numeric_limits<uint32_t>::max()) continue;
    if (field.minimiser != v) {
      const glm::vec3 d = x[v] - skeletal[v];
      gap[v] = std::fabs(field.f - (glm::dot(d, d) - radius[v] * radius[v]));
    }
  }
}

}  // namespace skelform::runtime::fair_detail
