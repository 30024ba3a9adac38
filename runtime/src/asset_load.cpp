// Asset loading (asset_load.h). Order of work, per deformable: the extension's arrays (read
// through extension_layout.h's table, so reader and writer share one definition), their
// counts and index ranges, then the dense vertices from the glTF primitives, then what is
// derived from the rest evaluation. Nothing is indexed before it is checked: a corrupt file
// ends in an error, never in a read out of bounds.
#include "asset_load.h"

#include "dss_frame.h"
#include "extension_layout.h"
#include "joint_arcs.h"
#include "refine.h"
#include "skelform_weight.h"
#include "skin_repair.h"
#include "skin_blend.h"

#include <tiny_gltf.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

static_assert(skelform::format::kMajorVersion == SF_EXTENSION_MAJOR_VERSION,
              "skelform.h's SF_EXTENSION_MAJOR_VERSION is the extension version the loader reads");

namespace skelform::runtime {
namespace {

namespace format = skelform::format;

// The deepest Loop level a runtime accepts: 4^8 refined triangles per control triangle is
// already far beyond any dense mesh; a larger value is corruption.
constexpr int kMaxSubdivisionLevel = 8;

// Sets of four joint influences per vertex (control.joints, JOINTS_n), per deformable
// (skelform.h "Limits"): 64 influences per vertex. Every set costs memory and skinning time
// per vertex; without a bound, one accessor named thousands of times in a few kilobytes of
// JSON made a load take gigabytes.
constexpr size_t kMaxInfluenceSets = 16;

// The largest magnitude of a length the asset stores (positions, medial radii, displacements,
// residuals; skelform.h "Limits"). Far beyond any mesh float positions can describe, and
// small enough that the evaluation's squares and cubes of lengths stay finite (1e36).
constexpr double kMaxLength = 1e12;
// Slack of the unit-vector and barycentric checks: float rounding of what the baker wrote.
constexpr double kUnitSlack = 1e-3;
constexpr double kBarycentricSlack = 1e-5;

[[noreturn]] void invalid(const std::string& what, const std::string& problem) {
  throw LoadError(SF_ERROR_INVALID_DATA, what + ": " + problem);
}

std::string number_text(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

[[noreturn]] void beyond_influence_limit(const std::string& what, size_t sets) {
  throw LoadError(SF_ERROR_UNSUPPORTED, what + ": " + std::to_string(sets) +
                                            " influence sets; this runtime reads at most " +
                                            std::to_string(kMaxInfluenceSets) + " per deformable (" +
                                            std::to_string(4 * kMaxInfluenceSets) + " joints per vertex)");
}

// --- JSON members of the extension (tinygltf::Value) ---

const tinygltf::Value* member(const tinygltf::Value& object, const char* key) {
  if (!object.IsObject() || !object.Has(key)) return nullptr;
  return &object.Get(key);
}

// An integer JSON value within [low, high]; `label` names it in the message.
int integer_value(const tinygltf::Value& value, const std::string& what, const std::string& label, int low, int high) {
  // JSON does not distinguish 3 from 3.0; tinygltf may store either.
  const double number = value.IsNumber() ? value.GetNumberAsDouble() : std::nan("");
  if (!value.IsNumber() || number != std::floor(number) || number < low || number > high)
    invalid(what, label + " must be an integer within " + std::to_string(low) + ".." + std::to_string(high));
  return static_cast<int>(number);
}

// An integer member within [low, high]; absent gives `fallback` when not required.
int integer_member(const tinygltf::Value& object, const char* key, const std::string& what, bool required, int fallback,
                   int low, int high) {
  const tinygltf::Value* value = member(object, key);
  if (!value) {
    if (required) invalid(what, std::string("required member '") + key + "' is missing");
    return fallback;
  }
  return integer_value(*value, what, std::string("member '") + key + "'", low, high);
}

const tinygltf::Value& object_member(const tinygltf::Value& object, const char* key, const std::string& what) {
  const tinygltf::Value* value = member(object, key);
  if (!value || !value->IsObject()) invalid(what, std::string("required object '") + key + "' is missing");
  return *value;
}

int accessor_member(const tinygltf::Value& group, const char* key, const std::string& what, size_t accessor_total) {
  return integer_member(group, key, what, true, -1, 0,
                        static_cast<int>(std::min<size_t>(accessor_total, std::numeric_limits<int>::max())) - 1);
}

// --- Extension arrays ---

int component_type_of(format::Component component) { return static_cast<int>(component); }

std::string array_label(const format::ArraySpec& spec) { return std::string(spec.group) + "." + spec.name; }

// One array of kArrays read and type-checked (counts are checked afterwards, when every
// quantity they refer to is known).
struct ReadArray {
  const format::ArraySpec* spec = nullptr;
  std::string what;
  std::vector<double> values;
  size_t items() const {  // elements, or triangles for index arrays
    return values.size() / static_cast<size_t>(spec->components) / static_cast<size_t>(spec->indices_per_item);
  }
};

// `set_accessor` >= 0 reads one set of a joint/weight array (the JSON holds an array of
// accessors there) instead of the member the spec names.
ReadArray read_array(const tinygltf::Model& model, const tinygltf::Value& deformable, const format::ArraySpec& spec,
                     const std::string& prefix, int set_accessor = -1, size_t set = 0) {
  ReadArray array;
  array.spec = &spec;
  array.what = prefix + " " + array_label(spec) + (set_accessor >= 0 ? "[" + std::to_string(set) + "]" : "");
  int accessor = set_accessor;
  if (accessor < 0) {
    const tinygltf::Value& group = object_member(deformable, spec.group, prefix);
    accessor = accessor_member(group, spec.name, array.what, model.accessors.size());
  }
  array.values = gltf::read_exact(model, accessor, component_type_of(spec.component), spec.components, array.what);
  const size_t elements = array.values.size() / static_cast<size_t>(spec.components);
  if (elements % static_cast<size_t>(spec.indices_per_item) != 0)
    invalid(array.what,
            std::to_string(elements) + " indices, not a multiple of " + std::to_string(spec.indices_per_item));
  return array;
}

// The counts every array is checked against (extension_layout.h CountOf).
struct Counts {
  size_t control_vertices = 0;
  size_t control_triangles = 0;
  size_t refined_vertices = 0;
  size_t refined_triangles = 0;
  size_t stencil_entries = 0;
  size_t dense_vertices = 0;

  size_t expected(format::CountOf count) const {
    switch (count) {
      case format::CountOf::control_vertices:
        return control_vertices;
      case format::CountOf::control_triangles:
        return control_triangles;
      case format::CountOf::refined_vertices:
        return refined_vertices;
      case format::CountOf::refined_vertices_plus_one:
        return refined_vertices + 1;
      case format::CountOf::refined_triangles:
        return refined_triangles;
      case format::CountOf::stencil_entries:
        return stencil_entries;
      case format::CountOf::dense_vertices:
        return dense_vertices;
    }
    return 0;
  }
};

const char* count_name(format::CountOf count) {
  switch (count) {
    case format::CountOf::control_vertices:
      return "control vertices";
    case format::CountOf::control_triangles:
      return "control triangles";
    case format::CountOf::refined_vertices:
      return "refined vertices";
    case format::CountOf::refined_vertices_plus_one:
      return "refined vertices + 1";
    case format::CountOf::refined_triangles:
      return "refined triangles";
    case format::CountOf::stencil_entries:
      return "stencil entries";
    case format::CountOf::dense_vertices:
      return "dense vertices (vertexCount)";
  }
  return "?";
}

// Finds the array named group.name among those read from kArrays.
const ReadArray& find_array(const std::vector<ReadArray>& arrays, const char* group, const char* name) {
  for (const ReadArray& array : arrays)
    if (std::string(array.spec->group) == group && std::string(array.spec->name) == name) return array;
  // Only reachable if extension_layout.h renamed a member this file relies on: a build
  // mismatch, reported rather than crashed on.
  throw LoadError(SF_ERROR_UNSUPPORTED, std::string("runtime does not know the extension array ") + group + "." + name);
}

// Every value of an index array is an integer below `limit` (what it indexes).
void check_indices(const ReadArray& array, size_t limit, const char* indexed) {
  for (size_t i = 0; i < array.values.size(); ++i) {
    if (array.values[i] >= static_cast<double>(limit))
      invalid(array.what, "index " + std::to_string(static_cast<uint64_t>(array.values[i])) + " at position " +
                              std::to_string(i) + " is out of range (" + std::to_string(limit) + " " + indexed + ")");
  }
}

template <class T>
void copy_scalars(const std::vector<double>& values, Array<T>& out) {
  out.resize(values.size());
  for (size_t i = 0; i < values.size(); ++i) out[i] = static_cast<T>(values[i]);
}

void copy_vec3(const std::vector<double>& values, Array<glm::vec3>& out) {
  out.resize(values.size() / 3);
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = glm::vec3(static_cast<float>(values[3 * i]), static_cast<float>(values[3 * i + 1]),
                       static_cast<float>(values[3 * i + 2]));
}

void copy_vec2(const std::vector<double>& values, Array<glm::vec2>& out) {
  out.resize(values.size() / 2);
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = glm::vec2(static_cast<float>(values[2 * i]), static_cast<float>(values[2 * i + 1]));
}

// Every value of `array` is a length within ±kMaxLength.
void check_lengths(const ReadArray& array) {
  for (size_t i = 0; i < array.values.size(); ++i)
    if (!(std::fabs(array.values[i]) <= kMaxLength))
      invalid(array.what, "value " + number_text(array.values[i]) + " at position " + std::to_string(i) +
                              " is beyond the length limit " + number_text(kMaxLength));
}

// The ranges of the extension's float arrays (skelform.h "Limits"; the spec's "Limits"): the
// lengths, unit normals, Loop stencil weights (in [0, 1] as the baker writes them; the reader
// allows [-1, 1]) and barycentrics inside their triangle. Beyond them the evaluation would
// overflow, or compute garbage from what cannot be a bake.
void check_value_limits(const std::vector<ReadArray>& arrays) {
  const std::pair<const char*, const char*> lengths[] = {{"control", "positions"},
                                                         {"control", "skeletalPositions"},
                                                         {"control", "medialRadius"},
                                                         {"binding", "displacement"},
                                                         {"binding", "residual"}};
  for (const auto& [group, name] : lengths) check_lengths(find_array(arrays, group, name));
  const ReadArray& normals = find_array(arrays, "control", "normals");
  for (size_t v = 0; 3 * v + 2 < normals.values.size(); ++v) {
    const double* n = &normals.values[3 * v];
    if (!(std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) <= 1.0 + kUnitSlack))
      invalid(normals.what, "control vertex " + std::to_string(v) + " has a normal longer than 1");
  }
  const ReadArray& weights = find_array(arrays, "subdivision", "stencilWeights");
  for (size_t i = 0; i < weights.values.size(); ++i)
    if (!(std::fabs(weights.values[i]) <= 1.0))
      invalid(weights.what,
              "weight " + number_text(weights.values[i]) + " of entry " + std::to_string(i) + " is outside [-1, 1]");
  const ReadArray& barycentric = find_array(arrays, "binding", "barycentric");
  for (size_t v = 0; 2 * v + 1 < barycentric.values.size(); ++v) {
    const double b1 = barycentric.values[2 * v], b2 = barycentric.values[2 * v + 1];
    if (!(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 + kBarycentricSlack))
      invalid(barycentric.what, "vertex " + std::to_string(v) + " has (" + number_text(b1) + ", " + number_text(b2) +
                                    "), not a point of its triangle (b1, b2 >= 0, b1 + b2 <= 1)");
  }
}

// --- Skin influences (dense and control alike) ---

// Sets of four (joint, weight) per vertex, gathered before the final `influences` width is
// known; missing sets read as zero weights.
struct InfluenceSets {
  std::vector<std::vector<glm::uvec4>> joints;
  std::vector<std::vector<glm::vec4>> weights;
};

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

// --- Dense vertices from the glTF primitives ---

// Triangles of one primitive, in its own vertex numbering, by the glTF topology rules.
void triangulate(int mode, const std::vector<uint32_t>& corner, uint32_t first_vertex, const std::string& what,
                 Array<uint32_t>& out) {
  const size_t n = corner.size();
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    if (n % 3 != 0) invalid(what, "TRIANGLES with " + std::to_string(n) + " vertex indices, not a multiple of 3");
    for (size_t i = 0; i < n; ++i) out.push_back(first_vertex + corner[i]);
    return;
  }
  if (n < 3) invalid(what, std::to_string(n) + " vertices make no triangle");
  for (size_t i = 0; i + 2 < n; ++i) {
    std::array<uint32_t, 3> t;
    if (mode == TINYGLTF_MODE_TRIANGLE_STRIP)  // odd triangles swap to keep the winding
      t = {corner[i], corner[i + 1 + i % 2], corner[i + 2 - i % 2]};
    else
      t = {corner[i + 1], corner[i + 2], corner[0]};
    for (uint32_t v : t) out.push_back(first_vertex + v);
  }
}

// `weight_override` receives every dense vertex's _SKELFORM_WEIGHT (-1 where its primitive has
// none).
void read_primitives(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                     Deformable& deformable, InfluenceSets& dense_sets, std::vector<std::string>& dense_labels,
                     std::vector<float>& weight_override) {
  const tinygltf::Mesh& mesh = model.meshes[static_cast<size_t>(deformable.mesh)];
  const tinygltf::Value* list = member(json, format::kPrimitives);
  if (!list || !list->IsArray() || list->ArrayLen() == 0)
    invalid(prefix, std::string("'") + format::kPrimitives + "' must be a non-empty array");
  const size_t count = list->ArrayLen();
  if (count > mesh.primitives.size())
    invalid(prefix, "lists " + std::to_string(count) + " primitives; mesh " + std::to_string(deformable.mesh) +
                        " has " + std::to_string(mesh.primitives.size()));
  std::vector<bool> seen(mesh.primitives.size(), false);
  deformable.primitives.reserve(count);
  size_t vertex_total = 0;
  for (size_t p = 0; p < count; ++p) {
    const tinygltf::Value& item = list->Get(static_cast<int>(p));
    const double number = item.IsNumber() ? item.GetNumberAsDouble() : -1.0;
    if (!(number >= 0) || number != std::floor(number) || number >= static_cast<double>(mesh.primitives.size()))
      invalid(prefix,
              "primitives[" + std::to_string(p) + "] is not a primitive of mesh " + std::to_string(deformable.mesh));
    const size_t index = static_cast<size_t>(number);
    if (seen[index]) invalid(prefix, "primitive " + std::to_string(index) + " is listed twice");
    seen[index] = true;
    const tinygltf::Primitive& primitive = mesh.primitives[index];
    const std::string what =
        prefix + " mesh " + std::to_string(deformable.mesh) + " primitive " + std::to_string(index);

    const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;  // absent = TRIANGLES
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
      invalid(what, "mode " + std::to_string(mode) + " is not a triangle mode, so it cannot have been baked");
    const auto attribute = [&](const std::string& semantic) {
      const auto found = primitive.attributes.find(semantic);
      return found == primitive.attributes.end() ? -1 : found->second;
    };
    const int position_accessor = attribute("POSITION");
    if (position_accessor < 0) invalid(what, "has no POSITION attribute");
    const std::vector<glm::dvec3> positions = gltf::read_vec3(model, position_accessor, what + " POSITION");
    for (size_t v = 0; v < positions.size(); ++v)
      for (int k = 0; k < 3; ++k)
        if (!(std::fabs(positions[v][k]) <= kMaxLength))
          invalid(what + " POSITION", "vertex " + std::to_string(v) + " has " + number_text(positions[v][k]) +
                                          ", beyond the length limit " + number_text(kMaxLength));
    const size_t vertex_count = positions.size();
    if (vertex_total + vertex_count > std::numeric_limits<uint32_t>::max())
      throw LoadError(SF_ERROR_UNSUPPORTED, what + ": more than 2^32-1 vertices in the deformable");

    PrimitiveRecord record;
    record.primitive = static_cast<int32_t>(index);
    record.first_vertex = static_cast<uint32_t>(vertex_total);
    record.vertex_count = static_cast<uint32_t>(vertex_count);
    for (const glm::dvec3& position : positions) deformable.rest_positions.push_back(glm::vec3(position));
    const int override_accessor = attribute(format::kSkelformWeightAttribute);
    if (override_accessor >= 0) {
      const std::vector<float> values =
          gltf::read_unit_scalars(model, override_accessor, what + " " + format::kSkelformWeightAttribute);
      if (values.size() != vertex_count)
        invalid(what, std::string(format::kSkelformWeightAttribute) + " count differs from POSITION count");
      weight_override.insert(weight_override.end(), values.begin(), values.end());
    } else {
      weight_override.insert(weight_override.end(), vertex_count, -1.0f);
    }

    const int normal_accessor = attribute("NORMAL");
    record.has_normals = normal_accessor >= 0;
    if (record.has_normals) {
      const std::vector<glm::dvec3> normals = gltf::read_vec3(model, normal_accessor, what + " NORMAL");
      if (normals.size() != vertex_count) invalid(what, "NORMAL count differs from POSITION count");
      for (const glm::dvec3& normal : normals) deformable.rest_normals.push_back(glm::vec3(normal));
    } else {
      deformable.rest_normals.resize(deformable.rest_normals.size() + vertex_count, glm::vec3(0.0f));
    }
    const int tangent_accessor = attribute("TANGENT");
    record.has_tangents = tangent_accessor >= 0;
    if (record.has_tangents) {
      const std::vector<glm::dvec4> tangents = gltf::read_vec4(model, tangent_accessor, what + " TANGENT");
      if (tangents.size() != vertex_count) invalid(what, "TANGENT count differs from POSITION count");
      for (const glm::dvec4& tangent : tangents) deformable.rest_tangents.push_back(glm::vec4(tangent));
    } else {
      deformable.rest_tangents.resize(deformable.rest_tangents.size() + vertex_count, glm::vec4(0.0f));
    }

    std::vector<uint32_t> corners;
    if (primitive.indices >= 0) {
      corners = gltf::read_indices(model, primitive.indices, vertex_count, what + " indices");
    } else {
      corners.resize(vertex_count);
      for (size_t i = 0; i < vertex_count; ++i) corners[i] = static_cast<uint32_t>(i);
    }
    const size_t first_index = deformable.dense_triangles.size();
    triangulate(mode, corners, record.first_vertex, what, deformable.dense_triangles);
    record.first_triangle = static_cast<uint32_t>(first_index / 3);
    record.triangle_count = static_cast<uint32_t>((deformable.dense_triangles.size() - first_index) / 3);

    if (deformable.skin >= 0) {
      // JOINTS_n/WEIGHTS_n, every set; sets an earlier or later primitive lacks hold zeros.
      for (size_t set = 0;; ++set) {
        const std::string n = std::to_string(set);
        const int joints = attribute("JOINTS_" + n);
        const int weights = attribute("WEIGHTS_" + n);
        if (joints < 0 && weights < 0) {
          if (set == 0) invalid(what, "belongs to a skinned deformable but has no JOINTS_0/WEIGHTS_0");
          break;
        }
        if (joints < 0 || weights < 0) invalid(what, "has only one of JOINTS_" + n + " and WEIGHTS_" + n);
        if (set >= kMaxInfluenceSets) beyond_influence_limit(what + " JOINTS_n", set + 1);
        const std::vector<glm::uvec4> joint_values = gltf::read_joints(model, joints, what + " JOINTS_" + n);
        const std::vector<glm::dvec4> weight_values = gltf::read_weights(model, weights, what + " WEIGHTS_" + n);
        if (joint_values.size() != vertex_count || weight_values.size() != vertex_count)
          invalid(what, "JOINTS_" + n + "/WEIGHTS_" + n + " count differs from POSITION count");
        if (set >= dense_sets.joints.size()) {
          dense_sets.joints.emplace_back(vertex_total, glm::uvec4(0));
          dense_sets.weights.emplace_back(vertex_total, glm::vec4(0.0f));
          dense_labels.push_back("JOINTS_" + n);
        }
        dense_sets.joints[set].insert(dense_sets.joints[set].end(), joint_values.begin(), joint_values.end());
        for (const glm::dvec4& w : weight_values) dense_sets.weights[set].push_back(glm::vec4(w));
      }
      for (size_t set = 0; set < dense_sets.joints.size(); ++set) {
        dense_sets.joints[set].resize(vertex_total + vertex_count, glm::uvec4(0));
        dense_sets.weights[set].resize(vertex_total + vertex_count, glm::vec4(0.0f));
      }
      // Exporter defects, repaired as the baker repaired them (skin_repair.h).
      const size_t slots = 4 * dense_sets.joints.size();
      std::vector<uint32_t> slot_joints(slots * vertex_count);
      std::vector<double> slot_weights(slots * vertex_count);
      for (size_t v = 0; v < vertex_count; ++v)
        for (size_t k = 0; k < slots; ++k) {
          slot_joints[v * slots + k] = dense_sets.joints[k / 4][vertex_total + v][int(k % 4)];
          slot_weights[v * slots + k] = double(dense_sets.weights[k / 4][vertex_total + v][int(k % 4)]);
        }
      skin::SkinRepairReport report;
      if (!skin::repair_skin(slot_joints.data(), slot_weights.data(), slots, positions.data(), vertex_count, report))
        invalid(what, "has vertices with no skin weight and no weighted vertex to take one from");
      if (report.repaired())
        for (size_t v = 0; v < vertex_count; ++v)
          for (size_t k = 0; k < slots; ++k) {
            dense_sets.joints[k / 4][vertex_total + v][int(k % 4)] = slot_joints[v * slots + k];
            dense_sets.weights[k / 4][vertex_total + v][int(k % 4)] = float(slot_weights[v * slots + k]);
          }
    }
    vertex_total += vertex_count;
    deformable.primitives.push_back(record);
  }
  deformable.vertex_count = static_cast<uint32_t>(vertex_total);
}

// Area-weighted normals for the primitives without NORMAL (Fox has none): each triangle adds
// its unnormalised face normal to its corners. Vertices no triangle with area touches keep
// (0,0,0) here and get the bound surface normal once the rest frames exist.
void compute_missing_normals(Deformable& deformable) {
  std::vector<bool> computed(deformable.vertex_count, false);
  bool any = false;
  for (const PrimitiveRecord& record : deformable.primitives) {
    if (record.has_normals) continue;
    any = true;
    for (uint32_t v = 0; v < record.vertex_count; ++v) computed[record.first_vertex + v] = true;
  }
  if (!any) return;
  const Array<glm::vec3>& p = deformable.rest_positions;
  for (size_t t = 0; t + 2 < deformable.dense_triangles.size(); t += 3) {
    const uint32_t i0 = deformable.dense_triangles[t], i1 = deformable.dense_triangles[t + 1],
                   i2 = deformable.dense_triangles[t + 2];
    if (!computed[i0]) continue;  // a triangle's corners share one primitive
    const glm::vec3 face = glm::cross(p[i1] - p[i0], p[i2] - p[i0]);
    deformable.rest_normals[i0] += face;
    deformable.rest_normals[i1] += face;
    deformable.rest_normals[i2] += face;
  }
  for (size_t v = 0; v < deformable.vertex_count; ++v) {
    if (!computed[v]) continue;
    const float length = glm::length(deformable.rest_normals[v]);
    deformable.rest_normals[v] =
        length > 1e-30f && std::isfinite(length) ? deformable.rest_normals[v] / length : glm::vec3(0.0f);
  }
}

// --- One deformable ---

void load_deformable(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                     Deformable& deformable) {
  if (!json.IsObject()) invalid(prefix, "is not a JSON object");
  const int int_max = std::numeric_limits<int>::max();
  deformable.mesh = integer_member(json, format::kMesh, prefix, true, -1, 0, static_cast<int>(model.meshes.size()) - 1);
  deformable.node = integer_member(json, format::kNode, prefix, false, -1, 0, static_cast<int>(model.nodes.size()) - 1);
  deformable.skin = integer_member(json, format::kSkin, prefix, false, -1, 0, static_cast<int>(model.skins.size()) - 1);
  if (deformable.node >= 0 && model.nodes[static_cast<size_t>(deformable.node)].mesh != deformable.mesh)
    invalid(prefix,
            "node " + std::to_string(deformable.node) + " does not instance mesh " + std::to_string(deformable.mesh));
  if (deformable.skin >= 0) {
    const size_t joints = model.skins[static_cast<size_t>(deformable.skin)].joints.size();
    if (joints == 0) invalid(prefix, "skin " + std::to_string(deformable.skin) + " has no joints");
    // Joint indices are stored as UNSIGNED_SHORT.
    if (joints > 65536) throw LoadError(SF_ERROR_UNSUPPORTED, prefix + ": skin with more than 65536 joints");
    deformable.joint_count = static_cast<uint32_t>(joints);
  }
  const int vertex_count = integer_member(json, format::kVertexCount, prefix, true, 0, 1, int_max);

  // The extension's arrays, straight from the layout table.
  std::vector<ReadArray> arrays;
  arrays.reserve(format::kArrayCount);
  for (const format::ArraySpec& spec : format::kArrays) arrays.push_back(read_array(model, json, spec, prefix));

  const ReadArray& offsets = find_array(arrays, "subdivision", "stencilOffsets");
  const tinygltf::Value& subdivision = object_member(json, "subdivision", prefix);
  deformable.subdivision_level = static_cast<uint32_t>(integer_member(
      subdivision, format::kSubdivisionLevel, prefix + " subdivision", true, 0, 0, kMaxSubdivisionLevel));

  // The quantities CountOf names: defined by the array that carries them, then every array
  // is checked against them.
  Counts counts;
  counts.dense_vertices = static_cast<size_t>(vertex_count);
  counts.control_vertices = find_array(arrays, "control", "positions").items();
  counts.control_triangles = find_array(arrays, "control", "indices").items();
  counts.refined_triangles = find_array(arrays, "subdivision", "indices").items();
  if (offsets.values.size() < 2) invalid(offsets.what, "needs at least 2 offsets (one refined vertex)");
  counts.refined_vertices = offsets.values.size() - 1;
  if (offsets.values.front() != 0) invalid(offsets.what, "the first offset must be 0");
  for (size_t v = 1; v < offsets.values.size(); ++v)
    if (offsets.values[v] < offsets.values[v - 1])
      invalid(offsets.what, "offsets decrease at refined vertex " + std::to_string(v - 1));
  counts.stencil_entries = static_cast<size_t>(offsets.values.back());
  for (const ReadArray& array : arrays) {
    const size_t expected = counts.expected(array.spec->count);
    if (array.items() != expected)
      invalid(array.what, "has " + std::to_string(array.items()) +
                              (array.spec->indices_per_item == 3 ? " triangles" : " elements") + "; expected " +
                              std::to_string(expected) + " (" + count_name(array.spec->count) + ")");
  }

  // Index ranges and value ranges.
  check_indices(find_array(arrays, "control", "indices"), counts.control_vertices, "control vertices");
  check_indices(find_array(arrays, "subdivision", "stencilIndices"), counts.control_vertices, "control vertices");
  check_indices(find_array(arrays, "subdivision", "indices"), counts.refined_vertices, "refined vertices");
  check_indices(find_array(arrays, "binding", "triangle"), counts.refined_triangles, "refined triangles");
  const ReadArray& radius = find_array(arrays, "control", "medialRadius");
  for (size_t i = 0; i < radius.values.size(); ++i)
    if (radius.values[i] < 0) invalid(radius.what, "control vertex " + std::to_string(i) + " has a negative radius");
  check_value_limits(arrays);
  if (counts.control_vertices > std::numeric_limits<uint32_t>::max() ||
      counts.refined_vertices > std::numeric_limits<uint32_t>::max())
    throw LoadError(SF_ERROR_UNSUPPORTED, prefix + ": more than 2^32-1 control or refined vertices");

  deformable.control_vertex_count = static_cast<uint32_t>(counts.control_vertices);
  deformable.refined_vertex_count = static_cast<uint32_t>(counts.refined_vertices);
  copy_vec3(find_array(arrays, "control", "positions").values, deformable.control_positions);
  copy_vec3(find_array(arrays, "control", "normals").values, deformable.control_normals);
  copy_scalars(find_array(arrays, "control", "indices").values, deformable.control_indices);
  copy_vec3(find_array(arrays, "control", "skeletalPositions").values, deformable.skeletal_positions);
  copy_scalars(radius.values, deformable.medial_radius);
  copy_scalars(offsets.values, deformable.stencil_offsets);
  copy_scalars(find_array(arrays, "subdivision", "stencilIndices").values, deformable.stencil_indices);
  copy_scalars(find_array(arrays, "subdivision", "stencilWeights").values, deformable.stencil_weights);
  copy_scalars(find_array(arrays, "subdivision", "indices").values, deformable.refined_indices);
  copy_scalars(find_array(arrays, "binding", "triangle").values, deformable.binding_triangle);
  copy_vec2(find_array(arrays, "binding", "barycentric").values, deformable.binding_barycentric);
  copy_scalars(find_array(arrays, "binding", "displacement").values, deformable.binding_displacement);
  copy_vec2(find_array(arrays, "binding", "residual").values, deformable.binding_residual);
  arrays.clear();
  arrays.shrink_to_fit();

  // Skin of the control vertices: arrays of accessors, one per set of four (kJointSet/kWeightSet).
  InfluenceSets control_sets;
  std::vector<std::string> control_labels;
  if (deformable.skin >= 0) {
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
      control_labels.push_back("control.joints[" + std::to_string(set) + "]");
    }
    finish_influences(control_sets, counts.control_vertices, deformable.joint_count, prefix + " control",
                      control_labels);
  }

