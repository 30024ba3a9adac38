// Evaluation through the C API (runtime/src/api_evaluate.cpp and the stage files it runs):
// - rest pose: every method reproduces the original vertices and authored normals/tangents
//   (DESIGN.md "rest error" ≤ 1e-5 of the diagonal; normals within 0.1°), from rest and
//   incrementally, on a procedural capsule (always) and on every skinned sample model;
// - a posed CesiumMan: skelform stays finite and close to LBS away from the bent joint, and
//   the LBS/DQS baselines equal a straightforward double-precision reference;
// - the handle driver moves the surface toward its targets;
// - error paths: wrong joint count, NaN matrix, write before evaluate, bad primitive,
//   out-of-range fairing options, bad handle sets; no allocation in evaluate/write.
#include "counting_heap.h"
#include "runtime/runtime_models.h"

#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>

#include <atomic>
#include <cstdlib>

namespace {

using skelform::test::Evaluated;
using skelform::test::RuntimeModel;

using skelform::test::InstancePtr;

struct Variant {
  const char* name;
  sf_eval_options options;
};

// Every way to evaluate: skelform with both reconstructions and the three skeleton skinnings, the
// two baselines; `flags` added by the caller.
std::vector<Variant> variants() {
  std::vector<Variant> v;
  sf_eval_options o{};
  v.push_back({"skelform carried/arcs", o});
  o.skeleton_skinning = SF_SKELETON_DQS;
  v.push_back({"skelform carried/DQS", o});
  o.skeleton_skinning = SF_SKELETON_LBS;
  v.push_back({"skelform carried/LBS", o});
  o = {};
  o.reconstruction = SF_RECONSTRUCTION_PAPER;
  v.push_back({"skelform paper L=3", o});
  o.homotopy_steps = 1;
  v.push_back({"skelform paper L=1", o});
  o = {};
  o.method = SF_METHOD_LBS;
  v.push_back({"LBS", o});
  o.method = SF_METHOD_DQS;
  v.push_back({"DQS", o});
  return v;
}

// Angle between two directions in double, by atan2 (acos of a float-normalised dot product
// cannot resolve below ~0.02°, the very scale of the 0.1° tolerance).
double angle_degrees(glm::vec3 a, glm::vec3 b) {
  const glm::dvec3 x(a), y(b);
  return std::atan2(glm::length(glm::cross(x, y)), glm::dot(x, y)) * 180.0 / glm::pi<double>();
}

struct RestError {
  double position = 0;  // max |evaluated − original| / diagonal
  double normal = 0;    // max angle to the authored normal, degrees
  double tangent = 0;   // max angle to the authored tangent, degrees
  bool finite = true;
  bool unit_normals = true;
  bool tangent_w = true;
};

RestError rest_error(const RuntimeModel& model, const Evaluated& e) {
  RestError r;
  size_t v = 0;
  for (const auto& prim : model.primitives) {
    for (size_t i = 0; i < prim.positions.size(); ++i, ++v) {
      r.finite = r.finite && std::isfinite(e.positions[v].x) && std::isfinite(e.positions[v].y) &&
                 std::isfinite(e.positions[v].z) && std::isfinite(e.normals[v].x);
      r.position = std::max(r.position, double(glm::length(e.positions[v] - prim.positions[i])) / model.diagonal);
      r.unit_normals = r.unit_normals && std::abs(glm::length(e.normals[v]) - 1.0f) < 1e-4f;
      if (!prim.normals.empty()) r.normal = std::max(r.normal, angle_degrees(e.normals[v], prim.normals[i]));
      if (!prim.tangents.empty()) {
        r.tangent = std::max(r.tangent, angle_degrees(glm::vec3(e.tangents[v]), glm::vec3(prim.tangents[i])));
        r.tangent_w = r.tangent_w && e.tangents[v].w == prim.tangents[i].w;
      }
    }
  }
  return r;
}

// Identity joints, every variant, from rest and then incrementally (three evaluations in a
// row, so the incremental start is itself an incremental result).
void check_rest_pose(const RuntimeModel& model) {
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model.asset, 0, &info) == SF_OK);
  const bool skinned = info.joint_count > 0;
  double worst = 0;
  for (const Variant& variant : variants()) {
    if (!skinned && variant.options.method != SF_METHOD_SKELFORM) continue;
    InstancePtr instance(model.asset);
    const std::vector<glm::mat4> identity(info.joint_count, glm::mat4(1.0f));
    REQUIRE(sf_instance_set_joint_matrices(instance, identity.empty() ? nullptr : &identity[0][0][0], identity.size(),
                                           0) == SF_OK);
    for (int round = 0; round < 4; ++round) {
      sf_eval_options options = variant.options;
      if (round == 0) options.flags |= SF_EVAL_FROM_REST;
      REQUIRE_MESSAGE(sf_instance_evaluate(instance, &options) == SF_OK, sf_instance_last_error(instance));
      const RestError r = rest_error(model, skelform::test::write_all(instance, model.asset));
      INFO(model.name << ", " << std::string(variant.name)
                      << std::string(round == 0 ? ", from rest" : ", incremental"));
      CHECK(r.finite);
      CHECK(r.unit_normals);
      CHECK(r.tangent_w);
      CHECK(r.position <= 1e-5);
      CHECK(r.normal <= 0.1);
      CHECK(r.tangent <= 0.1);
      worst = std::max(worst, r.position);
      if (round == 0 || round == 3)
        MESSAGE(model.name << " rest " << std::string(variant.name)
                           << std::string(round == 0 ? " from rest" : " incremental") << ": position error "
                           << r.position << " of the diagonal, normals " << r.normal << " deg, tangents " << r.tangent
                           << " deg");
    }
  }
  CHECK(worst <= 1e-5);
}

}  // namespace

