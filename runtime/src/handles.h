// Free-form handle driver (DESIGN.md runtime step 1, driver "handles"; paper sec. 3 and
// Figs. 1, 11, 12, which deform the skeletal mesh with the free-form technique of the paper's
// reference [25], Yoshizawa, Belyaev, Seidel, "A simple approach to interactive free-form
// shape deformations", PG 2002).
//
// The caller moves a few skeletal vertices (handles) and holds others (pinned); every other
// skeletal vertex follows the displacement field δ that minimises the discrete bilaplacian
// energy on the skeletal mesh S:
//     Δ²δ = 0 at free vertices,  δ = given at handles,  δ = 0 at pinned vertices,
// with Δ the uniform (umbrella) Laplacian of the mesh's connectivity (handles.cpp says why not
// the cotangent one). S' = S + δ.
//
// Cost model: handle_system_create builds and factorises the system once per handle set
// (allocates; tens of milliseconds for a few thousand control vertices); handle_system_solve
// never allocates and never calls Eigen, so it is safe in the per-frame path the C API
// promises allocation-free. It either substitutes into the stored factor, or, when the set has
// few distinct handles, sums precomputed per-handle basis fields (the field is linear in the
// handle displacements), whichever costs fewer operations per frame.
//
// Rules beyond the paper:
// - A connected component of the skeletal mesh with no handle and no pinned vertex (and any
//   vertex no triangle uses) does not move: δ = 0 there. Its bilaplacian system would be
//   singular (any constant δ has zero energy); "untouched parts stay at rest" is the choice an
//   animator expects.
// - A control vertex listed several times as a handle (different original vertices of a glTF
//   seam can map to the same control vertex) gets the mean of its displacements. Listed
//   several times as pinned, it is simply pinned.
#pragma once

#include "asset.h"
#include "memory.h"

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>

namespace skelform::runtime {

// The factorised bilaplacian system of one handle set on one deformable's skeletal mesh.
// Opaque: only handles.cpp knows its layout (no Eigen type in it). One system is used by one
// thread at a time (its solve scratch lives inside it), as its sf_instance is.
struct HandleSystem;

// Builds and factorises the system for `d`'s skeletal mesh (Deformable::skeletal_positions,
// triangles Deformable::control_indices over d.control_vertex_count vertices).
// `handle_control` (handle_count entries) and `pinned_control` (pinned_count entries, may be
// NULL when 0) are control-vertex indices. The system's own arrays come from `alloc`; Eigen's
// temporaries during assembly and factorisation use the default heap (freed before return).
// Throws std::invalid_argument for an empty handle set, an index >= control_vertex_count, a
// vertex both handle and pinned, or a deformable whose skeletal arrays are inconsistent;
// std::bad_alloc when memory runs out; std::runtime_error if the factorisation fails
// (cannot happen for a valid mesh: the reduced system is positive definite by construction).
HandleSystem* handle_system_create(const Deformable& d, const uint32_t* handle_control, size_t handle_count,
                                   const uint32_t* pinned_control, size_t pinned_count, const AllocatorRef& alloc);

// How handle_system_solve evaluates the field (see the cost model above).
enum class HandleSolvePath {
  automatic,     // the cheaper of the two per frame (what handle_system_create uses)
  substitution,  // forward/diagonal/backward substitution into the stored LDLᵀ factor
  basis,         // one precomputed field per distinct handle vertex, summed
};

// handle_system_create with the path forced (tests and benchmarks compare the two).
HandleSystem* handle_system_create_with(const Deformable& d, const uint32_t* handle_control, size_t handle_count,
                                        const uint32_t* pinned_control, size_t pinned_count, const AllocatorRef& alloc,
                                        HandleSolvePath path);

// The path a system uses (never `automatic`).
HandleSolvePath handle_system_path(const HandleSystem& s);

// Releases a system made with the same allocator. NULL is ignored.
void handle_system_destroy(HandleSystem* s, const AllocatorRef& alloc);

// The handle_count given at creation: the number of displacements handle_system_solve reads.
size_t handle_system_handle_count(const HandleSystem& s);

// skeletal_out[v] = d.skeletal_positions[v] + δ[v] for v in [0, d.control_vertex_count), where
// δ interpolates handle_displacements[i] (handle_count entries, in creation order) at handle
// i and 0 at the pinned vertices. `d` must be the deformable the system was created for.
// skeletal_out must hold control_vertex_count entries and must not alias the inputs.
// No allocation, no exceptions; double precision inside.
void handle_system_solve(const HandleSystem& s, const Deformable& d, const glm::vec3* handle_displacements,
                         glm::vec3* skeletal_out);

}  // namespace skelform::runtime
