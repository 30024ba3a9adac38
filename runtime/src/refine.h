// Runtime step 4 (DESIGN.md), first half: Loop refinement of the (deformed) control mesh and
// of its normals with the baked stencils, and the DSS frame of each dense
// vertex's bound point. asset_derive.cpp runs these once on the rest control mesh (to derive
// Deformable::rest_frames); the evaluation runs them every frame on the faired control mesh.
//
// Same arithmetic as the baker (bake/src/subdivision.cpp apply_stencils and dss_frame.h), in
// float and in the same order, so the rest pose reproduces the bake bit for bit.
//
// Allocation-free, exception-free, no state: safe in the per-frame path and on any thread.
// Every function trusts the asset's validation (asset_load.cpp): indices in range, counts as
// extension_layout.h says.
#pragma once

#include "asset.h"
#include "skelform/core/dss_frame.h"

#include <glm/vec3.hpp>

#include <cstdint>

namespace skelform::runtime {

// The refined surface of `control` (control_vertex_count positions): its positions and its
// unit vertex normals (dss_frame.h, extension version 2), in one pass over the stencils.
//  - Refined vertex v = sum of stencil_weights[s] * control[stencil_indices[s]] over
//    s in [stencil_offsets[v], stencil_offsets[v+1]), each sum started from zero and taken in
//    stencil order (spec "Stencil evaluation"), read from the grouped copy of the stencils
//    (Deformable::stencil_group_rows: same entries, same order per row, kStencilLanes rows
//    summed side by side).
//  - Its normal: the same sum over the control mesh's area-weighted normal sums (computed
//    into `control_normal_sums`, control_vertex_count entries of scratch), normalised as the
//    rows are stored (dss::normalise_or_zero's bits: zero where the sum vanishes).
// The baker's bits (bake/src/subdivision.cpp apply_stencils, refined_normals), for the named
// refined vertices (Deformable::named_refined_count, the first ones), the only ones computed:
// the others are left as they are. `refined` and `refined_normals` hold named_refined_count
// entries; no two buffers may alias. `control` and `control_normal_sums` are read a whole
// 16-byte vector at a time (vec3_sse.h PaddedVec3Reader): each holds kVec3ReadPadding
// (memory.h) readable vectors past its control_vertex_count positions.
// With `skeletal` (control_vertex_count positions, S indexed like `control`), each control
// normal sum is first turned onto the medial direction control − skeletal
// (dss::medial_normal_sums: extension version 2.1); null leaves the area-weighted sums.
// `lanes`: null, or 8 × control_vertex_count floats of scratch: where the CPU has AVX2 the walk
// then copies each control vertex's position and normal sum there side by side and reads both
// as one 32-byte vector (the same sums, bit for bit).
void refine_surface(const Deformable& deformable, const glm::vec3* control, const glm::vec3* skeletal,
                    glm::vec3* control_normal_sums, glm::vec3* refined, glm::vec3* refined_normals,
                    float* lanes = nullptr);

// refine_surface of the rest pose (Deformable::control_positions over skeletal_positions),
// from padded copies it makes itself: the loader's rest evaluation, once per load (the
// asset's own arrays stay exactly control_vertex_count long).
void refine_rest_surface(const Deformable& deformable, glm::vec3* refined, glm::vec3* refined_normals);

// dss::add_face_normals, to the bit (SSE2 where the compiler targets it, refine_normals.cpp):
// adds each triangle's (p1 - p0) × (p2 - p0) to `sums` at its three corners, in triangle order.
// `positions` holds vertex_count entries, every index is below it.
void add_face_normals(const glm::vec3* positions, size_t vertex_count, const uint32_t* indices, size_t triangle_count,
                      glm::vec3* sums);

// dss::medial_normal_sums, to the bit (SSE2 where the compiler targets it, refine_normals.cpp):
// turns each of the `vertex_count` normal sums halfway onto positions − skeletal.
void medial_normal_sums(const glm::vec3* positions, const glm::vec3* skeletal, size_t vertex_count, glm::vec3* sums);

// Divides each of the `count` vectors by its length, in place, block-wise and branch-free so
// the square roots and divisions vectorise (correctly rounded per lane: the bits of the scalar
// v / length). A vector of length ≤ 1e-30 becomes +0 (dss::normalise_or_zero's rule).
// With `usable` (count entries): 1 where the length was > 1e-30 and finite, else 0, for a
// caller with a fallback of its own.
void normalise_vectors(glm::vec3* vectors, size_t count, uint8_t* usable = nullptr);

// The DSS frame (point q(b), normal n(b), tangent, bitangent) of dense vertex `vertex`'s bound
// point on the refined mesh given by `refined` positions and their `normals`: dss_frame.h
// exactly, fallbacks included. (displace.cpp evaluates the same formula block-wise and falls
// back to this for the vertices that need a fallback.) Needs Deformable::binding_corners.
inline dss::SurfaceFrame bound_frame(const Deformable& deformable, const glm::vec3* refined, const glm::vec3* normals,
                                     uint32_t vertex) {
  const uint32_t* corner = deformable.binding_corners.data() + 3 * size_t{vertex};
  const glm::vec2 b = deformable.binding_barycentric[vertex];
  return dss::surface_frame(refined[corner[0]], refined[corner[1]], refined[corner[2]], normals[corner[0]],
                            normals[corner[1]], normals[corner[2]], b.x, b.y);
}

}  // namespace skelform::runtime
