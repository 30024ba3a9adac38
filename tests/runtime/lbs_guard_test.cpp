// runtime/src/lbs_guard.h through the C API: what skelform promises against linear blend
// skinning on any character, in any pose. Every intersecting pair of the output is one LBS has
// too; a closed mesh's volume is never further from its bind volume than LBS's; a vertex with
// one influence is LBS's result bit for bit. And runtime/src/instance.h JointTransforms: joint
// matrices scaled uniformly give the unscaled result scaled (Blender's armature scale of 100,
// Mixamo's 0.01), and a joint scaled on its own scales the thickness of what it drives.
#include "gltf_animation.h"
#include "instance.h"
#include "runtime/runtime_models.h"
#include "runtime/welded_surface.h"
#include "skelform/bake/metrics.h"
#include "skelform/bake/self_intersection.h"

#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <tuple>

namespace {

using skelform::bake::TriangleMesh;
using skelform::bake::Vec3;
using skelform::test::RuntimeModel;

struct Instance : skelform::test::InstancePtr {
  using InstancePtr::InstancePtr;
  skelform::test::Evaluated evaluate(const sf_asset* asset, const std::vector<glm::mat4>& pose, uint32_t method,
                                     uint32_t flags = 0) {
    REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0) == SF_OK);
    sf_eval_options options{};
    options.method = method;
    options.flags = flags;
    REQUIRE(sf_instance_evaluate(instance, &options) == SF_OK);
    return skelform::test::write_all(instance, asset);
  }
};

// The pairs of `skelform` not in `lbs` (both sorted).
size_t pairs_outside(const std::vector<std::pair<uint32_t, uint32_t>>& skelform,
                     const std::vector<std::pair<uint32_t, uint32_t>>& lbs) {
  size_t outside = 0;
  for (const auto& p : skelform) outside += std::binary_search(lbs.begin(), lbs.end(), p) ? 0 : 1;
  return outside;
}

// A single influence: one joint carries ≥ 0.999 of the vertex's (JOINTS_0/WEIGHTS_0) skin.
bool single_influence(const skelform::test::OriginalPrimitive& p, size_t v) {
  float largest = 0, total = 0;
  for (int k = 0; k < 4; ++k) {
    float same = 0;
    for (int i = 0; i < 4; ++i)
      if (p.joints[v][i] == p.joints[v][k]) same += p.weights[v][i];
    largest = std::max(largest, same);
    total += p.weights[v][k];
  }
  return total > 0 && largest / total >= 0.999f;
}

glm::mat4 bend_twist(double bend_degrees, double twist_degrees) {
  return glm::mat4_cast(glm::angleAxis(float(bend_degrees * glm::pi<double>() / 180), glm::vec3(1, 0, 0)) *
                        glm::angleAxis(float(twist_degrees * glm::pi<double>() / 180), glm::vec3(0, 0, 1)));
}

}  // namespace

TEST_CASE(
    "guard: every intersecting pair of the output is one LBS has; a closed mesh's volume error never exceeds LBS's") {
  // The two capsules bent and twisted from 0 to 150 degrees (their child joint is at the
  // origin), evaluated from rest and incrementally through the bend.
  for (const RuntimeModel* model : {&skelform::test::capsule_model(), &skelform::test::bent_capsule_model()}) {
    const skelform::test::WeldedSurface w = skelform::test::welded_surface(*model);
    Instance skelform(model->asset), lbs(model->asset);
    size_t frames = 0, skelform_pairs = 0, lbs_pairs = 0;
    for (int bend = 0; bend <= 150; bend += 10) {
      for (double twist : {0.0, 90.0}) {
        const std::vector<glm::mat4> pose = {glm::mat4(1.0f), bend_twist(bend, twist)};
        const TriangleMesh s =
            skelform::test::posed(w, skelform.evaluate(model->asset, pose, SF_METHOD_SKELFORM).positions);
        const TriangleMesh l = skelform::test::posed(w, lbs.evaluate(model->asset, pose, SF_METHOD_LBS).positions);
        const auto sp = skelform::bake::self_intersecting_pairs(s);
        const auto lp = skelform::bake::self_intersecting_pairs(l);
        INFO(model->name << " bent " << bend << ", twisted " << twist << ": skelform " << sp.size() << " pairs, LBS "
                         << lp.size());
        CHECK(pairs_outside(sp, lp) == 0);
        const double skelform_dv = std::fabs(skelform::bake::enclosed_volume(s) / w.rest_volume - 1.0);
        const double lbs_dv = std::fabs(skelform::bake::enclosed_volume(l) / w.rest_volume - 1.0);
        CHECK(skelform_dv <= lbs_dv + 1e-6);
        ++frames;
        skelform_pairs += sp.size();
        lbs_pairs += lp.size();
      }
    }
    MESSAGE(model->name << ": " << frames << " poses, pairs skelform " << skelform_pairs << " / LBS " << lbs_pairs);
  }
}

