// Validated glTF accessor reading (gltf_read.h): every accessor, bufferView and buffer range
// is checked before it is read, a lying count cannot exhaust memory, and sparse accessors
// are applied with their indices checked.
#include "skelform/core/gltf_read.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace skelform::gltf {
namespace {

using detail::invalid;
using detail::read_u32_le;

int component_size(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return 4;
    default:
      return 0;  // INT and DOUBLE are not glTF 2.0 accessor component types
  }
}

const char* component_name(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
      return "BYTE";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return "UNSIGNED_BYTE";
    case TINYGLTF_COMPONENT_TYPE_SHORT:
      return "SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return "UNSIGNED_SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
      return "UNSIGNED_INT";
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return "FLOAT";
    default:
      return "an invalid component type";
  }
}

const char* type_name(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR:
      return "SCALAR";
    case TINYGLTF_TYPE_VEC2:
      return "VEC2";
    case TINYGLTF_TYPE_VEC3:
      return "VEC3";
    case TINYGLTF_TYPE_VEC4:
      return "VEC4";
    case TINYGLTF_TYPE_MAT2:
      return "MAT2";
    case TINYGLTF_TYPE_MAT3:
      return "MAT3";
    case TINYGLTF_TYPE_MAT4:
      return "MAT4";
    default:
      return "an invalid type";
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
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return normalized ? p[0] / 255.0 : p[0];
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      const double v = static_cast<int16_t>(static_cast<uint16_t>(p[0] | p[1] << 8));
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      const double v = static_cast<uint16_t>(p[0] | p[1] << 8);
      return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
      return read_u32_le(p);
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      const uint32_t bits = read_u32_le(p);
      float f;
      std::memcpy(&f, &bits, sizeof f);
      return f;
    }
    default:
      return 0.0;
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
                      std::to_string(view.byteLength) + ") runs past the end of buffer " + std::to_string(view.buffer) +
                      " (" + std::to_string(buffer_size) + " bytes)");
  return {buffer.data.data() + view.byteOffset, view.byteLength};
}

// What a reader accepts.
struct AccessorSpec {
  int type;                              // TINYGLTF_TYPE_*
  std::vector<int> component_types;      // accepted TINYGLTF_COMPONENT_TYPE_*
  bool integers_must_be_normalized;      // WEIGHTS: integer weights are only meaningful normalized
  bool integers_must_not_be_normalized;  // indices and joints are plain integers
  // A type or component type outside the accepted ones: unsupported for core attributes
  // (valid glTF, another reader might take it), invalid where a format fixes the layout.
  GltfError::Kind mismatch = GltfError::unsupported;
};

const tinygltf::Accessor& checked_accessor(const tinygltf::Model& model, int index, const std::string& what) {
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size())
    invalid(what, "accessor " + std::to_string(index) + " does not exist (" + std::to_string(model.accessors.size()) +
                      " accessors)");
  const tinygltf::Accessor& accessor = model.accessors[static_cast<size_t>(index)];
  if (accessor.count < 1) invalid(what, "accessor " + std::to_string(index) + " has count 0");
  return accessor;
}

// The shape of an accessor's elements.
struct ElementLayout {
  size_t components;       // per element
  size_t component_bytes;  // per component
  size_t element_bytes;    // components × component_bytes
  size_t count;            // elements
};

// The accessor's type, component type and normalisation against `spec`.
void check_accessor_format(const tinygltf::Accessor& accessor, const AccessorSpec& spec, const std::string& where) {
  const bool type_ok = accessor.type == spec.type;
  const bool component_ok = std::find(spec.component_types.begin(), spec.component_types.end(),
                                      accessor.componentType) != spec.component_types.end();
  if (!type_ok || !component_ok) {
    std::string expected;
    for (int c : spec.component_types) expected += (expected.empty() ? "" : "/") + std::string(component_name(c));
    throw GltfError(spec.mismatch, where + " is " + component_name(accessor.componentType) + " " +
                                       type_name(accessor.type) + "; expected " + expected + " " +
                                       type_name(spec.type));
  }
  const bool is_float = accessor.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT;
  if (is_float && accessor.normalized) invalid(where, "FLOAT components cannot be normalized");
  if (!is_float && spec.integers_must_be_normalized && !accessor.normalized)
    throw GltfError(GltfError::unsupported, where + " has integer components that are not normalized");
  if (!is_float && spec.integers_must_not_be_normalized && accessor.normalized)
    invalid(where, "integer indices cannot be normalized");
}

// The accessor's stored elements (its bufferView, checked to hold them), or zeros when it has
// none.
std::vector<double> read_stored(const tinygltf::Model& model, const tinygltf::Accessor& accessor,
                                const ElementLayout& layout, const std::string& where) {
  const size_t count = layout.count, components = layout.components, element_bytes = layout.element_bytes;
  std::vector<double> values;
  if (accessor.bufferView < 0) {
    // Zeros (plus sparse values): no stored data bounds the count, so cap it at a size no
    // real skinned mesh reaches rather than attempt an absurd allocation.
    constexpr size_t kMaxImplicitElements = size_t{1} << 26;
    if (count > kMaxImplicitElements)
      throw GltfError(GltfError::unsupported, where + " has no bufferView and declares " + std::to_string(count) +
                                                  " elements (more than 2^26)");
    values.assign(count * components, 0.0);
    return values;
  }
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
          decode_component(element + c * layout.component_bytes, accessor.componentType, accessor.normalized);
  }
  return values;
}

