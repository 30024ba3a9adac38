// The contact pass (contact.h).
#include "contact.h"

#include "triangles_meet.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif

namespace skelform::runtime {
namespace {

constexpr uint32_t kEntriesPerTriangle = 8;  // grid entries reserved per triangle (it overlaps ~3 cells)
constexpr uint32_t kCellsPerTriangle = 4;    // grid cells at most, per triangle
constexpr uint32_t kStarMaskBits = 32;       // star triangles ContactWorkspace::candidate_shared tells apart
constexpr int kMaxCellsPerAxis = 1024;
constexpr uint8_t kActive = 1, kMoved = 2, kMovable = 4;  // ContactWorkspace::state bits
constexpr uint32_t kLookAgain = UINT32_MAX;               // ContactWorkspace::seen: it moved then

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

struct CellRange {
  int lo[3], hi[3];
  uint32_t cells() const {
    return uint32_t(hi[0] - lo[0] + 1) * uint32_t(hi[1] - lo[1] + 1) * uint32_t(hi[2] - lo[2] + 1);
  }
};

// The pass's view of the welded mesh: a uniform grid of the triangles' boxes as the pass found
// them, and the triangle tests at the current positions.
class Grid {
 public:
  Grid(const ContactMesh& mesh, float gap, ContactWorkspace& ws, const ContactPairs* shared)
      : mesh_(mesh), ws_(ws), x_(ws.positions.data()), gap_(gap), shared_(shared) {}

  // With a shared search (ContactPairs), its hierarchy stands in for the cells: only checks the
  // positions. Its boxes hold the triangles where they are (moved() keeps them so).
  bool use_shared() {
    for (uint32_t v = 0; v < mesh_.vertex_count; ++v)
      if (!finite(x_[v])) return false;
    return true;
  }

  // Welded vertex v has moved: with a shared search, its triangles' boxes grow to hold where
  // they are now, and their node boxes with them, so that a gather needs no pad for it. (The
  // pass's own grid pads its gathers by the cap instead.)
  void moved(uint32_t v) { set_boxes(v, true); }

  // With a shared search, the boxes of v's triangles set to where they are now (after the pass
  // took its moves back; their node boxes may stay grown: they still hold them).
  void reset_boxes(uint32_t v) { set_boxes(v, false); }

  // Buckets every triangle by its box now. `pad` is how far a vertex may move from here during
  // the pass: gather() looks that much further. False when a position is not finite (the pass
  // then does nothing).
  bool build(float pad) {
    const uint32_t n = mesh_.triangle_count;
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (uint32_t v = 0; v < mesh_.vertex_count; ++v) {
      if (!finite(x_[v])) return false;
      lo = glm::min(lo, x_[v]);
      hi = glm::max(hi, x_[v]);
    }
    const double extent_sum = store_boxes_and_normals();
    pad_ = pad;
    origin_ = lo - glm::vec3(pad);
    const glm::vec3 extent = hi - lo + glm::vec3(2.0f * pad);
    const float largest = std::max(extent.x, std::max(extent.y, extent.z));
    if (!(largest > 0.0f)) return false;
    choose_cells(extent, largest, float(extent_sum / double(std::max(n, 1u))));
    return bucket_triangles();
  }

  // Every intersecting pair once, to `visit(s, t)`, with the positions the grid was built from;
  // except inside a cell whose triangles all face within 60 degrees of their mean normal (at
  // the scale of a cell, one piece of surface is then a height field over the mean's plane:
  // most of a surface's cells, whose pairs of near neighbours would otherwise cost most of the
  // pass). Two skins in contact face each other, a fold turns triangles over: such cells are
  // tested. Two sheets crossing within a cell with normals less than 120 degrees apart are
  // missed; on the sample animations the result equals testing every cell, at a third of the
  // cost (docs/tuning.md; a narrower cone misses a tip through a face, contact_test.cpp).
  // Each candidate pair spends one of ws.budget; a spent budget ends the search early.
  template <class Visit>
  uint32_t for_each_pair(Visit&& visit) const {
    uint32_t count = 0;
    const uint32_t* offsets = ws_.cell_offsets.data();
    for (int z = 0; z < dims_[2]; ++z)
      for (int y = 0; y < dims_[1]; ++y)
        for (int x = 0; x < dims_[0]; ++x) {
          const size_t c = linear(x, y, z);
          if (offsets[c + 1] - offsets[c] < 2 || flat(offsets[c], offsets[c + 1])) continue;
          for (uint32_t i = offsets[c]; i < offsets[c + 1]; ++i) {
            const uint32_t s = ws_.entries[i];
            const CellRange rs = range(s);
            for (uint32_t j = i + 1; j < offsets[c + 1]; ++j) {
              if (!ws_.budget.spend()) return count;
              const uint32_t t = ws_.entries[j];
              // Each pair in the first cell of the overlap of both ranges only.
              const CellRange rt = range(t);
              if (std::max(rs.lo[0], rt.lo[0]) != x || std::max(rs.lo[1], rt.lo[1]) != y ||
                  std::max(rs.lo[2], rt.lo[2]) != z)
                continue;
              if (stored_boxes_meet(s, t) && meet(s, t)) {
                ++count;
                visit(s, t);
              }
            }
          }
        }
    return count;
  }

