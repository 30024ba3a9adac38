// The threading contract (skelform.h "Ownership and threads"): one immutable asset shared by
// many instances on many threads at once. 8 threads × 16 instances of one asset evaluate 128
// different poses concurrently (8 × 4 under ThreadSanitizer); every result must be bit-identical to the same pose evaluated
// on one thread; and one instance skinned by sf_instance_skin_range from 8 threads at once gives
// sf_instance_evaluate + sf_instance_write's LBS. A TSan build runs this test too (README:
// -DSKELFORM_SANITIZE=thread).
#include "runtime/runtime_models.h"

#include <algorithm>
#include <cstring>
#include <thread>

namespace {

constexpr int kThreads = 8;
// Under ThreadSanitizer every memory access is instrumented (~100× slower): 4 instances per
// thread still run every thread against the shared asset at once, which is what the race
// detector needs, in a fraction of the time.
#if defined(__SANITIZE_THREAD__)
constexpr int kInstancesPerThread = 4;
#else
constexpr int kInstancesPerThread = 16;
#endif

// Pose `index`: the child joint bent about a tilted axis, a different angle per index.
std::vector<glm::mat4> pose_of(const skelform::test::RuntimeModel& model, size_t joint, int index) {
  const float angle = -1.2f + 2.4f * float(index) / float(kThreads * kInstancesPerThread);
  const glm::vec3 axis = glm::normalize(glm::vec3(1.0f, 0.3f * float(index % 5), 0.2f));
  return skelform::test::bend_pose(model, joint, angle, axis);
}

// Every vertex of deformable 0 into `out` (positions, normals, tangents per primitive),
// without doctest assertions (workers must not assert); false on any failure.
bool write_outputs(const sf_asset* asset, const sf_instance* instance, std::vector<float>& out) {
  sf_deformable_info info{};
  if (sf_asset_deformable_info(asset, 0, &info) != SF_OK) return false;
  for (uint32_t p = 0; p < info.primitive_count; ++p) {
    sf_primitive_info pinfo{};
    if (sf_asset_primitive_info(asset, 0, p, &pinfo) != SF_OK) return false;
    const size_t n = pinfo.vertex_count, at = out.size();
    out.resize(at + n * (pinfo.has_tangents ? 10 : 6));
    sf_vertex_output o{};
    o.positions = out.data() + at;
    o.normals = out.data() + at + 3 * n;
    o.tangents = pinfo.has_tangents ? out.data() + at + 6 * n : nullptr;
    o.vertex_capacity = n;
    if (sf_instance_write(instance, p, &o) != SF_OK) return false;
  }
  return true;
}

// One instance's whole frame sequence: skelform from rest, skelform incremental with the
// paper's homotopy, DQS skeleton, and the two baselines; every output concatenated.
std::vector<float> run_sequence(const skelform::test::RuntimeModel& model, sf_instance* instance,
                                const std::vector<glm::mat4>& pose) {
  std::vector<float> bytes;
  bytes.reserve(1 << 16);
  if (sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0) != SF_OK) return {};
  sf_eval_options steps[5] = {};
  steps[0].flags = SF_EVAL_FROM_REST;
  steps[1].reconstruction = SF_RECONSTRUCTION_PAPER;
  steps[2].skeleton_skinning = SF_SKELETON_DQS;
  steps[3].method = SF_METHOD_LBS;
  steps[4].method = SF_METHOD_DQS;
  for (const sf_eval_options& options : steps) {
    if (sf_instance_evaluate(instance, &options) != SF_OK) return {};
    if (!write_outputs(model.asset, instance, bytes)) return {};
  }
  return bytes;
}

void check_threads(const skelform::test::RuntimeModel& model, size_t joint) {
  constexpr int total = kThreads * kInstancesPerThread;
  std::vector<std::vector<glm::mat4>> poses;
  for (int i = 0; i < total; ++i) poses.push_back(pose_of(model, joint, i));

  // Reference: every pose on this thread, one instance reused (results do not depend on
  // which instance computed them, only on its own sequence).
  std::vector<std::vector<float>> reference(total);
  {
    sf_instance* instance = nullptr;
    REQUIRE(sf_instance_create(model.asset, 0, &instance) == SF_OK);
    for (int i = 0; i < total; ++i) {
      reference[size_t(i)] = run_sequence(model, instance, poses[size_t(i)]);
      REQUIRE(!reference[size_t(i)].empty());
    }
    sf_instance_destroy(instance);
  }

  // Instances are created up front on the main thread, then 8 threads evaluate their 16 at
  // once. doctest's CHECK is not thread-safe: workers only record their results.
  std::vector<sf_instance*> instances(total, nullptr);
  for (sf_instance*& instance : instances) REQUIRE(sf_instance_create(model.asset, 0, &instance) == SF_OK);
  std::vector<std::vector<float>> results(total);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      for (int round = 0; round < 2; ++round)  // interleave more: every instance twice
        for (int i = t * kInstancesPerThread; i < (t + 1) * kInstancesPerThread; ++i)
          results[size_t(i)] = run_sequence(model, instances[size_t(i)], poses[size_t(i)]);
    });
  for (std::thread& thread : threads) thread.join();
  for (sf_instance* instance : instances) sf_instance_destroy(instance);

  int identical = 0;
  for (int i = 0; i < total; ++i) {
    const auto& a = results[size_t(i)];
    const auto& b = reference[size_t(i)];
    if (a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0) ++identical;
  }
  MESSAGE(model.name << ": " << identical << " of " << total << " concurrent evaluations bit-identical to one thread");
  CHECK(identical == total);
}

}  // namespace

