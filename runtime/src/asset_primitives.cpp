// The dense vertices of a deformable for the loader (asset_read.h), read from the glTF
// primitives it lists: positions, normals, tangents, the _SKELFORM_WEIGHT attribute, the
// triangles by the glTF topology rules and, for a skinned deformable, the JOINTS_n/WEIGHTS_n
// sets (repaired as the baker repaired them); then the normals the primitives lack.
#include "asset_read.h"

#include "skelform/core/gltf_read.h"
#include "skelform/core/skin_repair.h"

#include <glm/geometric.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace skelform::runtime::loader {
namespace {

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

// The accessor of a primitive's attribute, -1 when it has none.
int attribute_accessor(const tinygltf::Primitive& primitive, const std::string& semantic) {
  const auto found = primitive.attributes.find(semantic);
  return found == primitive.attributes.end() ? -1 : found->second;
}

// An optional per-vertex attribute (NORMAL, TANGENT) of a primitive appended to `out` in
// float, read with `read` (gltf_read.h); `vertex_count` zeros when the primitive has none.
// True when it has one.
template <class Float, class Double>
bool append_optional_attribute(const tinygltf::Model& model, const tinygltf::Primitive& primitive, const char* semantic,
                               size_t vertex_count, const std::string& what,
                               std::vector<Double> (*read)(const tinygltf::Model&, int, const std::string&),
                               Array<Float>& out) {
  const int accessor = attribute_accessor(primitive, semantic);
  if (accessor < 0) {
    out.resize(out.size() + vertex_count, Float(0.0f));
    return false;
  }
  const std::vector<Double> values = read(model, accessor, what + " " + semantic);
  if (values.size() != vertex_count) invalid(what, std::string(semantic) + " count differs from POSITION count");
  for (const Double& value : values) out.push_back(Float(value));
  return true;
}

// Entry `p` of the deformable's primitive list: a primitive of its mesh, not listed before.
size_t listed_primitive(const tinygltf::Value& item, size_t p, const tinygltf::Mesh& mesh, int mesh_index,
                        const std::string& prefix, std::vector<bool>& seen) {
  const double number = item.IsNumber() ? item.GetNumberAsDouble() : -1.0;
  if (!(number >= 0) || number != std::floor(number) || number >= static_cast<double>(mesh.primitives.size()))
    invalid(prefix, "primitives[" + std::to_string(p) + "] is not a primitive of mesh " + std::to_string(mesh_index));
  const size_t index = static_cast<size_t>(number);
  if (seen[index]) invalid(prefix, "primitive " + std::to_string(index) + " is listed twice");
  seen[index] = true;
  return index;
}

// The primitive's POSITION, every coordinate within the length limit.
std::vector<glm::dvec3> read_positions(const tinygltf::Model& model, const tinygltf::Primitive& primitive,
                                       const std::string& what) {
  const int position_accessor = attribute_accessor(primitive, "POSITION");
  if (position_accessor < 0) invalid(what, "has no POSITION attribute");
  const std::vector<glm::dvec3> positions = gltf::read_vec3(model, position_accessor, what + " POSITION");
  for (size_t v = 0; v < positions.size(); ++v)
    for (int k = 0; k < 3; ++k)
      if (!(std::fabs(positions[v][k]) <= kMaxLength))
        invalid(what + " POSITION", "vertex " + std::to_string(v) + " has " + number_text(positions[v][k]) +
                                        ", beyond the length limit " + number_text(kMaxLength));
  return positions;
}

// The per-vertex attributes besides POSITION: _SKELFORM_WEIGHT (-1 where absent), NORMAL and
// TANGENT (zeros where absent, `record` says which the primitive has).
void read_vertex_attributes(const tinygltf::Model& model, const tinygltf::Primitive& primitive, const std::string& what,
                            size_t vertex_count, PrimitiveRecord& record, Deformable& deformable,
                            std::vector<float>& weight_override) {
  const int override_accessor = attribute_accessor(primitive, format::kSkelformWeightAttribute);
  if (override_accessor >= 0) {
    const std::vector<float> values =
        gltf::read_unit_scalars(model, override_accessor, what + " " + format::kSkelformWeightAttribute);
    if (values.size() != vertex_count)
      invalid(what, std::string(format::kSkelformWeightAttribute) + " count differs from POSITION count");
    weight_override.insert(weight_override.end(), values.begin(), values.end());
  } else {
    weight_override.insert(weight_override.end(), vertex_count, -1.0f);
  }

  record.has_normals = append_optional_attribute(model, primitive, "NORMAL", vertex_count, what, gltf::read_vec3,
                                                 deformable.rest_normals);
  record.has_tangents = append_optional_attribute(model, primitive, "TANGENT", vertex_count, what, gltf::read_vec4,
                                                  deformable.rest_tangents);
}

// The primitive's triangles (its indices, or its vertices in order) into dense_triangles.
void read_triangles(const tinygltf::Model& model, const tinygltf::Primitive& primitive, int mode,
                    const std::string& what, size_t vertex_count, PrimitiveRecord& record, Deformable& deformable) {
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
}

// JOINTS_n/WEIGHTS_n, every set of the primitive appended to `dense_sets` after the
// `vertex_total` vertices before it; sets an earlier or later primitive lacks hold zeros.
void read_skin_sets(const tinygltf::Model& model, const tinygltf::Primitive& primitive, const std::string& what,
                    size_t vertex_total, size_t vertex_count, InfluenceSets& dense_sets,
                    std::vector<std::string>& dense_labels) {
  for (size_t set = 0;; ++set) {
    const std::string n = std::to_string(set);
    const int joints = attribute_accessor(primitive, "JOINTS_" + n);
    const int weights = attribute_accessor(primitive, "WEIGHTS_" + n);
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
}

// Exporter defects of the primitive's skin, repaired as the baker repaired them
// (skin_repair.h).
void repair_skin_sets(const std::vector<glm::dvec3>& positions, const std::string& what, size_t vertex_total,
                      size_t vertex_count, InfluenceSets& dense_sets) {
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

// One listed primitive of the deformable (mesh primitive `index`), after the `vertex_total`
// dense vertices of those before it; returns its vertex count.
size_t read_primitive(const tinygltf::Model& model, const tinygltf::Primitive& primitive, size_t index,
                      size_t vertex_total, const std::string& what, Deformable& deformable, InfluenceSets& dense_sets,
                      std::vector<std::string>& dense_labels, std::vector<float>& weight_override) {
  const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;  // absent = TRIANGLES
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
    invalid(what, "mode " + std::to_string(mode) + " is not a triangle mode, so it cannot have been baked");
  const std::vector<glm::dvec3> positions = read_positions(model, primitive, what);
  const size_t vertex_count = positions.size();
  if (vertex_total + vertex_count > std::numeric_limits<uint32_t>::max())
    throw LoadError(SF_ERROR_UNSUPPORTED, what + ": more than 2^32-1 vertices in the deformable");

  PrimitiveRecord record;
  record.primitive = static_cast<int32_t>(index);
  record.first_vertex = static_cast<uint32_t>(vertex_total);
  record.vertex_count = static_cast<uint32_t>(vertex_count);
  for (const glm::dvec3& position : positions) deformable.rest_positions.push_back(glm::vec3(position));
  read_vertex_attributes(model, primitive, what, vertex_count, record, deformable, weight_override);
  read_triangles(model, primitive, mode, what, vertex_count, record, deformable);
  if (deformable.skin >= 0) {
    read_skin_sets(model, primitive, what, vertex_total, vertex_count, dense_sets, dense_labels);
    repair_skin_sets(positions, what, vertex_total, vertex_count, dense_sets);
  }
  deformable.primitives.push_back(record);
  return vertex_count;
}

}  // namespace

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
    const size_t index = listed_primitive(list->Get(static_cast<int>(p)), p, mesh, deformable.mesh, prefix, seen);
    const std::string what =
        prefix + " mesh " + std::to_string(deformable.mesh) + " primitive " + std::to_string(index);
    vertex_total += read_primitive(model, mesh.primitives[index], index, vertex_total, what, deformable, dense_sets,
                                   dense_labels, weight_override);
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

}  // namespace skelform::runtime::loader
