// Limb joints bent along arcs (SF_SKELETON_ARCS, the default skeleton skinning): stage 1's
// deformation of the skeletal mesh, made so that the reconstruction M = S' + d·N cannot fold
// at deep bends.
//
// Why: linear blending turns the skeletal mesh through a joint within the skin's blend zone.
// Where that turn is tighter than the limb's radius (the bend above about zone / (1.5·radius),
// 38 degrees for a blend zone as wide as the radius), the offset surface at distance d runs
// backwards on the inside of the bend and loops over itself before any flow runs, and the
// flows cannot untangle the loop (tests/runtime/fair_test.cpp, the bent capsule). Bending the
// skeleton itself along a circular arc whose radius exceeds the limb's removes the loop at its
// source: the offset of a curve at less than its radius of curvature does not fold. Measured
// on the bent capsule (120 degrees, twisted 150): 170 intersecting pairs after the flows with a
// linearly blended skeleton, 0 with the arc.
//
// The model, per limb joint of the skin (a parent-child pair with a bone on each side), in
// bind space (z along the joint's axis u, J the child's head):
//  - within the zone |z| < F the skeletal mesh follows a centre line that runs straight along
//    the parent's axis, turns along an arc of radius ρ (the fillet of the corner at J), and
//    runs straight along the child's axis; both bones beyond the zone stay rigid, so the zone
//    is compressed along the line (the fillet is shorter than the corner) and its cross
//    sections are scaled up by a smooth bulge k(z) that gives the volume back (mean of k² over
//    the zone = its rest length / its bent length), no further than the arc's radius allows;
//  - the bend (swing) of the child relative to its parent follows the centre line; the twist
//    about the axis and any translation in the joint spread over the zone by a smoothstep in
//    z, as rotations (no candy wrapper, and no shear concentrated in the skin's blend);
//  - ρ = 1.5 and F = 4 limb radii (the mean distance of the joint's blended skeletal vertices
//    from the axis plus their medial radius), F capped so that two joints' zones on one bone
//    do not meet. Past the bend where the fillet no longer fits in the zone, ρ shrinks.
//  - The arc replaces the pair's linear blend gradually, from 0.75 to 1.25 of the bend (or
//    twist) where linear blending starts to fold there (from the skin's blend width, at most
//    60 degrees): milder poses are linear blending, bit for bit.
// The pair's share of a vertex's skin is replaced by this map (composed with the parent's
// joint matrix); its other influences blend linearly as before. Joints whose child branches
// (more than one child joint), bones without length and joints bent more than 60 degrees at
// bind are left to linear blending. Everything is derived at load time from the glTF skin
// (joint hierarchy, inverse bind matrices) and the baked control skin: no file format change.
#pragma once

#include "memory.h"
#include "skin_blend.h"

#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <cstdint>

namespace tinygltf {
class Model;
}

namespace skelform::runtime {

struct Deformable;

constexpr float kArcRadius = 1.5f;  // ρ, in limb radii
constexpr float kArcZone = 4.0f;    // F, in limb radii
constexpr uint32_t kNoArc = 0xffffffffu;

// One joint that bends along an arc, in bind space.
struct ArcJoint {
  uint16_t parent = 0, child = 0;    // skin joint indices
  glm::vec3 center{0.0f};            // J: the child's head at bind
  glm::vec3 axis{0.0f, 0.0f, 1.0f};  // u: unit, from the parent's side through J to the child's
  float zone = 0.0f;                 // F
  float radius = 0.0f;               // ρ
  float limb = 0.0f;                 // the limb's radius at the joint (ρ = 1.5 of it)
  float fold_bend = 0.0f;            // the bend above which linear blending folds here (radians)
  float section = 1.0f;              // the dense surface's distance from the axis over the control
                                     // mesh's, at the joint (the bulge of the control mesh that
                                     // scales the dense cross sections by k is 1 + section·(k − 1))
};

// One control vertex's part in an arc joint (kNoArc: none, plain blending).
struct ArcVertex {
  uint32_t joint = kNoArc;
  float axial = 0.0f;  // (S − J)·u at bind
  float share = 0.0f;  // w_parent + w_child: the part of its skin the arc replaces
};

// What an arc joint does in the current pose (from its two joint matrices).
struct ArcPose {
  JointAffine parent;            // A_P, the parent's joint matrix
  glm::vec3 bend_axis{1, 0, 0};  // e ⟂ u: the swing's axis
  glm::vec3 inward{0, 1, 0};     // e × u: the direction the arc turns to
  glm::vec3 bent_axis{0, 0, 1};  // R_e(θ)·u: the child's side of the centre line
  glm::vec3 translation{0.0f};   // the joint's own translation (X(J) − J)
  float bend = 0.0f;             // θ, the swing's angle, [0, π]
  float twist = 0.0f;            // τ about u, (−π, π]
  float arc_radius = 0.0f;       // ρ as it fits this bend
  float tangent = 0.0f;          // t = ρ·tan(θ/2): where the arc meets the straight lines
  float path = 0.0f;             // the centre line's length over the zone (2F at rest)
  float bulge = 0.0f;            // K − 1: the cross sections' largest scale, minus one
  float weight = 0.0f;           // how much the arc replaces the linear blend: 0 up to 0.75 of
                                 // the fold bend, 1 from 1.25 of it (smoothstep between)
};

// A point map x ↦ scale·rotation·x + translation.
struct ArcMap {
  glm::mat3 rotation{1.0f};
  float scale = 1.0f;
  glm::vec3 translation{0.0f};
};

// The pose of `joint` from the parent's and child's joint matrices (column-major, glTF's
// jointWorld × inverseBind). Finite for any finite input.
ArcPose make_arc_pose(const ArcJoint& joint, const glm::mat4& parent, const glm::mat4& child);

// The map of a bind-space point at axial coordinate `axial`, before the parent's joint matrix
// (that is, relative to the parent).
ArcMap arc_map(const ArcJoint& joint, const ArcPose& pose, float axial);

// Per evaluation: the pose of every arc joint of `d` from the prepared joint matrices.
void pose_joint_arcs(const Deformable& d, const JointAffine* joints, ArcPose* poses);

// Load time: the arc joints of `d`'s skin and every control vertex's part, from the glTF's
// joint hierarchy and inverse bind matrices and d's control skin and skeletal mesh. Leaves
// both empty for an unskinned deformable or a skin with no limb-like joint.
void build_joint_arcs(const tinygltf::Model& model, Deformable& d);

}  // namespace skelform::runtime
