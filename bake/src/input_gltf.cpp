// glTF 2.0 input (.gltf/.glb) through the Debian tinygltf shared library, and the validated
// accessor readers of gltf_access.h. tinygltf 2.7 leaves most range checks to its caller, so
// nothing here indexes a tinygltf vector or a buffer before checking it.
#include "skelform/bake/gltf_access.h"

#include "input_formats.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace skelform::bake {
namespace gltf {
namespace {

[[noreturn]] void invalid(const std::string& what, const std::string& problem) {
  throw Error(ErrorKind::invalid_input, what + ": " + problem);
}

// tinygltf reports several problems separated by newlines; our messages are one line.
std::string one_line(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) text.pop_back();
  std::string out;
  for (char c : text) {
    if (c == '\n') out += "; ";
    else if (c != '\r') out += c;
  }
  return out;
}

uint32_t read_u32_le(const unsigned char* p) {
  return uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24;
}

bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                void*) {
  return true;
}

// Checks the GLB container so tinygltf only ever sees a consistent one; returns the number
// of bytes the header declares.
size_t check_glb_container(const std::vector<unsigned char>& bytes, const std::string& name) {
  const size_t size = bytes.size();
  if (size < 12) invalid(name, "truncated .glb (" + std::to_string(size) + " bytes; the header alone needs 12)");
  if (std::memcmp(bytes.data(), "glTF", 4) != 0) invalid(name, "not a binary glTF file (bad magic)");
  const uint32_t version = read_u32_le(bytes.data() + 4);
  if (version != 2)
    throw Error(ErrorKind::unsupported, name + ": binary glTF version " + std::to_string(version) + " (only 2 is supported)");
  const uint64_t length = read_u32_le(bytes.data() + 8);
  if (length > size)
    invalid(name, "truncated .glb (header says " + std::to_string(length) + " bytes, file has " + std::to_string(size) + ")");
  if (length < 20) invalid(name, "malformed .glb (declared length " + std::to_string(length) + " leaves no room for the JSON chunk)");
  const uint64_t json_length = read_u32_le(bytes.data() + 12);
  if (read_u32_le(bytes.data() + 16) != 0x4E4F534Au) invalid(name, "malformed .glb (first chunk is not JSON)");
  if (json_length == 0) invalid(name, "malformed .glb (empty JSON chunk)");
  if (20 + json_length > length)
    invalid(name, "truncated .glb (JSON chunk of " + std::to_string(json_length) + " bytes does not fit)");
  uint64_t offset = 20 + json_length;
  while (offset < length) {
    if (length - offset < 8) invalid(name, "truncated .glb (chunk header cut off at byte " + std::to_string(offset) + ")");
    const uint64_t chunk_length = read_u32_le(bytes.data() + offset);
    if (chunk_length > length - offset - 8)
      invalid(name, "truncated .glb (chunk at byte " + std::to_string(offset) + " declares " +
                        std::to_string(chunk_length) + " bytes, " + std::to_string(length - offset - 8) + " remain)");
    offset += 8 + chunk_length;
  }
  return static_cast<size_t>(length);
}

std::string directory_of(const std::string& path) {
  const size_t slash = path.find_last_of("/\\");
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

int component_size(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;  // INT and DOUBLE are not glTF 2.0 accessor component types
  }
}

const char* component_name(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return "BYTE";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return "UNSIGNED_BYTE";
    case TINYGLTF_COMPONENT_TYPE_SHORT: return "SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return "UNSIGNED_SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return "UNSIGNED_INT";
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return "FLOAT";
    default: return "an invalid component type";
  }
}

const char* type_name(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return "SCALAR";
    case TINYGLTF_TYPE_VEC2: return "VEC2";
    case TINYGLTF_TYPE_VEC3: return "VEC3";
    case TINYGLTF_TYPE_VEC4: return "VEC4";
    case TINYGLTF_TYPE_MAT2: return "MAT2";
    case TINYGLTF_TYPE_MAT3: return "MAT3";
    case TINYGLTF_TYPE_MAT4: return "MAT4";
    default: return "an invalid type";
  }
}