TEST_CASE("guard: on a real animation every frame's pairs are LBS's") {
  const RuntimeModel* model = skelform::test::sample_model("Fox/Fox.glb");
  if (!model) return;
  const skelform::samples::GltfAnimation gltf =
      skelform::samples::GltfAnimation::load_file(skelform::test::data_file("Fox/Fox.glb").string());
  const skelform::test::WeldedSurface w = skelform::test::welded_surface(*model);
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model->asset, 0, &info) == SF_OK);
  for (size_t a = 0; a < gltf.animations().size(); ++a) {
    Instance skelform(model->asset), lbs(model->asset);
    const auto& anim = gltf.animations()[a];
    size_t outside = 0, frames = 0;
    for (double t = anim.start; t <= anim.end + 1e-9; t += 1.0 / 30.0, ++frames) {
      const std::vector<float> m = gltf.joint_matrices(size_t(info.skin), a, t);
      std::vector<glm::mat4> pose(m.size() / 16);
      for (size_t j = 0; j < pose.size(); ++j)
        for (int c = 0; c < 16; ++c) pose[j][c / 4][c % 4] = m[16 * j + size_t(c)];
      const auto sp = skelform::bake::self_intersecting_pairs(skelform::test::posed(
          w, skelform.evaluate(model->asset, pose, SF_METHOD_SKELFORM, frames == 0 ? SF_EVAL_FROM_REST : 0).positions));
      const auto lp = skelform::bake::self_intersecting_pairs(
          skelform::test::posed(w, lbs.evaluate(model->asset, pose, SF_METHOD_LBS).positions));
      outside += pairs_outside(sp, lp);
    }
    INFO("Fox '" << anim.name << "', " << frames << " frames");
    CHECK(outside == 0);
  }
}

TEST_CASE("guard: passing over the leaf pairs the rest bound parts changes no bit of the output") {
  // rest_clearance.h: the first round skips leaf pairs whose triangles the bound shows apart.
  // Its verdicts must be those of testing them: two instances, one testing every pair, give
  // the same bits on every frame of a real animation (and the bound does skip pairs there).
  const RuntimeModel* model = skelform::test::sample_model("Fox/Fox.glb");
  if (!model) return;
  const skelform::samples::GltfAnimation gltf =
      skelform::samples::GltfAnimation::load_file(skelform::test::data_file("Fox/Fox.glb").string());
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model->asset, 0, &info) == SF_OK);
  for (size_t a = 0; a < gltf.animations().size(); ++a) {
    Instance bound(model->asset), every(model->asset);
    every.instance->guard.use_clearance = false;
    const auto& anim = gltf.animations()[a];
    size_t frames = 0, skipped = 0, differing = 0;
    for (double t = anim.start; t <= anim.end + 1e-9; t += 2.0 / 30.0, ++frames) {
      const std::vector<float> m = gltf.joint_matrices(size_t(info.skin), a, t);
      std::vector<glm::mat4> pose(m.size() / 16);
      for (size_t j = 0; j < pose.size(); ++j)
        for (int c = 0; c < 16; ++c) pose[j][c / 4][c % 4] = m[16 * j + size_t(c)];
      const skelform::test::Evaluated x = bound.evaluate(model->asset, pose, SF_METHOD_SKELFORM);
      skipped += bound.instance->guard.leaves_apart;
      const skelform::test::Evaluated y = every.evaluate(model->asset, pose, SF_METHOD_SKELFORM);
      CHECK(every.instance->guard.leaves_apart == 0);
      differing += std::memcmp(x.positions.data(), y.positions.data(), x.positions.size() * sizeof(glm::vec3)) != 0 ||
                   std::memcmp(x.normals.data(), y.normals.data(), x.normals.size() * sizeof(glm::vec3)) != 0;
    }
    INFO("Fox '" << anim.name << "', " << frames << " frames, " << skipped << " leaf pairs passed over");
    CHECK(differing == 0);
    CHECK(skipped > 0);
  }
}

