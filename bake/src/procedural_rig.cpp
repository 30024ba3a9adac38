// The procedural test character rigged and animated in code (procedural_rig.h).
//
// Skin weights: the character is a smooth union of one tapered capsule per bone
// (procedural_character.cpp), so the natural owner of a surface point is the capsule it lies
// on. Each bone's influence is a Gaussian of how much farther the point is from that bone's
// capsule than from the nearest one, with a width proportional to the nearest capsule's radius:
// on a joint's ball (shared by the two bones of a chain) both bones are equally near, and the
// blend fades over about one limb radius on either side, which is what lets a bend stay smooth
// under linear blend skinning too (a fair baseline). A bone on the far side of the surface
// (the other thigh seen from an inner thigh, the torso seen from the inside of an arm) is
// excluded by the angle between the vertex normal and the direction from the bone.
#include "skelform/bake/procedural_rig.h"
#include "skelform/bake/glb_builder.h"
#include "skelform/bake/topology.h"

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace skelform::bake {
namespace {

constexpr double kDegree = glm::pi<double>() / 180.0;
// Blend width of the weights, in units of the nearest capsule's radius.
constexpr double kFalloffRadii = 0.6;
// Facing factor: a bone whose direction to the vertex makes cos <= kFacingZero with the
// vertex normal has no influence; cos >= kFacingFull keeps all of it.
constexpr double kFacingZero = -0.1;
constexpr double kFacingFull = 0.4;
// Keyframes per second of the generated animations (glTF LINEAR between them).
constexpr double kKeyRate = 30.0;

double smoothstep(double edge0, double edge1, double x) {
  const double t = std::clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

struct CapsuleDistance {
  double signed_distance;  // from the capsule's surface, negative inside
  double radius;           // capsule radius at the closest axis point
  Vec3 direction;          // unit, from the closest axis point to the vertex
};

CapsuleDistance capsule_distance(const CharacterJoint& bone, const Vec3& p) {
  const Vec3 axis = bone.tail - bone.head;
  const double length2 = glm::dot(axis, axis);
  const double t = length2 > 0 ? std::clamp(glm::dot(p - bone.head, axis) / length2, 0.0, 1.0) : 0.0;
  const Vec3 closest = bone.head + t * axis;
  const double radius = bone.head_radius + t * (bone.tail_radius - bone.head_radius);
  const Vec3 offset = p - closest;
  const double distance = glm::length(offset);
  const Vec3 direction = distance > 1e-12 ? offset / distance : Vec3(0.0, 1.0, 0.0);
  return {distance - radius, radius, direction};
}

int find_joint(const std::vector<CharacterJoint>& joints, const std::string& name) {
  for (size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == name) return int(j);
  throw Error(ErrorKind::usage, "procedural rig: the joint list has no '" + name + "'");
}

glm::dquat about(double degrees, const Vec3& axis) { return glm::angleAxis(degrees * kDegree, glm::normalize(axis)); }

const Vec3 kX{1.0, 0.0, 0.0}, kY{0.0, 1.0, 0.0}, kZ{0.0, 0.0, 1.0};

// Named joints of the test character's rig, resolved once.
struct RigJoints {
  int pelvis, spine, chest;
  std::array<int, 2> upper_arm, lower_arm, upper_leg, lower_leg, foot;  // [0] .L, [1] .R
  std::array<Vec3, 2> elbow_axis;  // elbow hinge: perpendicular to the upper arm and to z

  explicit RigJoints(const std::vector<CharacterJoint>& joints)
      : pelvis(find_joint(joints, "pelvis")), spine(find_joint(joints, "spine")), chest(find_joint(joints, "chest")) {
    for (int side = 0; side < 2; ++side) {
      const std::string suffix = side == 0 ? ".L" : ".R";
      upper_arm[side] = find_joint(joints, "upper_arm" + suffix);
      lower_arm[side] = find_joint(joints, "lower_arm" + suffix);
      upper_leg[side] = find_joint(joints, "upper_leg" + suffix);
      lower_leg[side] = find_joint(joints, "lower_leg" + suffix);
      foot[side] = find_joint(joints, "foot" + suffix);
      const CharacterJoint& arm = joints[size_t(upper_arm[side])];
      // Rotating the arm direction d about cross(z, d) by a negative angle swings it towards
      // +z (forward, the character faces +z): the flexion direction of an elbow.
      elbow_axis[side] = glm::normalize(glm::cross(kZ, glm::normalize(arm.tail - arm.head)));
    }
  }
};

// Sign convention of the hinges below: a rotation about +x by a negative angle swings a
// downward bone forward (+z) and leans an upward bone backward; knees flex with positive
// angles, hips and shoulders swing forward with negative ones.

RigPose walk_pose(const std::vector<CharacterJoint>& joints, const RigJoints& rig, double t) {
  RigPose pose;
  pose.rotations.assign(joints.size(), glm::dquat(1.0, 0.0, 0.0, 0.0));
  const double phase = 2.0 * glm::pi<double>() * t;  // one cycle per second
  const double s = std::sin(phase), c = std::cos(phase);
  pose.rotations[size_t(rig.pelvis)] = about(5.0 * s, kY);
  pose.rotations[size_t(rig.spine)] = about(3.0, kX) * about(-7.0 * s, kY);
  pose.rotations[size_t(rig.chest)] = about(-4.0 * s, kY);
  for (int side = 0; side < 2; ++side) {
    const double sign = side == 0 ? 1.0 : -1.0;  // the right side runs half a cycle behind
    const double hip = -25.0 * sign * s;
    // The knee flexes in the swing phase, while the hip moves forward (its angle decreases).
    const double swing = std::max(0.0, sign * c);
    const double knee = 5.0 + 50.0 * swing * swing;
    pose.rotations[size_t(rig.upper_leg[side])] = about(hip, kX);
    pose.rotations[size_t(rig.lower_leg[side])] = about(knee, kX);
    pose.rotations[size_t(rig.foot[side])] = about(-0.8 * (hip + knee), kX);
    // Arms swing against the legs of their side.
    pose.rotations[size_t(rig.upper_arm[side])] = about(20.0 * sign * s, kX);
    pose.rotations[size_t(rig.lower_arm[side])] = about(-(25.0 + 8.0 * sign * s), rig.elbow_axis[side]);
  }
  return pose;
}

RigPose bend_pose(const std::vector<CharacterJoint>& joints, const RigJoints& rig, double t) {
  RigPose pose;
  pose.rotations.assign(joints.size(), glm::dquat(1.0, 0.0, 0.0, 0.0));
  const double envelope = smoothstep(0.0, 0.8, t) * (1.0 - smoothstep(2.2, 3.0, t));
  const double twist = 50.0 * std::sin(2.0 * glm::pi<double>() * t / 3.0) * envelope;  // left, then right
  pose.rotations[size_t(rig.spine)] = about(20.0 * envelope, kX) * about(0.5 * twist, kY);
  pose.rotations[size_t(rig.chest)] = about(10.0 * envelope, kX) * about(0.5 * twist, kY);
  for (int side = 0; side < 2; ++side) {
    const double hip = -100.0 * envelope, knee = 120.0 * envelope;
    pose.rotations[size_t(rig.upper_leg[side])] = about(hip, kX);
    pose.rotations[size_t(rig.lower_leg[side])] = about(knee, kX);
    pose.rotations[size_t(rig.foot[side])] = about(-(hip + knee), kX);  // foot flat on the ground
    pose.rotations[size_t(rig.upper_arm[side])] = about(-45.0 * envelope, kX);
    pose.rotations[size_t(rig.lower_arm[side])] = about(-120.0 * envelope, rig.elbow_axis[side]);
  }
  return pose;
}

Vec3 joint_position(const std::vector<glm::dmat4>& world, int joint) { return Vec3(world[size_t(joint)][3]); }

}  // namespace

std::vector<Vec3> vertex_normals(const TriangleMesh& mesh) {
  std::vector<Vec3> normals = area_weighted_normals(mesh);
  for (Vec3& n : normals)
    if (n == Vec3(0.0)) n = Vec3(0.0, 1.0, 0.0);  // no area around the vertex: +y
  return normals;
}

std::vector<SkinInfluence> character_skin_weights(const TriangleMesh& mesh, const std::vector<Vec3>& normals,
                                                  const std::vector<CharacterJoint>& joints) {
  if (normals.size() != mesh.positions.size())
    throw Error(ErrorKind::usage, "procedural rig: one normal per vertex expected");
  if (joints.empty() || joints.size() > 65535)
    throw Error(ErrorKind::usage, "procedural rig: 1 to 65535 joints expected");
  std::vector<SkinInfluence> skin(mesh.positions.size());
  std::vector<CapsuleDistance> distance(joints.size());
  std::vector<std::pair<double, uint16_t>> candidates;
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    size_t nearest = 0;
    for (size_t j = 0; j < joints.size(); ++j) {
      distance[j] = capsule_distance(joints[j], mesh.positions[v]);
      if (distance[j].signed_distance < distance[nearest].signed_distance) nearest = j;
    }
    const double width = kFalloffRadii * distance[nearest].radius;
    candidates.clear();
    for (size_t j = 0; j < joints.size(); ++j) {
      const double excess = (distance[j].signed_distance - distance[nearest].signed_distance) / width;
      const double facing = smoothstep(kFacingZero, kFacingFull, glm::dot(normals[v], distance[j].direction));
      // The nearest bone always keeps full weight: every vertex has at least one influence.
      const double weight = j == nearest ? 1.0 : std::exp(-excess * excess) * facing;
      if (weight > 1e-4) candidates.emplace_back(weight, uint16_t(j));
    }
    std::sort(candidates.begin(), candidates.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    const size_t kept = std::min<size_t>(4, candidates.size());
    double total = 0;
    for (size_t k = 0; k < kept; ++k) total += candidates[k].first;
    SkinInfluence& influence = skin[v];
    float rest = 1.0f;
    for (size_t k = kept; k-- > 1;) {  // the strongest gets what float rounding leaves
      influence.joints[k] = candidates[k].second;
      influence.weights[k] = float(candidates[k].first / total);
      rest -= influence.weights[k];
    }
    influence.joints[0] = candidates[0].second;
    influence.weights[0] = rest;
  }
  return skin;
}

std::vector<glm::dmat4> joint_world_transforms(const std::vector<CharacterJoint>& joints, const RigPose& pose) {
  if (pose.rotations.size() != joints.size())
    throw Error(ErrorKind::usage, "procedural rig: one rotation per joint expected");
  std::vector<glm::dmat4> world(joints.size());
  for (size_t j = 0; j < joints.size(); ++j) {
    const int parent = joints[j].parent;
    if (parent >= int(j)) throw Error(ErrorKind::usage, "procedural rig: a parent must come before its children");
    const Vec3 translation =
        parent < 0 ? joints[j].head + pose.root_offset : joints[j].head - joints[size_t(parent)].head;
    const glm::dmat4 local = glm::translate(glm::dmat4(1.0), translation) * glm::mat4_cast(pose.rotations[j]);
    world[j] = parent < 0 ? local : world[size_t(parent)] * local;
  }
  return world;
}

std::vector<RigAnimation> test_character_animations(const std::vector<CharacterJoint>& joints) {
  const RigJoints rig(joints);
  RigPose bind;
  bind.rotations.assign(joints.size(), glm::dquat(1.0, 0.0, 0.0, 0.0));
  const std::vector<glm::dmat4> rest = joint_world_transforms(joints, bind);
  std::vector<RigAnimation> animations;

  RigAnimation walk{"walk", {}, {}};
  for (int k = 0; k <= int(kKeyRate); ++k) {
    const double t = k / kKeyRate;
    RigPose pose = walk_pose(joints, rig, t);
    // Pelvis bob: the lower ankle stays at its rest height (the stance foot on the ground).
    const std::vector<glm::dmat4> world = joint_world_transforms(joints, pose);
    const double lowest = std::min(joint_position(world, rig.foot[0]).y, joint_position(world, rig.foot[1]).y);
    pose.root_offset.y = joint_position(rest, rig.foot[0]).y - lowest;
    walk.times.push_back(t);
    walk.poses.push_back(std::move(pose));
  }
  animations.push_back(std::move(walk));

  RigAnimation bend{"bend", {}, {}};
  for (int k = 0; k <= int(3 * kKeyRate); ++k) {
    const double t = k / kKeyRate;
    RigPose pose = bend_pose(joints, rig, t);
    // Squat: the ankles stay where they are at rest (the legs are symmetric, so one suffices).
    const std::vector<glm::dmat4> world = joint_world_transforms(joints, pose);
    const Vec3 drift = joint_position(rest, rig.foot[0]) - joint_position(world, rig.foot[0]);
    pose.root_offset = Vec3(0.0, drift.y, drift.z);
    bend.times.push_back(t);
    bend.poses.push_back(std::move(pose));
  }
  animations.push_back(std::move(bend));
  return animations;
}

RiggedCharacter make_rigged_character(const CharacterOptions& options) {
  RiggedCharacter character;
  character.mesh = make_test_character(options);
  character.normals = vertex_normals(character.mesh);
  character.joints = test_character_joints(options);
  character.skin = character_skin_weights(character.mesh, character.normals, character.joints);
  character.animations = test_character_animations(character.joints);
  return character;
}

std::string rigged_character_glb(const RiggedCharacter& character) {
  using nlohmann::json;
  const size_t vertex_count = character.mesh.positions.size();
  const size_t joint_count = character.joints.size();
  if (character.normals.size() != vertex_count || character.skin.size() != vertex_count)
    throw Error(ErrorKind::usage, "procedural rig: normals and skin must have one entry per vertex");
  GlbBuilder glb;
  glb.document = {{"asset", {{"version", "2.0"}, {"generator", "skelform-character (procedural rig)"}}},
                  {"scene", 0},
                  {"bufferViews", json::array()},
                  {"accessors", json::array()}};

  std::vector<float> positions, normals, weights;
  std::vector<uint16_t> joint_indices;
  std::vector<uint32_t> indices;
  for (size_t v = 0; v < vertex_count; ++v) {
    for (int c = 0; c < 3; ++c) {
      positions.push_back(float(character.mesh.positions[v][c]));
      normals.push_back(float(character.normals[v][c]));
    }
    const SkinInfluence& influence = character.skin[v];
    for (size_t k = 0; k < 4; ++k) {
      if (influence.joints[k] >= joint_count) throw Error(ErrorKind::usage, "procedural rig: joint index out of range");
      joint_indices.push_back(influence.joints[k]);
      weights.push_back(influence.weights[k]);
    }
  }
  for (const Triangle& t : character.mesh.triangles) indices.insert(indices.end(), t.begin(), t.end());
  json attributes = {{"POSITION", glb.add_floats(positions, "VEC3", 3, 34962, true)},
                     {"NORMAL", glb.add_floats(normals, "VEC3", 3, 34962, false)}};
  attributes["JOINTS_0"] =
      glb.add_accessor({{"bufferView", glb.add_view(joint_indices.data(), joint_indices.size() * 2, 34962)},
                        {"componentType", 5123},
                        {"count", vertex_count},
                        {"type", "VEC4"}});
  attributes["WEIGHTS_0"] = glb.add_floats(weights, "VEC4", 4, 34962, false);
  const int index_accessor = glb.add_accessor({{"bufferView", glb.add_view(indices.data(), indices.size() * 4, 34963)},
                                               {"componentType", 5125},
                                               {"count", indices.size()},
                                               {"type", "SCALAR"}});
  glb.document["meshes"] =
      json::array({{{"name", "character"},
                    {"primitives", {{{"attributes", attributes}, {"indices", index_accessor}, {"material", 0}}}}}});
  glb.document["materials"] = json::array(
      {{{"name", "skin"},
        {"pbrMetallicRoughness",
         {{"baseColorFactor", {0.8, 0.62, 0.5, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.7}}}}});

  // Node 0: the skinned mesh; nodes 1..joint_count: the joints in rig order.
  json nodes = json::array({{{"name", "character"}, {"mesh", 0}, {"skin", 0}}});
  std::vector<float> inverse_bind;
  for (size_t j = 0; j < joint_count; ++j) {
    const CharacterJoint& joint = character.joints[j];
    const Vec3 translation = joint.parent < 0 ? joint.head : joint.head - character.joints[size_t(joint.parent)].head;
    json node = {{"name", joint.name}, {"translation", {translation.x, translation.y, translation.z}}};
    json children = json::array();
    for (size_t k = 0; k < joint_count; ++k)
      if (character.joints[k].parent == int(j)) children.push_back(k + 1);
    if (!children.empty()) node["children"] = children;
    nodes.push_back(node);
    const glm::mat4 inverse = glm::translate(glm::mat4(1.0f), -glm::vec3(joint.head));
    inverse_bind.insert(inverse_bind.end(), glm::value_ptr(inverse), glm::value_ptr(inverse) + 16);
  }
  glb.document["nodes"] = nodes;
  json skin_joints = json::array();
  for (size_t j = 0; j < joint_count; ++j) skin_joints.push_back(j + 1);
  glb.document["skins"] = json::array({{{"name", "character rig"},
                                        {"joints", skin_joints},
                                        {"skeleton", 1},
                                        {"inverseBindMatrices", glb.add_floats(inverse_bind, "MAT4", 16, 0, false)}}});
  glb.document["scenes"] = json::array({{{"nodes", {0, 1}}}});

  json animations = json::array();
  for (const RigAnimation& animation : character.animations) {
    if (animation.times.empty() || animation.poses.size() != animation.times.size())
      throw Error(ErrorKind::usage, "procedural rig: animation '" + animation.name + "' needs one pose per time");
    std::vector<float> times(animation.times.begin(), animation.times.end());
    const int input = glb.add_floats(times, "SCALAR", 1, 0, true);
    json samplers = json::array(), channels = json::array();
    for (size_t j = 0; j < joint_count; ++j) {
      std::vector<float> rotations;
      for (const RigPose& pose : animation.poses) {
        if (pose.rotations.size() != joint_count)
          throw Error(ErrorKind::usage, "procedural rig: one rotation per joint expected");
        const glm::dquat q = glm::normalize(pose.rotations[j]);
        rotations.insert(rotations.end(), {float(q.x), float(q.y), float(q.z), float(q.w)});  // glTF order
      }
      samplers.push_back(
          {{"input", input}, {"output", glb.add_floats(rotations, "VEC4", 4, 0, false)}, {"interpolation", "LINEAR"}});
      channels.push_back({{"sampler", samplers.size() - 1}, {"target", {{"node", j + 1}, {"path", "rotation"}}}});
    }
    std::vector<float> root_translation;
    for (const RigPose& pose : animation.poses) {
      const Vec3 t = character.joints[0].head + pose.root_offset;
      root_translation.insert(root_translation.end(), {float(t.x), float(t.y), float(t.z)});
    }
    samplers.push_back({{"input", input},
                        {"output", glb.add_floats(root_translation, "VEC3", 3, 0, false)},
                        {"interpolation", "LINEAR"}});
    channels.push_back({{"sampler", samplers.size() - 1}, {"target", {{"node", 1}, {"path", "translation"}}}});
    animations.push_back({{"name", animation.name}, {"samplers", samplers}, {"channels", channels}});
  }
  if (!animations.empty()) glb.document["animations"] = animations;
  return glb.finish();
}

}  // namespace skelform::bake
