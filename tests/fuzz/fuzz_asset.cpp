// fuzz_asset: a baked asset's bytes through the whole C API as an engine drives it. Load,
// then for every deformable: an instance at rest (identity joint matrices) and bent (joint 1
// turned 1.2 rad), evaluated with each method, and every primitive written out. Anything the
// API reports as SF_OK must be finite; everything created is destroyed (LeakSanitizer).
#include "fuzz_check.h"
#include "fuzz_output.h"
#include "skelform/skelform.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace {

using skelform::fuzz::check_coarse;
using skelform::fuzz::check_skin_ranges;
using skelform::fuzz::require;
using skelform::fuzz::write_primitives;

void evaluate_all_methods(sf_instance* instance, const sf_asset* asset, uint32_t deformable,
                          const sf_deformable_info& info) {
  sf_eval_options methods[4] = {};
  methods[1].method = SF_METHOD_LBS;
  methods[2].method = SF_METHOD_DQS;
  methods[3].reconstruction = SF_RECONSTRUCTION_PAPER;
  for (const sf_eval_options& options : methods) {
    if (sf_instance_evaluate(instance, &options) != SF_OK) continue;
    write_primitives(instance, asset, deformable, info);
    if (options.method == SF_METHOD_SKELFORM) check_coarse(instance, info);
    if (options.method == SF_METHOD_LBS || options.method == SF_METHOD_DQS)
      check_skin_ranges(instance, asset, deformable, info, options.method);
  }
}

void exercise_deformable(const sf_asset* asset, uint32_t deformable) {
  sf_deformable_info info{};
  require(sf_asset_deformable_info(asset, deformable, &info) == SF_OK,
          "sf_asset_deformable_info failed for an index below sf_asset_deformable_count");

  std::vector<uint32_t> triangles(size_t(info.control_triangle_count) * 3);
  if (sf_asset_control_triangles(asset, deformable, triangles.data(), triangles.size()) == SF_OK)
    for (uint32_t index : triangles)
      require(index < info.control_vertex_count, "sf_asset_control_triangles gave an index out of range");

  sf_instance* instance = nullptr;
  if (sf_instance_create(asset, deformable, &instance) != SF_OK) {
    require(instance == nullptr, "sf_instance_create failed but returned an instance");
    return;
  }
  require(instance != nullptr, "sf_instance_create returned SF_OK and no instance");
  require(sf_instance_last_error(instance) != nullptr, "sf_instance_last_error returned NULL");

  std::vector<float> matrices(size_t(info.joint_count) * 16, 0.0f);
  for (size_t j = 0; j < info.joint_count; ++j)
    for (size_t d = 0; d < 4; ++d) matrices[j * 16 + d * 5] = 1.0f;
  // Rest pose: identity joint matrices (an unskinned deformable has no skin input).
  if (info.joint_count > 0) sf_instance_set_joint_matrices(instance, matrices.data(), info.joint_count, 0);
  evaluate_all_methods(instance, asset, deformable, info);

  if (info.joint_count >= 2) {
    // Joint 1 turned 1.2 rad about x (column-major): a bend through whatever its weights cover.
    const float c = std::cos(1.2f), s = std::sin(1.2f);
    float* m = matrices.data() + 16;
    m[5] = c;
    m[6] = s;
    m[9] = -s;
    m[10] = c;
    if (sf_instance_set_joint_matrices(instance, matrices.data(), info.joint_count, 0) == SF_OK)
      evaluate_all_methods(instance, asset, deformable, info);
  }
  sf_instance_destroy(instance);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  char message[256];
  std::memset(message, 'x', sizeof message);
  sf_load_options options{};
  options.error_message = message;
  options.error_message_capacity = sizeof message;
  sf_asset* asset = nullptr;
  if (sf_asset_load_memory(data, size, &options, &asset) != SF_OK) {
    require(asset == nullptr, "sf_asset_load_memory failed but returned an asset");
    require(std::memchr(message, '\0', sizeof message) != nullptr, "a load error message is not NUL-terminated");
    return 0;
  }
  require(asset != nullptr, "sf_asset_load_memory returned SF_OK and no asset");
  const uint32_t deformables = sf_asset_deformable_count(asset);
  for (uint32_t d = 0; d < deformables; ++d) exercise_deformable(asset, d);
  sf_asset_destroy(asset);
  return 0;
}
