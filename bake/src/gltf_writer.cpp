// Bake step 8: the input glTF plus the SKELFORM_skeletal_deformation extension.
//
// The input JSON is edited as an insertion-ordered tree (nlohmann::ordered_json) rather than
// round-tripped through tinygltf's model writer, which reorders members, reformats numbers
// and drops what it does not model. Array names, component types and shapes come from the
// runtime's extension_layout.h, the format's single definition.
#include "skelform/bake/gltf_writer.h"

#include "skelform/bake/glb.h"
#include "skelform/bake/input.h"

#include "skelform/core/extension_layout.h"
#include "skelform/core/gltf_read.h"
#include "skelform/bake/mesh.h"
#include "skelform/bake/output.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <system_error>

namespace skelform::bake {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

constexpr uint32_t kGlbMagic = 0x46546C67;   // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942;   // "BIN\0"
constexpr size_t kGlbHeaderSize = 12;
constexpr size_t kChunkHeaderSize = 8;

[[noreturn]] void invalid(const std::string& message) { throw Error(ErrorKind::invalid_input, message); }

// ---------------------------------------------------------------------------------------
// Bytes

uint32_t read_u32(const std::string& bytes, size_t at) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data() + at);
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

// Little-endian, as glTF requires, whatever the host's byte order.
void append_u32(std::string& out, uint32_t value) {
  for (int shift = 0; shift < 32; shift += 8) out.push_back(char((value >> shift) & 0xFF));
}
void append_u16(std::string& out, uint16_t value) {
  out.push_back(char(value & 0xFF));
  out.push_back(char(value >> 8));
}
void append_f32(std::string& out, float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  append_u32(out, bits);
}

void pad_to_4(std::string& bytes, char fill) {
  while (bytes.size() % 4 != 0) bytes.push_back(fill);
}

// Bounded as the input stage reads (input.h: kMaxInputFileBytes).
std::string read_whole_file(const fs::path& path) {
  const std::vector<unsigned char> bytes = read_input_file(path.string());
  return std::string(bytes.begin(), bytes.end());
}

// ---------------------------------------------------------------------------------------
// Base64 and URIs (RFC 4648, RFC 3986)

constexpr char kBase64Alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

std::string base64_encode(const std::string& bytes) {
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 3 <= bytes.size(); i += 3) {
    const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16 | uint32_t(uint8_t(bytes[i + 1])) << 8 | uint8_t(bytes[i + 2]);
    for (int shift = 18; shift >= 0; shift -= 6) out.push_back(kBase64Alphabet[(v >> shift) & 63]);
  }
  const size_t rest = bytes.size() - i;
  if (rest > 0) {
    uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
    if (rest == 2) v |= uint32_t(uint8_t(bytes[i + 1])) << 8;
    out.push_back(kBase64Alphabet[(v >> 18) & 63]);
    out.push_back(kBase64Alphabet[(v >> 12) & 63]);
    out.push_back(rest == 2 ? kBase64Alphabet[(v >> 6) & 63] : '=');
    out.push_back('=');
  }
  return out;
}

std::string base64_decode(const std::string& text, const std::string& what) {
  int value_of[256];
  std::fill(std::begin(value_of), std::end(value_of), -1);
  for (int i = 0; i < 64; ++i) value_of[uint8_t(kBase64Alphabet[i])] = i;
  std::string out;
  out.reserve(text.size() / 4 * 3);
  uint32_t accumulator = 0;
  int bits = 0;
  size_t padding = 0;
  for (const char c : text) {
    if (c == '=') {
      ++padding;
      continue;
    }
    const int v = value_of[uint8_t(c)];
    if (v < 0 || padding > 0) invalid(what + ": invalid base64 data");
    accumulator = (accumulator << 6) | uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(char((accumulator >> bits) & 0xFF));
    }
  }
  if (padding > 2) invalid(what + ": invalid base64 padding");
  return out;
}

bool is_data_uri(const std::string& uri) { return uri.compare(0, 5, "data:") == 0; }

