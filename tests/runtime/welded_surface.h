// Deformable 0's dense mesh welded by rest position (the quality metric's rule: vertices at
// one rest position are one, so triangles across a glTF seam are adjacent, as they are), to
// pose with any method's output and count its intersecting pairs or measure its volume.
// Needs the samples' glTF reader (the tests that include it are built with the samples).
#pragma once

#include "gltf_animation.h"
#include "mesh_checks.h"
#include "runtime/runtime_models.h"
#include "skelform/bake/metrics.h"

#include <map>
#include <tuple>
#include <vector>

namespace skelform::test {

struct WeldedSurface {
  std::vector<uint32_t> representative;  // per welded vertex: its first original vertex
  bake::TriangleMesh rest;
  bool closed = false;
  double rest_volume = 0;
};

inline WeldedSurface welded_surface(const RuntimeModel& model, const samples::GltfAnimation& gltf) {
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model.asset, 0, &info) == SF_OK);
  WeldedSurface s;
  std::map<std::tuple<float, float, float>, uint32_t> ids;
  std::vector<uint32_t> welded;
  for (const auto& prim : model.primitives)
    for (const glm::vec3& p : prim.positions) {
      auto it = ids.find(std::make_tuple(p.x, p.y, p.z));
      if (it == ids.end()) {
        it = ids.emplace(std::make_tuple(p.x, p.y, p.z), uint32_t(s.rest.positions.size())).first;
        s.rest.positions.push_back(bake::Vec3(p));
        s.representative.push_back(uint32_t(welded.size()));
      }
      welded.push_back(it->second);
    }
  for (uint32_t p = 0; p < info.primitive_count; ++p) {
    sf_primitive_info pinfo{};
    REQUIRE(sf_asset_primitive_info(model.asset, 0, p, &pinfo) == SF_OK);
    const std::vector<uint32_t> tris = gltf.primitive_triangles(size_t(info.mesh), size_t(pinfo.gltf_primitive));
    for (size_t t = 0; t + 2 < tris.size(); t += 3) {
      const bake::Triangle tri = {welded[pinfo.first_vertex + tris[t]], welded[pinfo.first_vertex + tris[t + 1]],
                                  welded[pinfo.first_vertex + tris[t + 2]]};
      if (tri[0] != tri[1] && tri[1] != tri[2] && tri[2] != tri[0]) s.rest.triangles.push_back(tri);
    }
  }
  s.closed = analyze_mesh(s.rest).manifold_problem.empty();
  s.rest_volume = bake::enclosed_volume(s.rest);
  return s;
}

// The same from a model's own baked bytes.
inline WeldedSurface welded_surface(const RuntimeModel& model) {
  return welded_surface(model, samples::GltfAnimation::load_memory(model.baked_glb, model.name));
}

// The welded mesh at `positions` (one per original vertex, deformable order).
inline bake::TriangleMesh posed(const WeldedSurface& s, const std::vector<glm::vec3>& positions) {
  bake::TriangleMesh m = s.rest;
  for (size_t v = 0; v < m.positions.size(); ++v) m.positions[v] = bake::Vec3(positions[s.representative[v]]);
  return m;
}

}  // namespace skelform::test