TEST_CASE("evaluate: the rest pose reproduces the procedural capsule with every method from rest and incrementally") {
  check_rest_pose(skelform::test::capsule_model());
}

TEST_CASE("evaluate: the rest pose reproduces every skinned sample model within 1e-5 of its diagonal") {
  for (const std::string& name : skelform::test::sample_names())
    if (const RuntimeModel* model = skelform::test::sample_model(name)) check_rest_pose(*model);
}

namespace {

// Straightforward reference skinning in double from the ORIGINAL JOINTS_0/WEIGHTS_0.
std::vector<glm::dvec3> reference_skinning(const RuntimeModel& model, const std::vector<glm::mat4>& pose, bool dqs) {
  std::vector<glm::dvec3> out;
  for (const auto& prim : model.primitives)
    for (size_t i = 0; i < prim.positions.size(); ++i) {
      const glm::dvec3 p(prim.positions[i]);
      double total = 0;
      for (int k = 0; k < 4; ++k) total += prim.weights[i][k];
      if (!dqs) {
        glm::dmat4 m(0.0);
        for (int k = 0; k < 4; ++k) m += (double(prim.weights[i][k]) / total) * glm::dmat4(pose[prim.joints[i][k]]);
        out.push_back(glm::dvec3(m * glm::dvec4(p, 1.0)));
        continue;
      }
      // Dual quaternions (Kavan et al. 2008) of the rigid joint matrices; antipodality fixed
      // against the first influence.
      glm::dquat real0(0, 0, 0, 0), dual0(0, 0, 0, 0);
      const glm::dquat pivot = glm::quat_cast(glm::dmat3(pose[prim.joints[i][0]]));
      for (int k = 0; k < 4; ++k) {
        const glm::dmat4 m(pose[prim.joints[i][k]]);
        glm::dquat q = glm::quat_cast(glm::dmat3(m));
        const glm::dvec3 t(m[3]);
        const double w = double(prim.weights[i][k]) / total * (glm::dot(q, pivot) < 0 ? -1.0 : 1.0);
        const glm::dquat d = 0.5 * (glm::dquat(0.0, t.x, t.y, t.z) * q);
        real0 = real0 + w * q;
        dual0 = dual0 + w * d;
      }
      const double n = glm::length(real0);
      real0 = real0 / n;
      dual0 = dual0 / n;
      const glm::dquat tq = 2.0 * (dual0 * glm::conjugate(real0));
      out.push_back(real0 * p + glm::dvec3(tq.x, tq.y, tq.z));
    }
  return out;
}

// The joint to bend: the one with most vertices of its own among joints that have a child
// (an elbow or knee rather than a fingertip or the root), found from the original weights.
size_t joint_to_bend(const RuntimeModel& model) {
  std::vector<double> weight(model.inverse_bind.size(), 0.0);
  std::vector<int> children(model.inverse_bind.size(), 0);
  for (size_t j = 0; j < model.joint_parent.size(); ++j)
    if (model.joint_parent[j] >= 0) ++children[size_t(model.joint_parent[j])];
  for (const auto& prim : model.primitives)
    for (size_t i = 0; i < prim.weights.size(); ++i)
      for (int k = 0; k < 4; ++k) weight[prim.joints[i][k]] += prim.weights[i][k];
  size_t best = 0;
  double best_weight = -1;
  for (size_t j = 0; j < weight.size(); ++j)
    if (children[j] > 0 && model.joint_parent[j] >= 0 && weight[j] > best_weight) {
      best = j;
      best_weight = weight[j];
    }
  return best;
}

}  // namespace

