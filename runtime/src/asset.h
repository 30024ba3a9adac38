// The loaded, validated, immutable asset (sf_asset): everything an evaluation reads. Built by
// asset_load.cpp from a baked glTF; read by every runtime stage. Arrays are flat and indexed
// by the conventions below, so the hot loops read them without indirection.
#pragma once

#include "contact.h"
#include "fair.h"
#include "joint_arcs.h"
#include "memory.h"
#include "skelform/skelform.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstdint>

namespace skelform::runtime {

struct PrimitiveRecord {
  int32_t primitive = -1;     // index in the glTF mesh
  uint32_t first_vertex = 0;  // offset among the deformable's dense vertices
  uint32_t vertex_count = 0;
  uint32_t first_triangle = 0;  // offset in Deformable::dense_triangles (in triangles)
  uint32_t triangle_count = 0;
  bool has_normals = false;
  bool has_tangents = false;
};

// Stencil rows refine_surface sums side by side (Deformable::stencil_group_rows): enough
// independent sums to hide the latency of each one's additions.
constexpr uint32_t kStencilLanes = 4;

// One baked skinned mesh. "Dense" = the original glTF vertices of all its primitives,
// concatenated in primitive order (the binding order of the extension).
struct Deformable {
  explicit Deformable(const AllocatorRef& a)
      : primitives(a),
        rest_positions(a),
        rest_normals(a),
        rest_tangents(a),
        dense_triangles(a),
        dense_joints(a),
        dense_weights(a),
        skelform_weight(a),
        control_positions(a),
        control_normals(a),
        control_indices(a),
        skeletal_positions(a),
        medial_radius(a),
        control_joints(a),
        control_weights(a),
        joint_usage(a),
        control_rigid(a),
        stencil_offsets(a),
        stencil_indices(a),
        stencil_weights(a),
        stencil_group_rows(a),
        stencil_group_lengths(a),
        stencil_group_indices(a),
        stencil_group_weights(a),
        refined_indices(a),
        binding_triangle(a),
        binding_barycentric(a),
        binding_displacement(a),
        binding_residual(a),
        binding_corners(a),
        rest_normal_coords(a),
        rest_tangent_coords(a),
        handle_control_vertex(a),
        arc_joints(a),
        arc_vertices(a),
        fairing_topology(a),
        fairing_rest(a),
        welded(a),
        anchor_vertices(a),
        anchor_hosts(a) {}

  int32_t mesh = -1;
  int32_t node = -1;
  int32_t skin = -1;
  uint32_t joint_count = 0;  // joints of the skin (0 when unskinned)
  Array<PrimitiveRecord> primitives;

  // Dense vertices (from the glTF primitives themselves).
  uint32_t vertex_count = 0;
  Array<glm::vec3> rest_positions;
  Array<glm::vec3> rest_normals;    // authored NORMAL, or area-weighted from dense_triangles
  Array<glm::vec4> rest_tangents;   // authored TANGENT (xyz, w); empty entries where absent
  Array<uint32_t> dense_triangles;  // 3 per triangle, deformable-wide vertex indices
  // Dense skin for the LBS/DQS baselines: `influences` (4 × sets) per vertex, zero-weight
  // slots name joint 0.
  uint32_t influences = 0;
  Array<uint16_t> dense_joints;
  Array<float> dense_weights;
  // The skelform weight of every dense vertex (docs/SKELFORM_skeletal_deformation.md): the
  // output is LBS + w·(skelform − LBS), so 0 is exactly LBS (rigid parts), 1 is skelform.
  Array<float> skelform_weight;

  // Control mesh M and skeletal mesh S at rest: M = S + d·N (paper eq. (1)).
  uint32_t control_vertex_count = 0;
  Array<glm::vec3> control_positions;
  Array<glm::vec3> control_normals;
  Array<uint32_t> control_indices;  // 3 per triangle
  Array<glm::vec3> skeletal_positions;
  Array<float> medial_radius;
  // Skin of the control/skeletal vertices: `influences` (4 × sets) per vertex, as above.
  Array<uint16_t> control_joints;
  Array<float> control_weights;
  // Per joint: the sum of its weights over the control vertices (derived at load). Weighs each
  // joint's scale in the pose's reference scale (instance.h JointTransforms::scale).
  Array<float> joint_usage;
  // Per control vertex: 1 where its control skin is a single joint's (skelform weight 0): the
  // fairing keeps it where the skin puts it, so the flows bend only the blend zones.
  Array<uint8_t> control_rigid;

