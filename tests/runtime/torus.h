// A closed torus mesh, analytically known (volume 2π²Rr² in the limit), for the runtime's
// kernel tests: `around` × `tube` quads, outward oriented.
#pragma once

#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

namespace skelform::test {

constexpr double kPi = 3.14159265358979323846;

struct Torus {
  std::vector<glm::vec3> positions;
  std::vector<uint32_t> triangles;
  Torus(uint32_t around, uint32_t tube, float R, float r, glm::vec3 centre) {
    for (uint32_t i = 0; i < around; ++i)
      for (uint32_t j = 0; j < tube; ++j) {
        const double u = 2.0 * kPi * i / around, v = 2.0 * kPi * j / tube;
        const double ring = R + r * std::cos(v);
        positions.push_back(centre + glm::vec3(glm::dvec3(ring * std::cos(u), ring * std::sin(u), r * std::sin(v))));
      }
    auto at = [&](uint32_t i, uint32_t j) { return (i % around) * tube + j % tube; };
    for (uint32_t i = 0; i < around; ++i)
      for (uint32_t j = 0; j < tube; ++j) {
        const uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
        triangles.insert(triangles.end(), {a, b, c, a, c, d});
      }
  }
  uint32_t vertex_count() const { return uint32_t(positions.size()); }
  uint32_t triangle_count() const { return uint32_t(triangles.size() / 3); }
};

// The guard's per-vertex inputs with the torus's vertices as welded vertices: welded vertex w's
// representative (a dense vertex) is n − 1 − w, so that the kernels' gathers do not read in
// order; L, K and the skelform weight by dense vertex, λ by welded vertex, each set by
// `at(w, L, K, weight, λ)`.
struct ReversedSkin {
  std::vector<uint32_t> representative;
  std::vector<glm::vec3> lbs, skelform;
  std::vector<float> weight, factor;
  template <class At>
  ReversedSkin(uint32_t n, At at) : representative(n), lbs(n), skelform(n), weight(n), factor(n) {
    for (uint32_t w = 0; w < n; ++w) {
      const uint32_t r = n - 1 - w;
      representative[w] = r;
      at(w, lbs[r], skelform[r], weight[r], factor[w]);
    }
  }
};

}  // namespace skelform::test
