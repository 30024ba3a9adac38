// Test input for skelform-c-engine that needs no third-party model: writes OUT.glb, a
// procedural skinned capsule (bake::make_capsule) along z, radius 0.25, z in [-0.75, 0.75],
// with authored normals and tangents, skinned to a root joint at z = -0.5 and a child joint
// at z = 0 (weights blend over z in [-0.2, 0.2]); plus a second primitive without normals or
// tangents, a sphere at z = 1.1 on the child joint. The test bakes it with skelform-bake, so
// the example runs on two primitives, one of them without tangents, and a real bend.
//
//   skelform_c_engine_capsule OUT.glb
#include "skelform/bake/procedural.h"

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace {

using nlohmann::json;

// Appends `data` to `bin` (4-byte aligned) as a new bufferView and accessor; returns the accessor.
template <class T>
int add_accessor(json& document, std::string& bin, const std::vector<T>& data, int component_type, const char* type,
                 size_t count) {
  while (bin.size() % 4) bin.push_back('\0');
  document["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", data.size() * sizeof(T)}});
  bin.append(reinterpret_cast<const char*>(data.data()), data.size() * sizeof(T));
  document["accessors"].push_back({{"bufferView", document["bufferViews"].size() - 1},
                                   {"componentType", component_type}, {"count", count}, {"type", type}});
  return int(document["accessors"].size() - 1);
}

json add_primitive(json& document, std::string& bin, const skelform::bake::TriangleMesh& mesh, bool capsule) {
  const size_t n = mesh.positions.size();
  std::vector<float> positions, normals, tangents, weights;
  std::vector<uint16_t> joints;
  std::vector<uint32_t> indices;
  std::vector<glm::dvec3> normal_sum(n, glm::dvec3(0.0));
  for (const auto& t : mesh.triangles) {
    indices.insert(indices.end(), t.begin(), t.end());
    const glm::dvec3 face = glm::cross(mesh.positions[t[1]] - mesh.positions[t[0]], mesh.positions[t[2]] - mesh.positions[t[0]]);
    for (uint32_t v : t) normal_sum[v] += face;
  }
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (size_t i = 0; i < n; ++i) {
    const glm::vec3 p(mesh.positions[i]);
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
    positions.insert(positions.end(), {p.x, p.y, p.z});
    const glm::vec3 normal(glm::normalize(normal_sum[i]));
    normals.insert(normals.end(), {normal.x, normal.y, normal.z});
    glm::vec3 around = glm::cross(glm::vec3(0, 0, 1), normal);  // tangent: around the axis
    if (glm::length(around) < 1e-3f) around = glm::vec3(1, 0, 0) - normal.x * normal;
    around = glm::normalize(around);
    tangents.insert(tangents.end(), {around.x, around.y, around.z, 1.0f});
    const float s = std::clamp((p.z + 0.2f) / 0.4f, 0.0f, 1.0f);
    const float child = capsule ? s * s * (3.0f - 2.0f * s) : 1.0f;
    joints.insert(joints.end(), {0, 1, 0, 0});
    weights.insert(weights.end(), {1.0f - child, child, 0.0f, 0.0f});
  }
  json attributes;
  attributes["POSITION"] = add_accessor(document, bin, positions, 5126, "VEC3", n);
  document["accessors"].back()["min"] = {lo.x, lo.y, lo.z};
  document["accessors"].back()["max"] = {hi.x, hi.y, hi.z};
  if (capsule) {
    attributes["NORMAL"] = add_accessor(document, bin, normals, 5126, "VEC3", n);
    attributes["TANGENT"] = add_accessor(document, bin, tangents, 5126, "VEC4", n);
  }
  attributes["JOINTS_0"] = add_accessor(document, bin, joints, 5123, "VEC4", n);
  attributes["WEIGHTS_0"] = add_accessor(document, bin, weights, 5126, "VEC4", n);
  return {{"attributes", attributes}, {"indices", add_accessor(document, bin, indices, 5125, "SCALAR", indices.size())}};
}

void put_u32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(char((v >> (8 * i)) & 0xFF));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: skelform_c_engine_capsule OUT.glb\n");
    return 2;
  }
  json document = json::parse(R"({
    "asset": {"version": "2.0", "generator": "skelform c_engine test"},
    "scene": 0, "scenes": [{"nodes": [0, 1]}],
    "nodes": [{"name": "capsule", "mesh": 0, "skin": 0},
              {"name": "root", "translation": [0, 0, -0.5], "children": [2]},
              {"name": "tip", "translation": [0, 0, 0.5]}],
    "bufferViews": [], "accessors": []})");
  std::string bin;
  skelform::bake::TriangleMesh sphere = skelform::bake::make_icosphere(0.15, 2);
  for (auto& p : sphere.positions) p += skelform::bake::Vec3(0, 0, 1.1);
  const json capsule = add_primitive(document, bin, skelform::bake::make_capsule(0.25, 1.0, 24, 8, 6), true);
  document["meshes"] = json::array({{{"name", "capsule"}, {"primitives", {capsule, add_primitive(document, bin, sphere, false)}}}});
  // Inverse bind matrices (column-major): the inverses of the joints' bind world transforms,
  // translate(0, 0, -0.5) for the root and the identity for the tip at the origin.
  const std::vector<float> inverse_bind = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0.5f, 1,
                                           1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const int ibm = add_accessor(document, bin, inverse_bind, 5126, "MAT4", 2);
  document["skins"] = json::array({{{"joints", {1, 2}}, {"inverseBindMatrices", ibm}, {"skeleton", 1}}});
  while (bin.size() % 4) bin.push_back('\0');
  document["buffers"] = json::array({{{"byteLength", bin.size()}}});

  std::string text = document.dump();
  while (text.size() % 4) text.push_back(' ');
  std::string glb = "glTF";
  put_u32(glb, 2);
  put_u32(glb, uint32_t(12 + 8 + text.size() + 8 + bin.size()));
  put_u32(glb, uint32_t(text.size()));
  put_u32(glb, 0x4E4F534Au);  // "JSON"
  glb += text;
  put_u32(glb, uint32_t(bin.size()));
  put_u32(glb, 0x004E4942u);  // "BIN\0"
  glb += bin;
  std::ofstream out(argv[1], std::ios::binary);
  out.write(glb.data(), std::streamsize(glb.size()));
  if (!out.flush()) {
    std::fprintf(stderr, "skelform_c_engine_capsule: cannot write %s\n", argv[1]);
    return 1;
  }
  return 0;
}