TEST_CASE("guard: a vertex with one influence is LBS's result, bit for bit") {
  const RuntimeModel& model = skelform::test::capsule_model();
  Instance skelform(model.asset), lbs(model.asset);
  size_t rigid = 0;
  for (int bend = 0; bend <= 140; bend += 35) {
    const std::vector<glm::mat4> pose = {glm::mat4(1.0f), bend_twist(bend, 60)};
    const skelform::test::Evaluated s = skelform.evaluate(model.asset, pose, SF_METHOD_SKELFORM);
    const skelform::test::Evaluated l = lbs.evaluate(model.asset, pose, SF_METHOD_LBS);
    size_t first = 0;
    for (const auto& p : model.primitives) {
      for (size_t v = 0; v < p.positions.size(); ++v) {
        if (!single_influence(p, v)) continue;
        ++rigid;
        CHECK(std::memcmp(&s.positions[first + v], &l.positions[first + v], sizeof(glm::vec3)) == 0);
        CHECK(std::memcmp(&s.normals[first + v], &l.normals[first + v], sizeof(glm::vec3)) == 0);
      }
      first += p.positions.size();
    }
  }
  CHECK(rigid > 100);
}

TEST_CASE("scale: joint matrices scaled by s give the unscaled result scaled by s") {
  // Blender exports centimetre rigs with an armature scale of 100, Mixamo with 0.01: the
  // joint matrices are rotation x uniform scale. Scaling every matrix by s about the origin
  // must scale the output by s, and the rest pose (identity x s) must be the stored mesh x s.
  const RuntimeModel& model = skelform::test::bent_capsule_model();
  const std::vector<glm::mat4> pose = {glm::mat4(1.0f), bend_twist(70, 40)};
  Instance reference(model.asset);
  const skelform::test::Evaluated unscaled =
      reference.evaluate(model.asset, pose, SF_METHOD_SKELFORM, SF_EVAL_FROM_REST);
  for (float s : {100.0f, 0.01f, 3.7f}) {
    const glm::mat4 scale = glm::scale(glm::mat4(1.0f), glm::vec3(s));
    Instance scaled(model.asset);
    const skelform::test::Evaluated e =
        scaled.evaluate(model.asset, {scale * pose[0], scale * pose[1]}, SF_METHOD_SKELFORM, SF_EVAL_FROM_REST);
    double worst = 0, normal_worst = 0;
    for (size_t v = 0; v < e.positions.size(); ++v) {
      worst = std::max(worst, double(glm::length(e.positions[v] - s * unscaled.positions[v])));
      normal_worst = std::max(normal_worst, double(glm::length(e.normals[v] - unscaled.normals[v])));
    }
    INFO("scale " << s << ": largest difference " << worst / (s * model.diagonal) << " of the diagonal");
    CHECK(worst <= 1e-5 * s * model.diagonal);
    CHECK(normal_worst <= 1e-4);
    // The rest pose at that scale: the stored mesh, scaled.
    Instance rest(model.asset);
    const skelform::test::Evaluated r =
        rest.evaluate(model.asset, {scale, scale}, SF_METHOD_SKELFORM, SF_EVAL_FROM_REST);
    double rest_worst = 0;
    for (size_t v = 0; v < r.positions.size(); ++v)
      rest_worst = std::max(rest_worst, double(glm::length(r.positions[v] - s * model.primitives[0].positions[v])));
    CHECK(rest_worst <= 1e-5 * s * model.diagonal);
  }
}