  // Dense vertices from the glTF mesh itself.
  InfluenceSets dense_sets;
  std::vector<std::string> dense_labels;
  std::vector<float> weight_override;
  read_primitives(model, json, prefix, deformable, dense_sets, dense_labels, weight_override);
  if (deformable.vertex_count != counts.dense_vertices)
    invalid(prefix, std::string(format::kVertexCount) + " is " + std::to_string(counts.dense_vertices) +
                        " but the primitives' POSITION counts sum to " + std::to_string(deformable.vertex_count));
  if (deformable.skin >= 0) {
    finish_influences(dense_sets, deformable.vertex_count, deformable.joint_count, prefix + " dense skin",
                      dense_labels);
    const size_t sets = std::max(dense_sets.joints.size(), control_sets.joints.size());
    deformable.influences = static_cast<uint32_t>(4 * sets);
    store_influences(dense_sets, deformable.vertex_count, deformable.influences, deformable.dense_joints,
                     deformable.dense_weights);
    // The skelform weight: as baked (2.2), else the artist's attribute, else the skin's rule
    // (the baker's order too, skelform_weight.h).
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
  compute_missing_normals(deformable);
  build_joint_arcs(model, deformable);
}

// Renumbers the refined vertices in the order the dense vertices first name them as corners
// of their bound triangles (then the unnamed ones, in baked order): the per-frame DSS loop
// (displace.cpp) walks the dense vertices in order, and in the baked numbering their corners
// lie all over the refined arrays (several cache lines per dense vertex). A pure renaming: stencil rows move with their vertex, refined triangles keep
// their order and their corners' roles, so every refined position and normal is computed
// with the same operations in the same order, and the evaluation gives the same bits.
void renumber_refined_vertices(Deformable& deformable) {
  const uint32_t count = deformable.refined_vertex_count;
  constexpr uint32_t kUnnamed = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> new_of_old(count, kUnnamed), old_of_new;
  old_of_new.reserve(count);
  for (uint32_t v = 0; v < deformable.vertex_count; ++v)
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t old = deformable.refined_indices[3 * size_t{deformable.binding_triangle[v]} + k];
      if (new_of_old[old] != kUnnamed) continue;
      new_of_old[old] = static_cast<uint32_t>(old_of_new.size());
      old_of_new.push_back(old);
    }
  for (uint32_t old = 0; old < count; ++old)
    if (new_of_old[old] == kUnnamed) {
      new_of_old[old] = static_cast<uint32_t>(old_of_new.size());
      old_of_new.push_back(old);
    }
  Array<uint32_t> offsets(deformable.stencil_offsets.get_allocator());
  Array<uint32_t> indices(deformable.stencil_indices.get_allocator());
  Array<float> weights(deformable.stencil_weights.get_allocator());
  offsets.reserve(deformable.stencil_offsets.size());
  indices.reserve(deformable.stencil_indices.size());
  weights.reserve(deformable.stencil_weights.size());
  offsets.push_back(0);
  for (uint32_t old : old_of_new) {
    for (uint32_t s = deformable.stencil_offsets[old]; s < deformable.stencil_offsets[old + 1]; ++s) {
      indices.push_back(deformable.stencil_indices[s]);
      weights.push_back(deformable.stencil_weights[s]);
    }
    offsets.push_back(static_cast<uint32_t>(indices.size()));
  }
  deformable.stencil_offsets.swap(offsets);
  deformable.stencil_indices.swap(indices);
  deformable.stencil_weights.swap(weights);
  for (uint32_t& index : deformable.refined_indices) index = new_of_old[index];
}