// Decodes one little-endian component; normalized integers map to [0, 1] or [-1, 1] by the
// glTF formulas.
double decode_component(const unsigned char* p, int component_type, bool normalized) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      const double v = static_cast<int8_t>(p[0]);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.0 : p[0];
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      const double v = static_cast<int16_t>(static_cast<uint16_t>(p[0] | p[1] << 8));
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      const double v = static_cast<uint16_t>(p[0] | p[1] << 8);
      return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return read_u32_le(p);
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      const uint32_t bits = read_u32_le(p);
      float f;
      std::memcpy(&f, &bits, sizeof f);
      return f;
    }
    default: return 0.0;
  }
}

struct ByteRange {
  const unsigned char* data = nullptr;
  size_t size = 0;
};

// The bytes of bufferView `index`, after checking it lies inside its buffer.
ByteRange view_bytes(const tinygltf::Model& model, int index, const std::string& what) {
  if (index < 0 || static_cast<size_t>(index) >= model.bufferViews.size())
    invalid(what, "bufferView " + std::to_string(index) + " does not exist (" +
                      std::to_string(model.bufferViews.size()) + " bufferViews)");
  const tinygltf::BufferView& view = model.bufferViews[static_cast<size_t>(index)];
  if (view.buffer < 0 || static_cast<size_t>(view.buffer) >= model.buffers.size())
    invalid(what, "bufferView " + std::to_string(index) + " refers to buffer " + std::to_string(view.buffer) +
                      ", which does not exist");
  const tinygltf::Buffer& buffer = model.buffers[static_cast<size_t>(view.buffer)];
  const size_t buffer_size = buffer.data.size();
  if (view.byteOffset > buffer_size || view.byteLength > buffer_size - view.byteOffset)
    invalid(what, "bufferView " + std::to_string(index) + " (bytes " + std::to_string(view.byteOffset) + " + " +
                      std::to_string(view.byteLength) + ") runs past the end of buffer " +
                      std::to_string(view.buffer) + " (" + std::to_string(buffer_size) + " bytes)");
  return {buffer.data.data() + view.byteOffset, view.byteLength};
}

// What a reader accepts.
struct AccessorSpec {
  int type;                              // TINYGLTF_TYPE_*
  std::vector<int> component_types;      // accepted TINYGLTF_COMPONENT_TYPE_*
  bool integers_must_be_normalized;      // WEIGHTS: integer weights are only meaningful normalized
  bool integers_must_not_be_normalized;  // indices and joints are plain integers
};

const tinygltf::Accessor& checked_accessor(const tinygltf::Model& model, int index, const std::string& what) {
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size())
    invalid(what, "accessor " + std::to_string(index) + " does not exist (" + std::to_string(model.accessors.size()) +
                      " accessors)");
  const tinygltf::Accessor& accessor = model.accessors[static_cast<size_t>(index)];
  if (accessor.count < 1) invalid(what, "accessor " + std::to_string(index) + " has count 0");
  return accessor;
}