  // The box of the star of welded vertex v (its triangles) where they are now.
  void star_box(uint32_t v, glm::vec3& lo, glm::vec3& hi) const {
    lo = glm::vec3(std::numeric_limits<float>::max()), hi = glm::vec3(-std::numeric_limits<float>::max());
    for (uint32_t k = mesh_.incident_offsets[v]; k < mesh_.incident_offsets[v + 1]; ++k) {
      glm::vec3 a, b;
      box(mesh_.incident[k], a, b);
      lo = glm::min(lo, a);
      hi = glm::max(hi, b);
    }
  }

  // The triangles that may meet one around welded vertex v while v moves by up to `reach` and
  // the other vertices stay where they are, each once, into ws.candidates. `region` (6 floats)
  // receives where it looked: the box a candidate's box meets.
  void gather(uint32_t v, float reach, float* region) {
    if (++ws_.stamp == 0) {  // wrapped: forget every old mark
      std::fill(ws_.stamps.begin(), ws_.stamps.end(), 0u);
      std::fill(ws_.corner_stamps.begin(), ws_.corner_stamps.end(), 0u);
      ws_.stamp = 1;
    }
    ws_.candidates.clear();
    // The star triangles each corner of v's star belongs to (v itself: all of them).
    const uint32_t star_first = mesh_.incident_offsets[v];
    const uint32_t star_size = std::min(mesh_.incident_offsets[v + 1] - star_first, kStarMaskBits);
    for (uint32_t k = 0; k < star_size; ++k) {
      const uint32_t* q = mesh_.triangles.data() + 3 * size_t(mesh_.incident[star_first + k]);
      for (int corner = 0; corner < 3; ++corner) {
        const uint32_t c = q[corner];
        if (ws_.corner_stamps[c] != ws_.stamp) ws_.corner_stamps[c] = ws_.stamp, ws_.corner_stars[c] = 0;
        ws_.corner_stars[c] |= 1u << k;
      }
    }
    auto stars_of = [&](uint32_t c) { return ws_.corner_stamps[c] == ws_.stamp ? ws_.corner_stars[c] : 0u; };
    const uint32_t* offsets = ws_.cell_offsets.data();
    // The star of v (its triangles' box) grown by v's reach: where its triangles can be.
    glm::vec3 lo, hi;
    star_box(v, lo, hi);
    lo -= glm::vec3(reach);
    hi += glm::vec3(reach);
    region[0] = lo.x, region[1] = lo.y, region[2] = lo.z, region[3] = hi.x, region[4] = hi.y, region[5] = hi.z;
    // Another triangle is where it was bucketed, within the pad (in a shared search's
    // hierarchy, inside its grown box); kept if its box now meets the star's (the others do not
    // move while v does).
    auto consider = [&](uint32_t t) {
      if (ws_.stamps[t] == ws_.stamp || !ws_.budget.spend()) return;
      ws_.stamps[t] = ws_.stamp;
      glm::vec3 a, b;
      box(t, a, b);
      if (a.x > hi.x || lo.x > b.x || a.y > hi.y || lo.y > b.y || a.z > hi.z || lo.z > b.z) return;
      float* stored = ws_.candidate_boxes.data() + ws_.candidates.size();
      const size_t plane = ws_.candidate_stride;
      stored[0] = a.x, stored[plane] = a.y, stored[2 * plane] = a.z;
      stored[3 * plane] = b.x, stored[4 * plane] = b.y, stored[5 * plane] = b.z;
      const uint32_t* q = mesh_.triangles.data() + 3 * size_t(t);
      ws_.candidate_shared[ws_.candidates.size()] = stars_of(q[0]) | stars_of(q[1]) | stars_of(q[2]);
      ws_.candidates.push_back(t);  // at most every triangle: reserved
    };
    if (shared_) {
      const float query[6] = {lo.x, lo.y, lo.z, hi.x, hi.y, hi.z};
      query_triangle_hierarchy(*shared_->hierarchy, shared_->node_boxes, *shared_->boxes, query,
                               [&](uint32_t t) { consider(t); });
      return;
    }
    const CellRange r = cell_range(lo - glm::vec3(pad_), hi + glm::vec3(pad_));
    for (int z = r.lo[2]; z <= r.hi[2]; ++z)
      for (int y = r.lo[1]; y <= r.hi[1]; ++y)
        for (int x = r.lo[0]; x <= r.hi[0]; ++x) {
          const size_t c = linear(x, y, z);
          for (uint32_t i = offsets[c]; i < offsets[c + 1]; ++i) consider(ws_.entries[i]);
        }
  }

