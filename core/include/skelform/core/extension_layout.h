// The single definition of the SKELFORM_skeletal_deformation glTF extension's layout.
//
// The baker's writer and the runtime's reader both include this header, so the names,
// component types and shapes of the stored arrays cannot drift apart. The human-readable
// specification is docs/SKELFORM_skeletal_deformation.md (JSON schema beside it).
//
// Versioning: a reader accepts any minor version of its major version (minor versions only
// add optional members) and refuses a newer major version.
#pragma once

#include <cstddef>
#include <cstdint>

namespace skelform::format {

inline constexpr char kExtensionName[] = "SKELFORM_skeletal_deformation";
// Version 2: the refined mesh's vertex normals are the control mesh's normal sums refined by the
// stencils (dss_frame.h), where version 1 took the refined triangles' normals. The bindings of
// a version 1 asset belong to the other normal field, so a version 2 reader refuses it.
// Version 2.1: each control normal sum is first turned halfway onto the medial direction M − S
// (dss_frame.h medial_normal_sums). At rest the two rules give the same field to float
// rounding (S = M − d·N with N the area-weighted normal), so 2.0 and 2.1 data are read alike.
// Version 2.2: adds the optional per-vertex skelform weight (kSkelformWeight); a 2.0 or 2.1
// asset without it gets the weight derived from the skin, the rule the baker uses.
inline constexpr int kMajorVersion = 2;
inline constexpr int kMinorVersion = 2;

// glTF accessor component types used by the extension.
enum class Component : int {
  unsigned_short = 5123,
  unsigned_int = 5125,
  float32 = 5126,
};

// What an array's element count must equal; the reader checks every array against it.
enum class CountOf {
  control_vertices,   // control mesh vertex count (= skeletal mesh vertex count)
  control_triangles,  // control mesh triangle count (x3 indices)
  refined_vertices,   // vertices of the level-k subdivided control mesh
  refined_vertices_plus_one,
  refined_triangles,  // triangles of the level-k subdivided control mesh (x3 indices)
  stencil_entries,    // total number of stencil (index, weight) pairs
  dense_vertices,     // original glTF vertices of the deformable's primitives, concatenated
};

// One stored array: `group` is the member object of the deformable holding it, `name` the
// member naming its accessor index.
struct ArraySpec {
  const char* group;
  const char* name;
  Component component;
  int components;  // 1 = SCALAR, 2 = VEC2, 3 = VEC3, 4 = VEC4
  CountOf count;
  int indices_per_item;  // 3 for triangle index arrays (count = items x 3), else 1
};

// Arrays of one deformable, in the order the writer stores them. Joint/weight sets are
// listed separately (there may be several: kJointSet / kWeightSet).
inline constexpr ArraySpec kArrays[] = {
    // The decimated control mesh M after the tangent flow, its rest normals N, and its
    // Voronoi-based skeletal mesh S with medial radii d: M = S + d·N (paper eq. (1)).
    {"control", "positions", Component::float32, 3, CountOf::control_vertices, 1},
    {"control", "normals", Component::float32, 3, CountOf::control_vertices, 1},
    {"control", "indices", Component::unsigned_int, 1, CountOf::control_triangles, 3},
    {"control", "skeletalPositions", Component::float32, 3, CountOf::control_vertices, 1},
    {"control", "medialRadius", Component::float32, 1, CountOf::control_vertices, 1},
    // Loop subdivision straight from control vertices to level k: refined vertex v is
    // sum over s in [offsets[v], offsets[v+1]) of weights[s] * control[indices[s]].
    {"subdivision", "stencilOffsets", Component::unsigned_int, 1, CountOf::refined_vertices_plus_one, 1},
    {"subdivision", "stencilIndices", Component::unsigned_int, 1, CountOf::stencil_entries, 1},
    {"subdivision", "stencilWeights", Component::float32, 1, CountOf::stencil_entries, 1},
    {"subdivision", "indices", Component::unsigned_int, 1, CountOf::refined_triangles, 3},
    // DSS binding of every original vertex: refined triangle, barycentrics (b1, b2) with
    // b0 = 1 - b1 - b2, scalar displacement h along the interpolated unit normal, and the
    // tangential residual (components along the frame's tangent and bitangent).
    {"binding", "triangle", Component::unsigned_int, 1, CountOf::dense_vertices, 1},
    {"binding", "barycentric", Component::float32, 2, CountOf::dense_vertices, 1},
    {"binding", "displacement", Component::float32, 1, CountOf::dense_vertices, 1},
    {"binding", "residual", Component::float32, 2, CountOf::dense_vertices, 1},
};
inline constexpr size_t kArrayCount = sizeof(kArrays) / sizeof(kArrays[0]);

// Skin weights of the control (= skeletal) vertices, in sets of four like glTF's
// JOINTS_n/WEIGHTS_n: control.joints[i] and control.weights[i] are arrays of accessors.
inline constexpr ArraySpec kJointSet = {"control", "joints", Component::unsigned_short, 4, CountOf::control_vertices,
                                        1};
inline constexpr ArraySpec kWeightSet = {"control", "weights", Component::float32, 4, CountOf::control_vertices, 1};

// The skelform weight of every dense vertex (core/include/skelform/core/skelform_weight.h), in [0, 1]:
// the output is LBS + weight·(skelform − LBS). Optional (version 2.2); the reader derives it
// from the skin when it is absent.
inline constexpr ArraySpec kSkelformWeight = {"blend", "skelformWeight",        Component::float32,
                                              1,       CountOf::dense_vertices, 1};
// The vertex attribute through which an artist overrides the skelform weight, per primitive:
// SCALAR FLOAT or normalized UNSIGNED_BYTE / UNSIGNED_SHORT, every value in [0, 1]. glTF names
// application-specific attributes with a leading underscore.
inline constexpr char kSkelformWeightAttribute[] = "_SKELFORM_WEIGHT";

// Scalar members of a deformable (JSON integers).
inline constexpr char kMesh[] = "mesh";                // glTF mesh index
inline constexpr char kNode[] = "node";                // the skinned node instancing it (or -1 absent)
inline constexpr char kSkin[] = "skin";                // glTF skin index (absent: unskinned, handles only)
inline constexpr char kPrimitives[] = "primitives";    // primitive indices of the mesh, binding order
inline constexpr char kVertexCount[] = "vertexCount";  // dense vertices, all primitives
inline constexpr char kSubdivisionLevel[] = "level";   // in "subdivision"
inline constexpr char kDeformables[] = "deformables";  // root member: array of deformables
inline constexpr char kMajorVersionKey[] = "majorVersion";
inline constexpr char kMinorVersionKey[] = "minorVersion";

}  // namespace skelform::format
