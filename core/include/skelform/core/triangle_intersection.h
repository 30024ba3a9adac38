// Do two triangles meet? One definition for the runtime's LBS guard (lbs_guard.h) and the
// baker's self-intersection metric (bake/self_intersection.h), so the pairs the runtime keeps
// out of its output are exactly the pairs the metric counts.
//
// Separating-axis test in double precision over the 17 candidate axes of two triangles (two
// face normals, nine edge-edge cross products, six in-plane edge normals for the coplanar
// case): crossing, touching and coplanar overlaps are all found. Float input converts to
// double exactly, and every coordinate is first taken relative to the first corner, which
// keeps the products small. A degenerate triangle (a segment or a point) is handled by the
// same axes as far as they exist; a zero axis separates nothing.
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>

namespace skelform::geometry {

namespace detail {

inline bool separated_along(const glm::dvec3& axis, const glm::dvec3* a, const glm::dvec3* b) {
  if (!(glm::dot(axis, axis) > 0.0)) return false;
  const double pa0 = glm::dot(axis, a[0]), pa1 = glm::dot(axis, a[1]), pa2 = glm::dot(axis, a[2]);
  const double pb0 = glm::dot(axis, b[0]), pb1 = glm::dot(axis, b[1]), pb2 = glm::dot(axis, b[2]);
  const double min_a = std::min({pa0, pa1, pa2}), max_a = std::max({pa0, pa1, pa2});
  const double min_b = std::min({pb0, pb1, pb2}), max_b = std::max({pb0, pb1, pb2});
  return max_a < min_b || max_b < min_a;
}

}  // namespace detail

// True when the closed triangles (a0, a1, a2) and (b0, b1, b2) share at least one point
// (touching counts).
inline bool triangles_intersect(const glm::dvec3& a0, const glm::dvec3& a1, const glm::dvec3& a2, const glm::dvec3& b0,
                                const glm::dvec3& b1, const glm::dvec3& b2) {
  const glm::dvec3 origin = a0;
  const glm::dvec3 a[3] = {glm::dvec3(0.0), a1 - origin, a2 - origin};
  const glm::dvec3 b[3] = {b0 - origin, b1 - origin, b2 - origin};
  const glm::dvec3 edge_a[3] = {a[1] - a[0], a[2] - a[1], a[0] - a[2]};
  const glm::dvec3 edge_b[3] = {b[1] - b[0], b[2] - b[1], b[0] - b[2]};
  const glm::dvec3 normal_a = glm::cross(edge_a[0], edge_a[1]);
  const glm::dvec3 normal_b = glm::cross(edge_b[0], edge_b[1]);
  // Any separating axis decides, so the order only matters for speed: the face normals, then
  // the in-plane edge normals (which separate the near-coplanar neighbours of a smooth surface,
  // the pairs a mesh's broad phase yields most), then the edge-edge axes.
  if (detail::separated_along(normal_a, a, b) || detail::separated_along(normal_b, a, b)) return false;
  for (const glm::dvec3& ea : edge_a)
    if (detail::separated_along(glm::cross(normal_a, ea), a, b)) return false;
  for (const glm::dvec3& eb : edge_b)
    if (detail::separated_along(glm::cross(normal_b, eb), a, b)) return false;
  for (const glm::dvec3& ea : edge_a)
    for (const glm::dvec3& eb : edge_b)
      if (detail::separated_along(glm::cross(ea, eb), a, b)) return false;
  return true;
}

}  // namespace skelform::geometry