  // The intersecting pairs that the triangles around welded vertex v make now with the last
  // gather()'s candidates, but for those that intersect at rest: the modeller's, which the pass
  // leaves be (it neither counts them nor pushes out of them; pushing out of them moved a vertex
  // out of the part it was modelled into). With `push`, also the push of v out of them: for
  // each pair (s, t), where v lies behind t's plane or less than the gap in front of it, half
  // the way out to the gap along t's normal (t's corners take the other half when they are
  // pushed in turn), or the whole way when none of t's corners may move (a rigid part).
  // Like gather(), each triangle it looks at spends one of ws.budget, and a spent budget ends it.
  // A candidate's box is the one gather() stored: only v moves until the next gather, and a
  // triangle around v (whose stored box may be stale) shares v with every triangle of its
  // star, so meet() never counts it.
  // `stop_above`: the count may stop once it exceeds this (the caller asks only whether it
  // does; pass UINT32_MAX to count every pair).
  // With SSE2, four candidates' boxes at a time while the budget holds four more visits (it is
  // spent as one visit per candidate, in order, as the scalar loop spends it).
  // A candidate that shares a corner with the star triangle (gather()'s candidate_shared) is
  // passed over as meet() would reject it: most of those whose boxes meet are such neighbours.
  uint32_t pairs_around(uint32_t v, glm::vec3* push, uint32_t stop_above = UINT32_MAX) const {
    uint32_t count = 0;
    const size_t candidates = ws_.candidates.size();
    const float* planes = ws_.candidate_boxes.data();
    const uint32_t* shared = ws_.candidate_shared.data();
    const size_t plane = ws_.candidate_stride;
    const uint32_t star_first = mesh_.incident_offsets[v];
    // Candidate i's box meets the star triangle's (a, b) and the triangles intersect: counted,
    // and its push added. True when the count has passed stop_above.
    auto pair = [&](uint32_t s, size_t i) {
      const uint32_t t = ws_.candidates[i];
      if (!meet(s, t) || mesh_.intersects_at_rest(pair_key(s, t))) return false;
      ++count;
      if (push) add_push(v, t, *push);
      return count > stop_above;
    };
    for (uint32_t k = star_first; k < mesh_.incident_offsets[v + 1]; ++k) {
      const uint32_t s = mesh_.incident[k];
      const uint32_t bit = k - star_first < kStarMaskBits ? 1u << (k - star_first) : 0u;
      glm::vec3 a, b;
      box(s, a, b);
      size_t i = 0;
#if defined(__SSE2__)
      const __m128 ax = _mm_set1_ps(a.x), ay = _mm_set1_ps(a.y), az = _mm_set1_ps(a.z);
      const __m128 bx = _mm_set1_ps(b.x), by = _mm_set1_ps(b.y), bz = _mm_set1_ps(b.z);
      const __m128i star_bit = _mm_set1_epi32(int(bit));
      for (; i + 4 <= candidates && ws_.budget.left >= 4; i += 4) {
        ws_.budget.left -= 4;
        const float* c = planes + i;
        // Apart: a > c's hi or c's lo > b on some axis (false for NaN, as the scalar test).
        const __m128 apart = _mm_or_ps(
            _mm_or_ps(
                _mm_or_ps(_mm_cmpgt_ps(ax, _mm_loadu_ps(c + 3 * plane)), _mm_cmpgt_ps(_mm_loadu_ps(c), bx)),
                _mm_or_ps(_mm_cmpgt_ps(ay, _mm_loadu_ps(c + 4 * plane)), _mm_cmpgt_ps(_mm_loadu_ps(c + plane), by))),
            _mm_or_ps(_mm_cmpgt_ps(az, _mm_loadu_ps(c + 5 * plane)), _mm_cmpgt_ps(_mm_loadu_ps(c + 2 * plane), bz)));
        // The lanes that share no corner with s (all of them past the mask's 32 triangles: bit 0).
        const __m128i neighbour =
            _mm_and_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(shared + i)), star_bit);
        const int other = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(neighbour, _mm_setzero_si128())));
        for (int hits = ~_mm_movemask_ps(apart) & other & 0xF; hits; hits &= hits - 1) {
          const int lane = __builtin_ctz(unsigned(hits));
          if (pair(s, i + size_t(lane))) {
            ws_.budget.left += uint64_t(3 - lane);  // the lanes after it were not visited
            return count;
          }
        }
      }
#endif
      for (; i < candidates; ++i) {
        if (!ws_.budget.spend()) return count;
        const float* c = planes + i;
        if ((shared[i] & bit) || a.x > c[3 * plane] || c[0] > b.x || a.y > c[4 * plane] || c[plane] > b.y ||
            a.z > c[5 * plane] || c[2 * plane] > b.z)
          continue;
        if (pair(s, i)) return count;
      }
    }
    return count;
  }

 private:
  // The shared search's boxes of v's triangles: their boxes now, grown over the stored ones
  // (with their node boxes) or in their place.
  void set_boxes(uint32_t v, bool grow) {
    if (!shared_) return;
    const TriangleHierarchy& h = *shared_->hierarchy;
    for (uint32_t k = mesh_.incident_offsets[v]; k < mesh_.incident_offsets[v + 1]; ++k) {
      const uint32_t t = mesh_.incident[k];
      glm::vec3 a, b;
      box(t, a, b);
      float stored[6] = {a.x, a.y, a.z, b.x, b.y, b.z};
      if (grow) {
        float old[6];
        shared_->boxes->get(h.slot[t], old);
        grow_box(stored, old);
      }
      shared_->boxes->set(h.slot[t], stored);
      if (grow) grow_triangle_hierarchy(h, h.slot[t], stored, shared_->node_boxes);
    }
  }

  // Every triangle's box and unit normal at the current positions; returns the sum of the
  // boxes' largest extents.
  double store_boxes_and_normals() {
    double extent_sum = 0.0;
    float* boxes = ws_.boxes.data();
    for (uint32_t t = 0; t < mesh_.triangle_count; ++t) {
      glm::vec3 a, b;
      box(t, a, b);
      for (int k = 0; k < 3; ++k) {
        boxes[6 * size_t(t) + k] = a[k];
        boxes[6 * size_t(t) + 3 + k] = b[k];
      }
      const glm::vec3 e = b - a;
      extent_sum += double(std::max(e.x, std::max(e.y, e.z)));
      const uint32_t* q = mesh_.triangles.data() + 3 * size_t(t);
      const glm::vec3 normal = glm::cross(x_[q[1]] - x_[q[0]], x_[q[2]] - x_[q[0]]);
      const float nl = glm::length(normal);
      ws_.normals[t] = nl > 0.0f ? normal / nl : glm::vec3(0.0f);
    }
    return extent_sum;
  }

  // Cells sized by the mean triangle, coarsened until there are at most kCellsPerTriangle cells
  // per triangle (a surface fills few of them), fewer than kMaxCellsPerAxis per axis, and the
  // triangles' boxes take at most the entries reserved (kEntriesPerTriangle per triangle): a
  // mesh of very unequal triangles (a body of large ones, legs of small ones) needs cells
  // coarser than its mean. Leaves each triangle's cells in ws.ranges. One cell fits any mesh,
  // and 64 coarsenings by 1.26 reach it from the smallest start (largest · 1e-6); a non-finite
  // extent goes straight to it.
  void choose_cells(const glm::vec3& extent, float largest, float mean_size) {
    const uint32_t n = mesh_.triangle_count;
    float cell = std::max(mean_size, largest * 1e-6f);
    for (int attempt = 0; attempt < 64; ++attempt) {
      for (int k = 0; k < 3; ++k)
        dims_[k] = std::max(1, int(std::min(double(kMaxCellsPerAxis), std::ceil(double(extent[k]) / cell))));
      inverse_cell_ = 1.0f / cell;
      const double cells = double(dims_[0]) * dims_[1] * dims_[2];
      if (cells <= double(kCellsPerTriangle) * std::max(n, 1u) && dims_[0] < kMaxCellsPerAxis &&
          dims_[1] < kMaxCellsPerAxis && dims_[2] < kMaxCellsPerAxis && store_ranges())
        return;
      cell *= 1.26f;
    }
    dims_[0] = dims_[1] = dims_[2] = 1;
    store_ranges();
  }

  // Every triangle's cells (its stored box's) into ws.ranges; false as soon as they take more
  // than the reserved entries.
  bool store_ranges() {
    const uint64_t capacity = ws_.entries.size();
    uint64_t used = 0;
    int16_t* ranges = ws_.ranges.data();
    for (uint32_t t = 0; t < mesh_.triangle_count; ++t) {
      const CellRange r = cell_range(stored_lo(t), stored_hi(t));
      for (int k = 0; k < 3; ++k) {
        ranges[6 * size_t(t) + k] = int16_t(r.lo[k]);
        ranges[6 * size_t(t) + 3 + k] = int16_t(r.hi[k]);
      }
      used += r.cells();
      if (used > capacity) return false;
    }
    return true;
  }

  // Counting sort of the triangles into the cells of their ranges. False if they do not fit
  // the entries reserved (choose_cells makes them fit).
  bool bucket_triangles() {
    const uint32_t n = mesh_.triangle_count;
    const size_t cells = size_t(dims_[0]) * dims_[1] * dims_[2];
    uint32_t* offsets = ws_.cell_offsets.data();
    std::fill(offsets, offsets + cells + 1, 0u);
    uint64_t used = 0;
    for (uint32_t t = 0; t < n; ++t) {
      const CellRange r = range(t);
      used += r.cells();
      for (int z = r.lo[2]; z <= r.hi[2]; ++z)
        for (int y = r.lo[1]; y <= r.hi[1]; ++y)
          for (int x = r.lo[0]; x <= r.hi[0]; ++x) ++offsets[linear(x, y, z) + 1];
    }
    if (used > ws_.entries.size()) return false;
    for (size_t c = 0; c < cells; ++c) offsets[c + 1] += offsets[c];
    // Fill (offsets[c] walks forward; shifted back after).
    for (uint32_t t = 0; t < n; ++t) {
      const CellRange r = range(t);
      for (int z = r.lo[2]; z <= r.hi[2]; ++z)
        for (int y = r.lo[1]; y <= r.hi[1]; ++y)
          for (int x = r.lo[0]; x <= r.hi[0]; ++x) ws_.entries[offsets[linear(x, y, z)]++] = t;
    }
    for (size_t c = cells; c > 0; --c) offsets[c] = offsets[c - 1];
    offsets[0] = 0;
    return true;
  }

  void add_push(uint32_t v, uint32_t t, glm::vec3& push) const {
    const uint32_t* q = mesh_.triangles.data() + 3 * size_t(t);
    const glm::vec3 n = glm::cross(x_[q[1]] - x_[q[0]], x_[q[2]] - x_[q[0]]);
    const float length = glm::length(n);
    if (!(length > 0.0f)) return;
    const glm::vec3 unit = n / length;
    const float distance = glm::dot(x_[v] - x_[q[0]], unit);
    // Half the way when t's corners can take the other half, the whole way when none can move.
    const bool rigid = !((ws_.state[q[0]] | ws_.state[q[1]] | ws_.state[q[2]]) & kMovable);
    if (distance < gap_) push += (rigid ? 1.0f : 0.5f) * (gap_ - distance) * unit;
  }
  // Do the normals of the triangles in entries [begin, end) all lie within 60 degrees of their
  // mean (for_each_pair)?
  bool flat(uint32_t begin, uint32_t end) const {
    constexpr float kFlatCos = 0.5f;  // cos 60°
    glm::vec3 mean(0.0f);
    for (uint32_t i = begin; i < end; ++i) mean += ws_.normals[ws_.entries[i]];
    const float length = glm::length(mean);
    if (!(length > 0.0f)) return false;
    const float limit = kFlatCos * length;
    for (uint32_t i = begin; i < end; ++i)
      if (!(glm::dot(ws_.normals[ws_.entries[i]], mean) > limit)) return false;
    return true;
  }
  // Non-adjacent (no shared corner) and intersecting, at the current positions.
  bool meet(uint32_t s, uint32_t t) const {
    const uint32_t* p = mesh_.triangles.data() + 3 * size_t(s);
    const uint32_t* q = mesh_.triangles.data() + 3 * size_t(t);
    if (s == t || triangles_share_corner(p, q)) return false;
    return triangles_meet(x_[p[0]], x_[p[1]], x_[p[2]], x_[q[0]], x_[q[1]], x_[q[2]]);
  }
  bool stored_boxes_meet(uint32_t s, uint32_t t) const {
    const float* a = ws_.boxes.data() + 6 * size_t(s);
    const float* b = ws_.boxes.data() + 6 * size_t(t);
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
  }
  void box(uint32_t t, glm::vec3& lo, glm::vec3& hi) const {
    const uint32_t* q = mesh_.triangles.data() + 3 * size_t(t);
    lo = glm::min(x_[q[0]], glm::min(x_[q[1]], x_[q[2]]));
    hi = glm::max(x_[q[0]], glm::max(x_[q[1]], x_[q[2]]));
  }
  glm::vec3 stored_lo(uint32_t t) const {
    return glm::vec3(ws_.boxes[6 * size_t(t)], ws_.boxes[6 * size_t(t) + 1], ws_.boxes[6 * size_t(t) + 2]);
  }
  glm::vec3 stored_hi(uint32_t t) const {
    return glm::vec3(ws_.boxes[6 * size_t(t) + 3], ws_.boxes[6 * size_t(t) + 4], ws_.boxes[6 * size_t(t) + 5]);
  }
  int coordinate(float value, int k) const {
    // Clamped while still a float (fair_intersection.cpp cell_coordinate): a cell that underflowed makes c
    // inf, and inf converted to int is undefined behaviour.
    const float c = (value - origin_[k]) * inverse_cell_;
    if (!(c >= 0.0f)) return 0;
    if (!(c < float(dims_[k]))) return dims_[k] - 1;
    return int(c);
  }
  CellRange cell_range(const glm::vec3& lo, const glm::vec3& hi) const {
    CellRange r;
    for (int k = 0; k < 3; ++k) {
      r.lo[k] = coordinate(lo[k], k);
      r.hi[k] = coordinate(hi[k], k);
    }
    return r;
  }
  // The cells triangle t was bucketed in (its box when the pass began).
  CellRange range(uint32_t t) const {
    const int16_t* r = ws_.ranges.data() + 6 * size_t(t);
    return {{r[0], r[1], r[2]}, {r[3], r[4], r[5]}};
  }
  size_t linear(int x, int y, int z) const {
    return (size_t(z) * size_t(dims_[1]) + size_t(y)) * size_t(dims_[0]) + size_t(x);
  }

  const ContactMesh& mesh_;
  ContactWorkspace& ws_;
  const glm::vec3* x_;
  float gap_;
  const ContactPairs* shared_;
  glm::vec3 origin_{0.0f};
  float inverse_cell_ = 1.0f, pad_ = 0.0f;
  int dims_[3] = {1, 1, 1};
};

}  // namespace