// "scheme:" (http:, file:, ...) or an absolute path: nothing a relative copy can resolve.
bool is_absolute_uri(const std::string& uri) {
  if (!uri.empty() && uri[0] == '/') return true;
  const size_t colon = uri.find(':');
  if (colon == std::string::npos || colon == 0) return false;
  const size_t slash = uri.find('/');
  if (slash != std::string::npos && slash < colon) return false;
  return std::isalpha(uint8_t(uri[0])) && std::all_of(uri.begin(), uri.begin() + long(colon), [](char c) {
           return std::isalnum(uint8_t(c)) || c == '+' || c == '-' || c == '.';
         });
}

std::string percent_decode(const std::string& uri) {
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(uint8_t(uri[i + 1])) &&
        std::isxdigit(uint8_t(uri[i + 2]))) {
      out.push_back(char(std::stoi(uri.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else {
      out.push_back(uri[i]);
    }
  }
  return out;
}

// A relative path (generic form, '/' separated) as a URI reference: unreserved characters
// and '/' as they are, everything else as %XX.
std::string percent_encode_path(const std::string& path) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char c : path) {
    const auto u = uint8_t(c);
    if (std::isalnum(u) || c == '-' || c == '.' || c == '_' || c == '~' || c == '/') {
      out.push_back(c);
    } else {
      out.push_back('%');
      out.push_back(kHex[u >> 4]);
      out.push_back(kHex[u & 15]);
    }
  }
  return out;
}

// Decodes "data:[<media type>];base64,<data>".
std::string decode_data_uri(const std::string& uri, const std::string& what) {
  const size_t comma = uri.find(',');
  if (comma == std::string::npos) invalid(what + ": malformed data URI");
  const std::string header = uri.substr(0, comma);
  if (header.size() < 7 || header.compare(header.size() - 7, 7, ";base64") != 0) {
    throw Error(ErrorKind::unsupported, what + ": only base64 data URIs are supported");
  }
  return base64_decode(uri.substr(comma + 1), what);
}

// ---------------------------------------------------------------------------------------
// Input container

struct Container {
  Json document;
  bool is_glb = false;
  bool has_bin_chunk = false;
  std::string bin_chunk;
};

Json parse_json(const char* begin, const char* end) {
  // Some exporters pad the GLB JSON chunk with NULs instead of spaces; tolerate both.
  while (end > begin && (end[-1] == '\0' || end[-1] == ' ')) --end;
  // The document is written back out by a recursive serializer: its depth is bounded as the
  // reader bounds it.
  try {
    skelform::gltf::check_json_nesting(reinterpret_cast<const unsigned char*>(begin), static_cast<size_t>(end - begin),
                                       "the glTF JSON");
  } catch (const skelform::gltf::GltfError& e) {
    invalid(e.what());
  }
  Json document;
  try {
    document = Json::parse(begin, end);
  } catch (const nlohmann::json::exception& e) {
    invalid(std::string("the glTF JSON does not parse: ") + e.what());
  }
  if (!document.is_object()) invalid("the glTF JSON is not an object");
  return document;
}

Container parse_container(const std::string& bytes) {
  Container input;
  if (bytes.size() < 4 || read_u32(bytes, 0) != kGlbMagic) {
    input.document = parse_json(bytes.data(), bytes.data() + bytes.size());
    return input;
  }
  input.is_glb = true;
  if (bytes.size() < kGlbHeaderSize + kChunkHeaderSize) invalid("truncated GLB: no room for the JSON chunk");
  if (read_u32(bytes, 4) != 2) invalid("unsupported GLB version " + std::to_string(read_u32(bytes, 4)));
  const uint64_t total = read_u32(bytes, 8);
  if (total > bytes.size())
    invalid("truncated GLB: header says " + std::to_string(total) + " bytes, file has " + std::to_string(bytes.size()));
  uint64_t at = kGlbHeaderSize;
  bool first = true;
  while (at + kChunkHeaderSize <= total) {
    const uint64_t length = read_u32(bytes, size_t(at));
    const uint32_t type = read_u32(bytes, size_t(at) + 4);
    const uint64_t data = at + kChunkHeaderSize;
    if (data + length > total)
      invalid("bad GLB chunk length " + std::to_string(length) + " at byte " + std::to_string(at));
    if (first) {
      if (type != kChunkJson) invalid("GLB: the first chunk is not JSON");
      input.document = parse_json(bytes.data() + data, bytes.data() + data + length);
      first = false;
    } else if (type == kChunkBin && !input.has_bin_chunk) {
      input.has_bin_chunk = true;
      input.bin_chunk = bytes.substr(size_t(data), size_t(length));
    }  // unknown chunks are ignored, as the GLB specification requires
    at = data + ((length + 3) / 4) * 4;
  }
  if (first) invalid("truncated GLB: no JSON chunk");
  return input;
}

