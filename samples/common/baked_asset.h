// Loading a model into the runtime the way the sample tools do: a file that already carries
// the SKELFORM_skeletal_deformation extension is loaded as it is; any other skinned glTF is
// baked in memory first with the baker library's defaults (what skelform-bake writes).
#pragma once

#include "skelform/bake/bake.h"
#include "skelform/skelform.h"

#include <nlohmann/json.hpp>

#include <functional>
#include <string>
#include <vector>

namespace skelform::samples {

// An sf_asset owned by value (destroyed with it). Movable, not copyable.
struct AssetHandle {
  sf_asset* asset = nullptr;
  AssetHandle() = default;
  AssetHandle(const AssetHandle&) = delete;
  AssetHandle& operator=(const AssetHandle&) = delete;
  AssetHandle(AssetHandle&& other) noexcept : asset(other.asset) { other.asset = nullptr; }
  ~AssetHandle() { sf_asset_destroy(asset); }
};

struct LoadedAsset {
  AssetHandle asset;
  std::string bytes;                  // the file as read
  bool baked_here = false;            // true when the file had no extension and was baked in memory
  double bake_seconds = 0.0;          // time of that bake
  bake::BakeResult bake;              // its reports (empty when the file was already baked)
  std::vector<std::string> warnings;  // exporter defects the in-memory bake repaired (input.h)
};

// Reads the whole file, which must be a regular file of at most kMaxFileBytes
// (gltf_animation.h). Throws Failure: kExitIo when it cannot, kExitInvalidInput when larger.
std::string read_file_bytes(const std::string& path);

// The glTF JSON of .glb or .gltf bytes (the container recognised by its bytes). Throws Failure
// (kExitInvalidInput) for bytes that are no glTF.
nlohmann::json gltf_document(const std::string& bytes, const std::string& name);

// True when the glTF bytes (.glb or .gltf) list the extension in extensionsUsed. Throws
// Failure (kExitInvalidInput) for bytes that are no glTF.
bool has_skelform_extension(const std::string& bytes, const std::string& name);

// Reads `path` and loads it into the runtime, baking it in memory first when needed
// (`progress` as BakeOptions::progress; may be empty; `baking` is called once before a bake). Throws Failure with the exit code of
// the failure (the baker's and the loader's messages name the file) and bake::Error from the
// in-memory bake.
LoadedAsset load_or_bake(const std::string& path,
                         const std::function<void(const char* stage, size_t deformable, size_t count)>& progress = {},
                         const std::function<void()>& baking = {});

// run_main's `classify` (cli.h) for the tools that read glTF and bake in memory: GltfError and
// bake::Error (-1 for any other exception).
int classify_sample_error(const std::exception& e);

}  // namespace skelform::samples