  // Loop stencils to level `subdivision_level` and the refined triangles. The loader renumbers
  // the refined vertices (stencil rows and triangle corners alike) in the order the dense
  // vertices' bindings first name them, for locality (asset_derive.cpp
  // renumber_refined_vertices); the numbering is internal, the results are the baked ones.
  uint32_t subdivision_level = 0;
  uint32_t refined_vertex_count = 0;
  // The refined vertices some dense vertex's bound triangle names: after the renumbering, the
  // first named_refined_count. Only those are read (displace.cpp), so only those are refined,
  // grouped and kept per instance; the rest of the refined mesh only carries its triangles.
  uint32_t named_refined_count = 0;
  // The stencils as loaded (CSR): read while the asset loads, then released (empty once
  // sf_asset_load returns); the evaluation reads the grouped copy below.
  Array<uint32_t> stencil_offsets;  // refined_vertex_count + 1
  Array<uint32_t> stencil_indices;
  Array<float> stencil_weights;
  // The named rows of the same stencils grouped for refine_surface (asset_derive.cpp
  // group_stencils): rows of equal length, kStencilLanes per group, groups in order of length.
  // Group g has stencil_group_lengths[g] steps; step s holds entry s of each of its rows, lane by
  // lane (kStencilLanes indices and weights), so a group sums its rows side by side without a
  // data-dependent loop end. The last group of a length may repeat its last row to fill its lanes
  // (the row is then computed twice, to the same bits). Costs what the CSR did plus one row per
  // group (stencil_group_rows) and one length per group.
  Array<uint32_t> stencil_group_rows;     // kStencilLanes refined vertices per group
  Array<uint32_t> stencil_group_lengths;  // entries per row, one per group
  Array<uint32_t> stencil_group_indices;  // control vertices, kStencilLanes per step
  Array<float> stencil_group_weights;     // their weights, likewise
  Array<uint32_t> refined_indices;        // 3 per refined triangle

  // DSS binding of every dense vertex.
  Array<uint32_t> binding_triangle;
  Array<glm::vec2> binding_barycentric;
  Array<float> binding_displacement;
  Array<glm::vec2> binding_residual;

  // Derived at load time, for the per-frame loop of displace.cpp (36 bytes per dense vertex):
  //   binding_corners  the refined vertices of each dense vertex's bound triangle (3 per dense
  //                    vertex: refined_indices of binding_triangle, one indirection less);
  //   rest_normal_coords, rest_tangent_coords  the unit rest normal and tangent direction in
  //                    the rest frame F = (tangent, bitangent, normal) of the bound point
  //                    (dss_frame.h): c = normalize(F^T n_rest). The rotation R = F' F^T to the
  //                    deformed frame F' then carries the normal as R n_rest / |n_rest| = F' c
  //                    = c.x t' + c.y b' + c.z n', no 3x3 product and no renormalisation (F'
  //                    is orthonormal). A rest vector without a direction gets c = (0, 0, 1)
  //                    (normal) or (1, 0, 0) (tangent): the deformed frame's own normal or
  //                    tangent, the fallback the carried vectors have always had (and the
  //                    unused value where a primitive authors no tangents).
  Array<uint32_t> binding_corners;
  Array<glm::vec3> rest_normal_coords;
  Array<glm::vec3> rest_tangent_coords;
  // The control vertex that an original vertex used as a handle moves: the corner with the
  // largest barycentric of its refined triangle, then that refined vertex's heaviest stencil
  // entry.
  Array<uint32_t> handle_control_vertex;

  // Limb joints bent along arcs (joint_arcs.h, SF_SKELETON_ARCS), derived at load time from
  // the glTF skin: the joints, and per control vertex its part (empty: none in this skin).
  Array<ArcJoint> arc_joints;
  Array<ArcVertex> arc_vertices;

  // Fairing (fair.h), derived at load time: the control mesh's connectivity and the flows'
  // rest values. `fairing_supported` is false for a zero-radius (flat) skeleton, where the
  // medial balls are points and the flows have nothing to pull towards.
  FairingTopology fairing_topology;
  FairingRest fairing_rest;
  bool fairing_supported = false;

  // The dense mesh welded by rest position (contact.h), derived at load: the LBS guard
  // (lbs_guard.h) and the contact pass read its triangles.
  ContactMesh welded;
  // Junction anchors (lbs_guard.h anchor_junctions), derived at load (asset_derive.h): the dense
  // vertices skelform may move whose triangle crosses another as modelled, and per such vertex
  // the dense vertex whose skin it follows (its host: a vertex of the other triangle).
  Array<uint32_t> anchor_vertices;
  Array<uint32_t> anchor_hosts;
};

}  // namespace skelform::runtime

// The public opaque type.
struct sf_asset {
  explicit sf_asset(const skelform::runtime::AllocatorRef& a)
      : allocator(a), deformables(skelform::runtime::CallbackAllocator<skelform::runtime::Deformable>(a)) {}
  skelform::runtime::AllocatorRef allocator;
  skelform::runtime::Array<skelform::runtime::Deformable> deformables;
};