// Regroups the stencil rows for refine_surface (Deformable::stencil_group_rows): a stable
// sort of the rows by length, then kStencilLanes rows per group, entries lane-interleaved.
// Each row keeps its entries in stencil order, so it sums to the same bits as from the CSR;
// the sums of a group are independent, which hides their addition latency, and the inner
// loop's trip count is the same group after group (rows come in mixed lengths, in no order).
void group_stencils(Deformable& deformable) {
  const uint32_t count = deformable.refined_vertex_count;
  std::vector<uint32_t> by_length(count);
  for (uint32_t v = 0; v < count; ++v) by_length[v] = v;
  const auto length = [&](uint32_t v) { return deformable.stencil_offsets[v + 1] - deformable.stencil_offsets[v]; };
  std::stable_sort(by_length.begin(), by_length.end(), [&](uint32_t l, uint32_t r) { return length(l) < length(r); });
  deformable.stencil_group_rows.clear();
  deformable.stencil_group_lengths.clear();
  deformable.stencil_group_indices.clear();
  deformable.stencil_group_weights.clear();
  for (size_t first = 0; first < count;) {
    const uint32_t rows_length = length(by_length[first]);
    uint32_t lanes[kStencilLanes];
    for (uint32_t lane = 0; lane < kStencilLanes; ++lane) {
      // A short last group of this length repeats its last row.
      if (first < count && length(by_length[first]) == rows_length) ++first;
      lanes[lane] = by_length[first - 1];
      deformable.stencil_group_rows.push_back(lanes[lane]);
    }
    deformable.stencil_group_lengths.push_back(rows_length);
    for (uint32_t s = 0; s < rows_length; ++s)
      for (uint32_t lane = 0; lane < kStencilLanes; ++lane) {
        const uint32_t entry = deformable.stencil_offsets[lanes[lane]] + s;
        deformable.stencil_group_indices.push_back(deformable.stencil_indices[entry]);
        deformable.stencil_group_weights.push_back(deformable.stencil_weights[entry]);
      }
  }
}

