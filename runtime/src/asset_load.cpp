// Asset loading (asset_load.h): the driver. Order of work, per deformable: the extension's
// arrays (asset_arrays.cpp, through extension_layout.h's table, so reader and writer share
// one definition), their counts and index ranges, the control skin (asset_skin.cpp), then the
// dense vertices from the glTF primitives (asset_primitives.cpp), then what is derived from
// the rest evaluation (asset_derive.cpp). Nothing is indexed before it is checked: a corrupt
// file ends in an error, never in a read out of bounds.
#include "asset_load.h"

#include "asset_derive.h"
#include "asset_read.h"
#include "joint_arcs.h"

#include <tiny_gltf.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

static_assert(skelform::format::kMajorVersion == SF_EXTENSION_MAJOR_VERSION,
              "skelform.h's SF_EXTENSION_MAJOR_VERSION is the extension version the loader reads");

namespace skelform::runtime {
namespace {

using namespace loader;

// The deepest Loop level a runtime accepts: 4^8 refined triangles per control triangle is
// already far beyond any dense mesh; a larger value is corruption.
constexpr int kMaxSubdivisionLevel = 8;

// The glTF objects the deformable names (mesh, node, skin), checked against the model and
// each other, and the skin's joint count.
void read_references(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                     Deformable& deformable) {
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
}

// The extension's arrays, straight from the layout table, with the subdivision level; checked
// (counts, index and value ranges) and stored in `deformable`. Returns the counts.
Counts read_extension_arrays(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                             size_t dense_vertices, Deformable& deformable) {
  std::vector<ReadArray> arrays;
  arrays.reserve(format::kArrayCount);
  for (const format::ArraySpec& spec : format::kArrays) arrays.push_back(read_array(model, json, spec, prefix));

  const ReadArray& offsets = find_array(arrays, "subdivision", "stencilOffsets");
  const tinygltf::Value& subdivision = object_member(json, "subdivision", prefix);
  deformable.subdivision_level = static_cast<uint32_t>(integer_member(
      subdivision, format::kSubdivisionLevel, prefix + " subdivision", true, 0, 0, kMaxSubdivisionLevel));

  // The quantities CountOf names: defined by the array that carries them, then every array
  // is checked against them; then index ranges and value ranges.
  const Counts counts = count_arrays(arrays, offsets, dense_vertices);
  check_array_ranges(arrays, counts, prefix);
  store_arrays(arrays, counts, deformable);
  return counts;
}

void load_deformable(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                     Deformable& deformable) {
  if (!json.IsObject()) invalid(prefix, "is not a JSON object");
  read_references(model, json, prefix, deformable);
  const int vertex_count =
      integer_member(json, format::kVertexCount, prefix, true, 0, 1, std::numeric_limits<int>::max());
  const Counts counts = read_extension_arrays(model, json, prefix, static_cast<size_t>(vertex_count), deformable);

  // Skin of the control vertices: arrays of accessors, one per set of four (kJointSet/kWeightSet).
  InfluenceSets control_sets;
  if (deformable.skin >= 0) read_control_skin(model, json, prefix, counts, deformable, control_sets);

  // Dense vertices from the glTF mesh itself.
  InfluenceSets dense_sets;
  std::vector<std::string> dense_labels;
  std::vector<float> weight_override;
  read_primitives(model, json, prefix, deformable, dense_sets, dense_labels, weight_override);
  if (deformable.vertex_count != counts.dense_vertices)
    invalid(prefix, std::string(format::kVertexCount) + " is " + std::to_string(counts.dense_vertices) +
                        " but the primitives' POSITION counts sum to " + std::to_string(deformable.vertex_count));
  if (deformable.skin >= 0)
    finish_skin(model, json, prefix, counts, dense_sets, dense_labels, control_sets, weight_override, deformable);
  compute_missing_normals(deformable);
  build_joint_arcs(model, deformable);
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
    derive_junction_anchors(deformable);
  }
  return asset.release();
}

}  // namespace skelform::runtime