// The accessor's sparse substitutions into `values`, indices and values checked.
void apply_sparse(const tinygltf::Model& model, const tinygltf::Accessor& accessor, const ElementLayout& layout,
                  const std::string& where, std::vector<double>& values) {
  const size_t count = layout.count, components = layout.components, element_bytes = layout.element_bytes;
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
      values[static_cast<size_t>(target) * components + c] = decode_component(
          substitutes + s * element_bytes + c * layout.component_bytes, accessor.componentType, accessor.normalized);
  }
}

// Decodes accessor `index` into count × components doubles, validating everything the
// header promises.
std::vector<double> read_components(const tinygltf::Model& model, int index, const AccessorSpec& spec,
                                    const std::string& what) {
  const tinygltf::Accessor& accessor = checked_accessor(model, index, what);
  const std::string where = what + ": accessor " + std::to_string(index);
  check_accessor_format(accessor, spec, where);
  ElementLayout layout;
  layout.components = static_cast<size_t>(tinygltf::GetNumComponentsInType(static_cast<uint32_t>(accessor.type)));
  layout.component_bytes = static_cast<size_t>(component_size(accessor.componentType));
  layout.element_bytes = layout.components * layout.component_bytes;
  layout.count = accessor.count;
  // Bounded by the data that can actually be addressed, before any multiplication.
  if (layout.count > std::numeric_limits<uint32_t>::max())
    throw GltfError(GltfError::unsupported,
                    where + " has " + std::to_string(layout.count) + " elements (more than 2^32-1)");
  std::vector<double> values = read_stored(model, accessor, layout, where);
  if (accessor.sparse.isSparse) apply_sparse(model, accessor, layout, where, values);
  return values;
}

void check_finite(const std::vector<double>& values, size_t components, const std::string& what, int accessor) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i]))
      invalid(what, "accessor " + std::to_string(accessor) + " element " + std::to_string(i / components) +
                        " has a non-finite value");
  }
}

AccessorSpec float_spec(int type) { return {type, {TINYGLTF_COMPONENT_TYPE_FLOAT}, false, false}; }

}  // namespace

size_t accessor_count(const tinygltf::Model& model, int accessor, const std::string& what) {
  return checked_accessor(model, accessor, what).count;
}

std::vector<glm::dvec3> read_vec3(const tinygltf::Model& model, int accessor, const std::string& what) {
  const std::vector<double> v = read_components(model, accessor, float_spec(TINYGLTF_TYPE_VEC3), what);
  check_finite(v, 3, what, accessor);
  std::vector<glm::dvec3> out(v.size() / 3);
  for (size_t i = 0; i < out.size(); ++i) out[i] = glm::dvec3(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
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
      for (int row = 0; row < 4; ++row)
        out[i][column][row] = v[16 * i + 4 * static_cast<size_t>(column) + static_cast<size_t>(row)];
  return out;
}

std::vector<glm::uvec4> read_joints(const tinygltf::Model& model, int accessor, const std::string& what) {
  const AccessorSpec spec{
      TINYGLTF_TYPE_VEC4, {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT}, false, true};
  const std::vector<double> v = read_components(model, accessor, spec, what);
  std::vector<glm::uvec4> out(v.size() / 4);
  for (size_t i = 0; i < out.size(); ++i)
    for (int c = 0; c < 4; ++c) out[i][c] = static_cast<uint32_t>(v[4 * i + static_cast<size_t>(c)]);
  return out;
}

std::vector<glm::dvec4> read_weights(const tinygltf::Model& model, int accessor, const std::string& what) {
  const AccessorSpec spec{
      TINYGLTF_TYPE_VEC4,
      {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
      true,
      false};
  const std::vector<double> v = read_components(model, accessor, spec, what);
  std::vector<glm::dvec4> out(v.size() / 4);
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = glm::dvec4(v[4 * i], v[4 * i + 1], v[4 * i + 2], v[4 * i + 3]);
    if (out[i].x < 0 || out[i].y < 0 || out[i].z < 0 || out[i].w < 0)
      invalid(what,
              "accessor " + std::to_string(accessor) + " element " + std::to_string(i) + " has a negative weight");
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

std::vector<float> read_unit_scalars(const tinygltf::Model& model, int accessor, const std::string& what) {
  const std::vector<double> v = read_values(
      model, accessor, TINYGLTF_TYPE_SCALAR,
      {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
      what);
  std::vector<float> out(v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    if (!(v[i] >= 0.0 && v[i] <= 1.0))
      invalid(what, "accessor " + std::to_string(accessor) + " element " + std::to_string(i) + " is " +
                        std::to_string(v[i]) + ", outside [0, 1]");
    out[i] = static_cast<float>(v[i]);
  }
  return out;
}

std::vector<double> read_values(const tinygltf::Model& model, int accessor, int type,
                                const std::vector<int>& component_types, const std::string& what) {
  const std::vector<double> values = read_components(model, accessor, {type, component_types, true, false}, what);
  check_finite(values, static_cast<size_t>(tinygltf::GetNumComponentsInType(static_cast<uint32_t>(type))), what,
               accessor);
  return values;
}

std::vector<double> read_exact(const tinygltf::Model& model, int accessor, int component_type, int components,
                               const std::string& what) {
  static constexpr int kTypes[] = {TINYGLTF_TYPE_SCALAR, TINYGLTF_TYPE_VEC2, TINYGLTF_TYPE_VEC3, TINYGLTF_TYPE_VEC4};
  if (components < 1 || components > 4) throw std::invalid_argument("read_exact: components must be 1 to 4");
  AccessorSpec spec{kTypes[components - 1], {component_type}, false, true};
  spec.mismatch = GltfError::invalid;
  std::vector<double> values = read_components(model, accessor, spec, what);
  if (component_type == TINYGLTF_COMPONENT_TYPE_FLOAT)
    check_finite(values, static_cast<size_t>(components), what, accessor);
  return values;
}

}  // namespace skelform::gltf
