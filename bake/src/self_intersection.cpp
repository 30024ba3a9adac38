// The self-intersection metric (DESIGN.md "Metrics"): uniform-grid broad phase, separating-axis
// narrow phase in double.
#include "skelform/bake/self_intersection.h"

#include "skelform/core/triangle_intersection.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace skelform::bake {
namespace {

struct Box {
  Vec3 min, max;
};

bool boxes_overlap(const Box& p, const Box& q) {
  return p.min.x <= q.max.x && q.min.x <= p.max.x && p.min.y <= q.max.y && q.min.y <= p.max.y && p.min.z <= q.max.z &&
         q.min.z <= p.max.z;
}

}  // namespace

bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0, const Vec3& b1,
                         const Vec3& b2) {
  return geometry::triangles_intersect(a0, a1, a2, b0, b1, b2);
}

namespace {

// Calls found(s, t) once for every unordered intersecting pair of triangles sharing no
// vertex (s < t not guaranteed).
template <class Found>
void visit_self_intersections(const TriangleMesh& mesh, Found&& found) {
  const size_t triangle_count = mesh.triangles.size();
  if (triangle_count < 2) return;

  std::vector<Box> boxes(triangle_count);
  Box all{Vec3(1e300), Vec3(-1e300)};
  double extent_sum = 0.0;
  for (size_t t = 0; t < triangle_count; ++t) {
    const Triangle& tri = mesh.triangles[t];
    const Vec3& p0 = mesh.positions[tri[0]];
    const Vec3& p1 = mesh.positions[tri[1]];
    const Vec3& p2 = mesh.positions[tri[2]];
    boxes[t] = {glm::min(p0, glm::min(p1, p2)), glm::max(p0, glm::max(p1, p2))};
    all.min = glm::min(all.min, boxes[t].min);
    all.max = glm::max(all.max, boxes[t].max);
    const Vec3 size = boxes[t].max - boxes[t].min;
    extent_sum += std::max({size.x, size.y, size.z});
  }
  const Vec3 extent = all.max - all.min;
  const double largest = std::max({extent.x, extent.y, extent.z});
  if (!(largest > 0.0) || !std::isfinite(largest)) {
    // Everything at one point (or non-finite input): test every pair (tiny or broken meshes).
    for (size_t s = 0; s < triangle_count; ++s)
      for (size_t t = s + 1; t < triangle_count; ++t) {
        const Triangle& p = mesh.triangles[s];
        const Triangle& q = mesh.triangles[t];
        bool adjacent = false;
        for (uint32_t i : p)
          for (uint32_t j : q) adjacent |= i == j;
        if (!adjacent && triangles_intersect(mesh.positions[p[0]], mesh.positions[p[1]], mesh.positions[p[2]],
                                             mesh.positions[q[0]], mesh.positions[q[1]], mesh.positions[q[2]]))
          found(uint32_t(s), uint32_t(t));
      }
    return;
  }

  // Cell about the mean triangle size, so a triangle covers a few cells; coarsened until the
  // grid has at most ~4 cells per triangle (a surface fills few of a dense grid's cells).
  double cell = std::max(extent_sum / static_cast<double>(triangle_count), largest * 1e-6);
  const double max_cells = 4.0 * static_cast<double>(triangle_count) + 64.0;
  std::array<int64_t, 3> dims{};
  for (int attempt = 0; attempt < 64; ++attempt) {
    for (int k = 0; k < 3; ++k) dims[k] = std::max<int64_t>(1, static_cast<int64_t>(std::ceil(extent[k] / cell)));
    const double cells = static_cast<double>(dims[0]) * static_cast<double>(dims[1]) * static_cast<double>(dims[2]);
    if (cells <= max_cells) break;
    cell *= std::cbrt(cells / max_cells) * 1.01;
  }
  auto cell_of = [&](double x, int k) {
    const int64_t c = static_cast<int64_t>((x - all.min[k]) / cell);
    return std::clamp<int64_t>(c, 0, dims[k] - 1);
  };
  struct CellRange {
    std::array<int64_t, 3> lo, hi;
  };
  std::vector<CellRange> ranges(triangle_count);
  const size_t cell_count = static_cast<size_t>(dims[0] * dims[1] * dims[2]);
  std::vector<size_t> offsets(cell_count + 1, 0);
  auto linear = [&](int64_t x, int64_t y, int64_t z) { return static_cast<size_t>((z * dims[1] + y) * dims[0] + x); };
  for (size_t t = 0; t < triangle_count; ++t) {
    for (int k = 0; k < 3; ++k) {
      ranges[t].lo[k] = cell_of(boxes[t].min[k], k);
      ranges[t].hi[k] = cell_of(boxes[t].max[k], k);
    }
    const CellRange& r = ranges[t];
    for (int64_t z = r.lo[2]; z <= r.hi[2]; ++z)
      for (int64_t y = r.lo[1]; y <= r.hi[1]; ++y)
        for (int64_t x = r.lo[0]; x <= r.hi[0]; ++x) ++offsets[linear(x, y, z) + 1];
  }
  for (size_t c = 0; c < cell_count; ++c) offsets[c + 1] += offsets[c];
  std::vector<uint32_t> entries(offsets[cell_count]);
  std::vector<size_t> fill(offsets.begin(), offsets.end() - 1);
  for (size_t t = 0; t < triangle_count; ++t) {
    const CellRange& r = ranges[t];
    for (int64_t z = r.lo[2]; z <= r.hi[2]; ++z)
      for (int64_t y = r.lo[1]; y <= r.hi[1]; ++y)
        for (int64_t x = r.lo[0]; x <= r.hi[0]; ++x) entries[fill[linear(x, y, z)]++] = static_cast<uint32_t>(t);
  }

  for (int64_t z = 0; z < dims[2]; ++z)
    for (int64_t y = 0; y < dims[1]; ++y)
      for (int64_t x = 0; x < dims[0]; ++x) {
        const size_t c = linear(x, y, z);
        for (size_t i = offsets[c]; i < offsets[c + 1]; ++i) {
          const uint32_t s = entries[i];
          const Triangle& p = mesh.triangles[s];
          for (size_t j = i + 1; j < offsets[c + 1]; ++j) {
            const uint32_t t = entries[j];
            // Each pair once: in the first cell of the overlap of both cell ranges.
            if (std::max(ranges[s].lo[0], ranges[t].lo[0]) != x || std::max(ranges[s].lo[1], ranges[t].lo[1]) != y ||
                std::max(ranges[s].lo[2], ranges[t].lo[2]) != z)
              continue;
            if (!boxes_overlap(boxes[s], boxes[t])) continue;
            const Triangle& q = mesh.triangles[t];
            if (p[0] == q[0] || p[0] == q[1] || p[0] == q[2] || p[1] == q[0] || p[1] == q[1] || p[1] == q[2] ||
                p[2] == q[0] || p[2] == q[1] || p[2] == q[2])
              continue;
            if (triangles_intersect(mesh.positions[p[0]], mesh.positions[p[1]], mesh.positions[p[2]],
                                    mesh.positions[q[0]], mesh.positions[q[1]], mesh.positions[q[2]]))
              found(s, t);
          }
        }
      }
}

}  // namespace

size_t count_self_intersections(const TriangleMesh& mesh) {
  size_t count = 0;
  visit_self_intersections(mesh, [&](uint32_t, uint32_t) { ++count; });
  return count;
}

std::vector<std::pair<uint32_t, uint32_t>> self_intersecting_pairs(const TriangleMesh& mesh) {
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  visit_self_intersections(mesh, [&](uint32_t s, uint32_t t) { pairs.emplace_back(std::min(s, t), std::max(s, t)); });
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace skelform::bake
