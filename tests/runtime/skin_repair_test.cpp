// core/include/skelform/core/skin_repair.h: the exporter defects the baker and the runtime repair alike
// (docs/SKELFORM_skeletal_deformation.md "Skin defects"), on hand-made skins and end to end on a
// file with Blender's NaN weights: the baker warns naming the accessor and the elements, the
// runtime loads the baked file and skins the repaired vertices like their neighbours.
#include "capsule_glb.h"
#include "glb_edit.h"
#include "runtime/runtime_models.h"
#include "skelform/bake/bake.h"
#include "skelform/bake/gltf_writer.h"
#include "skelform/bake/input.h"
#include "skelform/skelform.h"
#include "skelform/core/skin_repair.h"

#include <doctest/doctest.h>
#include <glm/gtc/quaternion.hpp>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST_CASE("skin repair: NaN weights are 0, a vertex left without weight takes its nearest neighbour's skin") {
  // 4 slots per vertex. v0: Blender's unweighted vertex (NaN on joints 0, 0, 0, 0), nearest to
  // v1; v1: two joints; v2: one joint, far away; v3: joint 1 named twice.
  std::vector<uint32_t> joints = {0, 0, 0, 0, 1, 2, 0, 0, 3, 0, 0, 0, 1, 1, 0, 0};
  std::vector<double> weights = {kNaN, kNaN, kNaN, kNaN, 0.5, 0.5, 0, 0, 1, 0, 0, 0, 0.6, 0.4, 0, 0};
  const std::vector<glm::dvec3> positions = {{0, 0, 0}, {1, 0, 0}, {5, 0, 0}, {0, 3, 0}};
  skelform::skin::SkinRepairReport report;
  REQUIRE(skelform::skin::repair_skin(joints.data(), weights.data(), 4, positions.data(), 4, report));
  CHECK(report.non_finite == std::vector<uint32_t>{0});
  CHECK(report.inherited == std::vector<uint32_t>{0});
  CHECK(report.repeated_joints == 1);
  CHECK(report.repaired());
  for (int k = 0; k < 4; ++k) {
    CHECK(joints[size_t(k)] == joints[4 + size_t(k)]);
    CHECK(weights[size_t(k)] == weights[4 + size_t(k)]);
  }
  // A partly non-finite vertex keeps its finite weights.
  std::vector<uint32_t> j2 = {1, 2, 0, 0};
  std::vector<double> w2 = {0.7, kNaN, 0, 0};
  skelform::skin::SkinRepairReport partial;
  REQUIRE(skelform::skin::repair_skin(j2.data(), w2.data(), 4, positions.data(), 1, partial));
  CHECK(partial.non_finite == std::vector<uint32_t>{0});
  CHECK(partial.inherited.empty());
  CHECK(w2[0] == 0.7);
  CHECK(w2[1] == 0.0);
  // Nothing to inherit from: refused.
  std::vector<uint32_t> j3 = {0, 0, 0, 0, 0, 0, 0, 0};
  std::vector<double> w3 = {kNaN, 0, 0, 0, 0, 0, 0, 0};
  skelform::skin::SkinRepairReport none;
  CHECK_FALSE(skelform::skin::repair_skin(j3.data(), w3.data(), 4, positions.data(), 2, none));
  // A sound skin: nothing reported, nothing changed.
  std::vector<uint32_t> j4 = {4, 5, 0, 0};
  std::vector<double> w4 = {0.25, 0.75, 0, 0};
  skelform::skin::SkinRepairReport clean;
  REQUIRE(skelform::skin::repair_skin(j4.data(), w4.data(), 4, positions.data(), 1, clean));
  CHECK_FALSE(clean.repaired());
  CHECK(clean.repeated_joints == 0);
  CHECK(w4 == std::vector<double>{0.25, 0.75, 0, 0});
}

