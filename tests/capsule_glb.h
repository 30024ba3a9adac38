// A procedural skinned test model as a GLB, built with the baker library's shapes and no
// test framework: used by the runtime tests (runtime/runtime_models.h) and by the C engine
// example's test input (samples/c_engine_capsule.cpp), so both run on the same model.
#pragma once

#include "skelform/bake/glb_builder.h"
#include "skelform/bake/procedural.h"

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace skelform::test {

// The shape of capsule_glb()'s capsule: make_capsule(radius, length, 24, rings, 6) along z,
// the root joint at z = root_z, the child joint at z = 0, the child's weight a smoothstep
// over z in [-blend/2, blend/2]; with `sphere`, a second primitive (below).
struct CapsuleShape {
  double radius = 0.25, length = 1.0, root_z = -0.5, blend = 0.4;
  int rings = 8;
  bool sphere = true;
};

// A GLB of a capsule along z (by default radius 0.25, z in [-0.75, 0.75]) with authored
// normals and tangents, skinned to a root joint at z = -0.5 and a child joint at z = 0
// (weights blend over z in [-0.2, 0.2]), plus a primitive without normals or tangents: a
// sphere at z = 1.1 on the child joint. Two joints, two primitives, one skin: the smallest
// case with a bend.
inline std::string capsule_glb(const CapsuleShape& shape = {}) {
  using nlohmann::json;
  bake::GlbBuilder glb;
  glb.document = json::parse(R"({
    "asset": {"version": "2.0", "generator": "skelform tests"},
    "scene": 0, "scenes": [{"nodes": [0, 1]}],
    "nodes": [{"name": "capsule", "mesh": 0, "skin": 0},
              {"name": "root", "translation": [0, 0, -0.5], "children": [2]},
              {"name": "tip", "translation": [0, 0, 0.5]}],
    "bufferViews": [], "accessors": []})");
  glb.document["nodes"][1]["translation"] = {0.0, 0.0, shape.root_z};
  glb.document["nodes"][2]["translation"] = {0.0, 0.0, -shape.root_z};
  json primitives = json::array();
  const bake::TriangleMesh capsule = bake::make_capsule(shape.radius, shape.length, 24, shape.rings, 6);
  bake::TriangleMesh sphere = bake::make_icosphere(0.15, 2);
  for (auto& p : sphere.positions) p += bake::Vec3(0, 0, 1.1);
  for (int part = 0; part < (shape.sphere ? 2 : 1); ++part) {
    const bake::TriangleMesh& mesh = part == 0 ? capsule : sphere;
    const size_t n = mesh.positions.size();
    std::vector<float> positions, normals, tangents, weights;
    std::vector<uint16_t> joints;
    std::vector<uint32_t> indices;
    std::vector<glm::dvec3> normal_sum(n, glm::dvec3(0.0));
    for (const auto& t : mesh.triangles) {
      indices.insert(indices.end(), t.begin(), t.end());
      const glm::dvec3 face =
          glm::cross(mesh.positions[t[1]] - mesh.positions[t[0]], mesh.positions[t[2]] - mesh.positions[t[0]]);
      for (uint32_t v : t) normal_sum[v] += face;
    }
    for (size_t i = 0; i < n; ++i) {
      const glm::vec3 p(mesh.positions[i]);
      positions.insert(positions.end(), {p.x, p.y, p.z});
      const glm::vec3 normal(glm::normalize(normal_sum[i]));
      normals.insert(normals.end(), {normal.x, normal.y, normal.z});
      glm::vec3 around = glm::cross(glm::vec3(0, 0, 1), normal);
      if (glm::length(around) < 1e-3f) around = glm::vec3(1, 0, 0) - normal.x * normal;
      around = glm::normalize(around);
      tangents.insert(tangents.end(), {around.x, around.y, around.z, 1.0f});
      const float half = float(shape.blend / 2);
      const float s = std::clamp((p.z + half) / (2.0f * half), 0.0f, 1.0f);
      const float child = part == 0 ? s * s * (3.0f - 2.0f * s) : 1.0f;
      joints.insert(joints.end(), {0, 1, 0, 0});
      weights.insert(weights.end(), {1.0f - child, child, 0.0f, 0.0f});
    }
    // (bufferView targets are optional in glTF; this model has none.)
    json attributes;
    attributes["POSITION"] = glb.add_floats(positions, "VEC3", 3, 0, true);
    if (part == 0) {
      attributes["NORMAL"] = glb.add_floats(normals, "VEC3", 3, 0, false);
      attributes["TANGENT"] = glb.add_floats(tangents, "VEC4", 4, 0, false);
    }
    attributes["JOINTS_0"] = glb.add_accessor({{"bufferView", glb.add_view(joints.data(), joints.size() * 2, 0)},
                                               {"componentType", bake::GlbBuilder::kUnsignedShort},
                                               {"count", n},
                                               {"type", "VEC4"}});
    attributes["WEIGHTS_0"] = glb.add_floats(weights, "VEC4", 4, 0, false);
    const int index_accessor = glb.add_accessor({{"bufferView", glb.add_view(indices.data(), indices.size() * 4, 0)},
                                                 {"componentType", bake::GlbBuilder::kUnsignedInt},
                                                 {"count", indices.size()},
                                                 {"type", "SCALAR"}});
    primitives.push_back({{"attributes", attributes}, {"indices", index_accessor}});
  }
  glb.document["meshes"] = json::array({{{"name", "capsule"}, {"primitives", primitives}}});
  // Inverse bind matrices: the inverses of the joints' world transforms at bind.
  std::vector<float> inverse_bind;
  for (const glm::mat4& m : {glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, float(-shape.root_z))), glm::mat4(1.0f)})
    inverse_bind.insert(inverse_bind.end(), glm::value_ptr(m), glm::value_ptr(m) + 16);
  const int ibm = glb.add_floats(inverse_bind, "MAT4", 16, 0, false);
  glb.document["skins"] = json::array({{{"joints", {1, 2}}, {"inverseBindMatrices", ibm}, {"skeleton", 1}}});
  return glb.finish();
}

}  // namespace skelform::test