ContactWorkspace make_contact_workspace(const ContactMesh& mesh, const AllocatorRef& allocator) {
  ContactWorkspace ws(allocator);
  ws.positions.resize(mesh.vertex_count);

  ws.start.resize(mesh.vertex_count);
  ws.state.resize(mesh.vertex_count);
  ws.active.reserve(mesh.vertex_count);
  ws.stamps.assign(mesh.triangle_count, 0u);
  ws.candidates.reserve(mesh.triangle_count);
  ws.candidate_stride = mesh.triangle_count;
  ws.candidate_boxes.resize(6 * ws.candidate_stride);
  ws.candidate_shared.resize(mesh.triangle_count);
  ws.corner_stars.resize(mesh.vertex_count);
  ws.corner_stamps.assign(mesh.vertex_count, 0u);
  const size_t looks = std::min<size_t>(mesh.vertex_count, kContactSkipCapacity);
  ws.regions.resize(6 * looks);
  ws.seen.resize(looks);
  ws.move_boxes.resize(6 * looks);
  ws.moved.reserve(mesh.vertex_count);
  return ws;
}

void add_contact_grid(const ContactMesh& mesh, ContactWorkspace& ws) {
  ws.cell_offsets.resize(size_t(kCellsPerTriangle) * std::max(mesh.triangle_count, 1u) + 1);
  ws.ranges.resize(6 * size_t(mesh.triangle_count));
  ws.boxes.resize(6 * size_t(mesh.triangle_count));
  ws.normals.resize(mesh.triangle_count);
  ws.entries.resize(size_t(kEntriesPerTriangle) * mesh.triangle_count);
  ws.grid = true;
}