// Decodes accessor `index` into count × components doubles, validating everything the
// header promises.
std::vector<double> read_components(const tinygltf::Model& model, int index, const AccessorSpec& spec,
                                    const std::string& what) {
  const tinygltf::Accessor& accessor = checked_accessor(model, index, what);
  const std::string where = what + ": accessor " + std::to_string(index);
  const bool type_ok = accessor.type == spec.type;
  const bool component_ok = std::find(spec.component_types.begin(), spec.component_types.end(),
                                      accessor.componentType) != spec.component_types.end();
  if (!type_ok || !component_ok) {
    std::string expected;
    for (int c : spec.component_types) expected += (expected.empty() ? "" : "/") + std::string(component_name(c));
    throw Error(ErrorKind::unsupported, where + " is " + component_name(accessor.componentType) + " " +
                                            type_name(accessor.type) + "; expected " + expected + " " +
                                            type_name(spec.type));
  }
  const bool is_float = accessor.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT;
  if (is_float && accessor.normalized) invalid(where, "FLOAT components cannot be normalized");
  if (!is_float && spec.integers_must_be_normalized && !accessor.normalized)
    throw Error(ErrorKind::unsupported, where + " has integer components that are not normalized");
  if (!is_float && spec.integers_must_not_be_normalized && accessor.normalized)
    invalid(where, "integer indices cannot be normalized");

  const size_t components = static_cast<size_t>(tinygltf::GetNumComponentsInType(static_cast<uint32_t>(accessor.type)));
  const size_t component_bytes = static_cast<size_t>(component_size(accessor.componentType));
  const size_t element_bytes = components * component_bytes;
  const size_t count = accessor.count;
  // Bounded by the data that can actually be addressed, before any multiplication.
  if (count > std::numeric_limits<uint32_t>::max())
    throw Error(ErrorKind::unsupported, where + " has " + std::to_string(count) + " elements (more than 2^32-1)");
  std::vector<double> values;
  if (accessor.bufferView >= 0) {
    const ByteRange view = view_bytes(model, accessor.bufferView, where);
    const tinygltf::BufferView& view_info = model.bufferViews[static_cast<size_t>(accessor.bufferView)];
    size_t stride = element_bytes;
    if (view_info.byteStride != 0) {
      if (view_info.byteStride < element_bytes || view_info.byteStride > 252)
        invalid(where, "bufferView " + std::to_string(accessor.bufferView) + " has byteStride " +
                           std::to_string(view_info.byteStride) + " (needs " + std::to_string(element_bytes) +
                           " to 252 for this accessor)");
      stride = view_info.byteStride;
    }
    const uint64_t last_end = uint64_t{accessor.byteOffset} + uint64_t{count - 1} * stride + element_bytes;
    if (accessor.byteOffset > view.size || last_end > view.size)
      invalid(where, "runs past the end of bufferView " + std::to_string(accessor.bufferView) + " (byteOffset " +
                         std::to_string(accessor.byteOffset) + " + " + std::to_string(count) + " elements of stride " +
                         std::to_string(stride) + " needs " + std::to_string(last_end) + " bytes, the view has " +
                         std::to_string(view.size) + ")");
    // Allocated only now that the data is known to exist, so a lying count cannot exhaust memory.
    values.assign(count * components, 0.0);
    for (size_t i = 0; i < count; ++i) {
      const unsigned char* element = view.data + accessor.byteOffset + i * stride;
      for (size_t c = 0; c < components; ++c)
        values[i * components + c] =
            decode_component(element + c * component_bytes, accessor.componentType, accessor.normalized);
    }
  } else {
    // Zeros (plus sparse values): no stored data bounds the count, so cap it at a size no
    // real skinned mesh reaches rather than attempt an absurd allocation.
    constexpr size_t kMaxImplicitElements = size_t{1} << 26;
    if (count > kMaxImplicitElements)
      throw Error(ErrorKind::unsupported, where + " has no bufferView and declares " + std::to_string(count) +
                                              " elements (more than 2^26)");
    values.assign(count * components, 0.0);
  }

  if (accessor.sparse.isSparse) {
    const auto& sparse = accessor.sparse;
    const std::string sparse_where = where + " (sparse)";
    if (sparse.count < 1 || static_cast<size_t>(sparse.count) > count)
      invalid(sparse_where, "count " + std::to_string(sparse.count) + " is not within 1.." + std::to_string(count));
    const size_t sparse_count = static_cast<size_t>(sparse.count);
    const int index_type = sparse.indices.componentType;
    if (index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
      invalid(sparse_where, std::string("indices are ") + component_name(index_type) +
                                "; expected UNSIGNED_BYTE/UNSIGNED_SHORT/UNSIGNED_INT");
    const size_t index_bytes = static_cast<size_t>(component_size(index_type));
    const ByteRange index_view = view_bytes(model, sparse.indices.bufferView, sparse_where + " indices");
    const ByteRange value_view = view_bytes(model, sparse.values.bufferView, sparse_where + " values");
    if (sparse.indices.byteOffset < 0 ||
        uint64_t(sparse.indices.byteOffset) + uint64_t{sparse_count} * index_bytes > index_view.size)
      invalid(sparse_where, "indices run past the end of bufferView " + std::to_string(sparse.indices.bufferView));
    if (sparse.values.byteOffset < 0 ||
        uint64_t(sparse.values.byteOffset) + uint64_t{sparse_count} * element_bytes > value_view.size)
      invalid(sparse_where, "values run past the end of bufferView " + std::to_string(sparse.values.bufferView));
    const unsigned char* indices = index_view.data + sparse.indices.byteOffset;
    const unsigned char* substitutes = value_view.data + sparse.values.byteOffset;
    int64_t previous = -1;
    for (size_t s = 0; s < sparse_count; ++s) {
      const double target_value = decode_component(indices + s * index_bytes, index_type, false);
      const int64_t target = static_cast<int64_t>(target_value);
      if (static_cast<size_t>(target) >= count)
        invalid(sparse_where, "index " + std::to_string(target) + " at position " + std::to_string(s) +
                                  " is out of range (accessor count " + std::to_string(count) + ")");
      if (target <= previous)
        invalid(sparse_where, "indices are not strictly increasing at position " + std::to_string(s));
      previous = target;
      for (size_t c = 0; c < components; ++c)
        values[static_cast<size_t>(target) * components + c] =
            decode_component(substitutes + s * element_bytes + c * component_bytes, accessor.componentType,
                             accessor.normalized);
    }
  }
  return values;
}

void check_finite(const std::vector<double>& values, size_t components, const std::string& what, int accessor) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i]))
      invalid(what, "accessor " + std::to_string(accessor) + " element " + std::to_string(i / components) +
                        " has a non-finite value");
  }
}

