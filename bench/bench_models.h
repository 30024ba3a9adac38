// The models the benchmarks run on, prepared once and cached: CesiumMan as shipped, and
// CesiumMan Loop-subdivided (skelform::bake::loop_subdivide_input, influences interpolated)
// written as a new skinned glTF with CesiumMan's nodes, skin and animation, and their bakes.
#pragma once

#include "skelform/bake/input.h"

#include <filesystem>
#include <optional>
#include <string>

namespace skelform::bench {

// ../shared/data (compile definition SKELFORM_DATA_DIR); $SKELFORM_DATA_DIR overrides.
std::filesystem::path data_dir();

// CesiumMan.glb under the data directory, or nothing when the shared data is absent.
std::optional<std::filesystem::path> cesium_man_path();

// Where prepared files are cached: $TMPDIR/skelform-bench-cache (created on demand).
std::filesystem::path cache_dir();

// Writes a standard skinned .glb: `source_gltf` with the skinned mesh of `mesh`'s first
// primitive replaced by one indexed primitive holding `mesh` (POSITION, NORMAL, JOINTS_0,
// WEIGHTS_0; materials and images dropped). NORMAL is area-weighted over the welded mesh, the
// smooth normals an exporter writes: game assets ship authored normals, and the runtime carries
// authored normals (skelform through the DSS frame, LBS/DQS through the blended transform)
// where it would otherwise recompute them from the deformed faces. Nodes, skins, inverse bind
// matrices and animations are kept, so the source's animation poses the new mesh. Written
// atomically.
void write_skinned_glb(const std::string& source_gltf, const skelform::bake::InputMesh& mesh,
                       const std::string& output_path);

// CesiumMan Loop-subdivided `levels` times (0: the original file), as an unbaked .glb path.
// Cached; regenerated when missing or older than the running executable.
std::filesystem::path cesium_man_subdivided(int levels);

// The baked (skelform-bake defaults) version of cesium_man_subdivided(levels). Cached likewise.
std::filesystem::path cesium_man_baked(int levels);

// `source` baked with skelform-bake's defaults, cached as `cache_name`.skf.glb; regenerated
// when missing or older than the running executable or than `source`.
std::filesystem::path baked_file(const std::filesystem::path& source, const std::string& cache_name);

}  // namespace skelform::bench