// The top-level members the writer reads or edits must have their glTF types.
void check_structure(const Json& document) {
  for (const char* key : {"buffers", "bufferViews", "accessors", "meshes", "nodes", "skins", "images", "extensionsUsed",
                          "extensionsRequired"}) {
    if (document.contains(key) && !document[key].is_array())
      invalid(std::string("glTF member '") + key + "' is not an array");
  }
  if (document.contains("extensions") && !document["extensions"].is_object())
    invalid("glTF member 'extensions' is not an object");
  for (const char* key : {"buffers", "images"}) {
    if (!document.contains(key)) continue;
    for (const Json& item : document[key]) {
      if (!item.is_object()) invalid(std::string("an element of '") + key + "' is not an object");
      if (item.contains("uri") && !item["uri"].is_string())
        invalid(std::string("a uri in '") + key + "' is not a string");
    }
  }
  if (document.contains("buffers")) {
    for (const Json& buffer : document["buffers"]) {
      if (!buffer.contains("byteLength") || !buffer["byteLength"].is_number_integer() ||
          buffer["byteLength"].get<int64_t>() < 0) {
        invalid("a buffer has no valid byteLength");
      }
    }
  }
  for (const char* key : {"extensionsUsed", "extensionsRequired"}) {
    if (!document.contains(key)) continue;
    for (const Json& name : document[key]) {
      if (!name.is_string()) invalid(std::string("an element of '") + key + "' is not a string");
    }
  }
}

enum class Buffer0Origin { none, bin_chunk, data_uri, external };

struct Buffer0 {
  Buffer0Origin origin = Buffer0Origin::none;
  std::string bytes;       // exactly byteLength bytes
  fs::path external_path;  // when origin == external
};

Buffer0 load_buffer0(const Container& input, const fs::path& resource_dir) {
  Buffer0 buffer;
  const Json& document = input.document;
  if (!document.contains("buffers") || document["buffers"].empty()) return buffer;
  const Json& entry = document["buffers"][0];
  const auto byte_length = entry["byteLength"].get<uint64_t>();
  if (entry.contains("uri")) {
    const std::string uri = entry["uri"].get<std::string>();
    if (is_data_uri(uri)) {
      buffer.origin = Buffer0Origin::data_uri;
      buffer.bytes = decode_data_uri(uri, "buffer 0");
    } else if (is_absolute_uri(uri)) {
      throw Error(ErrorKind::unsupported, "buffer 0 has a URI the baker cannot read: " + uri);
    } else {
      buffer.origin = Buffer0Origin::external;
      buffer.external_path = resource_dir / fs::path(percent_decode(uri));
      buffer.bytes = read_whole_file(buffer.external_path);
    }
  } else {
    if (!input.is_glb || !input.has_bin_chunk) invalid("buffer 0 has no uri and there is no GLB BIN chunk");
    buffer.origin = Buffer0Origin::bin_chunk;
    buffer.bytes = input.bin_chunk;
  }
  if (buffer.bytes.size() < byte_length) {
    invalid("buffer 0 holds " + std::to_string(buffer.bytes.size()) + " bytes, less than its byteLength " +
            std::to_string(byte_length));
  }
  buffer.bytes.resize(size_t(byte_length));  // drop GLB padding: the original bytes, exactly
  return buffer;
}

