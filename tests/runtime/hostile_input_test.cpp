// Hostile and broken input to the runtime (issue 23): every asset or argument a game may be
// handed (mods, downloaded patches, a fuzzer) ends in an sf_result and a message, never in a
// crash, a hang, memory out of proportion to the input, or non-finite output reported as SF_OK.
// - a collapsed control mesh with tiny medial radii (the fairing grid's cells underflow) and
//   a huge medial radius (its search ring overflows an int) evaluate safely;
// - the runtime's documented limits: influence sets per deformable, homotopy steps, lengths,
//   stencil weights and barycentrics of an asset, bytes read from a file;
// - a pose whose output would not be finite is refused and the previous output kept;
// - sf_result_string of any value, files without an end (/dev/zero, a FIFO).
#include "asset.h"
#include "fair.h"
#include "glb_edit.h"
#include "runtime/runtime_models.h"

#include <doctest/doctest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <thread>
#include <vector>

namespace {

using skelform::test::Glb;
using Json = Glb::Json;

struct LoadResult {
  sf_result result = SF_OK;
  std::string message;
  sf_asset* asset = nullptr;
  LoadResult() = default;
  LoadResult(const LoadResult&) = delete;
  LoadResult& operator=(const LoadResult&) = delete;
  ~LoadResult() { sf_asset_destroy(asset); }
};

void load_bytes(const std::string& bytes, LoadResult& out) {
  char message[512] = "";
  sf_load_options options{};
  options.error_message = message;
  options.error_message_capacity = sizeof message;
  out.result = sf_asset_load_memory(bytes.data(), bytes.size(), &options, &out.asset);
  out.message = message;
}

// Loads `bytes` and checks the load is refused with `expected` and a message containing
// `fragment`, no asset made.
void check_refused(const std::string& bytes, sf_result expected, const std::string& fragment) {
  LoadResult load;
  load_bytes(bytes, load);
  CHECK_MESSAGE(load.result == expected, load.message);
  CHECK(load.asset == nullptr);
  CHECK_MESSAGE(load.message.find(fragment) != std::string::npos, load.message);
}

void load_path(const std::string& path, LoadResult& out) {
  char message[512] = "";
  sf_load_options options{};
  options.error_message = message;
  options.error_message_capacity = sizeof message;
  out.result = sf_asset_load_file(path.c_str(), &options, &out.asset);
  out.message = message;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

using skelform::test::InstancePtr;

// Every float value of an extension accessor set to `value`.
void fill_floats(Glb& glb, Json& accessor, size_t components, float value) {
  const size_t count = accessor["count"].get<size_t>() * components;
  for (size_t i = 0; i < count; ++i) glb.put_f32(glb.offset_of(accessor, i, 4), value);
}

struct Method {
  std::string name;
  sf_eval_options options;
};

// Each method and skeleton driver the pose goes through.
std::vector<Method> methods() {
  std::vector<Method> all;
  sf_eval_options o{};
  all.push_back({"skelform arcs", o});
  o.skeleton_skinning = SF_SKELETON_DQS;
  all.push_back({"skelform DQS skeleton", o});
  o = {};
  o.reconstruction = SF_RECONSTRUCTION_PAPER;
  all.push_back({"skelform paper homotopy", o});
  o = {};
  o.method = SF_METHOD_LBS;
  all.push_back({"LBS", o});
  o.method = SF_METHOD_DQS;
  all.push_back({"DQS", o});
  return all;
}

bool all_finite(const skelform::test::Evaluated& e) {
  for (size_t v = 0; v < e.positions.size(); ++v)
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(e.positions[v][k]) || !std::isfinite(e.normals[v][k])) return false;
  for (const glm::vec4& t : e.tangents)
    for (int k = 0; k < 4; ++k)
      if (!std::isfinite(t[k])) return false;
  return true;
}

bool same_bits(const skelform::test::Evaluated& a, const skelform::test::Evaluated& b) {
  return std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(glm::vec3)) == 0 &&
         std::memcmp(a.normals.data(), b.normals.data(), a.normals.size() * sizeof(glm::vec3)) == 0 &&
         std::memcmp(a.tangents.data(), b.tangents.data(), a.tangents.size() * sizeof(glm::vec4)) == 0;
}