AccessorSpec float_spec(int type) {
  return {type, {TINYGLTF_COMPONENT_TYPE_FLOAT}, false, false};
}

bool requires_extension(const tinygltf::Model& model, const std::string& extension) {
  return std::find(model.extensionsRequired.begin(), model.extensionsRequired.end(), extension) !=
         model.extensionsRequired.end();
}

}  // namespace

void parse_model(const std::vector<unsigned char>& bytes, bool binary, const std::string& name,
                 tinygltf::Model& model) {
  if (bytes.empty()) invalid(name, "empty file");
  if (bytes.size() > std::numeric_limits<unsigned int>::max())
    throw Error(ErrorKind::unsupported, name + ": file larger than 4 GiB");
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(skip_image, nullptr);
  std::string error;
  std::string warning;
  bool ok = false;
  if (binary) {
    const size_t length = check_glb_container(bytes, name);
    ok = loader.LoadBinaryFromMemory(&model, &error, &warning, bytes.data(), static_cast<unsigned int>(length),
                                     directory_of(name));
  } else {
    ok = loader.LoadASCIIFromString(&model, &error, &warning, reinterpret_cast<const char*>(bytes.data()),
                                    static_cast<unsigned int>(bytes.size()), directory_of(name));
  }
  if (!ok) invalid(name, "not a valid glTF 2.0 file: " + (error.empty() ? std::string("parse failed") : one_line(error)));
  for (const char* extension : {"KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_mesh_quantization"}) {
    if (requires_extension(model, extension))
      throw Error(ErrorKind::unsupported, name + ": requires " + extension +
                                              ", which the baker does not decode (export uncompressed geometry)");
  }
}

size_t accessor_count(const tinygltf::Model& model, int accessor, const std::string& what) {
  return checked_accessor(model, accessor, what).count;
}

