// Writing binary glTF (GLB, glTF 2.0 specification section 4.4): the one place that knows the
// container's layout. Used by the baker's writer and procedural rig, the samples' writers and
// the tests that build or edit GLB files in memory.
//
// Header-only and free of third-party types, so a target that writes GLB files needs this
// include directory only (CMake: skelform::glb), not the baker library.
// GlbBuilder (glb_builder.h) adds buffer views and accessors on top, with nlohmann/json.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace skelform::bake {

// The GLB of `json_text` (the glTF JSON, UTF-8) and `bin` (the bytes of buffer 0, the one
// without "uri"; empty: no BIN chunk): the 12-byte header, the JSON chunk padded with spaces
// and the BIN chunk padded with zeros to 4-byte multiples, every length little-endian.
// Throws std::length_error when the file would not fit the format's 32-bit length (4 GiB).
inline std::string glb_container(const std::string& json_text, const std::string& bin) {
  const auto padded = [](size_t size) { return (size + 3) / 4 * 4; };
  const uint64_t json_size = padded(json_text.size()), bin_size = padded(bin.size());
  const uint64_t total = 12 + 8 + json_size + (bin.empty() ? 0 : 8 + bin_size);
  if (total > UINT32_MAX) throw std::length_error("a GLB file is limited to 4 GiB");
  std::string out;
  out.reserve(static_cast<size_t>(total));
  const auto put_u32 = [&out](uint64_t value) {
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xffu));
  };
  put_u32(0x46546C67u);  // "glTF"
  put_u32(2);            // container version
  put_u32(total);
  put_u32(json_size);
  put_u32(0x4E4F534Au);  // "JSON"
  out += json_text;
  out.append(static_cast<size_t>(json_size) - json_text.size(), ' ');
  if (!bin.empty()) {
    put_u32(bin_size);
    put_u32(0x004E4942u);  // "BIN\0"
    out += bin;
    out.append(static_cast<size_t>(bin_size) - bin.size(), '\0');
  }
  return out;
}

}  // namespace skelform::bake