// Evaluates the asset at rest and with its second joint bent, by every method: each call
// either succeeds with finite output or is refused with a message.
void evaluate_everything(const sf_asset* asset) {
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(asset, 0, &info) == SF_OK);
  for (const Method& method : methods()) {
    CAPTURE(method.name);
    InstancePtr instance(asset);
    for (int pose = 0; pose < 2; ++pose) {
      std::vector<glm::mat4> matrices(info.joint_count, glm::mat4(1.0f));
      if (pose == 1 && info.joint_count > 1)
        matrices[1] = glm::rotate(glm::mat4(1.0f), 1.2f, glm::vec3(1.0f, 0.0f, 0.0f));
      REQUIRE(sf_instance_set_joint_matrices(instance, &matrices[0][0][0], matrices.size(), 0) == SF_OK);
      const sf_result result = sf_instance_evaluate(instance, &method.options);
      if (result != SF_OK) {
        CHECK_MESSAGE(std::string(sf_instance_last_error(instance)) != "", sf_result_string(result));
        continue;
      }
      CHECK(all_finite(skelform::test::write_all(instance, asset)));
      // The coarse meshes too, which an engine may draw (sf_instance_write_coarse).
      std::vector<float> coarse(3 * size_t{info.control_vertex_count});
      for (uint32_t mesh : {uint32_t(SF_COARSE_CONTROL), uint32_t(SF_COARSE_SKELETAL)})
        if (sf_instance_write_coarse(instance, mesh, coarse.data(), 0, info.control_vertex_count) == SF_OK)
          CHECK(std::all_of(coarse.begin(), coarse.end(), [](float x) { return std::isfinite(x); }));
    }
  }
}

}  // namespace

