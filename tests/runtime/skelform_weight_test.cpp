// core/include/skelform/core/skelform_weight.h and the extension's blend.skelformWeight (version 2.2): the
// rule's values, the baker storing what the runtime would derive, and an artist's
// _SKELFORM_WEIGHT attribute overriding it: 0 keeps a vertex on LBS bit for bit, out-of-range
// values are refused by the baker and the runtime alike.
#include "capsule_glb.h"
#include "skelform/core/extension_layout.h"
#include "glb_edit.h"
#include "runtime/runtime_models.h"
#include "skelform/bake/bake.h"
#include "skelform/bake/gltf_writer.h"
#include "skelform/bake/input.h"
#include "skelform/skelform.h"
#include "skelform/core/skelform_weight.h"

#include <doctest/doctest.h>
#include <glm/gtc/quaternion.hpp>

#include <cstring>
#include <string>
#include <vector>

namespace {

using skelform::skin::skelform_weight;

float weight_of(std::vector<uint16_t> joints, std::vector<float> weights) {
  return skelform_weight(joints.data(), weights.data(), uint32_t(joints.size()));
}

std::string bake(const std::string& bytes) {
  const skelform::bake::InputMesh input = skelform::bake::load_mesh_from_memory(
      std::vector<unsigned char>(bytes.begin(), bytes.end()), ".glb", "capsule.glb");
  return skelform::bake::baked_glb(bytes, ".", skelform::bake::bake_model(input).deformables);
}

// The capsule's first primitive with a _SKELFORM_WEIGHT attribute of `value` everywhere.
std::string with_override(float value) {
  skelform::test::Glb glb(skelform::test::capsule_glb());
  auto& primitive = glb.json["meshes"][0]["primitives"][0];
  const size_t count = glb.json["accessors"][primitive["attributes"]["POSITION"].get<size_t>()]["count"].get<size_t>();
  std::string bytes(4 * count, '\0');
  for (size_t v = 0; v < count; ++v) std::memcpy(&bytes[4 * v], &value, 4);
  primitive["attributes"][skelform::format::kSkelformWeightAttribute] = glb.append(bytes, 5126, "SCALAR", count);
  return glb.bytes();
}

struct Asset {
  sf_asset* asset = nullptr;
  sf_result result;
  char message[512] = "";
  explicit Asset(const std::string& bytes) {
    sf_load_options options{};
    options.error_message = message;
    options.error_message_capacity = sizeof message;
    result = sf_asset_load_memory(bytes.data(), bytes.size(), &options, &asset);
  }
  ~Asset() { sf_asset_destroy(asset); }
};

// Every vertex's position with `method` at a bent, twisted pose.
// The capsule's second joint bent by `bend` and twisted by `twist` (radians).
std::vector<glm::vec3> bent(const sf_asset* asset, uint32_t method, float bend = 1.6f, float twist = 1.0f) {
  sf_instance* instance = nullptr;
  REQUIRE(sf_instance_create(asset, 0, &instance) == SF_OK);
  const glm::mat4 pose[2] = {glm::mat4(1.0f), glm::mat4_cast(glm::angleAxis(bend, glm::vec3(1, 0, 0)) *
                                                             glm::angleAxis(twist, glm::vec3(0, 0, 1)))};
  REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], 2, 0) == SF_OK);
  sf_eval_options options{};
  options.method = method;
  REQUIRE(sf_instance_evaluate(instance, &options) == SF_OK);
  std::vector<glm::vec3> positions = skelform::test::write_all(instance, asset).positions;
  sf_instance_destroy(instance);
  return positions;
}

}  // namespace

TEST_CASE("skelform weight: 0 for one influence, 1 once another joint carries 5 %, smooth between") {
  CHECK(weight_of({3, 0, 0, 0}, {1, 0, 0, 0}) == 0.0f);
  CHECK(weight_of({3, 7, 0, 0}, {0.9995f, 0.0005f, 0, 0}) == 0.0f);  // ≥ 0.999: a single influence
  CHECK(weight_of({3, 3, 0, 0}, {0.5f, 0.5f, 0, 0}) == 0.0f);        // one joint named twice
  CHECK(weight_of({3, 7, 0, 0}, {0.95f, 0.05f, 0, 0}) == 1.0f);
  CHECK(weight_of({3, 7, 9, 0}, {0.4f, 0.3f, 0.3f, 0}) == 1.0f);
  CHECK(weight_of({3, 7, 0, 0}, {2.0f, 2.0f, 0, 0}) == 1.0f);  // unnormalised weights
  CHECK(weight_of({0, 0, 0, 0}, {0, 0, 0, 0}) == 0.0f);        // no weight at all
  // Rising monotonically and continuously from 0 to 1 between.
  float previous = 0.0f;
  for (int i = 0; i <= 100; ++i) {
    const float other = 0.0005f * float(i);
    const float w = weight_of({3, 7, 0, 0}, {1.0f - other, other, 0, 0});
    CHECK(w >= previous);
    CHECK(w - previous < 0.05f);
    previous = w;
  }
  CHECK(previous == 1.0f);
}