std::vector<Vec3> read_vec3(const tinygltf::Model& model, int accessor, const std::string& what) {
  const std::vector<double> v = read_components(model, accessor, float_spec(TINYGLTF_TYPE_VEC3), what);
  check_finite(v, 3, what, accessor);
  std::vector<Vec3> out(v.size() / 3);
  for (size_t i = 0; i < out.size(); ++i) out[i] = Vec3(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
  return out;
}

std::vector<glm::dvec4> read_vec4(const tinygltf::Model& model, int accessor, const std::string& what) {
  const std::vector<double> v = read_components(model, accessor, float_spec(TINYGLTF_TYPE_VEC4), what);
  check_finite(v, 4, what, accessor);
  std::vector<glm::dvec4> out(v.size() / 4);
  for (size_t i = 0; i < out.size(); ++i) out[i] = glm::dvec4(v[4 * i], v[4 * i + 1], v[4 * i + 2], v[4 * i + 3]);
  return out;
}

std::vector<glm::dmat4> read_mat4(const tinygltf::Model& model, int accessor, const std::string& what) {
  const std::vector<double> v = read_components(model, accessor, float_spec(TINYGLTF_TYPE_MAT4), what);
  check_finite(v, 16, what, accessor);
  std::vector<glm::dmat4> out(v.size() / 16);
  for (size_t i = 0; i < out.size(); ++i)
    for (int column = 0; column < 4; ++column)
      for (int row = 0; row < 4; ++row) out[i][column][row] = v[16 * i + 4 * static_cast<size_t>(column) + static_cast<size_t>(row)];
  return out;
}

std::vector<glm::uvec4> read_joints(const tinygltf::Model& model, int accessor, const std::string& what) {
  const AccessorSpec spec{TINYGLTF_TYPE_VEC4,
                          {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                          false,
                          true};
  const std::vector<double> v = read_components(model, accessor, spec, what);
  std::vector<glm::uvec4> out(v.size() / 4);
  for (size_t i = 0; i < out.size(); ++i)
    for (int c = 0; c < 4; ++c) out[i][c] = static_cast<uint32_t>(v[4 * i + static_cast<size_t>(c)]);
  return out;
}

std::vector<glm::dvec4> read_weights(const tinygltf::Model& model, int accessor, const std::string& what) {
  const AccessorSpec spec{TINYGLTF_TYPE_VEC4,
                          {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                           TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                          true,
                          false};
  const std::vector<double> v = read_components(model, accessor, spec, what);
  check_finite(v, 4, what, accessor);
  std::vector<glm::dvec4> out(v.size() / 4);
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = glm::dvec4(v[4 * i], v[4 * i + 1], v[4 * i + 2], v[4 * i + 3]);
    if (out[i].x < 0 || out[i].y < 0 || out[i].z < 0 || out[i].w < 0)
      invalid(what, "accessor " + std::to_string(accessor) + " element " + std::to_string(i) + " has a negative weight");
  }
  return out;
}

std::vector<uint32_t> read_indices(const tinygltf::Model& model, int accessor, size_t vertex_count,
                                   const std::string& what) {
  const AccessorSpec spec{TINYGLTF_TYPE_SCALAR,
                          {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                           TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT},
                          false,
                          true};
  const std::vector<double> v = read_components(model, accessor, spec, what);
  std::vector<uint32_t> out(v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    out[i] = static_cast<uint32_t>(v[i]);
    if (out[i] >= vertex_count)
      invalid(what, "index " + std::to_string(out[i]) + " at position " + std::to_string(i) + " of accessor " +
                        std::to_string(accessor) + " is out of range (" + std::to_string(vertex_count) + " vertices)");
  }
  return out;
}

}  // namespace gltf

namespace detail {
namespace {

const char* mode_name(int mode) {
  switch (mode) {
    case TINYGLTF_MODE_POINTS: return "POINTS";
    case TINYGLTF_MODE_LINE: return "LINES";
    case TINYGLTF_MODE_LINE_LOOP: return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP: return "LINE_STRIP";
    case TINYGLTF_MODE_TRIANGLES: return "TRIANGLES";
    case TINYGLTF_MODE_TRIANGLE_STRIP: return "TRIANGLE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_FAN: return "TRIANGLE_FAN";
    default: return "an unknown mode";
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
      throw Error(ErrorKind::invalid_input, what + ": TRIANGLES with " + std::to_string(n) +
                                                " vertex indices, which is not a multiple of 3");
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

// Appends the JOINTS_n/WEIGHTS_n sets of one skinned primitive to mesh.joint_sets and
// weight_sets, keeping every set as long as mesh.positions (the new primitive's vertices
// are already appended). Sets this primitive lacks, or earlier primitives lacked, hold zero
// weights. Weights are renormalised to sum to 1 over all sets (glTF requires the sum to be
// 1; exporters round); a vertex whose weights are all zero is refused.
void append_skin_influences(const tinygltf::Model& model, const tinygltf::Primitive& primitive, size_t joint_count,
                            size_t vertex_count, const std::string& what, InputMesh& mesh) {
  const size_t total = mesh.positions.size();
  const size_t first = total - vertex_count;
  for (size_t set = 0;; ++set) {
    const auto joints = primitive.attributes.find("JOINTS_" + std::to_string(set));
    const auto weights = primitive.attributes.find("WEIGHTS_" + std::to_string(set));
    if (joints == primitive.attributes.end() && weights == primitive.attributes.end()) {
      if (set == 0) gltf::invalid(what, "belongs to a skinned node but has no JOINTS_0/WEIGHTS_0");
      break;
    }
    const std::string set_name = std::to_string(set);
    if (joints == primitive.attributes.end()) gltf::invalid(what, "has WEIGHTS_" + set_name + " without JOINTS_" + set_name);
    if (weights == primitive.attributes.end()) gltf::invalid(what, "has JOINTS_" + set_name + " without WEIGHTS_" + set_name);
    const std::vector<glm::uvec4> joint_values = gltf::read_joints(model, joints->second, what + " JOINTS_" + set_name);
    const std::vector<glm::dvec4> weight_values = gltf::read_weights(model, weights->second, what + " WEIGHTS_" + set_name);
    if (joint_values.size() != vertex_count || weight_values.size() != vertex_count)
      gltf::invalid(what, "JOINTS_" + set_name + "/WEIGHTS_" + set_name + " count differs from POSITION count");
    if (set >= mesh.joint_sets.size()) {
      mesh.joint_sets.emplace_back(first, std::array<uint16_t, 4>{0, 0, 0, 0});
      mesh.weight_sets.emplace_back(first, std::array<float, 4>{0, 0, 0, 0});
    }
    for (size_t v = 0; v < vertex_count; ++v) {
      std::array<uint16_t, 4> j{};
      std::array<float, 4> w{};
      for (int k = 0; k < 4; ++k) {
        // A zero weight may name any joint; only influencing joints must exist in the skin.
        if (weight_values[v][k] > 0 && joint_values[v][k] >= joint_count)
          gltf::invalid(what, "vertex " + std::to_string(v) + " JOINTS_" + set_name + " names joint " +
                                  std::to_string(joint_values[v][k]) + " but the skin has " + std::to_string(joint_count));
        j[static_cast<size_t>(k)] = weight_values[v][k] > 0 ? static_cast<uint16_t>(joint_values[v][k]) : 0;
        w[static_cast<size_t>(k)] = static_cast<float>(weight_values[v][k]);
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
    if (!(sum > 0)) gltf::invalid(what, "vertex " + std::to_string(v - first) + " has no skin weight");
    for (auto& set : mesh.weight_sets)
      for (float& w : set[v]) w = static_cast<float>(w / sum);
  }
}

InputMesh load_gltf(const std::vector<unsigned char>& bytes, bool binary, const std::string& name,
                    const LoadOptions& options) {
  tinygltf::Model model;
  gltf::parse_model(bytes, binary, name, model);

  // The node that represents each mesh: the first skinned node using it, else (all_meshes)
  // the first node using it.
  const size_t mesh_count = model.meshes.size();
  std::vector<int> skinned_node(mesh_count, -1);
  std::vector<int> any_node(mesh_count, -1);
  for (size_t n = 0; n < model.nodes.size(); ++n) {
    const tinygltf::Node& node = model.nodes[n];
    if (node.mesh < 0) continue;
    if (static_cast<size_t>(node.mesh) >= mesh_count)
      gltf::invalid(name, "node " + std::to_string(n) + " refers to mesh " + std::to_string(node.mesh) + " (" +
                              std::to_string(mesh_count) + " meshes)");
    if (node.skin >= 0 && static_cast<size_t>(node.skin) >= model.skins.size())
      gltf::invalid(name, "node " + std::to_string(n) + " refers to skin " + std::to_string(node.skin) + " (" +
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
        throw Error(ErrorKind::unsupported, what + " has mode " + mode_name(mode) +
                                                "; only triangle primitives (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN) can be baked");
      if (mode > TINYGLTF_MODE_TRIANGLE_FAN) gltf::invalid(what, "unknown primitive mode " + std::to_string(mode));
      const auto position = primitive.attributes.find("POSITION");
      if (position == primitive.attributes.end()) gltf::invalid(what, "has no POSITION attribute");

      const std::vector<Vec3> positions = gltf::read_vec3(model, position->second, what + " POSITION");
      if (mesh.positions.size() + positions.size() > std::numeric_limits<uint32_t>::max())
        throw Error(ErrorKind::unsupported, what + ": more than 2^32-1 vertices in total");
      std::vector<uint32_t> corners;
      if (primitive.indices >= 0) {
        corners = gltf::read_indices(model, primitive.indices, positions.size(), what + " indices");
      } else {
        corners.resize(positions.size());
        for (size_t i = 0; i < corners.size(); ++i) corners[i] = static_cast<uint32_t>(i);
      }
      std::vector<Triangle> triangles = triangulate(mode, corners, what);

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
      mesh.positions.insert(mesh.positions.end(), positions.begin(), positions.end());
      mesh.triangles.insert(mesh.triangles.end(), triangles.begin(), triangles.end());
      mesh.primitives.push_back(record);
      if (skin >= 0) append_skin_influences(model, primitive, model.skins[static_cast<size_t>(skin)].joints.size(),
                                            positions.size(), what, mesh);
    }
  }

  if (mesh.primitives.empty()) {
    if (!options.all_meshes)
      throw Error(ErrorKind::invalid_input,
                  "no skinned mesh in " + name + " (use --all-meshes to bake unskinned meshes)");
    gltf::invalid(name, "no mesh with triangle primitives");
  }
  return mesh;
}

}  // namespace detail
}  // namespace skelform::bake
