// The procedural character's rig (bake/src/procedural_rig.cpp): skin weights that are valid
// glTF weights and share each joint between its bones, a bind pose that is the rest mesh, the
// animations' defining angles and contacts, and a GLB that reads back as written.
#include "skelform/bake/input.h"
#include "skelform/bake/procedural_rig.h"
#include "test_support.h"

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#if __has_include("gltf_animation.h")
#  include "gltf_animation.h"
#  define SKELFORM_HAVE_GLTF_ANIMATION 1
#endif

namespace {

using namespace skelform::bake;

const RiggedCharacter& character() {
  static const RiggedCharacter c = make_rigged_character();
  return c;
}

int joint_index(const std::string& name) {
  const auto& joints = character().joints;
  for (size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == name) return int(j);
  FAIL("no joint " << name);
  return -1;
}

float weight_of(const SkinInfluence& influence, int joint) {
  float w = 0;
  for (size_t k = 0; k < 4; ++k)
    if (influence.joints[k] == joint) w += influence.weights[k];
  return w;
}

Vec3 position_of(const std::vector<glm::dmat4>& world, int joint) { return Vec3(world[size_t(joint)][3]); }

// Angle in degrees between the directions of two bones in a pose (0 = straight).
double bend_degrees(const std::vector<glm::dmat4>& world, int parent, int child) {
  const auto& joints = character().joints;
  const auto direction = [&](int j) {
    const Vec3 rest = joints[size_t(j)].tail - joints[size_t(j)].head;
    return glm::normalize(Vec3(world[size_t(j)] * glm::dvec4(rest, 0.0)));
  };
  return std::acos(std::clamp(glm::dot(direction(parent), direction(child)), -1.0, 1.0)) * 180.0 / glm::pi<double>();
}

const RigPose& pose_at(const RigAnimation& animation, double t) {
  for (size_t k = 0; k < animation.times.size(); ++k)
    if (std::abs(animation.times[k] - t) < 1e-9) return animation.poses[k];
  FAIL("no key at " << t);
  return animation.poses[0];
}

}  // namespace

TEST_CASE("procedural rig: every vertex has normalised weights on distinct existing joints") {
  const RiggedCharacter& c = character();
  REQUIRE(c.joints.size() == 19);
  REQUIRE(c.skin.size() == c.mesh.positions.size());
  size_t worst = 0;
  double worst_error = 0;
  for (size_t v = 0; v < c.skin.size(); ++v) {
    const SkinInfluence& s = c.skin[v];
    double sum = 0;
    std::set<int> used;
    for (size_t k = 0; k < 4; ++k) {
      REQUIRE(s.weights[k] >= 0.0f);
      REQUIRE(s.joints[k] < c.joints.size());
      if (s.weights[k] > 0) {
        CHECK(used.insert(s.joints[k]).second);  // glTF: no joint twice among non-zero weights
      }
      sum += s.weights[k];
    }
    REQUIRE(s.weights[0] > 0.0f);  // every vertex moves with at least one bone
    if (std::abs(sum - 1.0) > worst_error) worst_error = std::abs(sum - 1.0), worst = v;
  }
  INFO("worst vertex " << worst);
  CHECK(worst_error < 1e-6);
}

