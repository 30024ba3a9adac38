// The procedural test character rigged and animated in code: skin weights from its own bones,
// vertex normals, a walk cycle and a deep bend, written as a standard skinned glTF 2.0 GLB.
// This is the input of the README's main job (skelform-character -o character.glb, then
// skelform-animate); no third-party model is involved.
//
// The rig is test_character_joints(): 19 joints, bind pose = each joint at its head position
// with no rotation, so joint j's inverse bind matrix is a translation by -head_j and a pose
// is one local rotation per joint (relative to the bind orientation, which is the identity)
// plus an offset of the root's translation.
#pragma once

#include "skelform/bake/mesh.h"
#include "skelform/bake/procedural.h"

#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace skelform::bake {

// Up to four joint influences of one vertex, strongest first. Unused slots have weight 0
// (and joint index 0).
struct SkinInfluence {
  std::array<uint16_t, 4> joints{};  // indices into the joint list
  std::array<float, 4> weights{};    // >= 0, summing to 1 within float rounding
};

// Area-weighted vertex normals of an outward-oriented mesh (unit length; +y for a vertex
// whose triangles have no area).
std::vector<Vec3> vertex_normals(const TriangleMesh& mesh);

// Skin weights of `mesh` for the bones `joints`: each bone's influence falls off smoothly with
// the distance from the vertex to the bone's tapered capsule (relative to the nearest bone and
// scaled by the local capsule radius, so a vertex on a joint between two bones gets both about
// equally and the blend spans about one limb radius on each side), and bones the surface
// faces away from (the other thigh, seen from the inner thigh) get none. The four strongest
// are kept and normalised. `normals` are the mesh's vertex normals.
std::vector<SkinInfluence> character_skin_weights(const TriangleMesh& mesh, const std::vector<Vec3>& normals,
                                                  const std::vector<CharacterJoint>& joints);

// A pose of the rig: local rotation of each joint relative to its bind orientation
// (identity), and the offset added to the root's bind translation, in the unit of the rig.
struct RigPose {
  std::vector<glm::dquat> rotations;  // one per joint, unit quaternions
  Vec3 root_offset{0.0, 0.0, 0.0};
};

// A keyframed animation of the rig, sampled densely (glTF LINEAR interpolation between keys
// reproduces it closely).
struct RigAnimation {
  std::string name;
  std::vector<double> times;   // seconds, strictly increasing, starting at 0
  std::vector<RigPose> poses;  // one per time
};

// World transform of every joint (forward kinematics down the parent chain): the joint's
// frame in the pose, whose origin is where its head went. At the bind pose (identity
// rotations, zero offset) joint j's world transform is a translation by its head.
std::vector<glm::dmat4> joint_world_transforms(const std::vector<CharacterJoint>& joints, const RigPose& pose);

// The two animations generated in code, for `joints` = test_character_joints(options):
//  "walk"  one 1 s cycle in place: hips ±25°, knees flexing up to ~55° in the swing, feet kept
//          flat, arms swinging against the legs with bent elbows, pelvis and spine twisting
//          in opposition; the pelvis bobs so the lower ankle stays at its rest height (loops).
//  "bend"  3 s from rest to a deep squat and back: knees and elbows at 120°, hips flexed
//          100°, arms raised forward, the spine leaning and twisting ±50° left then right
//          (the poses where linear blend skinning collapses); the ankles stay in place.
std::vector<RigAnimation> test_character_animations(const std::vector<CharacterJoint>& joints);

// Everything the rigged character's glTF holds.
struct RiggedCharacter {
  TriangleMesh mesh;                     // make_test_character(options)
  std::vector<Vec3> normals;             // vertex_normals(mesh)
  std::vector<CharacterJoint> joints;    // test_character_joints(options)
  std::vector<SkinInfluence> skin;       // character_skin_weights(...)
  std::vector<RigAnimation> animations;  // test_character_animations(joints)
};

// The character of `options`, rigged and animated. Deterministic.
RiggedCharacter make_rigged_character(const CharacterOptions& options = {});

// A standard glTF 2.0 GLB of the rigged character: one mesh node "character" (POSITION,
// NORMAL, JOINTS_0, WEIGHTS_0, uint32 indices, one material) with the skin, the joint nodes
// (named as the joints, bind pose = their heads, no rotation; inverse bind matrices are
// translations by -head) and one glTF animation per RigAnimation (a rotation channel per
// joint, a translation channel for the root; LINEAR). The same character gives the same bytes.
std::string rigged_character_glb(const RiggedCharacter& character);

}  // namespace skelform::bake