ContactStats resolve_contacts(const ContactMesh& mesh, float scale, glm::vec3* dense_positions,
                              uint32_t dense_vertex_count, ContactWorkspace& ws, const ContactBlend& blend,
                              const ContactPairs* detected) {
  ContactStats stats;
  ws.moved.clear();
  // The pass's lengths follow the output's scale (instance.h JointTransforms).
  const float gap = mesh.gap * scale, cap = mesh.cap * scale;
  if (mesh.triangle_count < 2 || dense_vertex_count != mesh.weld.size() || mesh.tangled_at_rest ||
      !(detected || ws.grid))
    return stats;
  glm::vec3* x = ws.positions.data();
  for (uint32_t w = 0; w < mesh.vertex_count; ++w) {
    const uint32_t r = mesh.representative[w];
    x[w] = blend.lbs ? blend_with_lbs(blend.lbs[r], dense_positions[r], blend.weight[r]) : dense_positions[r];
  }
  std::fill(ws.state.begin(), ws.state.end(), kMovable);
  if (blend.lbs)
    for (uint32_t i = 0; i < dense_vertex_count; ++i)
      if (!(blend.weight[i] >= kContactMinWeight)) ws.state[mesh.weld[i]] = 0;
  Grid grid(mesh, gap, ws, detected);
  if (!(detected ? grid.use_shared() : grid.build(cap))) return stats;  // a non-finite position: leave it
  ws.budget = PairBudget(mesh.triangle_count, kContactBudgetPasses);
  auto spent = [&] {
    stats.over_budget = ws.budget.left == 0;  // then move nothing: the counts were cut short
    return stats.over_budget;
  };
  // Detection: the corners of every intersecting pair become active.
  ws.active.clear();
  const uint32_t* tri = mesh.triangles.data();
  auto activate = [&](uint32_t s, uint32_t t) {
    // A pair the modeller made (it intersects at rest) is not a contact to resolve; a shared
    // search lists none (lbs_guard.h).
    if (!detected && mesh.intersects_at_rest(pair_key(s, t))) return;
    for (uint32_t k = 0; k < 3; ++k)
      for (uint32_t v : {tri[3 * size_t(s) + k], tri[3 * size_t(t) + k]})
        if ((ws.state[v] & (kActive | kMovable)) == kMovable) {
          ws.state[v] |= kActive;
          ws.active.push_back(v);  // capacity reserved for every vertex: no allocation
        }
  };
  if (detected) {
    for (size_t i = 0; i < detected->count; ++i)
      activate(uint32_t(detected->keys[i] >> 32), uint32_t(detected->keys[i]));
    stats.pairs_before = uint32_t(detected->count);
  } else {
    stats.pairs_before = grid.for_each_pair(activate);
  }
  if (spent() || stats.pairs_before == 0 || ws.active.empty()) return stats;
  std::sort(ws.active.begin(), ws.active.end());
  for (uint32_t v : ws.active) ws.start[v] = x[v];
  // Do no harm: an active vertex takes its push (or half, or a quarter of it) only if the
  // intersecting pairs around it do not become more; in index order, each seeing the moves
  // before it, sweep after sweep while some vertex moves. Its total motion stays within the
  // grid's pad. (Not more rather than fewer: a row of vertices crossing another sheet clears
  // only once all of them are out, and each alone changes no count; docs/tuning.md.)
  // Out of budget mid-way, the pass moves nothing: its moves are taken back, and with them the
  // growth of a shared search's boxes (Grid::moved), which the guard then reads as its own.
  auto give_up = [&] {
    for (uint32_t v : ws.active)
      if (ws.state[v] & kMoved) x[v] = ws.start[v];
    for (uint32_t v : ws.active)
      if (ws.state[v] & kMoved) grid.reset_boxes(v);
    return stats;
  };
  // After the first sweep, an active vertex that did not move when the pass last looked at it,
  // and near which nothing has moved since, is passed over: it would gather the same candidates
  // at the same places and decide again not to move (the output is the same bit for bit, only
  // the work budget is spent less: a pass that ran out of it before may now finish). Near: a
  // move's box (the moved vertex's star before and after it) meets the region of that look
  // (regions). Between two looks at a vertex every other active vertex is looked at once, so a
  // ring of as many moves holds those since. (With more active vertices than
  // kContactSkipCapacity, every vertex is looked at in every sweep.)
  const size_t active_count = ws.active.size();
  const bool skipping = active_count <= ws.seen.size();
  uint32_t moves = 0;
  const auto disturbed = [&](size_t i) {
    if (!skipping || ws.seen[i] == kLookAgain) return true;
    const float* r = ws.regions.data() + 6 * i;
    for (uint32_t m = ws.seen[i]; m < moves; ++m) {
      const float* b = ws.move_boxes.data() + 6 * (m % active_count);
      // Apart on some axis; not apart (NaN included) counts as near.
      if (!(r[3] < b[0] || b[3] < r[0] || r[4] < b[1] || b[4] < r[1] || r[5] < b[2] || b[5] < r[2])) return true;
    }
    return false;
  };
  for (uint32_t sweep = 0; sweep < kContactSweeps; ++sweep) {
    bool any = false;
    for (size_t i = 0; i < active_count; ++i) {
      const uint32_t v = ws.active[i];
      if (sweep > 0 && !disturbed(i)) {
        ws.seen[i] = moves;
        continue;
      }
      float unused[6];
      float* region = skipping ? ws.regions.data() + 6 * i : unused;
      if (skipping) ws.seen[i] = moves;
      // The triangles around v where it is: its pairs and its push.
      grid.gather(v, 0.0f, region);
      const glm::vec3 star_lo(region[0], region[1], region[2]), star_hi(region[3], region[4], region[5]);
      glm::vec3 push(0.0f);
      const uint32_t before = grid.pairs_around(v, &push);
      if (spent()) return give_up();
      if (before == 0 || !(glm::dot(push, push) > 0.0f)) continue;
      glm::vec3 total = x[v] + push - ws.start[v];
      const float length = glm::length(total);
      if (length > cap) total *= cap / length;
      glm::vec3 step = ws.start[v] + total - x[v];
      if (!(glm::dot(step, step) > 0.0f)) continue;  // at its cap already
      // Then those its star can meet on the way (the tries below take the step, half, a
      // quarter; twice its length covers the rounding of x + step).
      grid.gather(v, 2.0f * glm::length(step), region);
      const glm::vec3 old = x[v];
      bool accepted = false;
      for (int attempt = 0; attempt < 3 && !accepted; ++attempt, step *= 0.5f) {
        x[v] = old + step;
        accepted = grid.pairs_around(v, nullptr, before) <= before;
      }
      if (spent()) {
        x[v] = old;
        return give_up();
      }
      if (!accepted) {
        x[v] = old;
        continue;
      }
      ws.state[v] |= kMoved;
      grid.moved(v);
      any = true;
      if (!skipping) continue;
      glm::vec3 lo, hi;
      grid.star_box(v, lo, hi);
      lo = glm::min(lo, star_lo), hi = glm::max(hi, star_hi);
      float* b = ws.move_boxes.data() + 6 * (moves++ % active_count);
      b[0] = lo.x, b[1] = lo.y, b[2] = lo.z, b[3] = hi.x, b[4] = hi.y, b[5] = hi.z;
      ws.seen[i] = kLookAgain;
    }
    if (!any) break;
  }
  for (uint32_t v : ws.active)
    if (ws.state[v] & kMoved) ws.moved.push_back(v);  // capacity for every vertex
  stats.moved = uint32_t(ws.moved.size());
  if (stats.moved)
    for (uint32_t i = 0; i < dense_vertex_count; ++i)
      if (ws.state[mesh.weld[i]] & kMoved) {
        const glm::vec3& moved = x[mesh.weld[i]];
        // (With a blend, every copy of a moved vertex has w ≥ kContactMinWeight.)
        dense_positions[i] = blend.lbs ? blend.lbs[i] + (moved - blend.lbs[i]) / blend.weight[i] : moved;
      }
  return stats;
}

}  // namespace skelform::runtime
