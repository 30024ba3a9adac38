// Skin influences for the loader (asset_read.h): the control vertices' sets from the
// extension, the dense vertices' sets gathered by asset_primitives.cpp, both checked against
// the skin, renormalised and stored at one width per deformable, and what the evaluation
// derives from them once (skelform weight, rigid control vertices, joint usage).
#include "asset_read.h"

#include "skelform/core/skelform_weight.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace skelform::runtime::loader {
namespace {

// Checks joints against the skin and renormalises each vertex's weights to sum 1 over all
// sets (glTF requires the sum to be 1; exporters round), as the baker does. A vertex with no
// weight at all cannot be skinned: invalid.
void finish_influences(InfluenceSets& sets, size_t vertex_count, uint32_t joint_count, const std::string& what,
                       const std::vector<std::string>& set_labels) {
  for (size_t set = 0; set < sets.joints.size(); ++set) {
    for (size_t v = 0; v < vertex_count; ++v) {
      for (int k = 0; k < 4; ++k) {
        // A zero weight may name any joint; only influencing joints must exist in the skin.
        if (sets.weights[set][v][k] > 0 && sets.joints[set][v][k] >= joint_count)
          invalid(what, set_labels[set] + " vertex " + std::to_string(v) + " names joint " +
                            std::to_string(sets.joints[set][v][k]) + " but the skin has " +
                            std::to_string(joint_count));
        if (!(sets.weights[set][v][k] > 0)) sets.joints[set][v][k] = 0;
      }
    }
  }
  for (size_t v = 0; v < vertex_count; ++v) {
    double sum = 0;
    for (const auto& set : sets.weights)
      for (int k = 0; k < 4; ++k) sum += set[v][k];
    if (!(sum > 0)) invalid(what, "vertex " + std::to_string(v) + " has no skin weight");
    for (auto& set : sets.weights)
      for (int k = 0; k < 4; ++k) set[v][k] = static_cast<float>(set[v][k] / sum);
  }
}

// Interleaves the sets into `influences` slots per vertex (4 per set, padded with zero
// weights naming joint 0), the layout asset.h documents.
void store_influences(const InfluenceSets& sets, size_t vertex_count, uint32_t influences, Array<uint16_t>& joints,
                      Array<float>& weights) {
  joints.assign(vertex_count * influences, 0);
  weights.assign(vertex_count * influences, 0.0f);
  for (size_t set = 0; set < sets.joints.size(); ++set)
    for (size_t v = 0; v < vertex_count; ++v)
      for (int k = 0; k < 4; ++k) {
        const size_t slot = v * influences + 4 * set + static_cast<size_t>(k);
        joints[slot] = static_cast<uint16_t>(sets.joints[set][v][k]);
        weights[slot] = sets.weights[set][v][k];
      }
}

// One set of the control skin: its two accessors read, counted and the weights checked.
void read_control_set(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                      const Counts& counts, int joint_accessor, int weight_accessor, size_t set,
                      InfluenceSets& control_sets) {
  const ReadArray joint_array = read_array(model, json, format::kJointSet, prefix, joint_accessor, set);
  const ReadArray weight_array = read_array(model, json, format::kWeightSet, prefix, weight_accessor, set);
  for (const ReadArray* array : {&joint_array, &weight_array})
    if (array->items() != counts.control_vertices)
      invalid(array->what, "has " + std::to_string(array->items()) + " elements; expected " +
                               std::to_string(counts.control_vertices) + " (control vertices)");
  std::vector<glm::uvec4> set_joints(counts.control_vertices);
  std::vector<glm::vec4> set_weights(counts.control_vertices);
  for (size_t v = 0; v < counts.control_vertices; ++v)
    for (int k = 0; k < 4; ++k) {
      set_joints[v][k] = static_cast<uint32_t>(joint_array.values[4 * v + static_cast<size_t>(k)]);
      set_weights[v][k] = static_cast<float>(weight_array.values[4 * v + static_cast<size_t>(k)]);
      if (set_weights[v][k] < 0)
        invalid(weight_array.what, "control vertex " + std::to_string(v) + " has a negative weight");
    }
  control_sets.joints.push_back(std::move(set_joints));
  control_sets.weights.push_back(std::move(set_weights));
}

// The skelform weight: as baked (2.2), else the artist's attribute, else the skin's rule
// (the baker's order too, skelform_weight.h).
void read_skelform_weight(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                          const Counts& counts, const std::vector<float>& weight_override, Deformable& deformable) {
  deformable.skelform_weight.resize(deformable.vertex_count);
  if (const tinygltf::Value* blend = member(json, format::kSkelformWeight.group)) {
    if (!blend->IsObject()) invalid(prefix, std::string("'") + format::kSkelformWeight.group + "' is not an object");
    const ReadArray weights = read_array(model, json, format::kSkelformWeight, prefix);
    if (weights.items() != counts.dense_vertices)
      invalid(weights.what, "has " + std::to_string(weights.items()) + " elements; expected " +
                                std::to_string(counts.dense_vertices) + " (dense vertices)");
    for (size_t v = 0; v < weights.values.size(); ++v) {
      if (!(weights.values[v] >= 0.0 && weights.values[v] <= 1.0))
        invalid(weights.what, "vertex " + std::to_string(v) + " has a weight outside [0, 1]");
      deformable.skelform_weight[v] = static_cast<float>(weights.values[v]);
    }
  } else {
    for (uint32_t v = 0; v < deformable.vertex_count; ++v)
      deformable.skelform_weight[v] =
          weight_override[v] >= 0.0f
              ? weight_override[v]
              : skin::skelform_weight(deformable.dense_joints.data() + size_t{v} * deformable.influences,
                                      deformable.dense_weights.data() + size_t{v} * deformable.influences,
                                      deformable.influences);
  }
}

}  // namespace

