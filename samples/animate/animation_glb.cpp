// Writer of skelform-animate's file (animation_glb.h).
#include "animation_glb.h"

#include "skelform/bake/glb_builder.h"

#include <nlohmann/json.hpp>

#include <stdexcept>

namespace skelform::samples {
namespace {

using nlohmann::json;

using skelform::bake::GlbBuilder;
constexpr int kArrayBuffer = GlbBuilder::kArrayBuffer;

std::vector<float> difference(const std::vector<float>& frame, const std::vector<float>& base) {
  if (frame.size() != base.size())
    throw std::invalid_argument("animation_glb: a frame's vertex count differs from its base");
  std::vector<float> delta(frame.size());
  for (size_t i = 0; i < frame.size(); ++i) delta[i] = frame[i] - base[i];
  return delta;
}

json node_extras(const char* role, uint32_t deformable) {
  return {{"skelform", {{"role", role}, {"deformable", deformable}}}};
}

}  // namespace

std::string animation_glb(const AnimationFile& file) {
  size_t target_count = 0;
  for (const AnimationRange& animation : file.animations) {
    if (animation.first_target != target_count || animation.times.empty())
      throw std::invalid_argument("animation_glb: animations must own consecutive, non-empty target ranges");
    target_count += animation.times.size();
  }
  if (target_count == 0) throw std::invalid_argument("animation_glb: no frame");

  GlbBuilder glb;
  json& doc = glb.document;
  json meshes = json::array(), nodes = json::array(), scene_nodes = json::array();
  json target_names = json::array();
  for (const AnimationRange& animation : file.animations)
    for (size_t k = 0; k < animation.times.size(); ++k)
      target_names.push_back(animation.name + " " + std::to_string(k));
  const std::vector<float> zero_weights(target_count, 0.0f);

  // Materials: skelform and LBS in different colours so the two stand apart in any viewer;
  // the skeletal mesh translucent red inside the skelform mesh.
  doc["materials"] =
      json::array({{{"name", "skelform"},
                    {"pbrMetallicRoughness",
                     {{"baseColorFactor", {0.55, 0.7, 0.9, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.6}}}},
                   {{"name", "lbs"},
                    {"pbrMetallicRoughness",
                     {{"baseColorFactor", {0.95, 0.65, 0.4, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.6}}}},
                   {{"name", "skeletal"},
                    {"pbrMetallicRoughness",
                     {{"baseColorFactor", {0.9, 0.1, 0.1, 0.5}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.8}}},
                    {"alphaMode", "BLEND"},
                    {"doubleSided", true}}});

  for (const DeformableFrames& d : file.deformables) {
    json skelform_primitives = json::array(), lbs_primitives = json::array();
    for (const PrimitiveFrames& p : d.primitives) {
      const size_t values = p.rest_positions.size();
      if (p.rest_normals.size() != values || p.skelform_positions.size() != target_count ||
          p.skelform_normals.size() != target_count || p.lbs_positions.size() != target_count ||
          p.lbs_normals.size() != target_count)
        throw std::invalid_argument("animation_glb: deformable " + std::to_string(d.deformable) +
                                    ": one frame per target expected in every stream");
      // The base and the indices are shared by the skelform and LBS meshes.
      const int position = glb.add_floats(p.rest_positions, "VEC3", 3, kArrayBuffer, true);
      const int normal = glb.add_floats(p.rest_normals, "VEC3", 3, kArrayBuffer, false);
      const int indices = glb.add_indices(p.triangles);
      for (int method = 0; method < 2; ++method) {
        const auto& positions = method == 0 ? p.skelform_positions : p.lbs_positions;
        const auto& normals = method == 0 ? p.skelform_normals : p.lbs_normals;
        json targets = json::array();
        for (size_t k = 0; k < target_count; ++k)
          targets.push_back(
              {{"POSITION", glb.add_floats(difference(positions[k], p.rest_positions), "VEC3", 3, kArrayBuffer, true)},
               {"NORMAL", glb.add_floats(difference(normals[k], p.rest_normals), "VEC3", 3, kArrayBuffer, false)}});
        json primitive = {{"attributes", {{"POSITION", position}, {"NORMAL", normal}}},
                          {"indices", indices},
                          {"material", method},
                          {"targets", targets}};
        (method == 0 ? skelform_primitives : lbs_primitives).push_back(std::move(primitive));
      }
    }
    if (d.skeletal_positions.size() != target_count)
      throw std::invalid_argument("animation_glb: one skeletal frame per target expected");
    json skeletal_targets = json::array();
    const int skeletal_base = glb.add_floats(d.skeletal_rest, "VEC3", 3, kArrayBuffer, true);
    const int skeletal_indices = glb.add_indices(d.skeletal_triangles);
    for (size_t k = 0; k < target_count; ++k)
      skeletal_targets.push_back({{"POSITION", glb.add_floats(difference(d.skeletal_positions[k], d.skeletal_rest),
                                                              "VEC3", 3, kArrayBuffer, true)}});

    const json extras = {{"targetNames", target_names}};  // three.js: morphTargetDictionary
    const size_t first_mesh = meshes.size();
    meshes.push_back({{"name", "skelform:" + d.mesh_name},
                      {"primitives", skelform_primitives},
                      {"weights", zero_weights},
                      {"extras", extras}});
    meshes.push_back({{"name", "lbs:" + d.mesh_name},
                      {"primitives", lbs_primitives},
                      {"weights", zero_weights},
                      {"extras", extras}});
    meshes.push_back({{"name", "skeletal:" + d.mesh_name},
                      {"primitives",
                       {{{"attributes", {{"POSITION", skeletal_base}}},
                         {"indices", skeletal_indices},
                         {"material", 2},
                         {"targets", skeletal_targets}}}},
                      {"weights", zero_weights},
                      {"extras", extras}});
    const char* const roles[] = {"skelform", "lbs", "skeletal"};
    for (size_t r = 0; r < 3; ++r) {
      const float x = r == 1 ? file.offset : 0.0f;
      scene_nodes.push_back(nodes.size());
      nodes.push_back({{"name", std::string(roles[r]) + ":" + d.mesh_name},
                       {"mesh", first_mesh + r},
                       {"translation", {x, 0.0f, 0.0f}},
                       {"extras", node_extras(roles[r], d.deformable)}});
    }
  }
  doc["meshes"] = meshes;
  doc["nodes"] = nodes;
  doc["scenes"] = json::array({{{"nodes", scene_nodes}}});
  doc["scene"] = 0;

  json animations = json::array(), ranges = json::array();
  for (const AnimationRange& animation : file.animations) {
    const size_t frames = animation.times.size();
    const std::vector<float> times(animation.times.begin(), animation.times.end());
    const int input = glb.add_floats(times, "SCALAR", 1, 0, true);
    std::vector<float> one_hot(frames * target_count, 0.0f);
    for (size_t k = 0; k < frames; ++k) one_hot[k * target_count + animation.first_target + k] = 1.0f;
    const int output = glb.add_floats(one_hot, "SCALAR", 1, 0, false);
    json samplers = json::array(), channels = json::array();
    for (size_t node = 0; node < nodes.size(); ++node) {
      channels.push_back({{"sampler", samplers.size()}, {"target", {{"node", node}, {"path", "weights"}}}});
      samplers.push_back({{"input", input}, {"output", output}, {"interpolation", "LINEAR"}});
    }
    animations.push_back({{"name", animation.name}, {"samplers", samplers}, {"channels", channels}});
    ranges.push_back({{"name", animation.name},
                      {"first_target", animation.first_target},
                      {"frame_count", frames},
                      {"duration", animation.times.back()}});
  }
  doc["animations"] = animations;
  doc["asset"] = {{"version", "2.0"},
                  {"generator", "skelform-animate"},
                  {"extras",
                   {{"skelform",
                     {{"fps", file.fps},
                      {"source", file.source},
                      {"animations", ranges},
                      {"offset", {file.offset, 0.0f, 0.0f}}}}}}};
  return glb.finish();
}

}  // namespace skelform::samples
