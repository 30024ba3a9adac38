// Editing a GLB in tests: its JSON (member order kept) and BIN chunk, split apart, changed and
// packed again, to make the corrupt or unusual files a test needs from a good one.
#pragma once

#include "skelform/bake/glb.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <string>

namespace skelform::test {

inline uint32_t u32_at(const std::string& bytes, size_t offset) {
  uint32_t v;
  std::memcpy(&v, bytes.data() + offset, 4);
  return v;
}

// A GLB split into its JSON (editable, member order kept) and BIN chunk, and put back.
struct Glb {
  using Json = nlohmann::ordered_json;
  Json json;
  std::string bin;

  explicit Glb(const std::string& glb) {
    const uint32_t json_length = u32_at(glb, 12);
    json = Json::parse(glb.substr(20, json_length));
    const size_t bin_header = 20 + json_length;
    if (bin_header + 8 <= glb.size()) bin = glb.substr(bin_header + 8, u32_at(glb, bin_header));
  }

  std::string bytes() const { return skelform::bake::glb_container(json.dump(), bin); }

  Json& extension() { return json["extensions"]["SKELFORM_skeletal_deformation"]; }
  Json& deformable() { return extension()["deformables"][0]; }
  Json& accessor(const char* group, const char* name) {
    return json["accessors"][deformable()[group][name].get<size_t>()];
  }
  // Byte offset in BIN of element `element` (of `element_bytes`) of an accessor.
  size_t offset_of(Json& accessor, size_t element, size_t element_bytes) {
    const Json& view = json["bufferViews"][accessor["bufferView"].get<size_t>()];
    return view.value("byteOffset", size_t{0}) + accessor.value("byteOffset", size_t{0}) + element * element_bytes;
  }
  void put_u32(size_t offset, uint32_t value) { std::memcpy(&bin[offset], &value, 4); }
  void put_u16(size_t offset, uint16_t value) { std::memcpy(&bin[offset], &value, 2); }
  void put_f32(size_t offset, float value) { std::memcpy(&bin[offset], &value, 4); }
  float f32(size_t offset) const {
    float v;
    std::memcpy(&v, bin.data() + offset, 4);
    return v;
  }
  // Appends `bytes` to BIN as a new bufferView and an accessor over it; the accessor's index.
  int append(const std::string& bytes, int component_type, const char* type, size_t count) {
    while (bin.size() % 4) bin.push_back('\0');
    json["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes.size()}});
    bin += bytes;
    json["buffers"][0]["byteLength"] = bin.size();
    json["accessors"].push_back({{"bufferView", json["bufferViews"].size() - 1},
                                 {"componentType", component_type},
                                 {"count", count},
                                 {"type", type}});
    return int(json["accessors"].size() - 1);
  }
};

}  // namespace skelform::test