// ---------------------------------------------------------------------------------------
// Deformable shape checks: everything the runtime's reader will check, caught at bake time.

void require(bool condition, size_t deformable, const std::string& message) {
  if (!condition) throw std::invalid_argument("baked deformable " + std::to_string(deformable) + ": " + message);
}

template <typename T>
bool all_finite(const std::vector<T>& values) {
  const auto* data = reinterpret_cast<const float*>(values.data());
  const size_t count = values.size() * sizeof(T) / sizeof(float);
  return std::all_of(data, data + count, [](float v) { return std::isfinite(v); });
}

template <typename T>
bool all_below(const std::vector<T>& values, uint64_t limit) {
  return std::all_of(values.begin(), values.end(), [limit](T v) { return uint64_t(v) < limit; });
}

const Json* array_element(const Json& document, const char* key, int index) {
  if (index < 0 || !document.contains(key) || size_t(index) >= document[key].size()) return nullptr;
  return &document[key][size_t(index)];
}

void check_deformable(const Json& document, const BakedDeformable& d, size_t i) {
  const Json* mesh = array_element(document, "meshes", d.mesh);
  require(mesh != nullptr && mesh->is_object(), i, "mesh " + std::to_string(d.mesh) + " is not in the input");
  require(d.node == -1 || array_element(document, "nodes", d.node), i,
          "node " + std::to_string(d.node) + " is not in the input");
  require(d.skin == -1 || array_element(document, "skins", d.skin), i,
          "skin " + std::to_string(d.skin) + " is not in the input");
  require(!d.primitives.empty(), i, "no primitives");
  uint64_t position_count = 0;
  for (const int p : d.primitives) {
    const bool present = mesh->contains("primitives") && (*mesh)["primitives"].is_array() && p >= 0 &&
                         size_t(p) < (*mesh)["primitives"].size();
    require(present, i, "primitive " + std::to_string(p) + " is not in mesh " + std::to_string(d.mesh));
    const Json& primitive = (*mesh)["primitives"][size_t(p)];
    const Json* accessor = nullptr;
    if (primitive.is_object() && primitive.contains("attributes") && primitive["attributes"].is_object() &&
        primitive["attributes"].contains("POSITION") && primitive["attributes"]["POSITION"].is_number_integer()) {
      accessor = array_element(document, "accessors", primitive["attributes"]["POSITION"].get<int>());
    }
    require(
        accessor && accessor->is_object() && accessor->contains("count") && (*accessor)["count"].is_number_unsigned(),
        i, "primitive " + std::to_string(p) + " has no POSITION accessor with a count");
    position_count += (*accessor)["count"].get<uint64_t>();
  }
  require(std::set<int>(d.primitives.begin(), d.primitives.end()).size() == d.primitives.size(), i,
          "a primitive is listed twice");
  require(d.dense_vertex_count == position_count, i,
          "dense_vertex_count " + std::to_string(d.dense_vertex_count) +
              " differs from the primitives' POSITION count " + std::to_string(position_count));

  const size_t control = d.control_positions.size();
  require(control > 0, i, "empty control mesh");
  require(d.control_normals.size() == control && d.skeletal_positions.size() == control &&
              d.medial_radius.size() == control,
          i, "control normals, skeletal positions and medial radii must have one entry per control vertex");
  require(!d.control_indices.empty() && d.control_indices.size() % 3 == 0 && all_below(d.control_indices, control), i,
          "control indices must be triangles of control vertices");
  require(d.joint_sets.size() == d.weight_sets.size(), i, "as many joint sets as weight sets");
  require(d.skelform_weight.empty() || d.skelform_weight.size() == d.dense_vertex_count, i,
          "skelform weights need one entry per dense vertex");
  for (float w : d.skelform_weight) require(w >= 0.0f && w <= 1.0f, i, "a skelform weight outside [0, 1]");
  require(d.skin == -1 || !d.joint_sets.empty(), i, "a skinned deformable needs at least one joint/weight set");
  for (size_t s = 0; s < d.joint_sets.size(); ++s) {
    require(d.joint_sets[s].size() == control && d.weight_sets[s].size() == control, i,
            "joint/weight sets need one entry per control vertex");
    require(all_finite(d.weight_sets[s]), i, "non-finite weight");
  }

  require(d.stencil_offsets.size() >= 2 && d.stencil_offsets.front() == 0, i,
          "stencil offsets must start at 0 and cover at least one refined vertex");
  require(std::is_sorted(d.stencil_offsets.begin(), d.stencil_offsets.end()), i, "stencil offsets must not decrease");
  require(d.stencil_offsets.back() == d.stencil_indices.size() && d.stencil_weights.size() == d.stencil_indices.size(),
          i, "the last stencil offset must equal the number of stencil indices and weights");
  require(all_below(d.stencil_indices, control), i, "stencil index out of the control vertices");
  const size_t refined = d.stencil_offsets.size() - 1;
  require(!d.refined_indices.empty() && d.refined_indices.size() % 3 == 0 && all_below(d.refined_indices, refined), i,
          "refined indices must be triangles of refined vertices");

  const size_t dense = d.dense_vertex_count;
  require(d.binding_triangle.size() == dense && d.binding_barycentric.size() == dense &&
              d.binding_displacement.size() == dense && d.binding_residual.size() == dense,
          i, "binding arrays need one entry per dense vertex");
  require(all_below(d.binding_triangle, d.refined_indices.size() / 3), i,
          "binding triangle out of the refined triangles");
  require(all_finite(d.control_positions) && all_finite(d.control_normals) && all_finite(d.skeletal_positions) &&
              all_finite(d.medial_radius) && all_finite(d.stencil_weights) && all_finite(d.binding_barycentric) &&
              all_finite(d.binding_displacement) && all_finite(d.binding_residual),
          i, "non-finite value");
}

