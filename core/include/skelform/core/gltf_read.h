// Validated reading of glTF 2.0 data through tinygltf: the runtime's asset loader and the
// baker (bake/src/input_gltf.cpp, which turns GltfError into its own Error) check every
// accessor the same way. Part of skelform's core (core/CMakeLists.txt): compiled into the
// runtime with hidden symbols, never seen through the C API.
//
// tinygltf parses the JSON and resolves buffers but does not check that accessors fit their
// bufferViews, that bufferViews fit their buffers, that component types match their
// semantic, or that values are finite. These readers do, and throw GltfError (kind invalid,
// or unsupported for valid data the caller cannot use) with a one-line message starting
// with `what`, e.g. "Fox.glb: mesh 0 primitive 0 POSITION".
//
// Every reader: checks the accessor index, its type and component type, count >= 1, the
// byte range (accessor.byteOffset + (count-1)*stride + element size within the bufferView,
// the bufferView within its buffer, the stride within [element size, 252]), applies sparse
// substitution after validating it (indices strictly increasing and < count, both sparse
// views in range), and returns the values in accessor order. An accessor without a
// bufferView reads as zeros (then sparse), as the specification says. Result memory comes
// from the default heap: these are load-time temporaries.
//
// The header needs only a forward declaration of tinygltf::Model; include <tiny_gltf.h>
// (the Debian shared library, target TinyGLTF::TinyGLTF) where the model is built.
#pragma once

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace tinygltf {
class Model;
}

