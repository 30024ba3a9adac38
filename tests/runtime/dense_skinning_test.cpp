// SF_METHOD_LBS's kernels (runtime/src/dense_skinning.cpp): SSE2 and AVX2 (when this build
// and CPU have them) give the portable loop's floats bit for bit, positions, normals and
// tangents, on the capsule (authored tangents, a primitive without) and the Khronos samples,
// under random similarity poses, non-uniform scale and shear, and joints collapsed to a point
// (whose normals fall back to the rest normal). The kernel the runtime picks is one of them.
#include "glb_edit.h"
#include "instance.h"
#include "runtime/runtime_models.h"

#include <doctest/doctest.h>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cstring>
#include <random>
#include <string>
#include <vector>

namespace {

using skelform::runtime::Blend;
using skelform::runtime::DenseOutput;
using skelform::runtime::LinearKernel;

struct Output {
  explicit Output(size_t n)
      : positions(n, glm::vec3(7.0f)), normals(n, glm::vec3(7.0f)), tangents(n, glm::vec4(7.0f)) {}
  DenseOutput view() { return {positions.data(), normals.data(), tangents.data()}; }
  bool operator==(const Output& o) const {
    return std::memcmp(positions.data(), o.positions.data(), positions.size() * sizeof(glm::vec3)) == 0 &&
           std::memcmp(normals.data(), o.normals.data(), normals.size() * sizeof(glm::vec3)) == 0 &&
           std::memcmp(tangents.data(), o.tangents.data(), tangents.size() * sizeof(glm::vec4)) == 0;
  }
  std::vector<glm::vec3> positions, normals;
  std::vector<glm::vec4> tangents;
};

// Per joint: a random rotation and translation, times a uniform scale (kind 0), a
// non-uniform scale with shear (kind 1), every second joint collapsed to a point (kind 2), or
// a bottom row far from (0, 0, 0, 1) (kind 3: LBS ignores it, lane 3 of the AVX2 kernel's
// columns carries it).
std::vector<glm::mat4> random_pose(size_t joints, int kind, std::mt19937& random) {
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), scale(0.5f, 2.0f);
  std::vector<glm::mat4> pose(joints);
  for (size_t j = 0; j < joints; ++j) {
    const glm::vec3 axis = glm::normalize(glm::vec3(unit(random), unit(random), unit(random)) + glm::vec3(0, 0, 1e-3f));
    glm::mat4 m = glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(unit(random), unit(random), unit(random))),
                              3.0f * unit(random), axis);
    if (kind == 0) m = glm::scale(m, glm::vec3(scale(random)));
    if (kind == 1) {
      m = glm::scale(m, glm::vec3(scale(random), scale(random), scale(random)));
      m[1][0] += 0.3f * unit(random);  // shear
    }
    if (kind == 2 && j % 2 == 1) m = glm::mat4(glm::vec4(0.0f), glm::vec4(0.0f), glm::vec4(0.0f), m[3]);
    if (kind == 3)
      for (int c = 0; c < 4; ++c) m[c][3] = 3e38f;
    pose[j] = m;
  }
  return pose;
}

void check_kernels(const sf_asset* asset, const std::string& name) {
  INFO(name);
  sf_instance* instance = nullptr;
  REQUIRE(sf_instance_create(asset, 0, &instance) == SF_OK);
  const skelform::runtime::Deformable& d = *instance->deformable;
  REQUIRE(d.joint_count > 0);
  std::mt19937 random(20261127);
  for (int kind = 0; kind < 4; ++kind)
    for (int trial = 0; trial < 3; ++trial) {
      CAPTURE(kind);
      const std::vector<glm::mat4> pose = random_pose(d.joint_count, kind, random);
      REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0) == SF_OK);
      for (bool with_normals : {true, false}) {
        Output portable(d.vertex_count);
        CHECK(skelform::runtime::dense_skinning_linear(d, instance->joints, LinearKernel::portable, with_normals,
                                                       portable.view()));  // these poses stay finite
        for (LinearKernel kernel : {LinearKernel::sse2, LinearKernel::avx2}) {
          if (!skelform::runtime::linear_kernel_available(kernel)) continue;
          CAPTURE(int(kernel));
          Output out(d.vertex_count);
          CHECK(skelform::runtime::dense_skinning_linear(d, instance->joints, kernel, with_normals, out.view()));
          CHECK(out == portable);
        }
        Output chosen(d.vertex_count);
        CHECK(skelform::runtime::dense_skinning(d, instance->joints, Blend::linear, with_normals, chosen.view()));
        CHECK(chosen == portable);
      }
    }
  sf_instance_destroy(instance);
}

}  // namespace