// The rest evaluation, once: refined rest surface, the corners of every bound triangle, the
// rest normal and tangent in the frame at every bound point, and the control vertex a handle
// on each dense vertex moves.
void derive_rest_data(Deformable& deformable) {
  renumber_refined_vertices(deformable);
  group_stencils(deformable);
  std::vector<glm::vec3> refined(deformable.refined_vertex_count);
  std::vector<glm::vec3> normals(deformable.refined_vertex_count);
  refine_rest_surface(deformable, refined.data(), normals.data());

  deformable.binding_corners.resize(3 * size_t{deformable.vertex_count});
  for (uint32_t v = 0; v < deformable.vertex_count; ++v)
    for (uint32_t k = 0; k < 3; ++k)
      deformable.binding_corners[3 * size_t{v} + k] =
          deformable.refined_indices[3 * size_t{deformable.binding_triangle[v]} + k];
  deformable.rest_normal_coords.resize(deformable.vertex_count);
  deformable.rest_tangent_coords.resize(deformable.vertex_count);
  deformable.handle_control_vertex.resize(deformable.vertex_count);
  std::vector<bool> computed_normal(deformable.vertex_count, false);
  for (const PrimitiveRecord& record : deformable.primitives)
    if (!record.has_normals)
      for (uint32_t v = 0; v < record.vertex_count; ++v) computed_normal[record.first_vertex + v] = true;

  for (uint32_t v = 0; v < deformable.vertex_count; ++v) {
    const dss::SurfaceFrame frame = bound_frame(deformable, refined.data(), normals.data(), v);
    if (computed_normal[v] && deformable.rest_normals[v] == glm::vec3(0.0f)) deformable.rest_normals[v] = frame.normal;
    // Coordinates in the rest frame F (columns tangent, bitangent, normal): F^T x.
    const glm::mat3 to_frame = glm::transpose(glm::mat3(frame.tangent, frame.bitangent, frame.normal));
    deformable.rest_normal_coords[v] = normalize_or(to_frame * deformable.rest_normals[v], glm::vec3(0, 0, 1));
    deformable.rest_tangent_coords[v] =
        normalize_or(to_frame * glm::vec3(deformable.rest_tangents[v]), glm::vec3(1, 0, 0));

    // Corner with the largest barycentric, then its heaviest stencil entry. Corners whose
    // stencil is empty (legal, if odd) are skipped in barycentric order.
    const uint32_t* corner = deformable.binding_corners.data() + 3 * size_t{v};
    const glm::vec2 b = deformable.binding_barycentric[v];
    std::array<std::pair<float, uint32_t>, 3> by_weight = {
        {{1.0f - b.x - b.y, corner[0]}, {b.x, corner[1]}, {b.y, corner[2]}}};
    std::stable_sort(by_weight.begin(), by_weight.end(),
                     [](const auto& l, const auto& r) { return l.first > r.first; });
    uint32_t control = 0;
    for (const auto& [weight, refined_vertex] : by_weight) {
      (void)weight;
      const uint32_t begin = deformable.stencil_offsets[refined_vertex],
                     end = deformable.stencil_offsets[refined_vertex + 1];
      if (begin == end) continue;
      uint32_t best = begin;
      for (uint32_t s = begin + 1; s < end; ++s)
        if (deformable.stencil_weights[s] > deformable.stencil_weights[best]) best = s;
      control = deformable.stencil_indices[best];
      break;
    }
    deformable.handle_control_vertex[v] = control;
  }
  // The evaluation reads the grouped stencils only.
  Array<uint32_t>(deformable.stencil_offsets.get_allocator()).swap(deformable.stencil_offsets);
  Array<uint32_t>(deformable.stencil_indices.get_allocator()).swap(deformable.stencil_indices);
  Array<float>(deformable.stencil_weights.get_allocator()).swap(deformable.stencil_weights);
}