TEST_CASE(
    "evaluate: a bent CesiumMan stays finite and close to LBS away from the joint and the baselines match a "
    "reference") {
  const RuntimeModel* model = skelform::test::sample_model("CesiumMan/CesiumMan.glb");
  if (!model) return;
  const size_t joint = joint_to_bend(*model);
  const std::vector<glm::mat4> pose = skelform::test::bend_pose(*model, joint, 1.0f, glm::vec3(1, 0, 0));
  const glm::vec3 pivot(glm::inverse(model->inverse_bind[joint])[3]);
  InstancePtr instance(model->asset);
  REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0) == SF_OK);

  sf_eval_options options{};
  options.method = SF_METHOD_LBS;
  REQUIRE(sf_instance_evaluate(instance, &options) == SF_OK);
  const Evaluated lbs = skelform::test::write_all(instance, model->asset);
  options.method = SF_METHOD_DQS;
  REQUIRE(sf_instance_evaluate(instance, &options) == SF_OK);
  const Evaluated dqs = skelform::test::write_all(instance, model->asset);

  // The baselines against the double-precision reference.
  const std::vector<glm::dvec3> reference_lbs = reference_skinning(*model, pose, false);
  const std::vector<glm::dvec3> reference_dqs = reference_skinning(*model, pose, true);
  double lbs_error = 0, dqs_error = 0;
  for (size_t v = 0; v < reference_lbs.size(); ++v) {
    lbs_error = std::max(lbs_error, glm::length(glm::dvec3(lbs.positions[v]) - reference_lbs[v]) / model->diagonal);
    dqs_error = std::max(dqs_error, glm::length(glm::dvec3(dqs.positions[v]) - reference_dqs[v]) / model->diagonal);
  }
  MESSAGE("CesiumMan joint " << joint << " bent 1 rad: LBS vs reference " << lbs_error << ", DQS vs reference "
                             << dqs_error << " of the diagonal");
  CHECK(lbs_error < 1e-5);
  CHECK(dqs_error < 1e-5);

  for (const uint32_t reconstruction : {uint32_t(SF_RECONSTRUCTION_CARRIED), uint32_t(SF_RECONSTRUCTION_PAPER)}) {
    options = {};
    options.reconstruction = reconstruction;
    options.flags = SF_EVAL_FROM_REST;
    REQUIRE(sf_instance_evaluate(instance, &options) == SF_OK);
    const Evaluated ours = skelform::test::write_all(instance, model->asset);
    std::vector<double> all, far;
    bool finite = true;
    for (size_t v = 0; v < ours.positions.size(); ++v) {
      finite = finite && std::isfinite(ours.positions[v].x + ours.positions[v].y + ours.positions[v].z) &&
               std::isfinite(ours.normals[v].x + ours.normals[v].y + ours.normals[v].z);
      const double distance = double(glm::length(ours.positions[v] - lbs.positions[v])) / model->diagonal;
      all.push_back(distance);
      if (glm::length(lbs.positions[v] - pivot) > 0.25 * model->diagonal) far.push_back(distance);
    }
    CHECK(finite);
    REQUIRE(!far.empty());
    std::nth_element(all.begin(), all.begin() + all.size() / 2, all.end());
    std::nth_element(far.begin(), far.begin() + far.size() / 2, far.end());
    const double far_max = *std::max_element(far.begin(), far.end());
    double moved = 0;
    for (size_t v = 0; v < lbs.positions.size(); ++v)
      moved = std::max(moved, double(glm::length(lbs.positions[v] - model->primitives[0].positions[v])));
    const double all_max = *std::max_element(all.begin(), all.end());
    MESSAGE("CesiumMan bent, " << std::string(reconstruction ? "paper" : "carried")
                               << " reconstruction vs LBS (which moves vertices up to " << moved / model->diagonal
                               << "): median " << all[all.size() / 2] << ", max " << all_max
                               << ", median away from the joint " << far[far.size() / 2] << ", max away " << far_max
                               << " of the diagonal");
    CHECK(all[all.size() / 2] < 0.01);
    CHECK(far[far.size() / 2] < 0.002);
  }
}