// ---------------------------------------------------------------------------------------
// Appending arrays

const format::ArraySpec& spec_of(const char* group, const char* name) {
  for (const format::ArraySpec& spec : format::kArrays) {
    if (std::strcmp(spec.group, group) == 0 && std::strcmp(spec.name, name) == 0) return spec;
  }
  throw std::logic_error(std::string("extension_layout.h has no array ") + group + "." + name);
}

const char* accessor_type(int components) {
  switch (components) {
    case 1:
      return "SCALAR";
    case 2:
      return "VEC2";
    case 3:
      return "VEC3";
    case 4:
      return "VEC4";
  }
  throw std::logic_error("unsupported accessor component count");
}

// What the writer's C++ element type stores: its glTF component type and count, and how it
// is serialised. The spec check in add() keeps baked.h and extension_layout.h in step.
template <typename T>
struct Element;
template <>
struct Element<float> {
  static constexpr format::Component component = format::Component::float32;
  static constexpr int components = 1;
  static void append(std::string& out, float v) { append_f32(out, v); }
};
template <>
struct Element<uint32_t> {
  static constexpr format::Component component = format::Component::unsigned_int;
  static constexpr int components = 1;
  static void append(std::string& out, uint32_t v) { append_u32(out, v); }
};
template <>
struct Element<glm::vec2> {
  static constexpr format::Component component = format::Component::float32;
  static constexpr int components = 2;
  static void append(std::string& out, const glm::vec2& v) { append_f32(out, v.x), append_f32(out, v.y); }
};
template <>
struct Element<glm::vec3> {
  static constexpr format::Component component = format::Component::float32;
  static constexpr int components = 3;
  static void append(std::string& out, const glm::vec3& v) {
    append_f32(out, v.x), append_f32(out, v.y), append_f32(out, v.z);
  }
};
template <>
struct Element<std::array<float, 4>> {
  static constexpr format::Component component = format::Component::float32;
  static constexpr int components = 4;
  static void append(std::string& out, const std::array<float, 4>& v) {
    for (const float c : v) append_f32(out, c);
  }
};
template <>
struct Element<std::array<uint16_t, 4>> {
  static constexpr format::Component component = format::Component::unsigned_short;
  static constexpr int components = 4;
  static void append(std::string& out, const std::array<uint16_t, 4>& v) {
    for (const uint16_t c : v) append_u16(out, c);
  }
};