void read_control_skin(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                       const Counts& counts, const Deformable& deformable, InfluenceSets& control_sets) {
  const int int_max = std::numeric_limits<int>::max();
  std::vector<std::string> control_labels;
  const tinygltf::Value& control = object_member(json, format::kJointSet.group, prefix);
  const tinygltf::Value* joints = member(control, format::kJointSet.name);
  const tinygltf::Value* weights = member(control, format::kWeightSet.name);
  const std::string where = prefix + " " + format::kJointSet.group;
  if (!joints || !weights || !joints->IsArray() || !weights->IsArray() || joints->ArrayLen() == 0 ||
      joints->ArrayLen() != weights->ArrayLen())
    invalid(where, "a skinned deformable needs 'joints' and 'weights' arrays of equal, non-zero length");
  if (joints->ArrayLen() > kMaxInfluenceSets) beyond_influence_limit(where + " joints", joints->ArrayLen());
  for (size_t set = 0; set < joints->ArrayLen(); ++set) {
    const std::string index = "[" + std::to_string(set) + "]";
    const int joint_accessor = integer_value(joints->Get(static_cast<int>(set)), where,
                                             std::string(format::kJointSet.name) + index, 0, int_max);
    const int weight_accessor = integer_value(weights->Get(static_cast<int>(set)), where,
                                              std::string(format::kWeightSet.name) + index, 0, int_max);
    read_control_set(model, json, prefix, counts, joint_accessor, weight_accessor, set, control_sets);
    control_labels.push_back("control.joints[" + std::to_string(set) + "]");
  }
  finish_influences(control_sets, counts.control_vertices, deformable.joint_count, prefix + " control", control_labels);
}

void finish_skin(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                 const Counts& counts, InfluenceSets& dense_sets, const std::vector<std::string>& dense_labels,
                 const InfluenceSets& control_sets, const std::vector<float>& weight_override, Deformable& deformable) {
  finish_influences(dense_sets, deformable.vertex_count, deformable.joint_count, prefix + " dense skin", dense_labels);
  const size_t sets = std::max(dense_sets.joints.size(), control_sets.joints.size());
  deformable.influences = static_cast<uint32_t>(4 * sets);
  store_influences(dense_sets, deformable.vertex_count, deformable.influences, deformable.dense_joints,
                   deformable.dense_weights);
  read_skelform_weight(model, json, prefix, counts, weight_override, deformable);
  store_influences(control_sets, deformable.control_vertex_count, deformable.influences, deformable.control_joints,
                   deformable.control_weights);
  deformable.control_rigid.resize(deformable.control_vertex_count);
  for (uint32_t v = 0; v < deformable.control_vertex_count; ++v)
    deformable.control_rigid[v] =
        skin::skelform_weight(deformable.control_joints.data() + size_t{v} * deformable.influences,
                              deformable.control_weights.data() + size_t{v} * deformable.influences,
                              deformable.influences) == 0.0f;
  deformable.joint_usage.assign(deformable.joint_count, 0.0f);
  for (size_t slot = 0; slot < deformable.control_weights.size(); ++slot)
    deformable.joint_usage[deformable.control_joints[slot]] += deformable.control_weights[slot];
}

}  // namespace skelform::runtime::loader
