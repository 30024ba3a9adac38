// Rest clearances of neighbouring leaves and the pose's bound on them (rest_clearance.h).
#include "rest_clearance.h"

#include "avx2_lanes.h"
#include "cpu.h"
#include "skin_blend.h"

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#if defined(__SSE2__)
#  include <xmmintrin.h>
#endif

namespace skelform::runtime {

namespace {

// The separation of the projections of `a` and `b` on `axis` (times its length), and its
// squared length.
struct Separation {
  double separation, length_squared;
};

Separation separation_along(const glm::dvec3& axis, const glm::dvec3* a, const glm::dvec3* b) {
  const double pa0 = glm::dot(axis, a[0]), pa1 = glm::dot(axis, a[1]), pa2 = glm::dot(axis, a[2]);
  const double pb0 = glm::dot(axis, b[0]), pb1 = glm::dot(axis, b[1]), pb2 = glm::dot(axis, b[2]);
  const double min_a = std::min(pa0, std::min(pa1, pa2)), max_a = std::max(pa0, std::max(pa1, pa2));
  const double min_b = std::min(pb0, std::min(pb1, pb2)), max_b = std::max(pb0, std::max(pb1, pb2));
  return {std::max(min_b - max_a, min_a - max_b), glm::dot(axis, axis)};
}

// The squared distance between two boxes (lo xyz, hi xyz), less its rounding.
double box_gap_squared(const float* a, const float* b) {
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double g = std::max(0.0, std::max(double(b[k]) - double(a[3 + k]), double(a[k]) - double(b[3 + k])));
    sum += g * g;
  }
  return sum * (1.0 - 1e-15);
}

// The distance between two boxes, no larger than the true one.
double box_gap(const float* a, const float* b) { return std::sqrt(box_gap_squared(a, b)) * (1.0 - 1e-15); }

// `d` as a float no smaller than it.
float round_up(double d) {
  float f = float(d);
  if (double(f) < d) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

// `d` as a float no larger than it.
float round_down(double d) {
  float f = float(d);
  if (double(f) > d) f = std::nextafter(f, 0.0f);
  return f;
}

}  // namespace

double clearance_between(const glm::dvec3* a_in, const glm::dvec3* b_in, double enough) {
  // Relative to a's first corner, as geometry::triangles_intersect: the products stay small.
  const glm::dvec3 o = a_in[0];
  const glm::dvec3 a[3] = {glm::dvec3(0.0), a_in[1] - o, a_in[2] - o};
  const glm::dvec3 b[3] = {b_in[0] - o, b_in[1] - o, b_in[2] - o};
  // Each projection rounds by a few ulps of the coordinates' size: the result is less that.
  double size = 0.0;
  for (const glm::dvec3* p : {a, b})
    for (int k = 0; k < 3; ++k)
      size = std::max(size, std::max(std::abs(p[k].x), std::max(std::abs(p[k].y), std::abs(p[k].z))));
  const double rounding = 1e-12 * size;
  const double target = enough + rounding;
  // The axes in the order most likely to part two triangles of a surface by the most: the
  // line between their centroids, the face normals, the in-plane edge normals, the edge
  // pairs; stop at one that parts them by `enough`. An axis is divided by its length only
  // where it parts them by more than the best so far.
  double gap = 0.0;
  auto take = [&](const glm::dvec3& axis) {
    const Separation s = separation_along(axis, a, b);
    if (!(s.separation > 0.0) || !(s.length_squared > 0.0)) return false;
    if (s.separation * s.separation > gap * gap * s.length_squared) gap = s.separation / std::sqrt(s.length_squared);
    return gap >= target;
  };
  const glm::dvec3 ea[3] = {a[1] - a[0], a[2] - a[1], a[0] - a[2]};
  const glm::dvec3 eb[3] = {b[1] - b[0], b[2] - b[1], b[0] - b[2]};
  const glm::dvec3 na = glm::cross(ea[0], ea[1]), nb = glm::cross(eb[0], eb[1]);
  bool done = take((b[0] + b[1] + b[2]) - (a[0] + a[1] + a[2])) || take(na) || take(nb);
  for (int i = 0; i < 3 && !done; ++i) done = take(glm::cross(na, ea[i])) || take(glm::cross(nb, eb[i]));
  for (int i = 0; i < 3 && !done; ++i)
    for (int j = 0; j < 3 && !done; ++j) done = take(glm::cross(ea[i], eb[j]));
  return std::max(0.0, gap - rounding);
}

RestClearance build_rest_clearance(const TriangleHierarchy& h, const glm::vec3* welded_rest, const uint32_t* triangles,
                                   const AllocatorRef& allocator) {
  RestClearance c(allocator);
  const size_t nodes = h.nodes.size();
  if (nodes == 0) return c;
  c.vertex_offsets.assign(nodes + 1, 0u);
  c.anchor.assign(nodes, 0u);
  c.anchor_rest.assign(nodes, glm::vec3(0.0f));
  c.reach.assign(nodes, 0.0f);
  c.altitude.assign(nodes, 0.0f);
  c.sphere.assign(nodes, glm::vec4(0.0f));
  c.rest_boxes.assign(6 * nodes, 0.0f);
  // Boxes (children follow their parents: from the back).
  for (size_t n = nodes; n-- > 0;) {
    const HierarchyNode node = h.nodes[n];
    float* box = c.rest_boxes.data() + 6 * n;
    if (node.count == 0) {
      const float* c0 = c.rest_boxes.data() + 6 * size_t(node.first);
      std::copy(c0, c0 + 6, box);
      grow_box(box, c0 + 6);
      continue;
    }
    for (int k = 0; k < 3; ++k) box[k] = std::numeric_limits<float>::max(), box[3 + k] = -box[k];
    for (uint32_t i = node.first; i < node.first + node.count; ++i)
      for (int k = 0; k < 3; ++k) {
        const glm::vec3& p = welded_rest[triangles[3 * size_t(h.order[i]) + size_t(k)]];
        for (int axis = 0; axis < 3; ++axis) {
          box[axis] = std::min(box[axis], p[axis]);
          box[3 + axis] = std::max(box[3 + axis], p[axis]);
        }
      }
  }
  // Each leaf's vertices, anchor, sphere and offsets.
  for (size_t n = 0; n < nodes; ++n) {
    const HierarchyNode node = h.nodes[n];
    const size_t begin = c.vertices.size();
    for (uint32_t i = node.first; node.count > 0 && i < node.first + node.count; ++i)
      for (int k = 0; k < 3; ++k) c.vertices.push_back(triangles[3 * size_t(h.order[i]) + size_t(k)]);
    std::sort(c.vertices.begin() + ptrdiff_t(begin), c.vertices.end());
    c.vertices.erase(std::unique(c.vertices.begin() + ptrdiff_t(begin), c.vertices.end()), c.vertices.end());
    c.vertex_offsets[n + 1] = uint32_t(c.vertices.size());
    if (node.count == 0) continue;
    const float* box = c.rest_boxes.data() + 6 * n;
    const glm::vec3 centre(0.5 * (glm::dvec3(box[0], box[1], box[2]) + glm::dvec3(box[3], box[4], box[5])));
    double radius = 0.0, nearest = std::numeric_limits<double>::infinity();
    for (size_t k = begin; k < c.vertices.size(); ++k) {
      const double r = glm::length(glm::dvec3(welded_rest[c.vertices[k]]) - glm::dvec3(centre));
      radius = std::max(radius, r);
      if (r < nearest) nearest = r, c.anchor[n] = c.vertices[k];
    }
    c.sphere[n] = glm::vec4(centre, round_up(radius));
    // The least altitude of the leaf's triangles (twice the area over the longest edge).
    double altitude = std::numeric_limits<double>::infinity();
    for (uint32_t i = node.first; i < node.first + node.count; ++i) {
      const uint32_t* q = triangles + 3 * size_t(h.order[i]);
      const glm::dvec3 p0(welded_rest[q[0]]), p1(welded_rest[q[1]]), p2(welded_rest[q[2]]);
      const double longest = std::max({glm::length(p1 - p0), glm::length(p2 - p1), glm::length(p0 - p2)});
      const double twice_area = glm::length(glm::cross(p1 - p0, p2 - p0));
      altitude = std::min(altitude, longest > 0.0 ? twice_area / longest * (1.0 - 1e-12) : 0.0);
    }
    c.altitude[n] = std::isfinite(altitude) ? round_down(altitude) : 0.0f;
    c.anchor_rest[n] = welded_rest[c.anchor[n]];
    double reach = 0.0;
    for (size_t k = begin; k < c.vertices.size(); ++k) {
      const glm::dvec3 offset = glm::dvec3(welded_rest[c.vertices[k]]) - glm::dvec3(c.anchor_rest[n]);
      reach = std::max({reach, std::abs(offset.x), std::abs(offset.y), std::abs(offset.z)});
    }
    c.reach[n] = round_up(reach);
  }
  const size_t entries = c.vertices.size();
  const uint32_t reach = entries == 0 ? 0u : *std::max_element(c.vertices.begin(), c.vertices.end());
  c.gathers_fit = gather_offsets_fit(entries) && gather_offsets_fit(uint64_t(reach) + 1);
  c.offsets.resize(3 * entries);
  for (size_t n = 0; n < nodes; ++n)
    for (uint32_t k = c.vertex_offsets[n]; k < c.vertex_offsets[n + 1]; ++k) {
      const glm::vec3 offset = welded_rest[c.vertices[k]] - c.anchor_rest[n];  // rounded: see leaf_map
      for (size_t axis = 0; axis < 3; ++axis) c.offsets[axis * entries + k] = offset[int(axis)];
    }
  // The leaf pairs whose rest boxes meet, by a descent of the hierarchy against itself. Every
  // leaf pair and every pair of triangles compared spends from a budget linear in the
  // triangles: a mesh tangled over itself at rest (all boxes meeting all boxes) would make this
  // quadratic, and gets no clearances (every leaf pair is then tested, as without the bound).
  PairBudget budget(uint32_t(h.order.size()), kClearanceBudgetSearches);
  struct Pair {
    uint32_t a, b;
  };
  Array<Pair> leaf_pairs{CallbackAllocator<Pair>(allocator)};
  Array<Pair> stack{CallbackAllocator<Pair>(allocator)};
  stack.push_back({0, 0});
  while (!stack.empty()) {
    const Pair p = stack.back();
    stack.pop_back();
    const HierarchyNode na = h.nodes[p.a], nb = h.nodes[p.b];
    if (p.a == p.b) {
      if (na.count > 0) {
        if (!budget.spend()) return RestClearance(allocator);
        leaf_pairs.push_back(p);
      } else {
        stack.push_back({na.first, na.first});
        stack.push_back({na.first + 1, na.first + 1});
        stack.push_back({na.first, na.first + 1});
      }
      continue;
    }
    if (!hierarchy_boxes_meet(c.rest_boxes.data() + 6 * size_t(p.a), c.rest_boxes.data() + 6 * size_t(p.b))) continue;
    if (na.count > 0 && nb.count > 0) {
      if (!budget.spend()) return RestClearance(allocator);
      leaf_pairs.push_back({std::min(p.a, p.b), std::max(p.a, p.b)});
      continue;
    }
    auto size = [&](uint32_t n) {
      const float* box = c.rest_boxes.data() + 6 * size_t(n);
      return (box[3] - box[0]) + (box[4] - box[1]) + (box[5] - box[2]);
    };
    if (nb.count > 0 || (na.count == 0 && size(p.a) >= size(p.b))) {
      stack.push_back({na.first, p.b});
      stack.push_back({na.first + 1, p.b});
    } else {
      stack.push_back({p.a, nb.first});
      stack.push_back({p.a, nb.first + 1});
    }
  }
  // D of each pair, from the triangles' rest boxes by slot.
  Array<float> slot_boxes{CallbackAllocator<float>(allocator)};
  slot_boxes.resize(6 * h.order.size());
  for (size_t i = 0; i < h.order.size(); ++i) {
    const uint32_t* q = triangles + 3 * size_t(h.order[i]);
    for (int axis = 0; axis < 3; ++axis) {
      const float p0 = welded_rest[q[0]][axis], p1 = welded_rest[q[1]][axis], p2 = welded_rest[q[2]][axis];
      slot_boxes[6 * i + size_t(axis)] = std::min(p0, std::min(p1, p2));
      slot_boxes[6 * i + 3 + size_t(axis)] = std::max(p0, std::max(p1, p2));
    }
  }
  // D need not exceed what a pose's strays could use: kClearanceCap mean rest edges. Starting
  // from it, the search passes over every pair of triangles farther apart than that.
  double edge_sum = 0.0;
  for (size_t i = 0; i < h.order.size(); ++i) {
    const uint32_t* q = triangles + 3 * size_t(h.order[i]);
    for (int k = 0; k < 3; ++k) edge_sum += double(glm::length(welded_rest[q[k]] - welded_rest[q[(k + 1) % 3]]));
  }
  const double cap = h.order.empty() ? 0.0 : kClearanceCap * edge_sum / (3.0 * double(h.order.size()));
  // Self pairs first: they set each leaf's D near its own spacing, which
  // then passes over most pairs of the neighbours' triangles by their boxes.
  {
    Array<Pair> ordered{CallbackAllocator<Pair>(allocator)};
    ordered.reserve(leaf_pairs.size());
    for (const Pair& p : leaf_pairs)
      if (p.a == p.b) ordered.push_back(p);
    for (const Pair& p : leaf_pairs)
      if (p.a != p.b) ordered.push_back(p);
    leaf_pairs.swap(ordered);
  }
  Array<double> least_of{CallbackAllocator<double>(allocator)};
  least_of.assign(nodes, cap);
  for (const Pair& pair : leaf_pairs) {
    const HierarchyNode na = h.nodes[pair.a], nb = h.nodes[pair.b];
    const bool self = pair.a == pair.b;
    // A pair of triangles lowers a leaf's D only below it: the larger of the two bounds which.
    double least = std::max(least_of[pair.a], least_of[pair.b]);
    for (uint32_t i = na.first; i < na.first + na.count && least > 0.0; ++i) {
      const uint32_t* ct = triangles + 3 * size_t(h.order[i]);
      const float* bt = slot_boxes.data() + 6 * size_t(i);
      if (!self && box_gap_squared(bt, c.rest_boxes.data() + 6 * size_t(pair.b)) >= least * least) continue;
      const glm::dvec3 pt[3] = {glm::dvec3(welded_rest[ct[0]]), glm::dvec3(welded_rest[ct[1]]),
                                glm::dvec3(welded_rest[ct[2]])};
      for (uint32_t j = self ? i + 1 : nb.first; j < nb.first + nb.count && least > 0.0; ++j) {
        if (!budget.spend()) return RestClearance(allocator);
        const uint32_t* cs = triangles + 3 * size_t(h.order[j]);
        if (box_gap_squared(bt, slot_boxes.data() + 6 * size_t(j)) >= least * least) continue;  // as far at least
        if (triangles_share_corner(ct, cs)) continue;
        const glm::dvec3 ps[3] = {glm::dvec3(welded_rest[cs[0]]), glm::dvec3(welded_rest[cs[1]]),
                                  glm::dvec3(welded_rest[cs[2]])};
        least = std::min(least, clearance_between(pt, ps, least));
      }
    }
    least_of[pair.a] = std::min(least_of[pair.a], least);
    least_of[pair.b] = std::min(least_of[pair.b], least);
  }
  c.clearance.resize(nodes);
  for (size_t n = 0; n < nodes; ++n) c.clearance[n] = round_down(least_of[n]);
  return c;
}

namespace {

// A lower bound on the smallest eigenvalue of the symmetric G: its eigenvalues sum to 3q (q the
// mean of the diagonal), and their squared deviations from q to ‖G − qI‖²_F, so none is below
// q − √(2/3)·‖G − qI‖_F. Tight where G is near a multiple of I, as LᵀL is for a rotation and
// a scale; no trigonometry.
double least_eigenvalue_bound(const glm::dmat3& g) {
  const double q = (g[0][0] + g[1][1] + g[2][2]) / 3.0;
  const double off = g[0][1] * g[0][1] + g[0][2] * g[0][2] + g[1][2] * g[1][2];
  const double spread =
      (g[0][0] - q) * (g[0][0] - q) + (g[1][1] - q) * (g[1][1] - q) + (g[2][2] - q) * (g[2][2] - q) + 2.0 * off;
  return q - std::sqrt(2.0 / 3.0 * spread);
}

// stray_sums (rest_clearance.h) with SSE2 four entries at a time, else one at a time.
detail::StraySums stray_sums_baseline(const RestClearance& c, const glm::vec3* x, uint32_t begin, uint32_t end,
                                      const float* l, const glm::vec3& xa) {
  using detail::StraySums;
  const size_t entries = c.vertices.size();
  const float* ox = c.offsets.data();
  const float* oy = ox + entries;
  const float* oz = oy + entries;
  const uint32_t* v = c.vertices.data();
  StraySums sums;
  uint32_t k = begin;
#if defined(__SSE2__)
  __m128 squared = _mm_setzero_ps(), spread = _mm_setzero_ps(), nan = _mm_setzero_ps();
  const __m128 sign = _mm_set1_ps(-0.0f);
  const __m128 ax = _mm_set1_ps(xa.x), ay = _mm_set1_ps(xa.y), az = _mm_set1_ps(xa.z);
  __m128 m[9];
  for (int i = 0; i < 9; ++i) m[i] = _mm_set1_ps(l[i]);
  for (; k < end; k += 4) {
    // The last group repeats the leaf's last entry: a maximum does not mind.
    const uint32_t i1 = std::min(k + 1, end - 1), i2 = std::min(k + 2, end - 1), i3 = std::min(k + 3, end - 1);
    const glm::vec3 &p0 = x[v[k]], &p1 = x[v[i1]], &p2 = x[v[i2]], &p3 = x[v[i3]];
    const __m128 dx = _mm_sub_ps(_mm_setr_ps(p0.x, p1.x, p2.x, p3.x), ax);
    const __m128 dy = _mm_sub_ps(_mm_setr_ps(p0.y, p1.y, p2.y, p3.y), ay);
    const __m128 dz = _mm_sub_ps(_mm_setr_ps(p0.z, p1.z, p2.z, p3.z), az);
    const __m128 qx = _mm_setr_ps(ox[k], ox[i1], ox[i2], ox[i3]);
    const __m128 qy = _mm_setr_ps(oy[k], oy[i1], oy[i2], oy[i3]);
    const __m128 qz = _mm_setr_ps(oz[k], oz[i1], oz[i2], oz[i3]);
    auto row = [&](int r, __m128 d) {
      const __m128 lq =
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(m[3 * r], qx), _mm_mul_ps(m[3 * r + 1], qy)), _mm_mul_ps(m[3 * r + 2], qz));
      return _mm_sub_ps(d, lq);
    };
    const __m128 ex = row(0, dx), ey = row(1, dy), ez = row(2, dz);
    const __m128 e2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ex, ex), _mm_mul_ps(ey, ey)), _mm_mul_ps(ez, ez));
    const __m128 l1 = _mm_add_ps(_mm_add_ps(_mm_andnot_ps(sign, dx), _mm_andnot_ps(sign, dy)), _mm_andnot_ps(sign, dz));
    nan = _mm_or_ps(nan, _mm_or_ps(_mm_cmpunord_ps(e2, e2), _mm_cmpunord_ps(l1, l1)));
    squared = _mm_max_ps(squared, e2);
    spread = _mm_max_ps(spread, l1);
  }
  squared = _mm_max_ps(squared, _mm_shuffle_ps(squared, squared, _MM_SHUFFLE(1, 0, 3, 2)));
  squared = _mm_max_ps(squared, _mm_shuffle_ps(squared, squared, _MM_SHUFFLE(2, 3, 0, 1)));
  spread = _mm_max_ps(spread, _mm_shuffle_ps(spread, spread, _MM_SHUFFLE(1, 0, 3, 2)));
  spread = _mm_max_ps(spread, _mm_shuffle_ps(spread, spread, _MM_SHUFFLE(2, 3, 0, 1)));
  sums.squared = _mm_cvtss_f32(squared);
  sums.spread = _mm_cvtss_f32(spread);
  if (_mm_movemask_ps(nan)) sums.squared = std::numeric_limits<float>::quiet_NaN();