TEST_CASE("dense skinning: every LBS kernel gives the portable loop's bits") {
  const std::string sse2 = skelform::runtime::linear_kernel_available(LinearKernel::sse2) ? "sse2 " : "";
  const std::string avx2 =
      skelform::runtime::linear_kernel_available(LinearKernel::avx2) ? "avx2" : "(no avx2 on this CPU/build)";
  MESSAGE("kernels compared with the portable loop: " << sse2 << avx2);
  check_kernels(skelform::test::capsule_model().asset, "capsule");
  for (const std::string& name : skelform::test::sample_names())
    if (const skelform::test::RuntimeModel* model = skelform::test::sample_model(name))
      check_kernels(model->asset, name);
}

TEST_CASE("dense skinning: with 8 and 12 influences too (the AVX2 kernel's other forms)") {
  // The capsule with its skin repeated in JOINTS_1 (and JOINTS_2): every asset of the data
  // directory has 4 influences, so only this reaches the kernels' 8-influence and generic loops.
  const skelform::test::RuntimeModel& capsule = skelform::test::capsule_model();
  for (int sets : {2, 3}) {
    CAPTURE(sets);
    skelform::test::Glb glb(capsule.baked_glb);
    for (auto& primitive : glb.json["meshes"][0]["primitives"]) {
      auto& attributes = primitive["attributes"];
      for (int set = 1; set < sets; ++set) {
        attributes["JOINTS_" + std::to_string(set)] = attributes["JOINTS_0"];
        attributes["WEIGHTS_" + std::to_string(set)] = attributes["WEIGHTS_0"];
      }
    }
    const std::string bytes = glb.bytes();
    char message[512] = {};
    sf_load_options load{};
    load.error_message = message;
    load.error_message_capacity = sizeof message;
    sf_asset* asset = nullptr;
    REQUIRE_MESSAGE(sf_asset_load_memory(bytes.data(), bytes.size(), &load, &asset) == SF_OK, message);
    sf_instance* instance = nullptr;
    REQUIRE(sf_instance_create(asset, 0, &instance) == SF_OK);
    CHECK(instance->deformable->influences == uint32_t(4 * sets));
    sf_instance_destroy(instance);
    check_kernels(asset, "capsule, " + std::to_string(sets) + " influence sets");
    sf_asset_destroy(asset);
  }
}

TEST_CASE("dense skinning: every LBS kernel finds the positions that overflow where the portable loop does") {
  // z scaled by 3.4e38 (x, y kept): the capsule's vertices above z ≈ 1 overflow, those below do
  // not. Every range of one and of two vertices (both parities: the AVX2 kernel's pairs) gets
  // each kernel's verdict, which must be the portable loop's, on both primitives (with and
  // without tangents); and the verdicts must be of both kinds, or the test proves nothing.
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  skelform::test::InstancePtr instance(model.asset);
  const skelform::runtime::Deformable& d = *instance.instance->deformable;
  glm::mat4 stretch(1.0f);
  stretch[2][2] = 3.4e38f;
  const std::vector<glm::mat4> pose(d.joint_count, stretch);
  REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0) == SF_OK);
  size_t finite = 0, overflowing = 0;
  for (uint32_t p = 0; p < d.primitives.size(); ++p) {
    const uint32_t n = d.primitives[p].vertex_count;
    std::vector<float> buffer(16 * size_t{n});
    auto verdict = [&](LinearKernel kernel, uint32_t first, uint32_t count) {
      const skelform::runtime::StridedOutput out{
          reinterpret_cast<unsigned char*>(buffer.data()),
          64,
          reinterpret_cast<unsigned char*>(buffer.data() + 4),
          64,
          d.primitives[p].has_tangents ? reinterpret_cast<unsigned char*>(buffer.data() + 8) : nullptr,
          64};
      return skelform::runtime::dense_skinning_linear_range(d, instance.instance->joints, kernel, p, first, count, out);
    };
    for (uint32_t count : {1u, 2u})
      for (uint32_t first = 0; first + count <= n; ++first) {
        const bool expected = verdict(LinearKernel::portable, first, count);
        (expected ? finite : overflowing) += 1;
        for (LinearKernel kernel : {LinearKernel::sse2, LinearKernel::avx2})
          if (skelform::runtime::linear_kernel_available(kernel)) {
            CAPTURE(p);
            CAPTURE(first);
            CAPTURE(count);
            CAPTURE(int(kernel));
            CHECK(verdict(kernel, first, count) == expected);
          }
      }
  }
  MESSAGE("ranges finite / overflowing: " << finite << " / " << overflowing);
  CHECK(finite > 0);
  CHECK(overflowing > 0);
}