TEST_CASE("evaluate: the handle driver drags the capsule's tip toward its target and bad handle sets are refused") {
  const RuntimeModel& model = skelform::test::capsule_model();
  InstancePtr instance(model.asset);
  // The tip (largest z of the capsule) is the handle, the bottom (smallest z) is pinned.
  const auto& positions = model.primitives[0].positions;
  uint32_t top = 0, bottom = 0;
  for (uint32_t i = 0; i < positions.size(); ++i) {
    if (positions[i].z > positions[top].z) top = i;
    if (positions[i].z < positions[bottom].z) bottom = i;
  }
  CHECK(sf_instance_set_handle_set(instance, &top, 1, &top, 1) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(std::string(sf_instance_last_error(instance)).find("same skeletal vertex") != std::string::npos);
  CHECK(sf_instance_set_handle_set(instance, nullptr, 0, &bottom, 1) == SF_ERROR_INVALID_ARGUMENT);
  const uint32_t out_of_range = 1u << 30;
  CHECK(sf_instance_set_handle_set(instance, &out_of_range, 1, nullptr, 0) == SF_ERROR_INVALID_ARGUMENT);
  const float early[3] = {0, 0, 0};
  CHECK(sf_instance_set_handle_targets(instance, early, 1, 0) == SF_ERROR_NOT_READY);

  REQUIRE_MESSAGE(sf_instance_set_handle_set(instance, &top, 1, &bottom, 1) == SF_OK, sf_instance_last_error(instance));
  const glm::vec3 target = positions[top] + glm::vec3(0.3f, 0.0f, 0.0f);
  CHECK(sf_instance_set_handle_targets(instance, &target.x, 2, 0) == SF_ERROR_INVALID_ARGUMENT);
  const float nan_target[3] = {NAN, 0, 0};
  CHECK(sf_instance_set_handle_targets(instance, nan_target, 1, 0) == SF_ERROR_INVALID_ARGUMENT);
  REQUIRE(sf_instance_set_handle_targets(instance, &target.x, 1, 0) == SF_OK);
  sf_eval_options options{};
  options.method = SF_METHOD_LBS;
  CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_UNSUPPORTED);
  options = {};
  REQUIRE_MESSAGE(sf_instance_evaluate(instance, &options) == SF_OK, sf_instance_last_error(instance));
  const Evaluated moved = skelform::test::write_all(instance, model.asset);
  bool finite = true;
  for (const glm::vec3& p : moved.positions) finite = finite && std::isfinite(p.x + p.y + p.z);
  CHECK(finite);
  // The tip follows its target (the control handle is the nearest control vertex, so not
  // to the last digit), the pinned bottom stays.
  CHECK(moved.positions[top].x > positions[top].x + 0.2f);
  CHECK(glm::length(moved.positions[bottom] - positions[bottom]) < 0.01f);
  // Back to the skin driver: identity joints give the rest pose again.
  const glm::mat4 identity[2] = {glm::mat4(1.0f), glm::mat4(1.0f)};
  REQUIRE(sf_instance_set_joint_matrices(instance, &identity[0][0][0], 2, 0) == SF_OK);
  REQUIRE(sf_instance_evaluate(instance, nullptr) == SF_OK);
  CHECK(glm::length(skelform::test::write_all(instance, model.asset).positions[top] - positions[top]) < 1e-5f);
}