class ArrayAppender {
 public:
  ArrayAppender(Json& document, std::string& buffer) : document_(document), buffer_(buffer) {
    if (!document_.contains("bufferViews")) document_["bufferViews"] = Json::array();
    if (!document_.contains("accessors")) document_["accessors"] = Json::array();
  }

  // Appends `values` to buffer 0 as a new bufferView + accessor; returns the accessor index.
  template <typename T>
  int add(const format::ArraySpec& spec, const std::vector<T>& values, const std::string& label) {
    if (Element<T>::component != spec.component || Element<T>::components != spec.components) {
      throw std::logic_error(std::string("baked.h and extension_layout.h disagree on ") + spec.group + "." + spec.name);
    }
    pad_to_4(buffer_, '\0');
    const size_t offset = buffer_.size();
    for (const T& v : values) Element<T>::append(buffer_, v);
    Json view = Json::object();
    view["buffer"] = 0;
    view["byteOffset"] = offset;
    view["byteLength"] = buffer_.size() - offset;
    view["name"] = label;
    document_["bufferViews"].push_back(std::move(view));
    Json accessor = Json::object();
    accessor["bufferView"] = document_["bufferViews"].size() - 1;
    accessor["componentType"] = int(spec.component);
    accessor["count"] = values.size();
    accessor["type"] = accessor_type(spec.components);
    accessor["name"] = label;
    document_["accessors"].push_back(std::move(accessor));
    return int(document_["accessors"].size() - 1);
  }

 private:
  Json& document_;
  std::string& buffer_;
};

Json extension_of_deformable(ArrayAppender& arrays, const BakedDeformable& d, size_t index) {
  const std::string prefix = "SKELFORM " + std::to_string(index) + " ";
  auto add = [&](const char* group, const char* name, const auto& values) {
    return arrays.add(spec_of(group, name), values, prefix + group + "." + name);
  };
  Json control = Json::object();
  control["positions"] = add("control", "positions", d.control_positions);
  control["normals"] = add("control", "normals", d.control_normals);
  control["indices"] = add("control", "indices", d.control_indices);
  control["skeletalPositions"] = add("control", "skeletalPositions", d.skeletal_positions);
  control["medialRadius"] = add("control", "medialRadius", d.medial_radius);
  if (!d.joint_sets.empty()) {
    Json joints = Json::array(), weights = Json::array();
    for (size_t s = 0; s < d.joint_sets.size(); ++s) {
      const std::string set = "[" + std::to_string(s) + "]";
      joints.push_back(arrays.add(format::kJointSet, d.joint_sets[s], prefix + "control.joints" + set));
      weights.push_back(arrays.add(format::kWeightSet, d.weight_sets[s], prefix + "control.weights" + set));
    }
    control[format::kJointSet.name] = std::move(joints);
    control[format::kWeightSet.name] = std::move(weights);
  }
  Json subdivision = Json::object();
  subdivision[format::kSubdivisionLevel] = d.subdivision_level;
  subdivision["stencilOffsets"] = add("subdivision", "stencilOffsets", d.stencil_offsets);
  subdivision["stencilIndices"] = add("subdivision", "stencilIndices", d.stencil_indices);
  subdivision["stencilWeights"] = add("subdivision", "stencilWeights", d.stencil_weights);
  subdivision["indices"] = add("subdivision", "indices", d.refined_indices);
  Json binding = Json::object();
  binding["triangle"] = add("binding", "triangle", d.binding_triangle);
  binding["barycentric"] = add("binding", "barycentric", d.binding_barycentric);
  binding["displacement"] = add("binding", "displacement", d.binding_displacement);
  binding["residual"] = add("binding", "residual", d.binding_residual);

  Json deformable = Json::object();
  deformable[format::kMesh] = d.mesh;
  if (d.node >= 0) deformable[format::kNode] = d.node;
  if (d.skin >= 0) deformable[format::kSkin] = d.skin;
  deformable[format::kPrimitives] = d.primitives;
  deformable[format::kVertexCount] = d.dense_vertex_count;
  deformable["control"] = std::move(control);
  deformable["subdivision"] = std::move(subdivision);
  deformable["binding"] = std::move(binding);
  if (!d.skelform_weight.empty()) {
    Json blend = Json::object();
    blend[format::kSkelformWeight.name] =
        arrays.add(format::kSkelformWeight, d.skelform_weight,
                   prefix + format::kSkelformWeight.group + "." + format::kSkelformWeight.name);
    deformable[format::kSkelformWeight.group] = std::move(blend);
  }
  return deformable;
}