TEST_CASE("skin repair: a file with NaN weights bakes with warnings naming them and loads in the runtime") {
  skelform::test::Glb glb(skelform::test::capsule_glb());
  // Vertices 5 and 6 of the capsule: no vertex group, as Blender writes it.
  auto& primitive = glb.json["meshes"][0]["primitives"][0];
  const int weights_accessor = primitive["attributes"]["WEIGHTS_0"].get<int>();
  auto& weights = glb.json["accessors"][size_t(weights_accessor)];
  REQUIRE(weights["componentType"].get<int>() == 5126);
  for (size_t v : {5u, 6u})
    for (size_t k = 0; k < 4; ++k) glb.put_f32(glb.offset_of(weights, v, 16) + 4 * k, std::nanf(""));
  const std::string bytes = glb.bytes();

  const skelform::bake::InputMesh input =
      skelform::bake::load_mesh_from_memory(std::vector<unsigned char>(bytes.begin(), bytes.end()), ".glb", "nan.glb");
  std::string warnings;
  for (const std::string& w : input.warnings) warnings += w + "\n";
  MESSAGE(warnings);
  CHECK(contains(warnings, "WEIGHTS_0 (accessor " + std::to_string(weights_accessor) + ")"));
  CHECK(contains(warnings, "2 vertices with a non-finite weight (elements 5, 6)"));
  CHECK(contains(warnings, "given the skin of the nearest weighted vertex"));
  for (const auto& set : input.weight_sets)
    for (const auto& w : set)
      for (float x : w) CHECK(std::isfinite(x));

  const skelform::bake::BakeResult baked = skelform::bake::bake_model(input);
  const std::string baked_bytes = skelform::bake::baked_glb(bytes, ".", baked.deformables);
  sf_asset* asset = nullptr;
  REQUIRE(sf_asset_load_memory(baked_bytes.data(), baked_bytes.size(), nullptr, &asset) == SF_OK);
  sf_instance* instance = nullptr;
  REQUIRE(sf_instance_create(asset, 0, &instance) == SF_OK);
  // Bent: every vertex finite, the repaired ones included, with skelform and with LBS.
  const glm::mat4 pose[2] = {glm::mat4(1.0f), glm::mat4_cast(glm::angleAxis(1.2f, glm::vec3(1, 0, 0)))};
  REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], 2, 0) == SF_OK);
  for (uint32_t method : {uint32_t(SF_METHOD_SKELFORM), uint32_t(SF_METHOD_LBS)}) {
    sf_eval_options options{};
    options.method = method;
    REQUIRE(sf_instance_evaluate(instance, &options) == SF_OK);
    for (const glm::vec3& p : skelform::test::write_all(instance, asset).positions)
      CHECK((std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)));
  }
  sf_instance_destroy(instance);
  sf_asset_destroy(asset);
}

TEST_CASE("skin repair: a primitive whose every weight is NaN is refused, naming it") {
  skelform::test::Glb glb(skelform::test::capsule_glb());
  auto& primitive = glb.json["meshes"][0]["primitives"][0];
  auto& weights = glb.json["accessors"][primitive["attributes"]["WEIGHTS_0"].get<size_t>()];
  const size_t count = weights["count"].get<size_t>();
  for (size_t v = 0; v < count; ++v)
    for (size_t k = 0; k < 4; ++k) glb.put_f32(glb.offset_of(weights, v, 16) + 4 * k, std::nanf(""));
  const std::string bytes = glb.bytes();
  try {
    skelform::bake::load_mesh_from_memory(std::vector<unsigned char>(bytes.begin(), bytes.end()), ".glb",
                                          "all_nan.glb");
    FAIL("an all-NaN skin was accepted");
  } catch (const skelform::bake::Error& e) {
    CHECK(e.kind() == skelform::bake::ErrorKind::invalid_input);
    CHECK(contains(e.what(), "all_nan.glb: mesh 0"));
    CHECK(contains(e.what(), "no skin weight and no weighted vertex to take one from"));
  }
}
