// The reference every pair search is checked against: each pair of triangles that share no
// vertex, tested one by one with the exact triangle-pair test both the baker and the runtime
// use (skelform/core/triangle_intersection.h). Quadratic: for test meshes only.
#pragma once

#include "skelform/core/triangle_intersection.h"

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace skelform::test {

// Intersecting pairs (s, t), s < t, of `triangles` (vertex indices); `position(v)` gives vertex
// v as a glm::dvec3.
template <class Position>
std::vector<std::pair<uint32_t, uint32_t>> brute_force_pairs(const std::vector<std::array<uint32_t, 3>>& triangles,
                                                             Position&& position) {
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  for (uint32_t s = 0; s < triangles.size(); ++s)
    for (uint32_t t = s + 1; t < triangles.size(); ++t) {
      const std::array<uint32_t, 3>& p = triangles[s];
      const std::array<uint32_t, 3>& q = triangles[t];
      bool adjacent = false;
      for (uint32_t i : p)
        for (uint32_t j : q) adjacent = adjacent || i == j;
      if (!adjacent && skelform::geometry::triangles_intersect(position(p[0]), position(p[1]), position(p[2]),
                                                               position(q[0]), position(q[1]), position(q[2])))
        pairs.emplace_back(s, t);
    }
  return pairs;
}

}  // namespace skelform::test