#else
  for (; k < end; ++k) {
    const glm::vec3 d = x[v[k]] - xa;
    const glm::vec3 q(ox[k], oy[k], oz[k]);
    const glm::vec3 e(d.x - (l[0] * q.x + l[1] * q.y + l[2] * q.z), d.y - (l[3] * q.x + l[4] * q.y + l[5] * q.z),
                      d.z - (l[6] * q.x + l[7] * q.y + l[8] * q.z));
    const float e2 = e.x * e.x + e.y * e.y + e.z * e.z, l1 = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
    if (std::isnan(e2) || std::isnan(l1)) sums.squared = std::numeric_limits<float>::quiet_NaN();
    if (!std::isnan(sums.squared)) sums.squared = std::max(sums.squared, e2);
    sums.spread = std::max(sums.spread, l1);
  }
#endif
  return sums;
}

#if defined(SKELFORM_HAS_AVX2_KERNELS)
// stray_sums eight entries at a time: per entry the baseline's operations (the maxima do not
// depend on the order their terms come in, and a NaN is flagged apart), the last group
// repeating the leaf's last entry as the SSE2 loop's does. Entries and welded vertices must take
// int32 gather offsets (RestClearance::gathers_fit).
__attribute__((target("avx2"))) detail::StraySums stray_sums_avx2(const RestClearance& c, const glm::vec3* x,
                                                                  uint32_t begin, uint32_t end, const float* l,
                                                                  const glm::vec3& xa) {
  const size_t entries = c.vertices.size();
  const float* ox = c.offsets.data();
  const float* oy = ox + entries;
  const float* oz = oy + entries;
  const int* v = reinterpret_cast<const int*>(c.vertices.data());
  __m256 squared = _mm256_setzero_ps(), spread = _mm256_setzero_ps(), nan = _mm256_setzero_ps();
  const __m256 sign = _mm256_set1_ps(-0.0f);
  const __m256 anchor[3] = {_mm256_set1_ps(xa.x), _mm256_set1_ps(xa.y), _mm256_set1_ps(xa.z)};
  __m256 m[9];
  for (int i = 0; i < 9; ++i) m[i] = _mm256_set1_ps(l[i]);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), last = _mm256_set1_epi32(int(end) - 1);
  for (uint32_t k = begin; k < end; k += 8) {
    __m256i vertex;
    __m256 q[3];
    if (k + 8 <= end) {  // eight consecutive entries
      vertex = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(v + k));
      q[0] = _mm256_loadu_ps(ox + k), q[1] = _mm256_loadu_ps(oy + k), q[2] = _mm256_loadu_ps(oz + k);
    } else {
      const __m256i at = _mm256_min_epi32(_mm256_add_epi32(_mm256_set1_epi32(int(k)), lane), last);
      vertex = avx2::gather_epi32(v, at);
      q[0] = avx2::gather_ps(ox, at), q[1] = avx2::gather_ps(oy, at), q[2] = avx2::gather_ps(oz, at);
    }
    const __m256i vertex3 = _mm256_add_epi32(vertex, _mm256_add_epi32(vertex, vertex));
    __m256 d[3], e[3];
    for (int axis = 0; axis < 3; ++axis) {
      d[axis] = _mm256_sub_ps(avx2::gather_axis(x, axis, vertex3), anchor[axis]);
      const __m256 lq =
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(m[3 * axis], q[0]), _mm256_mul_ps(m[3 * axis + 1], q[1])),
                        _mm256_mul_ps(m[3 * axis + 2], q[2]));
      e[axis] = _mm256_sub_ps(d[axis], lq);
    }
    const __m256 e2 =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(e[0], e[0]), _mm256_mul_ps(e[1], e[1])), _mm256_mul_ps(e[2], e[2]));
    const __m256 l1 = _mm256_add_ps(_mm256_add_ps(_mm256_andnot_ps(sign, d[0]), _mm256_andnot_ps(sign, d[1])),
                                    _mm256_andnot_ps(sign, d[2]));
    nan = _mm256_or_ps(nan, _mm256_or_ps(_mm256_cmp_ps(e2, e2, _CMP_UNORD_Q), _mm256_cmp_ps(l1, l1, _CMP_UNORD_Q)));
    squared = _mm256_max_ps(squared, e2);
    spread = _mm256_max_ps(spread, l1);
  }
  alignas(32) float lanes[2][8];
  _mm256_store_ps(lanes[0], squared);
  _mm256_store_ps(lanes[1], spread);
  detail::StraySums sums;
  for (int i = 0; i < 8; ++i)
    sums.squared = std::max(sums.squared, lanes[0][i]), sums.spread = std::max(sums.spread, lanes[1][i]);
  if (_mm256_movemask_ps(nan)) sums.squared = std::numeric_limits<float>::quiet_NaN();
  return sums;
}
#endif