TEST_CASE("evaluate: invalid calls are refused with their result and a message and change nothing") {
  const RuntimeModel& model = skelform::test::capsule_model();
  sf_instance* none = nullptr;
  CHECK(sf_instance_create(nullptr, 0, &none) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(none == nullptr);
  CHECK(sf_instance_create(model.asset, 7, &none) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_create(model.asset, 0, nullptr) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_evaluate(nullptr, nullptr) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(std::string(sf_instance_last_error(nullptr)).empty());
  sf_instance_destroy(nullptr);

  InstancePtr instance(model.asset);
  CHECK(std::string(sf_instance_last_error(instance)).empty());
  float buffer[3] = {};
  sf_vertex_output output{};
  output.positions = buffer;
  output.vertex_capacity = 1u << 20;
  CHECK(sf_instance_write(instance, 0, &output) == SF_ERROR_NOT_READY);
  CHECK(!std::string(sf_instance_last_error(instance)).empty());

  glm::mat4 pose[3] = {glm::mat4(1.0f), glm::mat4(1.0f), glm::mat4(1.0f)};
  CHECK(sf_instance_set_joint_matrices(instance, &pose[0][0][0], 3, 0) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(std::string(sf_instance_last_error(instance)).find("2 joints") != std::string::npos);
  CHECK(sf_instance_set_joint_matrices(instance, &pose[0][0][0], 1, 0) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_set_joint_matrices(instance, nullptr, 2, 0) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_set_joint_matrices(instance, &pose[0][0][0], 2, 32) == SF_ERROR_INVALID_ARGUMENT);
  pose[1][3][2] = NAN;
  CHECK(sf_instance_set_joint_matrices(instance, &pose[0][0][0], 2, 0) == SF_ERROR_INVALID_ARGUMENT);
  pose[1][3][2] = INFINITY;
  CHECK(sf_instance_set_joint_matrices(instance, &pose[0][0][0], 2, 0) == SF_ERROR_INVALID_ARGUMENT);

  sf_eval_options options{};
  options.fairing_flags = 0x80;
  CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(std::string(sf_instance_last_error(instance)).find("fairing_flags") != std::string::npos);
  options = {};
  options.fairing_step = -0.1f;
  CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
  options.fairing_step = NAN;
  CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
  options = {};
  options.intersection_step = INFINITY;
  CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
  options = {};
  options.intersection_grid = 33;
  CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
  options = {};
  options.fairing_iterations = 1001;
  CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
  options = {};
  options.method = 9;
  CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
  options = {};
  options.reconstruction = 2;
  CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
  options = {};
  options.flags = 0x80;
  CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
  // Nothing was evaluated by the refused calls.
  CHECK(sf_instance_write(instance, 0, &output) == SF_ERROR_NOT_READY);

  // The refused NaN pose left the identity in place: the rest pose comes out.
  REQUIRE(sf_instance_evaluate(instance, nullptr) == SF_OK);
  CHECK(sf_instance_write(instance, 2, &output) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_write(instance, 0, nullptr) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(std::string(sf_instance_last_error(instance)).find("NULL") != std::string::npos);
  const Evaluated rest = skelform::test::write_all(instance, model.asset);
  CHECK(glm::length(rest.positions[0] - model.primitives[0].positions[0]) < 1e-5f);
}

TEST_CASE("evaluate: evaluation and output never allocate and everything the instance allocated is freed") {
  const RuntimeModel& model = skelform::test::capsule_model();
  skelform::test::CountingHeap counter;
  const sf_allocator allocator = counter.callbacks();
  sf_load_options load{};
  load.allocator = &allocator;
  sf_asset* asset = nullptr;
  REQUIRE(sf_asset_load_memory(model.baked_glb.data(), model.baked_glb.size(), &load, &asset) == SF_OK);
  const long after_load = counter.allocations.load();
  CHECK(after_load > 0);
  sf_instance* instance = nullptr;
  REQUIRE(sf_instance_create(asset, 0, &instance) == SF_OK);
  CHECK(counter.allocations.load() > after_load);  // the instance's buffers come from the asset's allocator

  uint32_t top = 0;
  const auto& positions = model.primitives[0].positions;
  for (uint32_t i = 0; i < positions.size(); ++i)
    if (positions[i].z > positions[top].z) top = i;
  REQUIRE(sf_instance_set_handle_set(instance, &top, 1, nullptr, 0) == SF_OK);  // allocates: allowed
  REQUIRE(sf_instance_set_contacts(instance, 1) == SF_OK);                      // allocates: allowed

  const long before = counter.allocations.load();
  const std::vector<glm::mat4> pose = skelform::test::bend_pose(model, 1, 0.8f, glm::vec3(1, 0, 0));
  for (const Variant& variant : variants())
    for (const uint32_t flags : {uint32_t(SF_EVAL_FROM_REST), 0u, uint32_t(SF_EVAL_SKIP_NORMALS)}) {
      REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0) == SF_OK);
      sf_eval_options options = variant.options;
      options.flags = flags;
      REQUIRE(sf_instance_evaluate(instance, &options) == SF_OK);
      skelform::test::write_all(instance, asset);
    }
  const glm::vec3 target = positions[top] + glm::vec3(0.1f);
  REQUIRE(sf_instance_set_handle_targets(instance, &target.x, 1, 0) == SF_OK);
  REQUIRE(sf_instance_evaluate(instance, nullptr) == SF_OK);
  skelform::test::write_all(instance, asset);
  CHECK(sf_instance_evaluate(instance, nullptr) == SF_OK);
  CHECK(counter.allocations.load() == before);

  sf_instance_destroy(instance);
  sf_asset_destroy(asset);
  CHECK(counter.allocations.load() == counter.frees.load());
}
