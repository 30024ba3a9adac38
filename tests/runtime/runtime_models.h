// Baked assets for the runtime's instance tests (evaluate_test, threads_test, output_test):
// models are baked inside the test with the baker library (load_mesh, bake_model, baked_glb)
// and loaded through the public C API, and the ORIGINAL glTF data (positions, authored
// normals and tangents, skin, joint hierarchy) is read independently with tinygltf, so a
// test compares the runtime's output with the input file, not with the loader's copy of it.
//
// - capsule_model(): a procedural two-joint capsule (normals and tangents authored) plus a
//   sphere primitive without normals or tangents; always available.
// - sample_model(name): a model of ../shared/data, or nullptr when absent.
// Each is baked once per process and kept (immutable assets are shareable).
//
// Without the baker (SKELFORM_TEST_WITH_BAKER 0: a runtime-only build), capsule_model() is the
// same capsule baked ahead of time, tests/data/capsule.skf.glb (tests/data/README.md), whose
// original data is read from that file (a baked glTF keeps its input's accessors), and
// sample_model() skips.
#pragma once

#if SKELFORM_TEST_WITH_BAKER
#  include "capsule_glb.h"
#  include "skelform/bake/bake.h"
#  include "skelform/bake/gltf_writer.h"
#  include "skelform/bake/input.h"
#  include "skelform/bake/procedural.h"
#endif
#include "skelform/skelform.h"
#include "test_support.h"

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

namespace skelform::test {

// Original data of one glTF primitive.
struct OriginalPrimitive {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;   // empty when not authored
  std::vector<glm::vec4> tangents;  // empty when not authored
  std::vector<glm::uvec4> joints;   // JOINTS_0
  std::vector<glm::vec4> weights;   // WEIGHTS_0
};

struct RuntimeModel {
  std::string name;
  sf_asset* asset = nullptr;
  std::string baked_glb;                      // the baked file, for tests that load their own asset
  std::vector<OriginalPrimitive> primitives;  // of deformable 0, in its primitive order
  std::vector<glm::mat4> inverse_bind;        // of deformable 0's skin
  std::vector<int> joint_parent;              // per skin joint: parent joint index or -1
  double diagonal = 0;                        // bounding-box diagonal of deformable 0's vertices
  ~RuntimeModel() { sf_asset_destroy(asset); }
};

namespace detail {

// Float elements of an accessor (FLOAT, or normalised UNSIGNED_BYTE/SHORT), `components` each.
inline std::vector<float> read_floats(const tinygltf::Model& model, int accessor_index, int components) {
  const tinygltf::Accessor& a = model.accessors[size_t(accessor_index)];
  const tinygltf::BufferView& view = model.bufferViews[size_t(a.bufferView)];
  const unsigned char* base = model.buffers[size_t(view.buffer)].data.data() + view.byteOffset + a.byteOffset;
  const size_t size = size_t(tinygltf::GetComponentSizeInBytes(uint32_t(a.componentType)));
  const size_t stride = view.byteStride ? view.byteStride : size * size_t(components);
  std::vector<float> out(a.count * size_t(components));
  for (size_t i = 0; i < a.count; ++i)
    for (int c = 0; c < components; ++c) {
      const unsigned char* p = base + i * stride + size_t(c) * size;
      float v = 0;
      if (a.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT)
        std::memcpy(&v, p, 4);
      else if (a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE)
        v = float(*p) / (a.normalized ? 255.0f : 1.0f);
      else {
        uint16_t u;
        std::memcpy(&u, p, 2);
        v = float(u) / (a.normalized ? 65535.0f : 1.0f);
      }
      out[i * size_t(components) + size_t(c)] = v;
    }
  return out;
}

inline tinygltf::Model parse_gltf(const std::string& bytes, const std::string& base_dir) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string error, warning;
  const bool glb = bytes.size() >= 4 && bytes.compare(0, 4, "glTF") == 0;
  const bool ok =
      glb ? loader.LoadBinaryFromMemory(&model, &error, &warning, reinterpret_cast<const unsigned char*>(bytes.data()),
                                        unsigned(bytes.size()), base_dir)
          : loader.LoadASCIIFromString(&model, &error, &warning, bytes.data(), unsigned(bytes.size()), base_dir);
  REQUIRE_MESSAGE(ok, error);
  return model;
}

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Loads `baked_glb`, reads the original data of deformable 0 from `bytes` (the input glTF).
inline std::unique_ptr<RuntimeModel> load_baked(const std::string& name, std::string baked_glb,
                                                const std::string& bytes, const std::string& base_dir) {
  auto result = std::make_unique<RuntimeModel>();
  result->name = name;
  result->baked_glb = std::move(baked_glb);
  char message[512] = {};
  sf_load_options options{};
  options.error_message = message;
  options.error_message_capacity = sizeof message;
  const sf_result loaded =
      sf_asset_load_memory(result->baked_glb.data(), result->baked_glb.size(), &options, &result->asset);
  REQUIRE_MESSAGE(loaded == SF_OK, name << ": " << message);

  const tinygltf::Model model = parse_gltf(bytes, base_dir);
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(result->asset, 0, &info) == SF_OK);
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (uint32_t p = 0; p < info.primitive_count; ++p) {
    sf_primitive_info pinfo{};
    REQUIRE(sf_asset_primitive_info(result->asset, 0, p, &pinfo) == SF_OK);
    const tinygltf::Primitive& prim = model.meshes[size_t(info.mesh)].primitives[size_t(pinfo.gltf_primitive)];
    OriginalPrimitive out;
    const std::vector<float> pos = read_floats(model, prim.attributes.at("POSITION"), 3);
    for (size_t i = 0; i < pos.size() / 3; ++i) {
      out.positions.emplace_back(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]);
      lo = glm::min(lo, out.positions.back());
      hi = glm::max(hi, out.positions.back());
    }
    if (prim.attributes.count("NORMAL")) {
      const std::vector<float> n = read_floats(model, prim.attributes.at("NORMAL"), 3);
      for (size_t i = 0; i < n.size() / 3; ++i) out.normals.emplace_back(n[3 * i], n[3 * i + 1], n[3 * i + 2]);
    }
    if (prim.attributes.count("TANGENT")) {
      const std::vector<float> t = read_floats(model, prim.attributes.at("TANGENT"), 4);
      for (size_t i = 0; i < t.size() / 4; ++i)
        out.tangents.emplace_back(t[4 * i], t[4 * i + 1], t[4 * i + 2], t[4 * i + 3]);
    }
    if (prim.attributes.count("JOINTS_0") && prim.attributes.count("WEIGHTS_0")) {
      // JOINTS are unnormalised integers: read_floats gives their values.
      const std::vector<float> j = read_floats(model, prim.attributes.at("JOINTS_0"), 4);
      const std::vector<float> w = read_floats(model, prim.attributes.at("WEIGHTS_0"), 4);
      for (size_t i = 0; i < j.size() / 4; ++i) {
        out.joints.emplace_back(unsigned(j[4 * i]), unsigned(j[4 * i + 1]), unsigned(j[4 * i + 2]),
                                unsigned(j[4 * i + 3]));
        out.weights.emplace_back(w[4 * i], w[4 * i + 1], w[4 * i + 2], w[4 * i + 3]);
      }
    }
    result->primitives.push_back(std::move(out));
  }
  result->diagonal = double(glm::length(hi - lo));
  if (info.skin >= 0) {
    const tinygltf::Skin& skin = model.skins[size_t(info.skin)];
    const size_t n = skin.joints.size();
    result->inverse_bind.assign(n, glm::mat4(1.0f));
    if (skin.inverseBindMatrices >= 0) {
      const std::vector<float> m = read_floats(model, skin.inverseBindMatrices, 16);
      for (size_t i = 0; i < n; ++i) result->inverse_bind[i] = glm::make_mat4(&m[16 * i]);
    }
    result->joint_parent.assign(n, -1);
    for (size_t i = 0; i < n; ++i)
      for (size_t k = 0; k < n; ++k)
        for (int child : model.nodes[size_t(skin.joints[k])].children)
          if (child == skin.joints[i]) result->joint_parent[i] = int(k);
  }
  return result;
}