const LeafMap& leaf_map(const RestClearance& c, const ClearancePose& pose, ClearanceMaps& maps, uint32_t n) {
  LeafMap& m = maps.maps[n];
  if (maps.stamps[n] == maps.stamp) return m;
  maps.stamps[n] = maps.stamp;
  const uint32_t anchor = c.anchor[n], r = pose.representative[anchor];
  float a[12];
  blend_affine(pose.affine, pose.joints + size_t(r) * pose.influences, pose.weights + size_t(r) * pose.influences,
               pose.influences, a);
  const float l[9] = {a[0], a[1], a[2], a[4], a[5], a[6], a[8], a[9], a[10]};
  double sum = 0.0;  // Σ |L_ij|
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) {
      m.linear[col][row] = l[3 * row + col];  // glm is column-major
      sum += std::abs(double(l[3 * row + col]));
    }
  const glm::vec3 xa = pose.positions[anchor];
  m.anchor = xa;
  const detail::StraySums sums =
      detail::stray_sums(c, pose.positions, c.vertex_offsets[n], c.vertex_offsets[n + 1], l, xa, cpu_has_avx2());
  // The float loop's rounding: each coordinate of x_v − x_anchor − L·offset_v, with the offset
  // itself rounded, is within a few units u = 2⁻²⁴ of |x_v − x_anchor|₁ + Σ|L_ij|·reach; the
  // bound takes 16 (and the square and root, a few u of the result).
  constexpr double u = 1.0 / 16777216.0;
  // Squares below 2⁻¹²⁶ lose their bits (subnormal, or flushed to zero where the caller set
  // FTZ/DAZ): 2⁻⁶⁰ more covers that in any case.
  m.stray = std::sqrt(double(sums.squared)) * (1.0 + 8.0 * u) +
            16.0 * u * (double(sums.spread) + sum * double(c.reach[n])) + std::ldexp(1.0, -60);
  const glm::dmat3 linear(m.linear);
  const glm::dmat3 g = glm::transpose(linear) * linear;
  const double trace = g[0][0] + g[1][1] + g[2][2];
  // Less the rounding, a few ulps of G's size.
  m.stretch = std::sqrt(std::max(0.0, least_eigenvalue_bound(g) - 1e-12 * trace));
  return m;
}

}  // namespace

