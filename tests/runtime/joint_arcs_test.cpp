// Limb joints bent along arcs (runtime/src/joint_arcs.h): the map's geometry on analytic
// poses, the loader's joints on the test capsule and the procedural character, and the
// default skeleton skinning through the C API. The bent capsule of the fairing issue, where
// the arcs take the pairs from 170 to 0, is in fair_test.cpp.
#include "asset.h"
#include "joint_arcs.h"
#include "runtime/runtime_models.h"

#include "skelform/bake/procedural_rig.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

using skelform::runtime::ArcJoint;
using skelform::runtime::ArcMap;
using skelform::runtime::ArcPose;

namespace {

ArcJoint capsule_joint(float scale = 1.0f) {
  ArcJoint joint;
  joint.parent = 0;
  joint.child = 1;
  joint.center = scale * glm::vec3(0.1f, -0.2f, 0.3f);
  joint.axis = glm::normalize(glm::vec3(0.2f, 0.3f, 1.0f));
  joint.limb = 0.2f * scale;
  joint.radius = skelform::runtime::kArcRadius * joint.limb;
  joint.zone = skelform::runtime::kArcZone * joint.limb;
  joint.fold_bend = 0.6f;
  return joint;
}

// The child's joint matrix for a rotation `rotation` of the child about the joint (the parent
// at bind): T(J)·R·T(−J).
glm::mat4 turned_about(const ArcJoint& joint, const glm::quat& rotation) {
  return glm::translate(glm::mat4(1.0f), joint.center) * glm::mat4_cast(rotation) *
         glm::translate(glm::mat4(1.0f), -joint.center);
}

glm::vec3 apply(const ArcMap& map, const glm::vec3& x) { return map.scale * (map.rotation * x) + map.translation; }

// A unit vector perpendicular to `u`.
glm::vec3 across(const glm::vec3& u) { return glm::normalize(glm::cross(u, glm::vec3(1, 0, 0))); }

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

TEST_CASE("joint arcs: at bind the map is the identity and the arc is off") {
  const ArcJoint joint = capsule_joint();
  const ArcPose pose = skelform::runtime::make_arc_pose(joint, glm::mat4(1.0f), glm::mat4(1.0f));
  CHECK(pose.bend == 0.0f);
  CHECK(pose.twist == 0.0f);
  CHECK(pose.weight == 0.0f);
  CHECK(pose.bulge == 0.0f);
  const glm::vec3 side = across(joint.axis);
  for (float z = -1.5f * joint.zone; z <= 1.5f * joint.zone; z += 0.01f) {
    const glm::vec3 x = joint.center + z * joint.axis + 0.15f * side;
    const ArcMap map = skelform::runtime::arc_map(joint, pose, z);
    CHECK(map.scale == 1.0f);
    CHECK(glm::length(apply(map, x) - x) < 1e-6f);
  }
}

TEST_CASE("joint arcs: beyond the zone the parent's side stays and the child's moves with the child joint") {
  std::mt19937 random(7);
  std::uniform_real_distribution<float> angle(-glm::pi<float>(), glm::pi<float>()), unit(-1.0f, 1.0f);
  const ArcJoint joint = capsule_joint();
  const glm::vec3 side = across(joint.axis);
  for (int round = 0; round < 200; ++round) {
    const glm::vec3 bend_axis =
        glm::normalize(glm::cross(joint.axis, glm::vec3(unit(random), unit(random), unit(random))));
    const glm::quat rotation = glm::angleAxis(0.5f * angle(random) + 0.5f * glm::pi<float>(), bend_axis) *
                               glm::angleAxis(angle(random), joint.axis);
    const glm::mat4 child =
        glm::translate(glm::mat4(1.0f), 0.01f * glm::vec3(unit(random), unit(random), unit(random))) *
        turned_about(joint, rotation);
    const ArcPose pose = skelform::runtime::make_arc_pose(joint, glm::mat4(1.0f), child);
    for (float z : {-2.0f * joint.zone, -joint.zone, joint.zone, 2.0f * joint.zone}) {
      const glm::vec3 x = joint.center + z * joint.axis + 0.17f * side;
      const glm::vec3 expected = z < 0.0f ? x : glm::vec3(child * glm::vec4(x, 1.0f));
      CHECK(glm::length(apply(skelform::runtime::arc_map(joint, pose, z), x) - expected) < 2e-5f);
    }
  }
}

TEST_CASE(
    "joint arcs: the map is continuous along the axis, the centre line turns no tighter than the arc, the zone keeps "
    "its volume") {
  const ArcJoint joint = capsule_joint();
  const glm::vec3 side = across(joint.axis);
  for (float degrees : {20.0f, 60.0f, 90.0f, 120.0f, 150.0f}) {
    const glm::vec3 bend_axis = glm::normalize(glm::cross(joint.axis, glm::vec3(0, 1, 0)));
    const glm::quat rotation =
        glm::angleAxis(degrees * glm::pi<float>() / 180.0f, bend_axis) * glm::angleAxis(2.5f, joint.axis);
    const ArcPose pose = skelform::runtime::make_arc_pose(joint, glm::mat4(1.0f), turned_about(joint, rotation));
    CHECK(pose.bend == doctest::Approx(degrees * glm::pi<float>() / 180.0f).epsilon(1e-4));
    CHECK(pose.twist == doctest::Approx(2.5f).epsilon(1e-4));
    const int steps = 600;  // (finer, the float positions' rounding shows in the turn)
    const float dz = 3.0f * joint.zone / steps;
    glm::vec3 previous_point(0.0f), previous_centre(0.0f);
    glm::dvec3 previous_tangent(0.0);
    double largest_step = 0.0, sharpest = 0.0, volume = 0.0;
    for (int i = 0; i <= steps; ++i) {
      const float z = -1.5f * joint.zone + dz * float(i);
      const ArcMap map = skelform::runtime::arc_map(joint, pose, z);
      const glm::vec3 point = apply(map, joint.center + z * joint.axis + 0.2f * side);
      const glm::vec3 centre = apply(map, joint.center + z * joint.axis);
      if (i > 0) {
        largest_step = std::max(largest_step, double(glm::length(point - previous_point)));
        const glm::dvec3 tangent = glm::dvec3(centre - previous_centre) / double(dz);
        if (i > 1 && glm::length(tangent) > 1e-3 && glm::length(previous_tangent) > 1e-3) {
          const double turn =
              std::atan2(glm::length(glm::cross(tangent, previous_tangent)), glm::dot(tangent, previous_tangent));
          sharpest = std::max(sharpest, turn / (0.5 * (glm::length(tangent) + glm::length(previous_tangent)) * dz));
        }
        // Cross sections scale by k, the centre line's length element is |dC/dz|.
        volume += double(map.scale) * map.scale * glm::length(tangent) * dz;
        previous_tangent = tangent;
      }
      previous_point = point;
      previous_centre = centre;
    }
    INFO(degrees << " degrees: arc radius " << pose.arc_radius << ", bulge " << pose.bulge << ", largest step "
                 << largest_step << ", curvature " << sharpest << ", volume " << volume << " of " << 3.0f * joint.zone);
    CHECK(largest_step < 20.0 * dz);                    // no jump
    CHECK(sharpest <= 1.03 / double(pose.arc_radius));  // curvature at most 1/ρ
    if (degrees <= 120.0f) {
      CHECK(pose.arc_radius == doctest::Approx(joint.radius));  // the fillet fits the zone
      CHECK(volume == doctest::Approx(3.0 * joint.zone).epsilon(2e-3));
    }
  }
}

TEST_CASE("joint arcs: scale-invariant and finite on degenerate poses") {
  const ArcJoint small = capsule_joint(1.0f), large = capsule_joint(1000.0f);
  const glm::quat rotation = glm::angleAxis(1.7f, across(small.axis)) * glm::angleAxis(-0.8f, small.axis);
  const ArcPose a = skelform::runtime::make_arc_pose(small, glm::mat4(1.0f), turned_about(small, rotation));
  const ArcPose b = skelform::runtime::make_arc_pose(large, glm::mat4(1.0f), turned_about(large, rotation));
  const glm::vec3 side = across(small.axis);
  for (float z = -1.2f * small.zone; z <= 1.2f * small.zone; z += 0.05f) {
    const glm::vec3 x = small.center + z * small.axis + 0.1f * side;
    const glm::vec3 p = apply(skelform::runtime::arc_map(small, a, z), x);
    const glm::vec3 q = apply(skelform::runtime::arc_map(large, b, 1000.0f * z), 1000.0f * x);
    CHECK(glm::length(q - 1000.0f * p) < 1e-3f * 1000.0f * 1e-2f);
  }
  // Bent right back (θ = π), a zero (singular) parent, a child with NaN-free but huge values.
  const glm::mat4 back = turned_about(small, glm::angleAxis(glm::pi<float>(), across(small.axis)));
  for (const auto& [parent, child] : {std::make_pair(glm::mat4(1.0f), back), std::make_pair(glm::mat4(0.0f), back),
                                      std::make_pair(glm::mat4(1.0f), glm::mat4(1e30f))}) {
    const ArcPose pose = skelform::runtime::make_arc_pose(small, parent, child);
    CHECK(std::isfinite(pose.bend));
    CHECK(std::isfinite(pose.bulge));
    CHECK(std::isfinite(pose.weight));
    for (float z = -1.2f * small.zone; z <= 1.2f * small.zone; z += 0.05f) {
      const ArcMap map = skelform::runtime::arc_map(small, pose, z);
      CHECK(finite(apply(map, small.center + z * small.axis + 0.1f * side)));
    }
  }
}

TEST_CASE("joint arcs: the loader finds the limb joints of the capsule and the procedural character") {
  {
    const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
    const skelform::runtime::Deformable& d = model.asset->deformables[0];
    REQUIRE(d.arc_joints.size() == 1);
    const ArcJoint& joint = d.arc_joints[0];
    CHECK(joint.parent == 0);
    CHECK(joint.child == 1);
    CHECK(glm::length(joint.center) < 1e-6f);
    CHECK(glm::length(joint.axis - glm::vec3(0, 0, 1)) < 1e-3f);
    // The capsule's radius is 0.25: the limb radius is the skeletal vertices' distance from
    // the axis plus their medial radius, about that.
    CHECK(joint.limb == doctest::Approx(0.25).epsilon(0.2));
    CHECK(joint.radius == doctest::Approx(1.5f * joint.limb));
    CHECK(joint.zone <= 4.0f * joint.limb + 1e-6f);
    CHECK(joint.zone >= joint.limb);
    // The blend (weights over z in [-0.2, 0.2]) folds from r·θ·max w' = 1: 0.4 / (1.5 · 0.25)
    // rad, about 61 degrees; the capsule's rings (0.125 apart) sample the blend coarsely, so
    // the estimate is lower, never higher.
    CHECK(joint.fold_bend <= 0.4 / (1.5 * 0.25));
    CHECK(joint.fold_bend >= 0.5 * 0.4 / (1.5 * 0.25));
    // Every blended control vertex takes the arc.
    REQUIRE(d.arc_vertices.size() == d.control_vertex_count);
    size_t blended = 0;
    for (uint32_t v = 0; v < d.control_vertex_count; ++v) {
      float child = 0.0f;
      for (uint32_t k = 0; k < d.influences; ++k)
        if (d.control_joints[v * d.influences + k] == 1) child += d.control_weights[v * d.influences + k];
      if (child <= 0.0f || child >= 1.0f) continue;
      ++blended;
      CHECK(d.arc_vertices[v].joint == 0);
      CHECK(d.arc_vertices[v].share == doctest::Approx(1.0f));
    }
    CHECK(blended > 0);
  }
  {
    const skelform::bake::RiggedCharacter character = skelform::bake::make_rigged_character();
    const std::unique_ptr<skelform::test::RuntimeModel> model =
        skelform::test::detail::bake_and_load("character.glb", skelform::bake::rigged_character_glb(character), ".glb",
                                              skelform::test::scratch_dir("joint_arcs").string());
    const skelform::runtime::Deformable& d = model->asset->deformables[0];
    std::vector<int> children(character.joints.size(), 0);
    for (const auto& j : character.joints)
      if (j.parent >= 0) ++children[size_t(j.parent)];
    auto index = [&](const char* name) {
      for (size_t j = 0; j < character.joints.size(); ++j)
        if (character.joints[j].name == name) return int(j);
      FAIL("no joint " << name);
      return -1;
    };
    auto has_arc = [&](int parent, int child) {
      for (const ArcJoint& a : d.arc_joints)
        if (a.parent == parent && a.child == child) return true;
      return false;
    };
    // Knees and elbows (the skin's joint order is the rig's).
    for (const char* side : {".L", ".R"}) {
      CHECK(
          has_arc(index((std::string("upper_leg") + side).c_str()), index((std::string("lower_leg") + side).c_str())));
      CHECK(
          has_arc(index((std::string("upper_arm") + side).c_str()), index((std::string("lower_arm") + side).c_str())));
    }
    for (const ArcJoint& a : d.arc_joints) {
      CHECK(children[a.child] <= 1);  // never where the child branches (chest, pelvis)
      CHECK(character.joints[a.child].parent == int(a.parent));
      CHECK(glm::length(a.axis) == doctest::Approx(1.0f));
      CHECK(a.zone >= a.limb);
    }
  }
}

TEST_CASE("joint arcs: the default skeleton skinning equals linear blending at a mild bend and not at a deep one") {
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  sf_instance *arcs = nullptr, *linear = nullptr;
  REQUIRE(sf_instance_create(model.asset, 0, &arcs) == SF_OK);
  REQUIRE(sf_instance_create(model.asset, 0, &linear) == SF_OK);
  sf_eval_options arcs_options{}, linear_options{};
  linear_options.skeleton_skinning = SF_SKELETON_LBS;
  for (float degrees : {10.0f, 110.0f}) {
    const std::vector<glm::mat4> pose =
        skelform::test::bend_pose(model, 1, degrees * glm::pi<float>() / 180.0f, glm::vec3(1, 0, 0));
    REQUIRE(sf_instance_set_joint_matrices(arcs, &pose[0][0][0], pose.size(), 0) == SF_OK);
    REQUIRE(sf_instance_set_joint_matrices(linear, &pose[0][0][0], pose.size(), 0) == SF_OK);
    REQUIRE(sf_instance_evaluate(arcs, &arcs_options) == SF_OK);
    REQUIRE(sf_instance_evaluate(linear, &linear_options) == SF_OK);
    const skelform::test::Evaluated a = skelform::test::write_all(arcs, model.asset);
    const skelform::test::Evaluated b = skelform::test::write_all(linear, model.asset);
    const bool same = std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(glm::vec3)) == 0;
    INFO(degrees << " degrees");
    CHECK(same == (degrees < 45.0f));
    for (const glm::vec3& p : a.positions) REQUIRE(finite(p));
  }
  arcs_options.skeleton_skinning = 3;
  CHECK(sf_instance_evaluate(arcs, &arcs_options) == SF_ERROR_INVALID_ARGUMENT);
  sf_instance_destroy(arcs);
  sf_instance_destroy(linear);
}