// Adds the extension to `document` and its arrays to `buffer0` (the original buffer 0 bytes).
void add_extension(Json& document, std::string& buffer0, const std::vector<BakedDeformable>& deformables) {
  if (deformables.empty()) throw std::invalid_argument("no baked deformable to write");
  for (size_t i = 0; i < deformables.size(); ++i) check_deformable(document, deformables[i], i);
  if (!document.contains("buffers")) document["buffers"] = Json::array();
  if (document["buffers"].empty()) document["buffers"].push_back(Json::object({{"byteLength", 0}}));

  ArrayAppender arrays(document, buffer0);
  Json list = Json::array();
  for (size_t i = 0; i < deformables.size(); ++i) list.push_back(extension_of_deformable(arrays, deformables[i], i));
  pad_to_4(buffer0, '\0');
  document["buffers"][0]["byteLength"] = buffer0.size();

  Json extension = Json::object();
  extension[format::kMajorVersionKey] = format::kMajorVersion;
  extension[format::kMinorVersionKey] = format::kMinorVersion;
  extension[format::kDeformables] = std::move(list);
  if (!document.contains("extensions")) document["extensions"] = Json::object();
  document["extensions"][format::kExtensionName] = std::move(extension);  // a re-bake replaces the old one

  if (!document.contains("extensionsUsed")) document["extensionsUsed"] = Json::array();
  Json& used = document["extensionsUsed"];
  if (std::find(used.begin(), used.end(), format::kExtensionName) == used.end()) used.push_back(format::kExtensionName);
  // Optional by design: a viewer without the extension shows the ordinary skin.
  if (document.contains("extensionsRequired")) {
    Json& required = document["extensionsRequired"];
    required.erase(std::remove(required.begin(), required.end(), format::kExtensionName), required.end());
    if (required.empty()) document.erase("extensionsRequired");
  }
}

// ---------------------------------------------------------------------------------------
// Output containers

std::string glb_bytes(const Json& document, const std::string& bin) {
  try {
    return glb_container(document.dump(), bin);
  } catch (const std::length_error&) {
    throw Error(ErrorKind::unsupported, "the baked GLB would exceed 4 GiB");
  }
}

struct Baked {
  Json document;
  Buffer0 buffer0;  // original bytes + extension arrays; origin as in the input
};

Baked bake_document(const std::string& input_bytes, const fs::path& resource_dir,
                    const std::vector<BakedDeformable>& deformables) {
  Container input = parse_container(input_bytes);
  check_structure(input.document);
  Baked baked;
  baked.buffer0 = load_buffer0(input, resource_dir);
  baked.document = std::move(input.document);
  add_extension(baked.document, baked.buffer0.bytes, deformables);
  return baked;
}

std::string to_glb(Baked& baked) {
  baked.document["buffers"][0].erase("uri");  // buffer 0 without uri = the BIN chunk
  return glb_bytes(baked.document, baked.buffer0.bytes);
}

std::string lowercase_extension(const fs::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return extension;
}

bool is_same_file(const fs::path& a, const fs::path& b) { return same_file(a.string(), b.string()); }