detail::StraySums detail::stray_sums(const RestClearance& c, const glm::vec3* x, uint32_t begin, uint32_t end,
                                     const float* l, const glm::vec3& xa, bool avx2) {
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (avx2 && c.gathers_fit) return stray_sums_avx2(c, x, begin, end, l, xa);
#else
  (void)avx2;
#endif
  return stray_sums_baseline(c, x, begin, end, l, xa);
}

bool leaves_apart(const RestClearance& c, const ClearancePose& pose, ClearanceMaps& maps, uint32_t a, uint32_t b) {
  // Leaves whose rest boxes meet: each one's D holds for their pairs. Others: their boxes' gap.
  const float* box_a = c.rest_boxes.data() + 6 * size_t(a);
  const float* box_b = c.rest_boxes.data() + 6 * size_t(b);
  const double clearance =
      hierarchy_boxes_meet(box_a, box_b) ? double(std::max(c.clearance[a], c.clearance[b])) : box_gap(box_a, box_b);
  if (!(clearance > 0.0)) return false;
  const LeafMap& ma = leaf_map(c, pose, maps, a);
  const LeafMap& mb = a == b ? ma : leaf_map(c, pose, maps, b);
  // Neither leaf's triangles collapse: a vertex is at least σ_min·h from the line of its
  // opposite edge under the map (h: the leaf's least rest altitude), and strays r from there, as
  // the edge's ends do, so 2r < σ_min·h keeps every altitude positive. (The exact test's axes
  // part two separated triangles only where neither has collapsed to a segment or a point.)
  if (!(2.0 * ma.stray < ma.stretch * double(c.altitude[a]) * (1.0 - 1e-6)) ||
      !(2.0 * mb.stray < mb.stretch * double(c.altitude[b]) * (1.0 - 1e-6)))
    return false;
  const double room = ma.stretch * clearance * (1.0 - 1e-6);
  double reach = ma.stray + mb.stray;
  if (!(room > reach * (1.0 + 1e-6))) return false;  // the strays alone fill it (NaN: no)
  if (a != b) {
    // b's vertices under a's map: A_b(q) − A_a(q) at q = c_b + δ, |δ| ≤ ρ_b.
    const glm::dvec3 centre(c.sphere[b]);
    const glm::dmat3 la(ma.linear), lb(mb.linear);
    const glm::dvec3 at_centre = glm::dvec3(mb.anchor) - glm::dvec3(ma.anchor) +
                                 lb * (centre - glm::dvec3(c.anchor_rest[b])) -
                                 la * (centre - glm::dvec3(c.anchor_rest[a]));
    const glm::dmat3 difference = lb - la;
    double frobenius = 0.0;
    for (int col = 0; col < 3; ++col) frobenius += glm::dot(difference[col], difference[col]);
    reach += glm::length(at_centre) + std::sqrt(frobenius) * double(c.sphere[b].w);
  }
  return room > reach * (1.0 + 1e-6);
}

}  // namespace skelform::runtime