TEST_CASE("scale: a joint scaled on its own scales the thickness of what it drives") {
  // The child joint scaled by k about the joint (the origin): the child's part, which moves
  // with it alone, is LBS's exact scaling; the blend zone's distance from the axis lies
  // between the parent's 1 and the child's k times its rest distance.
  const RuntimeModel& model = skelform::test::capsule_model();
  const skelform::test::OriginalPrimitive& capsule = model.primitives[0];
  for (float k : {1.5f, 0.6f}) {
    const std::vector<glm::mat4> pose = {glm::mat4(1.0f), glm::scale(glm::mat4(1.0f), glm::vec3(k))};
    Instance skelform(model.asset), lbs(model.asset);
    const skelform::test::Evaluated s = skelform.evaluate(model.asset, pose, SF_METHOD_SKELFORM, SF_EVAL_FROM_REST);
    const skelform::test::Evaluated l = lbs.evaluate(model.asset, pose, SF_METHOD_LBS);
    size_t blended = 0;
    for (size_t v = 0; v < capsule.positions.size(); ++v) {
      const glm::vec3 p = capsule.positions[v];
      const float rest_radius = std::hypot(p.x, p.y);
      if (rest_radius < 1e-3f) continue;
      const float radius = std::hypot(s.positions[v].x, s.positions[v].y) / rest_radius;
      if (single_influence(capsule, v)) {
        CHECK(s.positions[v] == l.positions[v]);
      } else {
        ++blended;
        CHECK(radius >= std::min(1.0f, k) - 1e-4f);
        CHECK(radius <= std::max(1.0f, k) + 1e-4f);
      }
    }
    CHECK(blended > 20);
  }
}

TEST_CASE("scale: non-uniform scale and shear degrade gracefully: finite, rigid parts exact, no pair LBS lacks") {
  // No single radius scale exists for them (instance.h JointTransforms: |det|^(1/3) stands in);
  // what must hold is what the guards promise whatever the matrices.
  const RuntimeModel& model = skelform::test::capsule_model();
  const skelform::test::WeldedSurface w = skelform::test::welded_surface(model);
  glm::mat4 shear(1.0f);
  shear[1][0] = 0.6f;  // x += 0.6 y
  const std::vector<glm::mat4> children = {glm::scale(glm::mat4(1.0f), glm::vec3(1.6f, 1.0f, 0.5f)),
                                           bend_twist(60, 30) * shear,
                                           glm::scale(bend_twist(90, 0), glm::vec3(2.0f, 0.3f, 1.0f))};
  for (size_t c = 0; c < children.size(); ++c) {
    const std::vector<glm::mat4> pose = {glm::mat4(1.0f), children[c]};
    Instance skelform(model.asset), lbs(model.asset);
    const skelform::test::Evaluated s = skelform.evaluate(model.asset, pose, SF_METHOD_SKELFORM, SF_EVAL_FROM_REST);
    const skelform::test::Evaluated l = lbs.evaluate(model.asset, pose, SF_METHOD_LBS);
    INFO("child matrix " << c);
    for (const glm::vec3& p : s.positions) CHECK((std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)));
    for (const glm::vec3& n : s.normals) CHECK(std::fabs(glm::length(n) - 1.0f) < 1e-4f);
    const auto sp = skelform::bake::self_intersecting_pairs(skelform::test::posed(w, s.positions));
    const auto lp = skelform::bake::self_intersecting_pairs(skelform::test::posed(w, l.positions));
    CHECK(pairs_outside(sp, lp) == 0);
    const skelform::test::OriginalPrimitive& capsule = model.primitives[0];
    for (size_t v = 0; v < capsule.positions.size(); ++v)
      if (single_influence(capsule, v)) CHECK(s.positions[v] == l.positions[v]);
  }
}
