// glTF 2.0 input (.gltf/.glb) through the Debian tinygltf shared library. Every accessor is
// read through the validated readers the runtime uses too (skelform/core/gltf_read.h), so
// nothing here indexes a tinygltf vector or a buffer before checking it, and both halves of
// skelform refuse the same files with the same sentences: the reader's GltfError becomes
// the baker's Error of the same kind and message, at load_gltf.
#include "input_formats.h"
#include "skelform/core/extension_layout.h"
#include "skelform/core/gltf_read.h"
#include "skelform/core/skin_repair.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace skelform::bake {
namespace detail {
namespace {

[[noreturn]] void invalid(const std::string& what, const std::string& problem) {
  throw Error(ErrorKind::invalid_input, what + ": " + problem);
}

const char* mode_name(int mode) {
  switch (mode) {
    case TINYGLTF_MODE_POINTS:
      return "POINTS";
    case TINYGLTF_MODE_LINE:
      return "LINES";
    case TINYGLTF_MODE_LINE_LOOP:
      return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP:
      return "LINE_STRIP";
    case TINYGLTF_MODE_TRIANGLES:
      return "TRIANGLES";
    case TINYGLTF_MODE_TRIANGLE_STRIP:
      return "TRIANGLE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_FAN:
      return "TRIANGLE_FAN";
    default:
      return "an unknown mode";
  }
}

std::string mesh_label(const tinygltf::Model& model, size_t mesh) {
  std::string label = "mesh " + std::to_string(mesh);
  const std::string& mesh_name = model.meshes[mesh].name;
  if (!mesh_name.empty()) label += " ('" + mesh_name.substr(0, 64) + "')";
  return label;
}

// Triangles of one primitive, in its own vertex numbering, by the glTF topology rules.
std::vector<Triangle> triangulate(int mode, const std::vector<uint32_t>& corner, const std::string& what) {
  std::vector<Triangle> triangles;
  const size_t n = corner.size();
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    if (n % 3 != 0)
      throw Error(ErrorKind::invalid_input,
                  what + ": TRIANGLES with " + std::to_string(n) + " vertex indices, which is not a multiple of 3");
    triangles.reserve(n / 3);
    for (size_t i = 0; i + 2 < n; i += 3) triangles.push_back(Triangle{corner[i], corner[i + 1], corner[i + 2]});
  } else {
    if (n < 3)
      throw Error(ErrorKind::invalid_input, what + ": " + std::string(mode_name(mode)) + " with " + std::to_string(n) +
                                                " vertices has no triangle");
    triangles.reserve(n - 2);
    for (size_t i = 0; i + 2 < n; ++i) {
      if (mode == TINYGLTF_MODE_TRIANGLE_STRIP)  // odd triangles swap to keep the winding
        triangles.push_back(Triangle{corner[i], corner[i + 1 + i % 2], corner[i + 2 - i % 2]});
      else
        triangles.push_back(Triangle{corner[i + 1], corner[i + 2], corner[0]});
    }
  }
  return triangles;
}

}  // namespace

// "elements 3, 17, 40 and 2 more" (primitive-local vertex indices).
std::string element_list(const std::vector<uint32_t>& elements) {
  constexpr size_t kShown = 8;
  std::string text = elements.size() == 1 ? "element " : "elements ";
  for (size_t i = 0; i < elements.size() && i < kShown; ++i) text += (i ? ", " : "") + std::to_string(elements[i]);
  if (elements.size() > kShown) text += " and " + std::to_string(elements.size() - kShown) + " more";
  return text;
}