TEST_CASE("procedural rig: elbows and knees are shared by their two bones and limbs belong to their bones") {
  const RiggedCharacter& c = character();
  for (const char* side : {".L", ".R"}) {
    for (const auto& [upper, lower] : {std::pair{"upper_arm", "lower_arm"}, std::pair{"upper_leg", "lower_leg"}}) {
      const int a = joint_index(upper + std::string(side)), b = joint_index(lower + std::string(side));
      const CharacterJoint& bone = c.joints[size_t(b)];
      const Vec3 axis = glm::normalize(bone.tail - bone.head);
      const Vec3 mid = 0.5 * (bone.head + bone.tail);
      size_t at_joint = 0, at_middle = 0;
      for (size_t v = 0; v < c.mesh.positions.size(); ++v) {
        const Vec3 p = c.mesh.positions[v];
        const double along = glm::dot(p - bone.head, axis);
        const double radial = glm::length(p - bone.head - along * axis);
        if (radial > 1.6 * bone.head_radius) continue;  // another part of the body
        const SkinInfluence& s = c.skin[v];
        if (std::abs(along) < 0.3 * bone.head_radius) {
          // On the joint's ring (a band of the mesh's resolution): both bones, neither far
          // ahead of the other.
          ++at_joint;
          CHECK(weight_of(s, a) + weight_of(s, b) > 0.9f);
          CHECK(weight_of(s, a) > 0.25f);
          CHECK(weight_of(s, b) > 0.25f);
        }
        if (std::abs(glm::dot(p - mid, axis)) < 0.05 * glm::length(bone.tail - bone.head) &&
            radial < 1.6 * bone.tail_radius) {
          ++at_middle;  // mid-bone: rigid
          CHECK(weight_of(s, b) > 0.95f);
        }
      }
      const std::string limb = std::string(upper) + side;
      INFO(limb);
      CHECK(at_joint >= 8);
      CHECK(at_middle >= 8);
    }
  }
}

TEST_CASE("procedural rig: a thigh takes no weight from the other leg") {
  const RiggedCharacter& c = character();
  const std::set<int> right = {joint_index("upper_leg.R"), joint_index("lower_leg.R"), joint_index("foot.R")};
  const double knee_height = c.joints[size_t(joint_index("lower_leg.L"))].head.y;
  size_t checked = 0;
  for (size_t v = 0; v < c.mesh.positions.size(); ++v) {
    const Vec3 p = c.mesh.positions[v];
    if (p.x <= 0.02 || p.y > knee_height + 0.2) continue;  // left leg, hip to foot
    ++checked;
    for (int j : right) CHECK(weight_of(c.skin[v], j) == 0.0f);
  }
  CHECK(checked > 100);
}

TEST_CASE("procedural rig: the animations reach their defining poses and keep their contacts") {
  const RiggedCharacter& c = character();
  REQUIRE(c.animations.size() == 2);
  const RigAnimation& walk = c.animations[0];
  const RigAnimation& bend = c.animations[1];
  CHECK(walk.name == "walk");
  CHECK(bend.name == "bend");
  CHECK(walk.times.front() == 0.0);
  CHECK(walk.times.back() == doctest::Approx(1.0));
  CHECK(bend.times.back() == doctest::Approx(3.0));
  RigPose bind;
  bind.rotations.assign(c.joints.size(), glm::dquat(1.0, 0.0, 0.0, 0.0));
  const std::vector<glm::dmat4> rest = joint_world_transforms(c.joints, bind);
  for (size_t j = 0; j < c.joints.size(); ++j) CHECK(glm::length(position_of(rest, int(j)) - c.joints[j].head) < 1e-12);

  // The walk loops: its last key is its first.
  const std::vector<glm::dmat4> first = joint_world_transforms(c.joints, walk.poses.front());
  const std::vector<glm::dmat4> last = joint_world_transforms(c.joints, walk.poses.back());
  for (size_t j = 0; j < c.joints.size(); ++j)
    CHECK(glm::length(position_of(first, int(j)) - position_of(last, int(j))) < 1e-9);
  // The stance ankle stays on its rest height.
  const int foot_l = joint_index("foot.L"), foot_r = joint_index("foot.R");
  for (const RigPose& pose : walk.poses) {
    const auto world = joint_world_transforms(c.joints, pose);
    CHECK(std::min(position_of(world, foot_l).y, position_of(world, foot_r).y) ==
          doctest::Approx(c.joints[size_t(foot_l)].head.y));
  }
  // The bend starts and ends at rest, and at its middle the knees and elbows are at 120
  // degrees with the ankles where they were.
  for (const RigPose* pose : {&bend.poses.front(), &bend.poses.back()}) {
    const auto world = joint_world_transforms(c.joints, *pose);
    for (size_t j = 0; j < c.joints.size(); ++j)
      CHECK(glm::length(position_of(world, int(j)) - c.joints[j].head) < 1e-9);
  }
  const auto deep = joint_world_transforms(c.joints, pose_at(bend, 1.5));
  for (const char* side : {".L", ".R"}) {
    INFO(std::string(side));
    // The thigh and shin bones are about 5 degrees apart at rest (the knee sits forward of
    // the hip-ankle line), so the 120-degree knee hinge shows as 120-125 between them.
    const double knee =
        bend_degrees(deep, joint_index(std::string("upper_leg") + side), joint_index(std::string("lower_leg") + side));
    CHECK(knee > 118.0);
    CHECK(knee < 127.0);
    CHECK(bend_degrees(deep, joint_index(std::string("upper_arm") + side),
                       joint_index(std::string("lower_arm") + side)) == doctest::Approx(120.0).epsilon(0.01));
    const int foot = joint_index(std::string("foot") + side);
    CHECK(glm::length(position_of(deep, foot) - c.joints[size_t(foot)].head) < 1e-9);
  }
  // The spine twists one way, then the other (about y, measured on the chest's x axis).
  double most_left = 0, most_right = 0;
  for (const RigPose& pose : bend.poses) {
    const auto world = joint_world_transforms(c.joints, pose);
    const Vec3 x_axis(world[size_t(joint_index("chest"))][0]);
    const double yaw = std::atan2(-x_axis.z, x_axis.x) * 180.0 / glm::pi<double>();
    most_left = std::max(most_left, yaw);
    most_right = std::min(most_right, yaw);
  }
  CHECK(most_left > 40.0);
  CHECK(most_right < -40.0);
}