#if SKELFORM_TEST_WITH_BAKER
// Bakes `bytes` (a .glb or .gltf), loads the result, reads the original data of deformable 0.
inline std::unique_ptr<RuntimeModel> bake_and_load(const std::string& name, const std::string& bytes,
                                                   const std::string& extension, const std::string& base_dir) {
  const std::vector<unsigned char> input_bytes(bytes.begin(), bytes.end());
  const bake::InputMesh input = bake::load_mesh_from_memory(input_bytes, extension, base_dir + "/" + name);
  const bake::BakeResult baked = bake::bake_model(input);
  return load_baked(name, bake::baked_glb(bytes, base_dir, baked.deformables), bytes, base_dir);
}
#endif

// The capsule baked ahead of time (tests/data/README.md), loaded; original data from the file.
inline std::unique_ptr<RuntimeModel> load_capsule_fixture() {
  const std::filesystem::path path = std::filesystem::path(SKELFORM_SOURCE_DIR) / "tests/data/capsule.skf.glb";
  const std::string bytes = read_file(path);
  REQUIRE_MESSAGE(!bytes.empty(), path.string() << " is missing or empty");
  return load_baked("capsule.skf.glb", bytes, bytes, path.parent_path().string());
}

inline std::mutex& cache_mutex() {
  static std::mutex m;
  return m;
}
inline std::map<std::string, std::unique_ptr<RuntimeModel>>& cache() {
  static std::map<std::string, std::unique_ptr<RuntimeModel>> c;
  return c;
}

}  // namespace detail

inline const RuntimeModel& capsule_model() {
  std::lock_guard<std::mutex> lock(detail::cache_mutex());
  auto& slot = detail::cache()["capsule"];
#if SKELFORM_TEST_WITH_BAKER
  if (!slot) slot = detail::bake_and_load("capsule.glb", capsule_glb(), ".glb", scratch_dir("runtime_models").string());
#else
  if (!slot) slot = detail::load_capsule_fixture();
#endif
  return *slot;
}