TEST_CASE("skelform weight: the baker stores per vertex what the runtime derives from the skin") {
  const std::string baked = bake(skelform::test::capsule_glb());
  skelform::test::Glb glb(baked);
  CHECK(glb.extension()["minorVersion"] == skelform::format::kMinorVersion);
  auto& stored = glb.accessor("blend", "skelformWeight");
  auto& primitive = glb.json["meshes"][0]["primitives"][0];
  auto& joints = glb.json["accessors"][primitive["attributes"]["JOINTS_0"].get<size_t>()];
  auto& weights = glb.json["accessors"][primitive["attributes"]["WEIGHTS_0"].get<size_t>()];
  const size_t count = weights["count"].get<size_t>();
  size_t rigid = 0, blended = 0;
  for (size_t v = 0; v < count; ++v) {
    uint16_t j[4];
    float w[4];
    std::memcpy(j, &glb.bin[glb.offset_of(joints, v, 8)], 8);
    for (size_t k = 0; k < 4; ++k) w[k] = glb.f32(glb.offset_of(weights, v, 16) + 4 * k);
    const float expected = skelform_weight(j, w, 4);
    CHECK(glb.f32(glb.offset_of(stored, v, 4)) == expected);
    rigid += expected == 0.0f;
    blended += expected > 0.0f;
  }
  CHECK(rigid > 0);
  CHECK(blended > 0);
  // An asset without the array (as baked before 2.2) evaluates exactly as the baked one.
  skelform::test::Glb older(baked);
  older.deformable().erase("blend");
  older.extension()["minorVersion"] = 1;
  Asset with(baked), without(older.bytes());
  REQUIRE(with.result == SF_OK);
  REQUIRE(without.result == SF_OK);
  CHECK(bent(with.asset, SF_METHOD_SKELFORM) == bent(without.asset, SF_METHOD_SKELFORM));
}

TEST_CASE("skelform weight: an artist's 0 keeps the primitive on LBS bit for bit; 1 gives skelform") {
  Asset lbs_only(bake(with_override(0.0f)));
  REQUIRE(lbs_only.result == SF_OK);
  CHECK(bent(lbs_only.asset, SF_METHOD_SKELFORM) == bent(lbs_only.asset, SF_METHOD_LBS));
  Asset derived(bake(skelform::test::capsule_glb()));
  REQUIRE(derived.result == SF_OK);
  // At a moderate bend (at the deep one the guard may keep LBS's result wherever skelform's
  // would add an intersection).
  CHECK(bent(derived.asset, SF_METHOD_SKELFORM, 0.8f, 0.0f) != bent(derived.asset, SF_METHOD_LBS, 0.8f, 0.0f));
  // Without blend.skelformWeight the runtime reads the attribute itself.
  skelform::test::Glb older(bake(with_override(0.0f)));
  older.deformable().erase("blend");
  Asset from_attribute(older.bytes());
  REQUIRE(from_attribute.result == SF_OK);
  CHECK(bent(from_attribute.asset, SF_METHOD_SKELFORM) == bent(from_attribute.asset, SF_METHOD_LBS));
}

TEST_CASE("skelform weight: values outside [0, 1] are refused by the baker and the runtime, naming the attribute") {
  const std::string bad = with_override(1.5f);
  try {
    bake(bad);
    FAIL("a weight of 1.5 was baked");
  } catch (const skelform::bake::Error& e) {
    CHECK(e.kind() == skelform::bake::ErrorKind::invalid_input);
    CHECK(std::string(e.what()).find("_SKELFORM_WEIGHT") != std::string::npos);
    CHECK(std::string(e.what()).find("outside [0, 1]") != std::string::npos);
  }
  // A baked file whose stored weights were edited out of range, and one whose attribute was.
  skelform::test::Glb edited(bake(skelform::test::capsule_glb()));
  edited.put_f32(edited.offset_of(edited.accessor("blend", "skelformWeight"), 3, 4), -0.25f);
  Asset refused(edited.bytes());
  CHECK(refused.result == SF_ERROR_INVALID_DATA);
  CHECK(std::string(refused.message).find("skelformWeight") != std::string::npos);
  skelform::test::Glb attribute(bake(with_override(0.5f)));
  attribute.deformable().erase("blend");
  auto& primitive = attribute.json["meshes"][0]["primitives"][0];
  auto& values = attribute.json["accessors"][primitive["attributes"]["_SKELFORM_WEIGHT"].get<size_t>()];
  attribute.put_f32(attribute.offset_of(values, 0, 4), 2.0f);
  Asset refused_attribute(attribute.bytes());
  CHECK(refused_attribute.result == SF_ERROR_INVALID_DATA);
  CHECK(std::string(refused_attribute.message).find("_SKELFORM_WEIGHT") != std::string::npos);
}