namespace {

// Interleaved vertex buffer of one primitive as an engine lays it out: position, a gap,
// normal, a gap, tangent, a gap (16 floats per vertex), filled with a marker.
constexpr size_t kStrideFloats = 16;
constexpr float kMarker = -12345.0f;

sf_vertex_output interleaved(std::vector<float>& buffer, size_t count, bool normals, bool tangents) {
  buffer.assign(count * kStrideFloats, kMarker);
  sf_vertex_output o{};
  o.positions = buffer.data();
  o.position_stride = kStrideFloats * sizeof(float);
  o.normals = normals ? buffer.data() + 4 : nullptr;
  o.normal_stride = kStrideFloats * sizeof(float);
  o.tangents = tangents ? buffer.data() + 8 : nullptr;
  o.tangent_stride = kStrideFloats * sizeof(float);
  o.vertex_capacity = count;
  return o;
}

// sf_instance_skin_range over a whole primitive in uneven ranges against sf_instance_evaluate
// + sf_instance_write of the same method: the same bits, gaps untouched.
void check_ranges(const skelform::test::RuntimeModel& model) {
  INFO(model.name);
  skelform::test::InstancePtr ranged(model.asset), evaluated(model.asset);
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model.asset, 0, &info) == SF_OK);
  std::mt19937 random(7);
  for (int kind = 0; kind < 2; ++kind) {
    const std::vector<glm::mat4> pose = random_pose(info.joint_count, kind, random);
    REQUIRE(sf_instance_set_joint_matrices(ranged, &pose[0][0][0], pose.size(), 0) == SF_OK);
    REQUIRE(sf_instance_set_joint_matrices(evaluated, &pose[0][0][0], pose.size(), 0) == SF_OK);
    for (uint32_t method : {uint32_t(SF_METHOD_LBS), uint32_t(SF_METHOD_DQS)}) {
      CAPTURE(method);
      sf_eval_options options{};
      options.method = method;
      REQUIRE(sf_instance_evaluate(evaluated, &options) == SF_OK);
      for (uint32_t p = 0; p < info.primitive_count; ++p) {
        sf_primitive_info pinfo{};
        REQUIRE(sf_asset_primitive_info(model.asset, 0, p, &pinfo) == SF_OK);
        const size_t n = pinfo.vertex_count;
        std::vector<float> expected, got;
        const sf_vertex_output whole = interleaved(expected, n, true, pinfo.has_tangents != 0);
        REQUIRE(sf_instance_write(evaluated, p, &whole) == SF_OK);
        interleaved(got, n, true, pinfo.has_tangents != 0);
        // Ranges of 1, 7, 55, 439, ... vertices, the last one what is left.
        for (uint32_t first = 0, size = 1; first < n; first += size, size = size * 8 - 1) {
          const uint32_t count = std::min<uint32_t>(size, uint32_t(n) - first);
          sf_vertex_output part = whole;
          part.vertex_capacity = count;
          part.positions = got.data() + first * kStrideFloats;
          part.normals = part.positions + 4;
          part.tangents = pinfo.has_tangents ? part.positions + 8 : nullptr;
          REQUIRE(sf_instance_skin_range(ranged, method, p, first, count, &part) == SF_OK);
        }
        CHECK(std::memcmp(got.data(), expected.data(), got.size() * sizeof(float)) == 0);
        // Positions only: the normal and tangent slots keep the marker.
        std::vector<float> positions_only;
        const sf_vertex_output bare = interleaved(positions_only, n, false, false);
        REQUIRE(sf_instance_skin_range(ranged, method, p, 0, uint32_t(n), &bare) == SF_OK);
        bool same_positions = true, slots_untouched = true;
        for (size_t v = 0; v < n; ++v) {
          same_positions &= std::memcmp(&positions_only[v * kStrideFloats], &expected[v * kStrideFloats], 12) == 0;
          for (size_t k = 3; k < kStrideFloats; ++k)
            slots_untouched &= positions_only[v * kStrideFloats + k] == kMarker;
        }
        CHECK(same_positions);
        CHECK(slots_untouched);
      }
    }
  }
}

}  // namespace

