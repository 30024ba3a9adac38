#include "skelform/bake/densify.h"

#include "skelform/bake/subdivision.h"
#include "skelform/bake/weld.h"

#include <algorithm>
#include <map>

namespace skelform::bake {

InputMesh loop_subdivide_input(const InputMesh& input, int levels) {
  if (input.primitives.empty()) throw Error(ErrorKind::invalid_input, "densify: empty input");
  const WeldedMesh welded = weld(input);
  const SubdivisionStencils stencils = build_loop_stencils(welded.mesh, levels);

  InputMesh out;
  out.source_path = input.source_path;
  const size_t refined = stencils.refined_vertex_count();
  out.positions.assign(refined, Vec3(0.0));
  const bool skinned = !input.joint_sets.empty();
  if (skinned) {
    out.joint_sets.assign(1, std::vector<std::array<uint16_t, 4>>(refined, {0, 0, 0, 0}));
    out.weight_sets.assign(1, std::vector<std::array<float, 4>>(refined, {0, 0, 0, 0}));
  }
  std::map<uint16_t, double> influence;
  for (size_t v = 0; v < refined; ++v) {
    influence.clear();
    for (uint32_t s = stencils.offsets[v]; s < stencils.offsets[v + 1]; ++s) {
      const uint32_t original = welded.original_of_welded[stencils.indices[s]];
      const double w = stencils.weights[s];
      out.positions[v] += w * input.positions[original];
      for (size_t set = 0; set < input.joint_sets.size(); ++set)
        for (int k = 0; k < 4; ++k)
          if (input.weight_sets[set][original][k] > 0)
            influence[input.joint_sets[set][original][k]] += w * input.weight_sets[set][original][k];
    }
    if (!skinned) continue;
    // Loop weights can be negative for far neighbours only at extraordinary vertices; the
    // largest four positive influences carry the skin.
    std::vector<std::pair<double, uint16_t>> ranked;
    for (const auto& [joint, weight] : influence)
      if (weight > 0) ranked.push_back({weight, joint});
    std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    ranked.resize(std::min<size_t>(ranked.size(), 4));
    double total = 0;
    for (const auto& r : ranked) total += r.first;
    for (size_t k = 0; k < ranked.size(); ++k) {
      out.joint_sets[0][v][k] = ranked[k].second;
      out.weight_sets[0][v][k] = static_cast<float>(ranked[k].first / total);
    }
  }
  out.triangles = stencils.refined_triangles;

  InputPrimitive primitive = input.primitives.front();
  primitive.primitive = 0;
  primitive.first_vertex = 0;
  primitive.vertex_count = static_cast<uint32_t>(refined);
  primitive.first_triangle = 0;
  primitive.triangle_count = static_cast<uint32_t>(out.triangles.size());
  primitive.indexed = true;
  out.primitives.push_back(primitive);
  return out;
}

}  // namespace skelform::bake