#if SKELFORM_TEST_WITH_BAKER

// The fairing issue's capsule (tests/runtime/fair_test.cpp): radius 0.2, z in [-1, 1], the
// root joint at its end, the child joint at z = 0, weights blending over z in [-0.1, 0.1].
inline CapsuleShape bent_capsule_shape() {
  CapsuleShape shape;
  shape.radius = 0.2;
  shape.length = 1.6;
  shape.rings = 40;
  shape.root_z = -1.0;
  shape.blend = 0.2;
  shape.sphere = false;
  return shape;
}
inline const RuntimeModel& bent_capsule_model() {
  std::lock_guard<std::mutex> lock(detail::cache_mutex());
  auto& slot = detail::cache()["bent capsule"];
  if (!slot)
    slot = detail::bake_and_load("bent_capsule.glb", capsule_glb(bent_capsule_shape()), ".glb",
                                 scratch_dir("runtime_models").string());
  return *slot;
}

#endif

// The skinned sample models of ../shared/data, by folder name.
inline const std::vector<std::string>& sample_names() {
  static const std::vector<std::string> names = {"CesiumMan/CesiumMan.glb", "Fox/Fox.glb",
                                                 "RiggedFigure/RiggedFigure.glb", "RiggedSimple/RiggedSimple.glb",
                                                 "SimpleSkin/SimpleSkin.gltf"};
  return names;
}

// A baked sample, or nullptr (with a MESSAGE) when the data is absent.
inline const RuntimeModel* sample_model(const std::string& relative) {
#if SKELFORM_TEST_WITH_BAKER
  const std::filesystem::path path = data_file(relative);
  if (path.empty()) {
    MESSAGE("skipped: " << relative << " not found under " << data_dir() << " (set SKELFORM_DATA_DIR)");
    return nullptr;
  }
  std::lock_guard<std::mutex> lock(detail::cache_mutex());
  auto& slot = detail::cache()[relative];
  if (!slot)
    slot = detail::bake_and_load(path.filename().string(), detail::read_file(path), path.extension().string(),
                                 path.parent_path().string());
  return slot.get();
#else
  MESSAGE("skipped: " << relative << " needs the baker (SKELFORM_BUILD_BAKE=OFF)");
  return nullptr;
#endif
}

// Skinning matrices that bend joint `joint` (and its descendants) by `angle` radians about
// `axis` through the joint's bind position; every other joint stays at bind (identity).
inline std::vector<glm::mat4> bend_pose(const RuntimeModel& model, size_t joint, float angle, glm::vec3 axis) {
  const size_t n = model.inverse_bind.size();
  const glm::vec3 pivot(glm::inverse(model.inverse_bind[joint])[3]);
  const glm::mat4 bend = glm::translate(glm::mat4(1.0f), pivot) * glm::rotate(glm::mat4(1.0f), angle, axis) *
                         glm::translate(glm::mat4(1.0f), -pivot);
  std::vector<glm::mat4> pose(n, glm::mat4(1.0f));
  for (size_t j = 0; j < n; ++j)
    for (int k = int(j); k >= 0; k = model.joint_parent[size_t(k)])
      if (size_t(k) == joint) pose[j] = bend;
  return pose;
}

// Every vertex of deformable 0, primitive by primitive, as written by sf_instance_write.
struct Evaluated {
  std::vector<glm::vec3> positions, normals;
  std::vector<glm::vec4> tangents;  // zero for primitives without tangents
};

// An instance of `asset` for one test, destroyed with it; converts to sf_instance*.
struct InstancePtr {
  sf_instance* instance = nullptr;
  explicit InstancePtr(const sf_asset* asset) { REQUIRE(sf_instance_create(asset, 0, &instance) == SF_OK); }
  ~InstancePtr() { sf_instance_destroy(instance); }
  InstancePtr(const InstancePtr&) = delete;
  InstancePtr& operator=(const InstancePtr&) = delete;
  operator sf_instance*() const { return instance; }
};

inline Evaluated write_all(const sf_instance* instance, const sf_asset* asset) {
  Evaluated out;
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(asset, 0, &info) == SF_OK);
  out.positions.resize(info.vertex_count);
  out.normals.resize(info.vertex_count);
  out.tangents.assign(info.vertex_count, glm::vec4(0.0f));
  for (uint32_t p = 0; p < info.primitive_count; ++p) {
    sf_primitive_info pinfo{};
    REQUIRE(sf_asset_primitive_info(asset, 0, p, &pinfo) == SF_OK);
    sf_vertex_output o{};
    o.positions = &out.positions[pinfo.first_vertex].x;
    o.normals = &out.normals[pinfo.first_vertex].x;
    o.tangents = pinfo.has_tangents ? &out.tangents[pinfo.first_vertex].x : nullptr;
    o.vertex_capacity = pinfo.vertex_count;
    REQUIRE(sf_instance_write(instance, p, &o) == SF_OK);
  }
  return out;
}

}  // namespace skelform::test