TEST_CASE("dense skinning: sf_instance_skin_range gives evaluate + write's bits, range by range, in place") {
  check_ranges(skelform::test::capsule_model());
  for (const std::string& name : skelform::test::sample_names())
    if (const skelform::test::RuntimeModel* model = skelform::test::sample_model(name)) check_ranges(*model);
}

TEST_CASE("dense skinning: sf_instance_skin_range refuses bad calls with their code and changes nothing") {
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  skelform::test::InstancePtr instance(model.asset);
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model.asset, 0, &info) == SF_OK);
  sf_primitive_info pinfo{}, plain{};
  REQUIRE(sf_asset_primitive_info(model.asset, 0, 0, &pinfo) == SF_OK);
  REQUIRE(pinfo.has_tangents == 1);
  REQUIRE(info.primitive_count == 2);
  REQUIRE(sf_asset_primitive_info(model.asset, 0, 1, &plain) == SF_OK);
  REQUIRE(plain.has_tangents == 0);
  const uint32_t n = pinfo.vertex_count;
  std::vector<float> buffer;
  const sf_vertex_output o = interleaved(buffer, n, true, true);
  const std::vector<float> untouched = buffer;
  // The instance's message is a previous call's, and stays: this call keeps none.
  CHECK(sf_instance_set_joint_matrices(instance, nullptr, 1, 0) == SF_ERROR_INVALID_ARGUMENT);
  const std::string message = sf_instance_last_error(instance);
  REQUIRE(!message.empty());
  CHECK(sf_instance_skin_range(nullptr, SF_METHOD_LBS, 0, 0, n, &o) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 0, 0, n, nullptr) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_skin_range(instance, 7, 0, 0, n, &o) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_SKELFORM, 0, 0, n, &o) == SF_ERROR_UNSUPPORTED);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 2, 0, 1, &o) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 0, 1, n, &o) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 0, n + 1, 0, &o) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 0, 1, 0xffffffffu, &o) == SF_ERROR_INVALID_ARGUMENT);
  sf_vertex_output small = o;
  small.vertex_capacity = n - 1;
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 0, 0, n, &small) == SF_ERROR_INVALID_ARGUMENT);
  for (int stream = 0; stream < 3; ++stream) {
    sf_vertex_output narrow = o;
    (stream == 0   ? narrow.position_stride
     : stream == 1 ? narrow.normal_stride
                   : narrow.tangent_stride) = stream == 2 ? 12 : 8;
    CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 0, 0, n, &narrow) == SF_ERROR_INVALID_ARGUMENT);
  }
  std::vector<float> other;
  const sf_vertex_output tangents = interleaved(other, plain.vertex_count, true, true);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 1, 0, plain.vertex_count, &tangents) == SF_ERROR_UNSUPPORTED);
  CHECK(buffer == untouched);
  CHECK(sf_instance_last_error(instance) == message);
  // A pose whose positions overflow: refused (the range's buffers then hold anything).
  // (A uniform scale and a translation near FLT_MAX: p·s + t overflows wherever p > 0.)
  glm::mat4 scaled(3.4e38f);
  scaled[3] = glm::vec4(3.4e38f, 3.4e38f, 3.4e38f, 1.0f);
  std::vector<glm::mat4> huge(info.joint_count, scaled);
  REQUIRE(sf_instance_set_joint_matrices(instance, &huge[0][0][0], huge.size(), 0) == SF_OK);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 0, 0, n, &o) == SF_ERROR_INVALID_ARGUMENT);
  sf_eval_options lbs{};
  lbs.method = SF_METHOD_LBS;
  CHECK(sf_instance_evaluate(instance, &lbs) == SF_ERROR_INVALID_ARGUMENT);
  // DQS keeps this pose finite (the degenerate rotation leaves no stretch): both calls agree.
  sf_eval_options dqs{};
  dqs.method = SF_METHOD_DQS;
  const sf_result evaluated = sf_instance_evaluate(instance, &dqs);
  sf_result ranged = SF_OK;
  for (uint32_t p = 0; p < info.primitive_count; ++p) {
    sf_primitive_info each{};
    REQUIRE(sf_asset_primitive_info(model.asset, 0, p, &each) == SF_OK);
    std::vector<float> scratch;
    const sf_vertex_output to = interleaved(scratch, each.vertex_count, true, false);
    if (sf_instance_skin_range(instance, SF_METHOD_DQS, p, 0, each.vertex_count, &to) != SF_OK)
      ranged = SF_ERROR_INVALID_ARGUMENT;
  }
  CHECK(ranged == evaluated);
  // An empty range is a valid no-op.
  std::vector<float> empty;
  const sf_vertex_output none = interleaved(empty, 0, true, true);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 0, n, 0, &none) == SF_OK);
}