namespace skelform::gltf {

// The one exception type of this reader. The message is one line, ready for a user.
class GltfError : public std::runtime_error {
 public:
  enum Kind {
    invalid,      // malformed file or invalid data (truncation, indices, NaN, ...)
    unsupported,  // valid glTF the reader does not handle (compression, wrong accessor types)
    io,           // a file the asset references could not be read
  };
  GltfError(Kind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  Kind kind() const noexcept { return kind_; }

 private:
  Kind kind_;
};

namespace detail {

// What gltf_read.cpp and gltf_accessors.cpp share: an invalid-data error naming `what`, and a
// little-endian 32-bit read.
[[noreturn]] inline void invalid(const std::string& what, const std::string& problem) {
  throw GltfError(GltfError::invalid, what + ": " + problem);
}
inline uint32_t read_u32_le(const unsigned char* p) {
  return uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24;
}

}  // namespace detail

// Where external files (buffer and image URIs that are not data URIs) may come from.
enum class ExternalFiles {
  // Read them relative to the directory of `name`. A buffer that cannot be read makes the
  // parse fail as invalid (the baker's long-standing behaviour).
  read,
  // As `read`, but a buffer that cannot be read is an io error.
  read_io_errors,
  // Never touch the file system (loading from memory): a buffer with an external URI is
  // unsupported. Images are never decoded, so their URIs do not matter.
  refuse,
};

// True when `bytes` start with the GLB magic "glTF": the container to parse them as.
bool is_glb(const unsigned char* bytes, size_t size);

// The deepest nesting of JSON arrays and objects a glTF document may have. tinygltf converts
// the JSON into its Value tree by recursion, one stack frame per level, so a document nested
// thousands deep (valid JSON, a few bytes per level) would overflow the stack. glTF's own
// schema needs 6 levels; the rest is headroom for extras and extensions.
inline constexpr size_t kMaxJsonNesting = 64;

// Throws GltfError(invalid), its message starting with `name`, when the JSON text `json` nests
// arrays and objects deeper than kMaxJsonNesting. One linear pass counting brackets outside
// strings; malformed JSON is left to the parser to report.
void check_json_nesting(const unsigned char* json, size_t size, const std::string& name);

// The checks parse_model makes before tinygltf sees `bytes`, for a caller that runs tinygltf
// itself: for a .glb (binary = true) the container (header, chunk lengths), and the JSON
// text's nesting (at most kMaxJsonNesting, counted in one pass outside strings). Throws
// GltfError(invalid), or GltfError(unsupported) for a GLB version other than 2.
void check_before_parsing(const unsigned char* bytes, size_t size, bool binary, const std::string& name);

// Parses a .gltf (binary = false) or .glb (binary = true) held in `bytes` into `model`.
// `name` appears in messages and, for .gltf, its directory resolves external buffer URIs.
// Images are not decoded (only geometry and skins matter). check_before_parsing runs first,
// so truncated files and too deeply nested JSON fail cleanly. Standard exceptions tinygltf
// throws on inconsistent data (it indexes with at() in places) become GltfError(invalid)
// naming the file; std::bad_alloc passes through. Files that require a geometry-compression
// extension (Draco, meshopt, mesh quantization) are refused as unsupported. File paths are
// never shell-expanded (tinygltf's default would).
void parse_model(const unsigned char* bytes, size_t size, bool binary, const std::string& name, tinygltf::Model& model,
                 ExternalFiles external = ExternalFiles::read);

// The number of elements of accessor `accessor`, after checking the index and count >= 1.
size_t accessor_count(const tinygltf::Model& model, int accessor, const std::string& what);

// FLOAT VEC3 (POSITION, NORMAL), every component finite.
std::vector<glm::dvec3> read_vec3(const tinygltf::Model& model, int accessor, const std::string& what);

// FLOAT VEC4 (TANGENT: xyz direction, w = handedness ±1), every component finite.
std::vector<glm::dvec4> read_vec4(const tinygltf::Model& model, int accessor, const std::string& what);

// FLOAT MAT4 (inverseBindMatrices), column-major as stored, every component finite.
std::vector<glm::dmat4> read_mat4(const tinygltf::Model& model, int accessor, const std::string& what);

// JOINTS_n: VEC4 UNSIGNED_BYTE or UNSIGNED_SHORT, not normalized. Joint indices index the
// skin's `joints` array; the caller checks them against its size.
std::vector<glm::uvec4> read_joints(const tinygltf::Model& model, int accessor, const std::string& what);

// WEIGHTS_n: VEC4 FLOAT, or normalized UNSIGNED_BYTE / UNSIGNED_SHORT mapped to [0, 1].
// No finite weight negative. Non-finite weights are returned as they are, and the sum is not
// checked: the caller repairs both (core/include/skelform/core/skin_repair.h).
std::vector<glm::dvec4> read_weights(const tinygltf::Model& model, int accessor, const std::string& what);

// A per-vertex weight in [0, 1] (the _SKELFORM_WEIGHT attribute): SCALAR FLOAT, or normalized
// UNSIGNED_BYTE / UNSIGNED_SHORT; every value finite and within [0, 1].
std::vector<float> read_unit_scalars(const tinygltf::Model& model, int accessor, const std::string& what);

// Primitive indices: SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT, not normalized,
// each < vertex_count.
std::vector<uint32_t> read_indices(const tinygltf::Model& model, int accessor, size_t vertex_count,
                                   const std::string& what);

// Any other numeric data (animation sampler input and output, the samples' helper): `type`
// (TINYGLTF_TYPE_*) with a component type among `component_types`, FLOAT or a normalized
// integer type (mapped by the specification's formulas; integer components that are not
// normalized are unsupported), every value finite; count × components doubles.
std::vector<double> read_values(const tinygltf::Model& model, int accessor, int type,
                                const std::vector<int>& component_types, const std::string& what);

// An array whose layout a format fixes exactly (the SKELFORM extension's arrays):
// `component_type` (a TINYGLTF_COMPONENT_TYPE_*), `components` per element (1-4, SCALAR to
// VEC4), not normalized; FLOAT values finite. Any other layout is invalid data, not
// unsupported: the format allows no alternative. Values are returned as doubles (exact for
// FLOAT and for integers below 2^53).
std::vector<double> read_exact(const tinygltf::Model& model, int accessor, int component_type, int components,
                               const std::string& what);

}  // namespace skelform::gltf
