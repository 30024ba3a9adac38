// Exporter defects in a glTF skin, repaired the same way by the baker (bake/src/input_gltf.cpp,
// which reports them as warnings) and the runtime loader (runtime/src/asset_primitives.cpp),
// so the two agree on every vertex's skin. The rules (docs/SKELFORM_skeletal_deformation.md
// "Skin defects"):
//  - a non-finite weight (Blender writes NaN for a vertex in no vertex group: 0/0) is 0;
//  - a vertex left with no weight at all takes the skin of the nearest vertex of its primitive
//    (by rest position) that has one: the skin it would have been painted with; a primitive
//    with no weighted vertex cannot be repaired;
//  - a joint named in several slots of one vertex is left as it is: skinning sums the slots,
//    so the result is that of one slot with the summed weight; it is counted.
// Negative weights and joints outside the skin are refused by the readers, not repaired.
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace skelform::skin {

struct SkinRepairReport {
  std::vector<uint32_t> non_finite;  // vertices with a non-finite weight (now 0), primitive-local
  std::vector<uint32_t> inherited;   // vertices without weight that took their nearest weighted vertex's skin
  uint32_t repeated_joints = 0;      // vertices naming one joint with weight in several slots
  bool repaired() const { return !non_finite.empty() || !inherited.empty(); }
};

// The largest number of (unweighted vertex, candidate) distance tests repair_skin makes: a
// primitive whose repair would need more is refused (a file of mostly unweighted vertices is
// not an exporter's slip to patch over).
constexpr double kMaxRepairTests = 5e7;

// One primitive's skin in place: `slots` (joint, weight) pairs per vertex (4 per JOINTS_n /
// WEIGHTS_n set), vertex-major; `positions` its rest positions. Returns false when a vertex
// has no weight and none can be inherited (no weighted vertex in the primitive, or more than
// kMaxRepairTests tests).
inline bool repair_skin(uint32_t* joints, double* weights, size_t slots, const glm::dvec3* positions,
                        size_t vertex_count, SkinRepairReport& report) {
  std::vector<uint32_t> unweighted;
  for (size_t v = 0; v < vertex_count; ++v) {
    double* w = weights + v * slots;
    bool non_finite = false;
    double sum = 0.0;
    for (size_t k = 0; k < slots; ++k) {
      if (!std::isfinite(w[k])) {
        w[k] = 0.0;
        non_finite = true;
      }
      sum += w[k];
    }
    if (non_finite) report.non_finite.push_back(uint32_t(v));
    if (!(sum > 0.0)) unweighted.push_back(uint32_t(v));
    bool repeated = false;
    for (size_t a = 0; a < slots && !repeated; ++a)
      for (size_t b = a + 1; b < slots && !repeated; ++b)
        repeated = w[a] > 0.0 && w[b] > 0.0 && joints[v * slots + a] == joints[v * slots + b];
    report.repeated_joints += repeated ? 1u : 0u;
  }
  if (unweighted.empty()) return true;
  if (double(unweighted.size()) * double(vertex_count) > kMaxRepairTests) return false;
  std::vector<uint8_t> has_weight(vertex_count, 1);
  for (uint32_t v : unweighted) has_weight[v] = 0;
  for (uint32_t v : unweighted) {
    size_t best = vertex_count;
    double best_distance = std::numeric_limits<double>::infinity();
    for (size_t u = 0; u < vertex_count; ++u) {
      if (!has_weight[u]) continue;
      const glm::dvec3 d = positions[u] - positions[v];
      const double distance = glm::dot(d, d);
      if (distance < best_distance) {
        best_distance = distance;
        best = u;
      }
    }
    if (best == vertex_count) return false;
    for (size_t k = 0; k < slots; ++k) {
      joints[size_t(v) * slots + k] = joints[best * slots + k];
      weights[size_t(v) * slots + k] = weights[best * slots + k];
    }
    report.inherited.push_back(v);
  }
  return true;
}

}  // namespace skelform::skin
