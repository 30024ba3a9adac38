// fuzz_handles: handle files (docs/handles-json.md) through the samples' reader
// (samples/common/handle_file.h, as skelform-pose --handles reads them) and then the
// runtime's handle driver, on the tests' procedural capsule (tests/capsule_glb.h), baked once
// at start-up. A file the reader refuses ends with skelform::cli::Failure, as
// skelform-pose reports it; any other exception escapes as a finding. A file it accepts sets
// the handles and targets and evaluates: SF_OK output must be finite.
#include "capsule_glb.h"
#include "cli.h"
#include "fuzz_check.h"
#include "fuzz_output.h"
#include "handle_file.h"
#include "skelform/bake/bake.h"
#include "skelform/bake/gltf_writer.h"
#include "skelform/bake/input.h"
#include "skelform/skelform.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

using skelform::samples::HandleSet;

namespace {

sf_asset* g_capsule = nullptr;

void evaluate_handles(const HandleSet& set) {
  sf_instance* instance = nullptr;
  skelform::fuzz::require(sf_instance_create(g_capsule, 0, &instance) == SF_OK,
                          "sf_instance_create failed on the capsule");
  sf_deformable_info info{};
  sf_asset_deformable_info(g_capsule, 0, &info);
  if (sf_instance_set_handle_set(instance, set.vertices.data(), set.vertices.size(), set.pinned.data(),
                                 set.pinned.size()) == SF_OK &&
      sf_instance_set_handle_targets(instance, set.targets.data(), set.vertices.size(), 0) == SF_OK) {
    sf_eval_options reconstructions[2] = {};
    reconstructions[1].reconstruction = SF_RECONSTRUCTION_PAPER;
    for (const sf_eval_options& options : reconstructions) {
      if (sf_instance_evaluate(instance, &options) != SF_OK) continue;
      skelform::fuzz::write_primitives(instance, g_capsule, 0, info);
      skelform::fuzz::check_coarse(instance, info);
    }
  }
  sf_instance_destroy(instance);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const std::string glb = skelform::test::capsule_glb();
  const std::vector<unsigned char> bytes(glb.begin(), glb.end());
  const std::string name = "/nonexistent-skelform-fuzz/capsule.glb";
  const skelform::bake::InputMesh input = skelform::bake::load_mesh_from_memory(bytes, ".glb", name);
  const skelform::bake::BakeResult baked = skelform::bake::bake_model(input);
  const std::string baked_glb = skelform::bake::baked_glb(glb, "/nonexistent-skelform-fuzz", baked.deformables);
  skelform::fuzz::require(sf_asset_load_memory(baked_glb.data(), baked_glb.size(), nullptr, &g_capsule) == SF_OK,
                          "the baked capsule does not load");

  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  HandleSet set;
  try {
    set = skelform::samples::parse_handles(std::string(reinterpret_cast<const char*>(data), size), "fuzz.json");
  } catch (const skelform::cli::Failure&) {
    return 0;  // refused with a message, as skelform-pose would report it
  }
  evaluate_handles(set);
  return 0;
}