TEST_SUITE("hostile input") {
  TEST_CASE("a control mesh collapsed to a point with tiny medial radii evaluates without a write out of bounds") {
    // Issue 23 finding 1: the fairing grid's cell is the extent (here ~1e-36) over 20, its
    // inverse overflows to inf, and a cell coordinate of inf was converted to int.
    const skelform::test::RuntimeModel& capsule = skelform::test::capsule_model();
    for (const float radius : {1e-37f, 1e-36f, 1e-35f}) {
      CAPTURE(radius);
      Glb glb(capsule.baked_glb);
      fill_floats(glb, glb.accessor("control", "positions"), 3, 0.0f);
      fill_floats(glb, glb.accessor("control", "skeletalPositions"), 3, 0.0f);
      fill_floats(glb, glb.accessor("control", "medialRadius"), 1, radius);
      LoadResult load;
      load_bytes(glb.bytes(), load);
      REQUIRE_MESSAGE(load.result == SF_OK, load.message);
      evaluate_everything(load.asset);
    }
  }

  TEST_CASE("the fairing grid stays inside its cells for a collapsed mesh and for a medial radius of 3e38") {
    // The grid directly (fair.h), as every evaluation builds it: an octahedron's control mesh.
    const std::vector<uint32_t> triangles = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    const skelform::runtime::AllocatorRef allocator;
    const skelform::runtime::FairingTopology topology =
        skelform::runtime::build_fairing_topology(triangles.data(), triangles.size() / 3, 6, allocator);
    skelform::runtime::FairingWorkspace workspace = skelform::runtime::make_fairing_workspace(topology, 32, allocator);
    const std::vector<glm::vec3> octahedron = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    SUBCASE("collapsed to a point, radii 1e-36: 1/cell is inf") {
      const std::vector<glm::vec3> skeletal(6, glm::vec3(0.0f));
      std::vector<glm::vec3> positions(6, glm::vec3(0.0f));
      positions[4] = glm::vec3(0.0f, 0.0f, 1e-39f);  // a subnormal extent: 1/cell overflows to inf
      const std::vector<float> radius(6, 1e-36f);
      skelform::runtime::FairingParams params;
      params.iterations = 2;
      params.grid_size = 32;
      const float residual =
          skelform::runtime::fair_run(topology, skeletal.data(), radius.data(), positions.data(), 6, params, workspace);
      CHECK(!std::isnan(residual));
    }
    SUBCASE("one medial radius of 3e38: the search ring is far beyond int") {
      std::vector<glm::vec3> skeletal(6), positions(6);
      for (size_t v = 0; v < 6; ++v) skeletal[v] = 0.5f * octahedron[v], positions[v] = octahedron[v];
      std::vector<float> radius(6, 0.5f);
      radius[0] = 3e38f;
      skelform::runtime::FairingParams params;
      params.iterations = 2;
      skelform::runtime::fair_run(topology, skeletal.data(), radius.data(), positions.data(), 6, params, workspace);
      for (const glm::vec3& p : positions) CHECK(std::isfinite(p.x + p.y + p.z));
    }
  }

  TEST_CASE("the asset's lengths, stencil weights, barycentrics and normals are checked against their limits") {
    const skelform::test::RuntimeModel& capsule = skelform::test::capsule_model();
    struct Corruption {
      const char* group;
      const char* name;
      size_t element;  // float index within the accessor
      float value;
      const char* message;
    };
    const Corruption corruptions[] = {
        {"control", "medialRadius", 3, 3e38f, "control.medialRadius"},  // issue 23 finding 3
        {"control", "medialRadius", 3, 2e12f, "control.medialRadius"},
        {"control", "positions", 4, -3e38f, "control.positions"},
        {"control", "skeletalPositions", 4, 1e13f, "control.skeletalPositions"},
        {"control", "normals", 1, 1e30f, "control.normals"},
        {"subdivision", "stencilWeights", 7, 1e30f, "subdivision.stencilWeights"},  // finding 9
        {"subdivision", "stencilWeights", 7, 3e38f, "subdivision.stencilWeights"},
        {"subdivision", "stencilWeights", 7, -2.0f, "subdivision.stencilWeights"},
        {"binding", "barycentric", 5, 1e30f, "binding.barycentric"},
        {"binding", "barycentric", 5, 3e38f, "binding.barycentric"},
        {"binding", "barycentric", 5, -0.5f, "binding.barycentric"},
        {"binding", "barycentric", 5, 1.5f, "binding.barycentric"},
        {"binding", "displacement", 2, 3e38f, "binding.displacement"},
        {"binding", "residual", 2, -1e30f, "binding.residual"},
    };
    for (const Corruption& c : corruptions) {
      CAPTURE(c.message);
      CAPTURE(c.value);
      Glb glb(capsule.baked_glb);
      glb.put_f32(glb.offset_of(glb.accessor(c.group, c.name), c.element, 4), c.value);
      check_refused(glb.bytes(), SF_ERROR_INVALID_DATA, c.message);
    }
    SUBCASE("a POSITION beyond the length limit") {
      Glb glb(capsule.baked_glb);
      const size_t accessor = glb.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<size_t>();
      glb.put_f32(glb.offset_of(glb.json["accessors"][accessor], 4, 4), 5e12f);
      check_refused(glb.bytes(), SF_ERROR_INVALID_DATA, "POSITION");
    }
  }

  TEST_CASE("an asset scaled to the length limit still evaluates to finite output") {
    // Every length of the capsule times 1e11 (its largest coordinate is then about 1e11, within
    // the 1e12 limit): the evaluation's squares and cubes of lengths must stay finite.
    const skelform::test::RuntimeModel& capsule = skelform::test::capsule_model();
    constexpr float kScale = 1e11f;
    Glb glb(capsule.baked_glb);
    auto scale = [&](Json& accessor, size_t components) {
      const size_t count = accessor["count"].get<size_t>() * components;
      for (size_t i = 0; i < count; ++i) {
        const size_t offset = glb.offset_of(accessor, i, 4);
        glb.put_f32(offset, glb.f32(offset) * kScale);
      }
    };
    scale(glb.accessor("control", "positions"), 3);
    scale(glb.accessor("control", "skeletalPositions"), 3);
    scale(glb.accessor("control", "medialRadius"), 1);
    scale(glb.accessor("binding", "displacement"), 1);
    scale(glb.accessor("binding", "residual"), 2);
    for (Json& primitive : glb.json["meshes"][0]["primitives"]) {
      Json& accessor = glb.json["accessors"][primitive["attributes"]["POSITION"].get<size_t>()];
      scale(accessor, 3);
      accessor.erase("min");
      accessor.erase("max");
    }
    LoadResult load;
    load_bytes(glb.bytes(), load);
    REQUIRE_MESSAGE(load.result == SF_OK, load.message);
    sf_deformable_info info{};
    REQUIRE(sf_asset_deformable_info(load.asset, 0, &info) == SF_OK);
    for (const Method& method : methods()) {
      CAPTURE(method.name);
      InstancePtr instance(load.asset);
      std::vector<glm::mat4> matrices(info.joint_count, glm::mat4(1.0f));
      matrices[1] = glm::rotate(glm::mat4(1.0f), 1.2f, glm::vec3(1.0f, 0.0f, 0.0f));
      REQUIRE(sf_instance_set_joint_matrices(instance, &matrices[0][0][0], matrices.size(), 0) == SF_OK);
      REQUIRE_MESSAGE(sf_instance_evaluate(instance, &method.options) == SF_OK, sf_instance_last_error(instance));
      CHECK(all_finite(skelform::test::write_all(instance, load.asset)));
    }
  }

  TEST_CASE("a joint placed beyond the length limit by its inverse bind matrix gets no arc, and stays finite") {
    // A fuzzer's find: inverse bind matrices of subnormal garbage, whose inverses put the joint
    // heads near 1e40, finite in double and infinite in float. An arc (a limb joint's circular
    // bend) was built from them with a centre and lengths of inf, and the bent pose gave a
    // skeletal and control mesh of NaN (sf_instance_write_coarse; the dense output fell back to
    // LBS and stayed finite). Joint heads beyond the asset's length limit now build no arc: the
    // skin's linear blend there, as for a skin without limb joints. Here the root's rotation
    // part is scaled by 1e-39, which puts its head at about 1e39 and leaves the child's arc
    // otherwise buildable.
    const skelform::test::RuntimeModel& capsule = skelform::test::capsule_model();
    REQUIRE_FALSE(capsule.asset->deformables[0].arc_joints.empty());  // the capsule has an arc
    Glb glb(capsule.baked_glb);
    Json& accessor = glb.json["accessors"][glb.json["skins"][0]["inverseBindMatrices"].get<size_t>()];
    for (size_t column = 0; column < 3; ++column)
      for (size_t row = 0; row < 3; ++row) {
        const size_t offset = glb.offset_of(accessor, 4 * column + row, 4);
        glb.put_f32(offset, glb.f32(offset) * 1e-39f);
      }
    LoadResult load;
    load_bytes(glb.bytes(), load);
    REQUIRE_MESSAGE(load.result == SF_OK, load.message);
    CHECK(load.asset->deformables[0].arc_joints.empty());
    evaluate_everything(load.asset);
  }

  TEST_CASE("influence sets beyond 16 per deformable are refused at load, quickly") {
    // Issue 23 finding 4: 5,000 sets naming one accessor took 17 s and 1 GB to load.
    const skelform::test::RuntimeModel& capsule = skelform::test::capsule_model();
    SUBCASE("control.joints and control.weights naming one accessor 5,000 times, and 17 times") {
      for (const size_t sets : {size_t{17}, size_t{5000}}) {
        Glb glb(capsule.baked_glb);
        Json& control = glb.deformable()["control"];
        const Json joints = control["joints"][0], weights = control["weights"][0];
        control["joints"] = Json::array();
        control["weights"] = Json::array();
        for (size_t s = 0; s < sets; ++s) control["joints"].push_back(joints), control["weights"].push_back(weights);
        const auto start = std::chrono::steady_clock::now();
        LoadResult load;
        load_bytes(glb.bytes(), load);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        CHECK_MESSAGE(load.result == SF_ERROR_UNSUPPORTED, load.message);
        CHECK_MESSAGE(contains(load.message, "influence sets"), load.message);
        CHECK(seconds < 2.0);
      }
    }
    SUBCASE("16 sets, the limit, load") {
      Glb glb(capsule.baked_glb);
      Json& control = glb.deformable()["control"];
      const Json joints = control["joints"][0], weights = control["weights"][0];
      for (size_t s = control["joints"].size(); s < 16; ++s)
        control["joints"].push_back(joints), control["weights"].push_back(weights);
      LoadResult load;
      load_bytes(glb.bytes(), load);
      CHECK_MESSAGE(load.result == SF_OK, load.message);
    }
    SUBCASE("a primitive with JOINTS_0 .. JOINTS_16") {
      Glb glb(capsule.baked_glb);
      Json& attributes = glb.json["meshes"][0]["primitives"][0]["attributes"];
      for (int s = 1; s <= 16; ++s) {
        attributes["JOINTS_" + std::to_string(s)] = attributes["JOINTS_0"];
        attributes["WEIGHTS_" + std::to_string(s)] = attributes["WEIGHTS_0"];
      }
      check_refused(glb.bytes(), SF_ERROR_UNSUPPORTED, "influence sets");
    }
  }

  TEST_CASE("homotopy_steps above 100 are refused") {
    // Issue 23 finding 5: UINT32_MAX steps meant hours inside one evaluation.
    const skelform::test::RuntimeModel& capsule = skelform::test::capsule_model();
    InstancePtr instance(capsule.asset);
    sf_eval_options options{};
    options.reconstruction = SF_RECONSTRUCTION_PAPER;
    options.homotopy_steps = 100;
    CHECK(sf_instance_evaluate(instance, &options) == SF_OK);
    options.homotopy_steps = 101;
    REQUIRE(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
    CHECK(contains(sf_instance_last_error(instance), "homotopy_steps"));
    options.homotopy_steps = std::numeric_limits<uint32_t>::max();
    CHECK(sf_instance_evaluate(instance, &options) == SF_ERROR_INVALID_ARGUMENT);
  }

  // Sets a sane bent pose, evaluates, then applies `hostile` (which sets the instance's input)
  // and evaluates again: that either succeeds with finite output or is refused (the setter or
  // the evaluation) with SF_ERROR_INVALID_ARGUMENT and a message, the previous output intact
  // bit for bit; and the sane pose evaluates again afterwards.
  template <class Hostile>
  void check_pose_refused_or_finite(const skelform::test::RuntimeModel& model, const sf_eval_options& options,
                                    bool expect_refusal, Hostile&& hostile) {
    InstancePtr instance(model.asset);
    const std::vector<glm::mat4> bent = skelform::test::bend_pose(model, 1, 0.8f, glm::vec3(1.0f, 0.0f, 0.0f));
    REQUIRE(sf_instance_set_joint_matrices(instance, &bent[0][0][0], bent.size(), 0) == SF_OK);
    REQUIRE(sf_instance_evaluate(instance, &options) == SF_OK);
    const skelform::test::Evaluated before = skelform::test::write_all(instance, model.asset);
    std::vector<float> coarse_before(3 * 4096, 0.0f), coarse_after(3 * 4096, 0.0f);
    const bool coarse = options.method == SF_METHOD_SKELFORM;
    if (coarse) REQUIRE(sf_instance_write_coarse(instance, SF_COARSE_CONTROL, coarse_before.data(), 0, 4096) == SF_OK);

    sf_result result = hostile(static_cast<sf_instance*>(instance));
    if (result == SF_OK) result = sf_instance_evaluate(instance, &options);
    if (result == SF_OK) {
      CHECK_FALSE(expect_refusal);
      CHECK(all_finite(skelform::test::write_all(instance, model.asset)));
    } else {
      CHECK_MESSAGE(result == SF_ERROR_INVALID_ARGUMENT, sf_instance_last_error(instance));
      CHECK(contains(sf_instance_last_error(instance), "finite"));
      CHECK(same_bits(skelform::test::write_all(instance, model.asset), before));
      if (coarse) {
        REQUIRE(sf_instance_write_coarse(instance, SF_COARSE_CONTROL, coarse_after.data(), 0, 4096) == SF_OK);
        CHECK(coarse_after == coarse_before);
      }
    }
    // The sane pose evaluates again; after a refusal, as on a fresh instance (the refused
    // pose's fairing is no warm start; the paper's homotopy continues from the last output).
    REQUIRE(sf_instance_set_joint_matrices(instance, &bent[0][0][0], bent.size(), 0) == SF_OK);
    REQUIRE_MESSAGE(sf_instance_evaluate(instance, &options) == SF_OK, sf_instance_last_error(instance));
    const skelform::test::Evaluated again = skelform::test::write_all(instance, model.asset);
    CHECK(all_finite(again));
    if (result != SF_OK && options.reconstruction == SF_RECONSTRUCTION_CARRIED) CHECK(same_bits(again, before));
  }

  TEST_CASE("a pose whose output would not be finite is refused and the previous output kept") {
    // Issue 23 finding 9: joint matrices of 3e38 gave non-finite output with SF_OK.
    const skelform::test::RuntimeModel& capsule = skelform::test::capsule_model();
    for (const Method& method : methods()) {
      CAPTURE(method.name);
      SUBCASE("every element 3e38") {
        // LBS of such matrices overflows; dual quaternions normalise the rotation away and may
        // stay finite, which is as good as a refusal.
        const bool overflows = method.options.method != SF_METHOD_DQS;
        check_pose_refused_or_finite(capsule, method.options, overflows, [&](sf_instance* instance) {
          const std::vector<float> huge(16 * capsule.inverse_bind.size(), 3e38f);
          return sf_instance_set_joint_matrices(instance, huge.data(), capsule.inverse_bind.size(), 0);
        });
      }
      SUBCASE("one joint scaled by 1e30") {
        check_pose_refused_or_finite(capsule, method.options, false, [&](sf_instance* instance) {
          std::vector<glm::mat4> pose(capsule.inverse_bind.size(), glm::mat4(1.0f));
          pose[1] = glm::scale(glm::mat4(1.0f), glm::vec3(1e30f));
          return sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0);
        });
      }
      SUBCASE("a translation of 3e38") {
        check_pose_refused_or_finite(capsule, method.options, false, [&](sf_instance* instance) {
          std::vector<glm::mat4> pose(capsule.inverse_bind.size(), glm::mat4(1.0f));
          pose[0][3] = glm::vec4(3e38f, -3e38f, 3e38f, 1.0f);
          return sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0);
        });
      }
    }
    SUBCASE("a handle target of 3e38") {
      sf_eval_options options{};
      check_pose_refused_or_finite(capsule, options, false, [&](sf_instance* instance) {
        const uint32_t handle = 0;
        sf_result result = sf_instance_set_handle_set(instance, &handle, 1, nullptr, 0);
        if (result != SF_OK) return result;
        const float target[3] = {3e38f, 3e38f, -3e38f};
        return sf_instance_set_handle_targets(instance, target, 1, 0);
      });
    }
  }

  TEST_CASE("sf_result_string names every value, known or not") {
    CHECK(std::string(sf_result_string(SF_ERROR_NOT_READY)) == "SF_ERROR_NOT_READY");
    // Values without an enumerator but within the enum's range (a negative value, undefined to
    // even form in C++, is checked from C: tests/header_c99.c).
    for (const int value : {8, 1000, 0x7ffffffe, 0x7fffffff})
      CHECK(std::string(sf_result_string(static_cast<sf_result>(value))) == "SF_ERROR_UNKNOWN");
  }

  TEST_CASE("sf_asset_load_file reads a file without an end only as far as a glTF can reach") {
    SUBCASE("/dev/zero is refused at once") {
      if (!std::filesystem::exists("/dev/zero")) return;
      const auto start = std::chrono::steady_clock::now();
      LoadResult load;
      load_path("/dev/zero", load);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      CHECK_MESSAGE(load.result == SF_ERROR_INVALID_DATA, load.message);
      CHECK(load.asset == nullptr);
      CHECK_MESSAGE(contains(load.message, "/dev/zero"), load.message);
      CHECK(seconds < 2.0);
    }
    SUBCASE("a FIFO carrying a .glb loads without waiting for the end of the stream") {
      const std::string path = (skelform::test::scratch_dir("hostile_input") / "asset.fifo").string();
      std::filesystem::remove(path);
      REQUIRE(mkfifo(path.c_str(), 0600) == 0);
      const std::string glb = skelform::test::capsule_model().baked_glb;
      // The writer sends the file and a few more bytes, then holds the FIFO open until the load
      // returns (at most 5 s): a reader waiting for the end of the stream would wait that long.
      std::atomic<bool> loaded{false};
      std::thread writer([&] {
        const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
        int fd = -1;
        while (fd < 0 && std::chrono::steady_clock::now() < give_up) {
          fd = open(path.c_str(), O_WRONLY | O_NONBLOCK);  // ENXIO until the reader has opened it
          if (fd < 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        if (fd < 0) return;
        fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK);
        const std::string bytes = glb + std::string(1024, '\0');
        for (size_t sent = 0; sent < bytes.size();) {
          const ssize_t n = write(fd, bytes.data() + sent, bytes.size() - sent);
          if (n <= 0) break;
          sent += size_t(n);
        }
        while (!loaded && std::chrono::steady_clock::now() < give_up)
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
        close(fd);
      });
      const auto start = std::chrono::steady_clock::now();
      LoadResult load;
      load_path(path, load);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      loaded = true;
      writer.join();
      CHECK_MESSAGE(load.result == SF_OK, load.message);
      CHECK(seconds < 2.0);
      std::filesystem::remove(path);
    }
  }

}  // TEST_SUITE
