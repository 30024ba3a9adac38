// Mesh input: glTF 2.0 (.gltf/.glb), OBJ, PLY (ASCII and binary) and OFF.
//
// Every loader validates before it hands data on: out-of-range indices, NaN/Inf positions,
// empty meshes and non-triangle primitives raise skelform::bake::Error with a one-line message
// naming the file and the offending element. Degenerate faces, duplicate faces, non-manifold
// edges, open boundaries and several components are valid input and are kept as they are
// (welding deals with them).
#pragma once

#include "skelform/bake/mesh.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace skelform::bake {

// Where a run of original vertices came from.
struct InputPrimitive {
  int mesh = -1;                // glTF mesh index; -1 for OBJ/PLY/OFF
  int primitive = -1;           // glTF primitive index within the mesh; -1 for OBJ/PLY/OFF
  int node = -1;                // first glTF node instancing the mesh (the skinned node); -1 if none
  int skin = -1;                // glTF skin of that node; -1 if unskinned
  uint32_t first_vertex = 0;    // offset of this primitive's vertices in InputMesh::positions
  uint32_t vertex_count = 0;    // number of vertices of this primitive (glTF POSITION count)
  uint32_t first_triangle = 0;  // offset of this primitive's triangles in InputMesh::triangles
  uint32_t triangle_count = 0;
  bool indexed = false;  // the glTF primitive has an index buffer
};

// All original vertices of every loaded primitive, concatenated in file order (mesh order,
// then primitive order). Triangle indices refer to this concatenated array.
struct InputMesh {
  std::string source_path;
  std::vector<Vec3> positions;
  std::vector<Triangle> triangles;
  std::vector<InputPrimitive> primitives;
  // glTF skin influences of each original vertex in sets of four (JOINTS_n / WEIGHTS_n, n in
  // file order); empty for unskinned input. Every set has positions.size() entries; a
  // primitive with fewer sets than another gets zero weights in the sets it lacks.
  std::vector<std::vector<std::array<uint16_t, 4>>> joint_sets;
  std::vector<std::vector<std::array<float, 4>>> weight_sets;
  // The artist's skelform weight (the _SKELFORM_WEIGHT attribute, extension_layout.h) of
  // each original vertex, -1 where its primitive has none; empty when no primitive has it.
  std::vector<float> skelform_weight_override;
  // Exporter defects the loader repaired (core/include/skelform/core/skin_repair.h), one line each, naming
  // the file, primitive, accessors and elements: the CLI prints them as warnings.
  std::vector<std::string> warnings;
};

// Limits of the input stage, the same for every format, so that no file makes the baker read
// or allocate without bound. Each loader checks them as it goes, before memory grows past
// them; an input beyond one is refused as unsupported, with the advice to decimate or split
// the mesh first.
//
// The largest file read: a regular file's size is checked before reading; anything else (a
// pipe, a device such as /dev/zero) is read until it passes the limit.
inline constexpr uint64_t kMaxInputFileBytes = uint64_t{1} << 30;  // 1 GiB
// The most triangles, after polygons, strips and fans are triangulated: 2^23 = 8,388,608,
// about four times the largest skinned meshes the baker is tested on.
inline constexpr size_t kMaxInputTriangles = size_t{1} << 23;
// The most vertices: three per triangle, as in a mesh that shares none.
inline constexpr size_t kMaxInputVertices = 3 * kMaxInputTriangles;
// The most JOINTS_n/WEIGHTS_n sets of one glTF primitive (64 influences per vertex); the
// runtime refuses assets with more.
inline constexpr size_t kMaxInfluenceSets = 16;

struct LoadOptions {
  // glTF: also load triangle primitives of meshes no skinned node uses. OBJ/PLY/OFF are
  // always loaded whole.
  bool all_meshes = false;
};

// Loads by file extension (case-insensitive): .gltf, .glb, .obj, .ply, .off.
// Throws Error on unreadable, malformed or invalid input, or input beyond the limits above;
// never returns an empty mesh.
InputMesh load_mesh(const std::string& path, const LoadOptions& options = {});

// The bytes of the file at `path` as load_mesh reads them: at most kMaxInputFileBytes, and a
// .glb (by its extension) no further than the length its header declares. Throws
// Error(io) when it cannot be opened or read, Error(unsupported) beyond the limit.
std::vector<unsigned char> read_input_file(const std::string& path);

// The same loaders on bytes already in memory; `name` is used in messages and, for .gltf,
// as the base for resolving external buffer URIs. `extension` selects the format (".obj", ...).
InputMesh load_mesh_from_memory(const std::vector<unsigned char>& bytes, const std::string& extension,
                                const std::string& name, const LoadOptions& options = {});

}  // namespace skelform::bake