TEST_CASE("procedural rig: the GLB reads back as the rig, its bind pose is the rest mesh, and it is deterministic") {
  const RiggedCharacter& c = character();
  const std::string glb = rigged_character_glb(c);
  CHECK(glb == rigged_character_glb(make_rigged_character()));
  const InputMesh input =
      load_mesh_from_memory(std::vector<unsigned char>(glb.begin(), glb.end()), ".glb", "character.glb");
  REQUIRE(input.positions.size() == c.mesh.positions.size());
  REQUIRE(input.primitives.size() == 1);
  CHECK(input.primitives[0].skin == 0);
  REQUIRE(input.joint_sets.size() == 1);
  for (size_t v = 0; v < input.positions.size(); ++v) {
    CHECK(glm::length(input.positions[v] - c.mesh.positions[v]) < 1e-6);
    float sum = 0;
    for (size_t k = 0; k < 4; ++k) {
      sum += input.weight_sets[0][v][k];
      CHECK(input.joint_sets[0][v][k] == c.skin[v].joints[k]);
    }
    CHECK(sum == doctest::Approx(1.0f).epsilon(1e-6));
  }
#ifdef SKELFORM_HAVE_GLTF_ANIMATION
  // Joint matrices at bind (jointWorld x inverseBind) are the identity: the skinned mesh at
  // its bind pose is the rest mesh as stored, and every animation starts from it.
  const auto gltf = skelform::samples::GltfAnimation::load_memory(glb, "character.glb");
  REQUIRE(gltf.animations().size() == 2);
  CHECK(gltf.animations()[0].name == "walk");
  CHECK(gltf.animations()[1].name == "bend");
  for (size_t pose = 0; pose < 2; ++pose) {
    const std::vector<float> m = pose == 0 ? gltf.bind_pose_joint_matrices(0) : gltf.joint_matrices(0, 1, 0.0);
    REQUIRE(m.size() == 16 * c.joints.size());
    for (size_t i = 0; i < m.size(); ++i) CHECK(m[i] == doctest::Approx(i % 16 % 5 == 0 ? 1.0f : 0.0f).epsilon(1e-6));
  }
#endif
}