// Appends the JOINTS_n/WEIGHTS_n sets of one skinned primitive to mesh.joint_sets and
// weight_sets, keeping every set as long as mesh.positions (the new primitive's vertices
// are already appended). Sets this primitive lacks, or earlier primitives lacked, hold zero
// weights. Exporter defects are repaired as skin_repair.h says, each with a warning in
// mesh.warnings; weights are then renormalised to sum to 1 over all sets (glTF requires the
// sum to be 1; exporters round).
void append_skin_influences(const tinygltf::Model& model, const tinygltf::Primitive& primitive, size_t joint_count,
                            size_t vertex_count, const std::string& what, InputMesh& mesh) {
  const size_t total = mesh.positions.size();
  const size_t first = total - vertex_count;
  // Every set of this primitive first, as (joint, weight) slots per vertex.
  std::vector<uint32_t> slot_joints;
  std::vector<double> slot_weights;
  std::vector<std::string> accessors;
  size_t sets = 0;
  for (size_t set = 0;; ++set) {
    const auto joints = primitive.attributes.find("JOINTS_" + std::to_string(set));
    const auto weights = primitive.attributes.find("WEIGHTS_" + std::to_string(set));
    if (joints == primitive.attributes.end() && weights == primitive.attributes.end()) {
      if (set == 0) invalid(what, "belongs to a skinned node but has no JOINTS_0/WEIGHTS_0");
      break;
    }
    const std::string set_name = std::to_string(set);
    if (set >= kMaxInfluenceSets)
      throw Error(ErrorKind::unsupported, what + " has more than " + std::to_string(kMaxInfluenceSets) +
                                              " JOINTS_n/WEIGHTS_n sets, the most skelform reads");
    if (joints == primitive.attributes.end()) invalid(what, "has WEIGHTS_" + set_name + " without JOINTS_" + set_name);
    if (weights == primitive.attributes.end()) invalid(what, "has JOINTS_" + set_name + " without WEIGHTS_" + set_name);
    const std::vector<glm::uvec4> joint_values =
        skelform::gltf::read_joints(model, joints->second, what + " JOINTS_" + set_name);
    const std::vector<glm::dvec4> weight_values =
        skelform::gltf::read_weights(model, weights->second, what + " WEIGHTS_" + set_name);
    if (joint_values.size() != vertex_count || weight_values.size() != vertex_count)
      invalid(what, "JOINTS_" + set_name + "/WEIGHTS_" + set_name + " count differs from POSITION count");
    accessors.push_back("WEIGHTS_" + set_name + " (accessor " + std::to_string(weights->second) + ")");
    sets = set + 1;
    slot_joints.resize(4 * sets * vertex_count);
    slot_weights.resize(4 * sets * vertex_count);
    // Re-lay the earlier sets' slots: vertex-major with 4 slots per set.
    for (size_t v = vertex_count; v-- > 0;)
      for (size_t k = 4 * set; k-- > 0;) {
        slot_joints[v * 4 * sets + k] = slot_joints[v * 4 * set + k];
        slot_weights[v * 4 * sets + k] = slot_weights[v * 4 * set + k];
      }
    for (size_t v = 0; v < vertex_count; ++v)
      for (int k = 0; k < 4; ++k) {
        slot_joints[v * 4 * sets + 4 * set + size_t(k)] = joint_values[v][k];
        slot_weights[v * 4 * sets + 4 * set + size_t(k)] = weight_values[v][k];
      }
  }
  skin::SkinRepairReport report;
  if (!skin::repair_skin(slot_joints.data(), slot_weights.data(), 4 * sets, mesh.positions.data() + first, vertex_count,
                         report))
    invalid(what, "has vertices with no skin weight and no weighted vertex to take one from");
  std::string sets_named;
  for (size_t i = 0; i < accessors.size(); ++i) sets_named += (i ? ", " : "") + accessors[i];
  if (!report.non_finite.empty())
    mesh.warnings.push_back(what + " " + sets_named + ": " + std::to_string(report.non_finite.size()) +
                            " vertices with a non-finite weight (" + element_list(report.non_finite) + "): read as 0");
  if (!report.inherited.empty())
    mesh.warnings.push_back(what + " " + sets_named + ": " + std::to_string(report.inherited.size()) +
                            " vertices without any weight (" + element_list(report.inherited) +
                            "): given the skin of the nearest weighted vertex");
  if (report.repeated_joints > 0)
    mesh.warnings.push_back(what + " " + sets_named + ": " + std::to_string(report.repeated_joints) +
                            " vertices name one joint in several slots: kept (skinning sums them)");
  for (size_t set = 0; set < sets; ++set) {
    if (set >= mesh.joint_sets.size()) {
      mesh.joint_sets.emplace_back(first, std::array<uint16_t, 4>{0, 0, 0, 0});
      mesh.weight_sets.emplace_back(first, std::array<float, 4>{0, 0, 0, 0});
    }
    for (size_t v = 0; v < vertex_count; ++v) {
      std::array<uint16_t, 4> j{};
      std::array<float, 4> w{};
      for (size_t k = 0; k < 4; ++k) {
        const uint32_t joint = slot_joints[v * 4 * sets + 4 * set + k];
        const double weight = slot_weights[v * 4 * sets + 4 * set + k];
        // A zero weight may name any joint; only influencing joints must exist in the skin.
        if (weight > 0 && joint >= joint_count)
          invalid(what, "vertex " + std::to_string(v) + " JOINTS_" + std::to_string(set) + " names joint " +
                            std::to_string(joint) + " but the skin has " + std::to_string(joint_count));
        j[k] = weight > 0 ? static_cast<uint16_t>(joint) : 0;
        w[k] = static_cast<float>(weight);
      }
      mesh.joint_sets[set].push_back(j);
      mesh.weight_sets[set].push_back(w);
    }
  }
  for (size_t set = 0; set < mesh.joint_sets.size(); ++set) {
    mesh.joint_sets[set].resize(total, std::array<uint16_t, 4>{0, 0, 0, 0});
    mesh.weight_sets[set].resize(total, std::array<float, 4>{0, 0, 0, 0});
  }
  for (size_t v = first; v < total; ++v) {
    double sum = 0;
    for (const auto& set : mesh.weight_sets)
      for (float w : set[v]) sum += w;
    if (!(sum > 0)) invalid(what, "vertex " + std::to_string(v - first) + " has no skin weight");
    for (auto& set : mesh.weight_sets)
      for (float& w : set[v]) w = static_cast<float>(w / sum);
  }
}