// The fairing's connectivity and rest values (fair.h), once per deformable.
void derive_fairing_data(Deformable& deformable, const AllocatorRef& allocator) {
  float largest_radius = 0.0f;
  for (float r : deformable.medial_radius) largest_radius = std::max(largest_radius, r);
  deformable.fairing_topology =
      build_fairing_topology(deformable.control_indices.data(), deformable.control_indices.size() / 3,
                             deformable.control_vertex_count, allocator);
  deformable.fairing_supported = largest_radius > 0.0f;
  if (!deformable.fairing_supported) return;
  FairingWorkspace scratch = make_fairing_workspace(deformable.fairing_topology, 0, allocator);
  deformable.fairing_rest =
      make_fairing_rest(deformable.fairing_topology, deformable.skeletal_positions.data(),
                        deformable.medial_radius.data(), deformable.control_positions.data(), 0, scratch, allocator);
}

struct AssetDeleter {
  AllocatorRef allocator;
  void operator()(sf_asset* asset) const { destroy_object(allocator, asset); }
};

}  // namespace

sf_asset* load_asset(const unsigned char* bytes, size_t size, const std::string& name, gltf::ExternalFiles external,
                     const AllocatorRef& allocator) {
  tinygltf::Model model;
  gltf::parse_model(bytes, size, gltf::is_glb(bytes, size), name, model, external);

  const auto extension = model.extensions.find(format::kExtensionName);
  if (extension == model.extensions.end())
    invalid(name,
            std::string("not a skelform-baked asset (run skelform-bake): no ") + format::kExtensionName + " extension");
  const tinygltf::Value& root = extension->second;
  const std::string prefix = name + ": " + format::kExtensionName;
  if (!root.IsObject()) invalid(prefix, "the extension is not a JSON object");
  const int major = integer_member(root, format::kMajorVersionKey, prefix, true, 0, 0, std::numeric_limits<int>::max());
  const int minor = integer_member(root, format::kMinorVersionKey, prefix, true, 0, 0, std::numeric_limits<int>::max());
  if (major > format::kMajorVersion)
    throw LoadError(SF_ERROR_VERSION_MISMATCH,
                    prefix + " is version " + std::to_string(major) + "." + std::to_string(minor) +
                        "; this runtime reads major version " + std::to_string(format::kMajorVersion) + " (up to " +
                        std::to_string(format::kMajorVersion) + "." + std::to_string(format::kMinorVersion) +
                        "): update skelform or bake with the matching skelform-bake");
  if (major < 1) invalid(prefix, "majorVersion " + std::to_string(major) + " does not exist (versions start at 1)");
  if (major < format::kMajorVersion)
    throw LoadError(SF_ERROR_VERSION_MISMATCH,
                    prefix + " is version " + std::to_string(major) + "." + std::to_string(minor) +
                        ", baked by an older skelform-bake whose binding used another normal field; this runtime "
                        "reads major version " +
                        std::to_string(format::kMajorVersion) +
                        " only: bake the asset again with this release's skelform-bake");

  const tinygltf::Value* deformables = member(root, format::kDeformables);
  if (!deformables || !deformables->IsArray() || deformables->ArrayLen() == 0)
    invalid(prefix, std::string("'") + format::kDeformables + "' must be a non-empty array");

  std::unique_ptr<sf_asset, AssetDeleter> asset(create_object<sf_asset>(allocator, allocator), AssetDeleter{allocator});
  asset->deformables.reserve(deformables->ArrayLen());
  for (size_t d = 0; d < deformables->ArrayLen(); ++d) {
    asset->deformables.emplace_back(allocator);
    Deformable& deformable = asset->deformables.back();
    load_deformable(model, deformables->Get(static_cast<int>(d)), prefix + " deformable " + std::to_string(d),
                    deformable);
    derive_rest_data(deformable);
    derive_fairing_data(deformable, allocator);
    deformable.welded =
        build_contact_mesh(deformable.rest_positions.data(), deformable.vertex_count, deformable.dense_triangles.data(),
                           deformable.dense_triangles.size() / 3, allocator);
  }
  return asset.release();
}

}  // namespace skelform::runtime
