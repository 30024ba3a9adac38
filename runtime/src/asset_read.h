// What the loader's files share (asset_load.h is its entry point): the errors and limits of a
// load, the extension's JSON members and arrays (asset_arrays.cpp), the skin influences
// (asset_skin.cpp) and the dense vertices of the glTF primitives (asset_primitives.cpp).
// Private to the loader; every function trusts nothing it reads and throws LoadError,
// gltf::GltfError or std::bad_alloc.
#pragma once

#include "asset.h"
#include "asset_load.h"
#include "skelform/core/extension_layout.h"

#include <tiny_gltf.h>

#include <glm/vec4.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace skelform::runtime::loader {

namespace format = skelform::format;

// Sets of four joint influences per vertex (control.joints, JOINTS_n), per deformable
// (skelform.h "Limits"): 64 influences per vertex. Every set costs memory and skinning time
// per vertex; without a bound, one accessor named thousands of times in a few kilobytes of
// JSON made a load take gigabytes.
constexpr size_t kMaxInfluenceSets = 16;

// The largest magnitude of a length the asset stores (positions, medial radii, displacements,
// residuals; skelform.h "Limits"). Far beyond any mesh float positions can describe, and
// small enough that the evaluation's squares and cubes of lengths stay finite (1e36).
constexpr double kMaxLength = 1e12;

// --- Errors (asset_arrays.cpp) ---

[[noreturn]] void invalid(const std::string& what, const std::string& problem);
std::string number_text(double value);
[[noreturn]] void beyond_influence_limit(const std::string& what, size_t sets);

// --- JSON members of the extension (tinygltf::Value; asset_arrays.cpp) ---

const tinygltf::Value* member(const tinygltf::Value& object, const char* key);
// An integer JSON value within [low, high]; `label` names it in the message.
int integer_value(const tinygltf::Value& value, const std::string& what, const std::string& label, int low, int high);
// An integer member within [low, high]; absent gives `fallback` when not required.
int integer_member(const tinygltf::Value& object, const char* key, const std::string& what, bool required, int fallback,
                   int low, int high);
const tinygltf::Value& object_member(const tinygltf::Value& object, const char* key, const std::string& what);

// --- Extension arrays (asset_arrays.cpp) ---

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
                     const std::string& prefix, int set_accessor = -1, size_t set = 0);

// Finds the array named group.name among those read from kArrays.
const ReadArray& find_array(const std::vector<ReadArray>& arrays, const char* group, const char* name);

// The counts every array is checked against (extension_layout.h CountOf).
struct Counts {
  size_t control_vertices = 0;
  size_t control_triangles = 0;
  size_t refined_vertices = 0;
  size_t refined_triangles = 0;
  size_t stencil_entries = 0;
  size_t dense_vertices = 0;

  size_t expected(format::CountOf count) const;
};

// The quantities CountOf names, each defined by the array that carries it (`offsets`, the
// stencil offsets, checked here), then every array checked against them.
Counts count_arrays(const std::vector<ReadArray>& arrays, const ReadArray& offsets, size_t dense_vertices);

// Index ranges and value ranges of every array, then the limits of the 32-bit counts.
void check_array_ranges(const std::vector<ReadArray>& arrays, const Counts& counts, const std::string& prefix);

// The checked arrays into `deformable` (control, subdivision and binding arrays, counts).
void store_arrays(const std::vector<ReadArray>& arrays, const Counts& counts, Deformable& deformable);

// --- Skin influences, dense and control alike (asset_skin.cpp) ---

// Sets of four (joint, weight) per vertex, gathered before the final `influences` width is
// known; missing sets read as zero weights.
struct InfluenceSets {
  std::vector<std::vector<glm::uvec4>> joints;
  std::vector<std::vector<glm::vec4>> weights;
};

// The control vertices' skin (kJointSet/kWeightSet: arrays of accessors, one per set of
// four), checked and renormalised; only for a skinned deformable.
void read_control_skin(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                       const Counts& counts, const Deformable& deformable, InfluenceSets& control_sets);

// The dense skin renormalised, both skins stored at the deformable's width, the skelform
// weight of every dense vertex (`weight_override`: read_primitives') and what is derived
// from the control skin; only for a skinned deformable.
void finish_skin(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                 const Counts& counts, InfluenceSets& dense_sets, const std::vector<std::string>& dense_labels,
                 const InfluenceSets& control_sets, const std::vector<float>& weight_override, Deformable& deformable);

// --- Dense vertices from the glTF primitives (asset_primitives.cpp) ---

// The primitives the deformable lists: positions, normals, tangents, triangles and (skinned)
// the JOINTS_n/WEIGHTS_n sets into `dense_sets`. `weight_override` receives every dense
// vertex's _SKELFORM_WEIGHT (-1 where its primitive has none).
void read_primitives(const tinygltf::Model& model, const tinygltf::Value& json, const std::string& prefix,
                     Deformable& deformable, InfluenceSets& dense_sets, std::vector<std::string>& dense_labels,
                     std::vector<float>& weight_override);

// Area-weighted normals for the primitives without NORMAL.
void compute_missing_normals(Deformable& deformable);

}  // namespace skelform::runtime::loader
