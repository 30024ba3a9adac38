// A GLB written from scratch: glTF JSON in an nlohmann::json document, buffer 0 grown view by
// view, then packed by glb_container (glb.h). Used by the procedural rig (skelform-character),
// skelform-animate's file and the tests' generated models. Header-only; the including target
// needs nlohmann/json (CMake: nlohmann_json::nlohmann_json).
#pragma once

#include "skelform/bake/glb.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace skelform::bake {

class GlbBuilder {
 public:
  // glTF componentType and bufferView target constants.
  static constexpr int kFloat = 5126, kUnsignedShort = 5123, kUnsignedInt = 5125;
  static constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

  // The glTF document; "buffers" is written by finish(). Callers add meshes, nodes, skins...
  nlohmann::json document = {{"bufferViews", nlohmann::json::array()}, {"accessors", nlohmann::json::array()}};

  // Appends `size` bytes as a new bufferView at a 4-byte aligned offset (every accessor type
  // is then aligned); `target` 0 = none (animation data, inverse bind matrices). Its index.
  int add_view(const void* data, size_t size, int target) {
    while (bin_.size() % 4) bin_.push_back('\0');
    nlohmann::json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", size}};
    if (target) view["target"] = target;
    bin_.append(static_cast<const char*>(data), size);
    document["bufferViews"].push_back(std::move(view));
    return static_cast<int>(document["bufferViews"].size() - 1);
  }
  // Appends an accessor; its index.
  int add_accessor(nlohmann::json accessor) {
    document["accessors"].push_back(std::move(accessor));
    return static_cast<int>(document["accessors"].size() - 1);
  }
  // A float accessor of `components` per element (`type` "SCALAR", "VEC3", "MAT4"...) in a
  // view of its own; with min/max when `bounds` (the specification requires them for POSITION
  // and animation input).
  int add_floats(const std::vector<float>& values, const char* type, size_t components, int target, bool bounds) {
    nlohmann::json accessor = {{"bufferView", add_view(values.data(), values.size() * sizeof(float), target)},
                               {"componentType", kFloat},
                               {"count", values.size() / components},
                               {"type", type}};
    if (bounds) {
      std::vector<float> lo(components, std::numeric_limits<float>::max());
      std::vector<float> hi(components, -std::numeric_limits<float>::max());
      for (size_t i = 0; i < values.size(); ++i) {
        lo[i % components] = std::min(lo[i % components], values[i]);
        hi[i % components] = std::max(hi[i % components], values[i]);
      }
      accessor["min"] = lo;
      accessor["max"] = hi;
    }
    return add_accessor(std::move(accessor));
  }
  // A triangle index accessor (unsigned int) in an element-array view of its own.
  int add_indices(const std::vector<uint32_t>& indices) {
    return add_accessor(
        {{"bufferView", add_view(indices.data(), indices.size() * sizeof(uint32_t), kElementArrayBuffer)},
         {"componentType", kUnsignedInt},
         {"count", indices.size()},
         {"type", "SCALAR"}});
  }

  // The GLB file: buffer 0 is the BIN chunk (glb_container). The builder is spent afterwards.
  std::string finish() {
    while (bin_.size() % 4) bin_.push_back('\0');
    document["buffers"] = nlohmann::json::array({{{"byteLength", bin_.size()}}});
    return glb_container(document.dump(), bin_);
  }

 private:
  std::string bin_;
};

}  // namespace skelform::bake