TEST_CASE("threads: 8 threads x several instances of the capsule give the single-thread results bit for bit") {
  check_threads(skelform::test::capsule_model(), 1);
}

TEST_CASE("threads: 8 threads x several instances of CesiumMan give the single-thread results bit for bit") {
  const skelform::test::RuntimeModel* model = skelform::test::sample_model("CesiumMan/CesiumMan.glb");
  if (!model) return;
  // Bend a joint near the middle of the skin's joint list (some limb), any works for the contract.
  check_threads(*model, model->inverse_bind.size() / 2);
}

TEST_CASE("threads: sf_instance_skin_range on one instance from 8 threads at once gives evaluate + write's bits") {
  // One character split as a job system splits it: each thread skins every eighth block of 16
  // vertices of every primitive into one shared buffer (disjoint ranges), and the whole
  // primitive into a buffer of its own (the same ranges read at once by every thread).
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model.asset, 0, &info) == SF_OK);
  skelform::test::InstancePtr instance(model.asset);
  const std::vector<glm::mat4> pose = pose_of(model, 1, 3);
  REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0) == SF_OK);
  sf_eval_options lbs{};
  lbs.method = SF_METHOD_LBS;
  REQUIRE(sf_instance_evaluate(instance, &lbs) == SF_OK);
  std::vector<float> reference;
  REQUIRE(write_outputs(model.asset, instance, reference));

  std::vector<sf_primitive_info> primitives(info.primitive_count);
  for (uint32_t p = 0; p < info.primitive_count; ++p)
    REQUIRE(sf_asset_primitive_info(model.asset, 0, p, &primitives[p]) == SF_OK);
  // write_outputs' layout: per primitive, positions, normals, then tangents if any.
  auto layout = [&](std::vector<float>& out, uint32_t p, uint32_t first, uint32_t count) {
    size_t at = 0;
    for (uint32_t q = 0; q < p; ++q) at += primitives[q].vertex_count * (primitives[q].has_tangents ? 10 : 6);
    const size_t n = primitives[p].vertex_count;
    sf_vertex_output o{};
    o.positions = out.data() + at + 3 * first;
    o.normals = out.data() + at + 3 * n + 3 * first;
    o.tangents = primitives[p].has_tangents ? out.data() + at + 6 * n + 4 * first : nullptr;
    o.vertex_capacity = count;
    return o;
  };
  constexpr uint32_t kBlock = 16;
  std::vector<float> shared(reference.size(), 0.0f);
  std::vector<std::vector<float>> own(kThreads, std::vector<float>(reference.size(), 0.0f));
  std::vector<int> failures(kThreads, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      for (uint32_t p = 0; p < info.primitive_count; ++p) {
        const uint32_t n = primitives[p].vertex_count;
        for (uint32_t first = uint32_t(t) * kBlock; first < n; first += kThreads * kBlock) {
          const uint32_t count = std::min(kBlock, n - first);
          const sf_vertex_output o = layout(shared, p, first, count);
          failures[size_t(t)] += sf_instance_skin_range(instance, SF_METHOD_LBS, p, first, count, &o) != SF_OK;
        }
        const sf_vertex_output whole = layout(own[size_t(t)], p, 0, n);
        failures[size_t(t)] += sf_instance_skin_range(instance, SF_METHOD_LBS, p, 0, n, &whole) != SF_OK;
      }
    });
  for (std::thread& thread : threads) thread.join();
  for (int t = 0; t < kThreads; ++t) {
    CHECK(failures[size_t(t)] == 0);
    CHECK(std::memcmp(own[size_t(t)].data(), reference.data(), reference.size() * sizeof(float)) == 0);
  }
  CHECK(std::memcmp(shared.data(), reference.data(), reference.size() * sizeof(float)) == 0);
}