namespace {

InputMesh read_gltf(const std::vector<unsigned char>& bytes, bool binary, const std::string& name,
                    const LoadOptions& options) {
  tinygltf::Model model;
  skelform::gltf::parse_model(bytes.data(), bytes.size(), binary, name, model);

  // The node that represents each mesh: the first skinned node using it, else (all_meshes)
  // the first node using it.
  const size_t mesh_count = model.meshes.size();
  std::vector<int> skinned_node(mesh_count, -1);
  std::vector<int> any_node(mesh_count, -1);
  for (size_t n = 0; n < model.nodes.size(); ++n) {
    const tinygltf::Node& node = model.nodes[n];
    if (node.mesh < 0) continue;
    if (static_cast<size_t>(node.mesh) >= mesh_count)
      invalid(name, "node " + std::to_string(n) + " refers to mesh " + std::to_string(node.mesh) + " (" +
                        std::to_string(mesh_count) + " meshes)");
    if (node.skin >= 0 && static_cast<size_t>(node.skin) >= model.skins.size())
      invalid(name, "node " + std::to_string(n) + " refers to skin " + std::to_string(node.skin) + " (" +
                        std::to_string(model.skins.size()) + " skins)");
    const size_t m = static_cast<size_t>(node.mesh);
    if (any_node[m] < 0) any_node[m] = static_cast<int>(n);
    if (node.skin >= 0 && skinned_node[m] < 0) skinned_node[m] = static_cast<int>(n);
  }

  InputMesh mesh;
  for (size_t m = 0; m < mesh_count; ++m) {
    if (!options.all_meshes && skinned_node[m] < 0) continue;
    const int node = skinned_node[m] >= 0 ? skinned_node[m] : any_node[m];
    const int skin = node >= 0 ? model.nodes[static_cast<size_t>(node)].skin : -1;
    const std::vector<tinygltf::Primitive>& primitives = model.meshes[m].primitives;
    for (size_t p = 0; p < primitives.size(); ++p) {
      const tinygltf::Primitive& primitive = primitives[p];
      const std::string what = name + ": " + mesh_label(model, m) + " primitive " + std::to_string(p);
      // An absent mode parses as -1 in tinygltf; the glTF default is TRIANGLES.
      const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
      if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
          mode == TINYGLTF_MODE_LINE_STRIP)
        throw Error(ErrorKind::unsupported,
                    what + " has mode " + mode_name(mode) +
                        "; only triangle primitives (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN) can be baked");
      if (mode > TINYGLTF_MODE_TRIANGLE_FAN) invalid(what, "unknown primitive mode " + std::to_string(mode));
      const auto position = primitive.attributes.find("POSITION");
      if (position == primitive.attributes.end()) invalid(what, "has no POSITION attribute");

      const std::vector<Vec3> positions = skelform::gltf::read_vec3(model, position->second, what + " POSITION");
      // Primitives may share accessors, so the totals grow faster than the file: checked
      // before each primitive is added.
      check_input_limits(mesh.positions.size() + positions.size(), mesh.triangles.size(), name);
      std::vector<uint32_t> corners;
      if (primitive.indices >= 0) {
        corners = skelform::gltf::read_indices(model, primitive.indices, positions.size(), what + " indices");
      } else {
        corners.resize(positions.size());
        for (size_t i = 0; i < corners.size(); ++i) corners[i] = static_cast<uint32_t>(i);
      }
      std::vector<Triangle> triangles = triangulate(mode, corners, what);
      check_input_limits(mesh.positions.size() + positions.size(), mesh.triangles.size() + triangles.size(), name);

      InputPrimitive record;
      record.mesh = static_cast<int>(m);
      record.primitive = static_cast<int>(p);
      record.node = node;
      record.skin = skin;
      record.first_vertex = static_cast<uint32_t>(mesh.positions.size());
      record.vertex_count = static_cast<uint32_t>(positions.size());
      record.first_triangle = static_cast<uint32_t>(mesh.triangles.size());
      record.triangle_count = static_cast<uint32_t>(triangles.size());
      record.indexed = primitive.indices >= 0;
      for (Triangle& t : triangles)
        for (uint32_t& v : t) v += record.first_vertex;
      const auto override_attribute = primitive.attributes.find(format::kSkelformWeightAttribute);
      if (override_attribute != primitive.attributes.end()) {
        const std::vector<float> values = skelform::gltf::read_unit_scalars(
            model, override_attribute->second, what + " " + format::kSkelformWeightAttribute);
        if (values.size() != positions.size())
          invalid(what, std::string(format::kSkelformWeightAttribute) + " count differs from POSITION count");
        mesh.skelform_weight_override.resize(mesh.positions.size(), -1.0f);
        mesh.skelform_weight_override.insert(mesh.skelform_weight_override.end(), values.begin(), values.end());
      } else if (!mesh.skelform_weight_override.empty()) {
        mesh.skelform_weight_override.resize(mesh.positions.size() + positions.size(), -1.0f);
      }
      mesh.positions.insert(mesh.positions.end(), positions.begin(), positions.end());
      mesh.triangles.insert(mesh.triangles.end(), triangles.begin(), triangles.end());
      mesh.primitives.push_back(record);
      if (skin >= 0)
        append_skin_influences(model, primitive, model.skins[static_cast<size_t>(skin)].joints.size(), positions.size(),
                               what, mesh);
    }
  }

  if (mesh.primitives.empty()) {
    if (!options.all_meshes)
      throw Error(ErrorKind::invalid_input,
                  "no skinned mesh in " + name + " (use --all-meshes to bake unskinned meshes)");
    invalid(name, "no mesh with triangle primitives");
  }
  return mesh;
}

}  // namespace

InputMesh load_gltf(const std::vector<unsigned char>& bytes, bool binary, const std::string& name,
                    const LoadOptions& options) {
  try {
    return read_gltf(bytes, binary, name, options);
  } catch (const skelform::gltf::GltfError& error) {
    switch (error.kind()) {
      case skelform::gltf::GltfError::unsupported:
        throw Error(ErrorKind::unsupported, error.what());
      case skelform::gltf::GltfError::io:
        throw Error(ErrorKind::io, error.what());
      case skelform::gltf::GltfError::invalid:
        break;
    }
    throw Error(ErrorKind::invalid_input, error.what());
  }
}

}  // namespace detail
}  // namespace skelform::bake
