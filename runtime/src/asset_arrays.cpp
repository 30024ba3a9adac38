// The extension's JSON members and arrays for the loader (asset_read.h): each array read
// through extension_layout.h's table (so reader and writer share one definition), then its
// count, index range and value range checked, then stored in the deformable. Nothing is
// indexed before it is checked: a corrupt file ends in an error, never in a read out of bounds.
#include "asset_read.h"

#include "skelform/core/gltf_read.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace skelform::runtime::loader {
namespace {

// Slack of the unit-vector and barycentric checks: float rounding of what the baker wrote.
constexpr double kUnitSlack = 1e-3;
constexpr double kBarycentricSlack = 1e-5;

int accessor_member(const tinygltf::Value& group, const char* key, const std::string& what, size_t accessor_total) {
  return integer_member(group, key, what, true, -1, 0,
                        static_cast<int>(std::min<size_t>(accessor_total, std::numeric_limits<int>::max())) - 1);
}

int component_type_of(format::Component component) { return static_cast<int>(component); }

std::string array_label(const format::ArraySpec& spec) { return std::string(spec.group) + "." + spec.name; }

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

}  // namespace

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

// --- JSON members of the extension ---

const tinygltf::Value* member(const tinygltf::Value& object, const char* key) {
  if (!object.IsObject() || !object.Has(key)) return nullptr;
  return &object.Get(key);
}

int integer_value(const tinygltf::Value& value, const std::string& what, const std::string& label, int low, int high) {
  // JSON does not distinguish 3 from 3.0; tinygltf may store either.
  const double number = value.IsNumber() ? value.GetNumberAsDouble() : std::nan("");
  if (!value.IsNumber() || number != std::floor(number) || number < low || number > high)
    invalid(what, label + " must be an integer within " + std::to_string(low) + ".." + std::to_string(high));
  return static_cast<int>(number);
}

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

// --- Extension arrays ---

ReadArray read_array(const tinygltf::Model& model, const tinygltf::Value& deformable, const format::ArraySpec& spec,
                     const std::string& prefix, int set_accessor, size_t set) {
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

const ReadArray& find_array(const std::vector<ReadArray>& arrays, const char* group, const char* name) {
  for (const ReadArray& array : arrays)
    if (std::string(array.spec->group) == group && std::string(array.spec->name) == name) return array;
  // Only reachable if extension_layout.h renamed a member this file relies on: a build
  // mismatch, reported rather than crashed on.
  throw LoadError(SF_ERROR_UNSUPPORTED, std::string("runtime does not know the extension array ") + group + "." + name);
}

size_t Counts::expected(format::CountOf count) const {
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

// --- Counts and ranges ---

Counts count_arrays(const std::vector<ReadArray>& arrays, const ReadArray& offsets, size_t dense_vertices) {
  Counts counts;
  counts.dense_vertices = dense_vertices;
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
  return counts;
}

void check_array_ranges(const std::vector<ReadArray>& arrays, const Counts& counts, const std::string& prefix) {
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
}

void store_arrays(const std::vector<ReadArray>& arrays, const Counts& counts, Deformable& deformable) {
  deformable.control_vertex_count = static_cast<uint32_t>(counts.control_vertices);
  deformable.refined_vertex_count = static_cast<uint32_t>(counts.refined_vertices);
  copy_vec3(find_array(arrays, "control", "positions").values, deformable.control_positions);
  copy_vec3(find_array(arrays, "control", "normals").values, deformable.control_normals);
  copy_scalars(find_array(arrays, "control", "indices").values, deformable.control_indices);
  copy_vec3(find_array(arrays, "control", "skeletalPositions").values, deformable.skeletal_positions);
  copy_scalars(find_array(arrays, "control", "medialRadius").values, deformable.medial_radius);
  copy_scalars(find_array(arrays, "subdivision", "stencilOffsets").values, deformable.stencil_offsets);
  copy_scalars(find_array(arrays, "subdivision", "stencilIndices").values, deformable.stencil_indices);
  copy_scalars(find_array(arrays, "subdivision", "stencilWeights").values, deformable.stencil_weights);
  copy_scalars(find_array(arrays, "subdivision", "indices").values, deformable.refined_indices);
  copy_scalars(find_array(arrays, "binding", "triangle").values, deformable.binding_triangle);
  copy_vec2(find_array(arrays, "binding", "barycentric").values, deformable.binding_barycentric);
  copy_scalars(find_array(arrays, "binding", "displacement").values, deformable.binding_displacement);
  copy_vec2(find_array(arrays, "binding", "residual").values, deformable.binding_residual);
}

}  // namespace skelform::runtime::loader