TEST_CASE("dense skinning: sf_instance_skin_range under the handle driver is unsupported") {
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  skelform::test::InstancePtr instance(model.asset);
  const uint32_t handle = 0, pinned = 1;
  REQUIRE(sf_instance_set_handle_set(instance, &handle, 1, &pinned, 1) == SF_OK);
  const float target[3] = {0.0f, 0.0f, 0.0f};
  REQUIRE(sf_instance_set_handle_targets(instance, target, 1, 0) == SF_OK);
  std::vector<float> buffer;
  const sf_vertex_output o = interleaved(buffer, 1, true, false);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 1, 0, 1, &o) == SF_ERROR_UNSUPPORTED);
  // Joint matrices select the skin again.
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model.asset, 0, &info) == SF_OK);
  const std::vector<glm::mat4> rest(info.joint_count, glm::mat4(1.0f));
  REQUIRE(sf_instance_set_joint_matrices(instance, &rest[0][0][0], rest.size(), 0) == SF_OK);
  CHECK(sf_instance_skin_range(instance, SF_METHOD_LBS, 1, 0, 1, &o) == SF_OK);
}

TEST_CASE("dense skinning: sf_instance_skin_range writes at any byte stride, as sf_instance_write does") {
  // 13-byte elements: every second position, normal and tangent starts off a 4-byte boundary.
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  skelform::test::InstancePtr instance(model.asset);
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model.asset, 0, &info) == SF_OK);
  std::mt19937 random(13);
  const std::vector<glm::mat4> pose = random_pose(info.joint_count, 0, random);
  REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0) == SF_OK);
  sf_eval_options lbs{};
  lbs.method = SF_METHOD_LBS;
  REQUIRE(sf_instance_evaluate(instance, &lbs) == SF_OK);
  for (uint32_t p = 0; p < info.primitive_count; ++p) {
    sf_primitive_info pinfo{};
    REQUIRE(sf_asset_primitive_info(model.asset, 0, p, &pinfo) == SF_OK);
    const size_t n = pinfo.vertex_count, stride = 13 + 13 + 17;
    std::vector<unsigned char> written(n * stride + 1, 0xAB), ranged(n * stride + 1, 0xAB);
    auto output = [&](std::vector<unsigned char>& bytes) {
      sf_vertex_output o{};
      o.positions = reinterpret_cast<float*>(bytes.data() + 1);
      o.position_stride = stride;
      o.normals = reinterpret_cast<float*>(bytes.data() + 1 + 13);
      o.normal_stride = stride;
      o.tangents = pinfo.has_tangents ? reinterpret_cast<float*>(bytes.data() + 1 + 26) : nullptr;
      o.tangent_stride = stride;
      o.vertex_capacity = n;
      return o;
    };
    const sf_vertex_output a = output(written), b = output(ranged);
    REQUIRE(sf_instance_write(instance, p, &a) == SF_OK);
    REQUIRE(sf_instance_skin_range(instance, SF_METHOD_LBS, p, 0, uint32_t(n), &b) == SF_OK);
    CHECK(written == ranged);
  }
}