// Makes the input's relative URIs (buffers other than 0, images) resolve from the output's
// directory; returns the files to copy (source, destination).
std::vector<std::pair<fs::path, fs::path>> relocate_uris(Json& document, const fs::path& input_dir,
                                                         const fs::path& output_dir) {
  std::vector<std::pair<fs::path, fs::path>> copies;
  std::error_code ec;
  if (fs::equivalent(input_dir, output_dir, ec)) return copies;
  auto relocate = [&](Json& item) {
    if (!item.is_object() || !item.contains("uri")) return;
    const std::string uri = item["uri"].get<std::string>();
    if (is_data_uri(uri) || is_absolute_uri(uri)) return;
    const fs::path relative = fs::path(percent_decode(uri)).lexically_normal();
    const fs::path source = input_dir / relative;
    if (!fs::is_regular_file(source, ec)) return;  // missing: keep the input's (broken) URI
    const bool inside = !relative.empty() && *relative.begin() != "..";
    if (inside) {
      copies.emplace_back(source, output_dir / relative);
    } else {
      const fs::path from_output = fs::relative(fs::weakly_canonical(source), fs::weakly_canonical(output_dir), ec);
      item["uri"] = percent_encode_path(ec || from_output.empty() ? fs::weakly_canonical(source).generic_string()
                                                                  : from_output.generic_string());
    }
  };
  if (document.contains("buffers")) {
    for (size_t i = 1; i < document["buffers"].size(); ++i) relocate(document["buffers"][i]);
  }
  if (document.contains("images")) {
    for (Json& image : document["images"]) relocate(image);
  }
  return copies;
}

}  // namespace

std::string baked_glb(const std::string& input, const std::string& resource_dir,
                      const std::vector<BakedDeformable>& deformables) {
  Baked baked = bake_document(input, resource_dir, deformables);
  return to_glb(baked);
}

void write_baked_gltf(const std::string& input_path, const std::vector<BakedDeformable>& deformables,
                      const std::string& output_path) {
  const fs::path input(input_path), output(output_path);
  const std::string container = lowercase_extension(output);
  if (container != ".glb" && container != ".gltf") {
    throw Error(ErrorKind::usage, "output " + output_path + " must end in .glb or .gltf");
  }
  if (is_same_file(input, output))
    throw Error(ErrorKind::usage, "output " + output_path + " would overwrite the input");
  const fs::path input_dir = input.parent_path().empty() ? fs::path(".") : input.parent_path();
  const fs::path output_dir = output.parent_path().empty() ? fs::path(".") : output.parent_path();

  std::error_code ec;
  if (!fs::is_directory(output_dir, ec))
    throw Error(ErrorKind::io, "output directory " + output_dir.string() + " does not exist");

  Baked baked = bake_document(read_whole_file(input), input_dir, deformables);
  const auto copies = relocate_uris(baked.document, input_dir, output_dir);
  auto refuse_overwrite = [&](const fs::path& target) {
    const bool hits_input =
        is_same_file(target, input) ||
        (baked.buffer0.origin == Buffer0Origin::external && is_same_file(target, baked.buffer0.external_path)) ||
        std::any_of(copies.begin(), copies.end(), [&](const auto& c) { return is_same_file(target, c.first); });
    if (hits_input)
      throw Error(ErrorKind::usage, "writing " + target.string() + " would overwrite a file the input uses");
  };

  std::string document_bytes;
  fs::path bin_path;
  if (container == ".glb") {
    document_bytes = to_glb(baked);
  } else if (baked.buffer0.origin == Buffer0Origin::data_uri) {
    baked.document["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64_encode(baked.buffer0.bytes);
    document_bytes = baked.document.dump(2) + "\n";
  } else {
    bin_path = output;
    bin_path.replace_extension(".bin");
    refuse_overwrite(bin_path);
    baked.document["buffers"][0]["uri"] = percent_encode_path(bin_path.filename().string());
    document_bytes = baked.document.dump(2) + "\n";
  }
  for (const auto& copy : copies) refuse_overwrite(copy.second);

  if (!bin_path.empty()) write_file_atomically(bin_path.string(), baked.buffer0.bytes);
  for (const auto& [source, destination] : copies) {
    if (is_same_file(source, destination)) continue;
    fs::create_directories(destination.parent_path(), ec);
    write_file_atomically(destination.string(), read_whole_file(source));
  }
  write_file_atomically(output.string(), document_bytes);
}

}  // namespace skelform::bake
