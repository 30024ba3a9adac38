// Validated reading of glTF 2.0 data through tinygltf, for the mesh loader and the glTF
// baker. A thin layer over the runtime's reader (core/include/skelform/core/gltf_read.h), so the baker and
// the runtime check every accessor the same way; this layer only turns its errors into
// skelform::bake::Error of the same kind and message.
//
// tinygltf parses the JSON and resolves buffers but does not check that accessors fit their
// bufferViews, that bufferViews fit their buffers, that component types match their semantic,
// or that values are finite. These readers do, and throw skelform::bake::Error
// (ErrorKind::invalid_input, or ErrorKind::unsupported for valid data the baker cannot use)
// with a one-line message starting with `what`, e.g. "Fox.glb: mesh 0 primitive 0 POSITION".
//
// Every reader: checks the accessor index, its type and component type, count >= 1, the
// byte range (accessor.byteOffset + (count-1)*stride + element size within the bufferView,
// the bufferView within its buffer, the stride within [element size, 252]), applies sparse
// substitution after validating it (indices strictly increasing and < count, both sparse
// views in range), and returns the values in accessor order. An accessor without a
// bufferView reads as zeros (then sparse), as the specification says.
//
// The header needs only a forward declaration of tinygltf::Model; include <tiny_gltf.h>
// (the Debian shared library, target TinyGLTF::TinyGLTF) where the model is built.
#pragma once

#include "skelform/bake/mesh.h"

#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace tinygltf {
class Model;
}

namespace skelform::bake::gltf {

// The deepest nesting of JSON arrays and objects a glTF document may have; deeper documents
// are refused as invalid before tinygltf parses them (its parser recurses once per level).
// The runtime's reader enforces it; this is its value for the baker's callers.
inline constexpr size_t kMaxJsonNesting = 64;

// Parses a .gltf (binary = false) or .glb (binary = true) held in `bytes` into `model`.
// `name` appears in messages and, for .gltf, its directory resolves external buffer URIs.
// Images are not decoded (only geometry and skins matter to the baker). The GLB container
// (header, chunk lengths) and the JSON nesting are checked before tinygltf sees them, so
// truncated or too deeply nested files fail cleanly; any standard exception tinygltf throws
// on inconsistent data is an invalid_input Error naming the file. Files that require a
// geometry-compression extension (Draco, meshopt, mesh quantization) are refused as
// unsupported.
void parse_model(const std::vector<unsigned char>& bytes, bool binary, const std::string& name, tinygltf::Model& model);

// The number of elements of accessor `accessor`, after checking the index and count >= 1.
size_t accessor_count(const tinygltf::Model& model, int accessor, const std::string& what);

// FLOAT VEC3 (POSITION, NORMAL), every component finite.
std::vector<Vec3> read_vec3(const tinygltf::Model& model, int accessor, const std::string& what);

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

}  // namespace skelform::bake::gltf
