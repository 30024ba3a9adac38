// skelform-animate: plays every animation of a skinned glTF through the skelform runtime and
// writes the result, with linear blend skinning beside it, as a standard glTF 2.0 GLB that any
// glTF viewer plays (animation_glb.h describes the file; the samples' web viewer reads it).
//
//   skelform-animate IN.glb|IN.gltf -o OUT.glb [--fps F] [--max-frames N] [--no-contacts] [--quiet]
//
// An input without the SKELFORM_skeletal_deformation extension is baked in memory first, with
// the baker library's defaults (what skelform-bake does). Then, through the C API as an engine
// would: one instance per deformable for skelform and one for LBS, joint matrices sampled by
// the samples' glTF helper, frames evaluated in order (incrementally; from rest on the first
// frame of each animation), default evaluation options otherwise (with --no-contacts, the
// skelform instances have the contact pass off: sf_instance_set_contacts). Failures print one line
// "skelform-animate: error: ..." and exit non-zero (codes in --help); the output is written
// atomically and depends only on the input and the options.
#include "animation_glb.h"
#include "atomic_file.h"
#include "baked_asset.h"
#include "cli.h"
#include "gltf_animation.h"
#include "skelform/bake/bake.h"
#include "skelform/bake/gltf_writer.h"
#include "skelform/bake/input.h"
#include "skelform/skelform.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace skelform::cli;  // exit codes, fail, option parsing
using skelform::samples::AnimationFile;
using skelform::samples::AnimationRange;
using skelform::samples::AssetHandle;
using skelform::samples::DeformableFrames;
using skelform::samples::GltfAnimation;
using skelform::samples::LoadedAsset;
using skelform::samples::PrimitiveFrames;
using Clock = std::chrono::steady_clock;

const char* const kUsage =
    "usage: skelform-animate IN.glb|IN.gltf -o OUT.glb [--fps F] [--max-frames N] [--no-contacts] [--quiet]\n"
    "\n"
    "Plays every animation of a skinned glTF 2.0 model through the skelform runtime and writes\n"
    "a standard glTF 2.0 GLB that any glTF viewer plays: per skinned mesh, the skelform result,\n"
    "linear blend skinning beside it (for comparison) and the deformed skeletal mesh, each\n"
    "sampled frame a morph target driven by an animation of the same name. An input without\n"
    "the SKELFORM_skeletal_deformation extension is baked first (in memory, skelform-bake's\n"
    "defaults). A model without animations gives one frame: the rest pose.\n"
    "\n"
    "Options:\n"
    "  -o, --output FILE   output .glb (required; never the input file)\n"
    "  --fps F             frames sampled per second of animation (default 30)\n"
    "  --max-frames N      at most N frames per animation (default 300); a longer animation\n"
    "                      is sampled at N evenly spaced times over its whole duration\n"
    "  --no-contacts       skelform with the runtime's contact pass off (it resolves the output's\n"
    "                      remaining self-intersections; on by default, see docs/runtime-api.md)\n"
    "  -q, --quiet         no progress on stderr, no summary line\n"
    "  -h, --help          this text\n"
    "  --version           print the version\n"
    "\n"
    "Exit codes: 0 success, 1 bad command line, 2 invalid or unsupported input,\n"
    "            3 file could not be read or written, 4 internal error.\n";

constexpr const char* kExtensionName = "SKELFORM_skeletal_deformation";

struct Arguments {
  std::string input;
  std::string output;
  double fps = 30.0;
  size_t max_frames = 300;
  bool quiet = false;
  bool contacts = true;
};

Arguments parse_arguments(int argc, char** argv) {
  Arguments args;
  std::vector<std::string> positional;
  skelform::cli::ArgumentCursor cursor(argc, argv);
  while (cursor.next()) {
    const std::string& arg = cursor.arg();
    if (arg == "-o" || arg == "--output")
      args.output = cursor.value();
    else if (arg == "--fps")
      args.fps = parse_positive(arg, cursor.value(), 1000.0);
    else if (arg == "--max-frames")
      args.max_frames = parse_integer(arg, cursor.value(), 1, 100000);
    else if (arg == "-q" || arg == "--quiet")
      args.quiet = true;
    else if (arg == "--no-contacts")
      args.contacts = false;
    else if (cursor.is_option())
      cursor.unknown();
    else
      positional.push_back(arg);
  }
  if (positional.size() != 1) fail(kExitUsage, "expected one input file, got " + std::to_string(positional.size()));
  args.input = positional[0];
  if (args.output.empty()) fail(kExitUsage, "missing -o OUT.glb");
  if (lowercase_extension(args.output) != ".glb") fail(kExitUsage, "the output must be a .glb file");
  std::error_code ignored;
  if (std::filesystem::equivalent(args.input, args.output, ignored))
    fail(kExitUsage, "refusing to overwrite the input file " + args.input);
  return args;
}

// Owns one instance; every failed call becomes a Failure naming the call.
struct Instance {
  sf_instance* handle = nullptr;
  uint32_t deformable = 0;
  Instance() = default;
  Instance(const Instance&) = delete;
  Instance& operator=(const Instance&) = delete;
  Instance(Instance&& other) noexcept : handle(other.handle), deformable(other.deformable) { other.handle = nullptr; }
  ~Instance() { sf_instance_destroy(handle); }

  void check(sf_result result, const char* call) const {
    if (result != SF_OK)
      fail(exit_code_of(result), std::string(call) + " failed for deformable " + std::to_string(deformable) + ": " +
                                     sf_instance_last_error(handle) + " (" + sf_result_string(result) + ")");
  }
};

// Both instances of a deformable and where its frames go.
struct Character {
  sf_deformable_info info{};
  std::vector<sf_primitive_info> primitives;
  Instance skelform, lbs;
  DeformableFrames frames;
};

std::vector<float> identity_matrices(size_t joint_count) {
  std::vector<float> matrices(16 * joint_count, 0.0f);
  for (size_t j = 0; j < joint_count; ++j)
    for (size_t i = 0; i < 16; i += 5) matrices[16 * j + i] = 1.0f;
  return matrices;
}

// Writes every primitive's positions and normals of `instance`'s last evaluation.
void write_vertices(const Instance& instance, const Character& character, std::vector<std::vector<float>>& positions,
                    std::vector<std::vector<float>>& normals) {
  positions.resize(character.primitives.size());
  normals.resize(character.primitives.size());
  for (uint32_t p = 0; p < character.primitives.size(); ++p) {
    const size_t count = character.primitives[p].vertex_count;
    positions[p].assign(3 * count, 0.0f);
    normals[p].assign(3 * count, 0.0f);
    sf_vertex_output output{};
    output.positions = positions[p].data();
    output.normals = normals[p].data();
    output.vertex_capacity = count;
    instance.check(sf_instance_write(instance.handle, p, &output), "sf_instance_write");
  }
}

std::vector<float> skeletal_positions(const Character& character) {
  std::vector<float> positions(3 * size_t{character.info.control_vertex_count});
  character.skelform.check(sf_instance_write_coarse(character.skelform.handle, SF_COARSE_SKELETAL, positions.data(), 0,
                                                    character.info.control_vertex_count),
                           "sf_instance_write_coarse");
  return positions;
}

// Frame times of an animation of `duration` seconds: every 1/fps from 0, the last exactly at
// the end; at most max_frames, evenly spread over the whole duration when capped.
std::vector<double> frame_times(double duration, double fps, size_t max_frames) {
  if (!(duration > 0.0)) return {0.0};
  const double steps = std::ceil(duration * fps - 1e-6);
  std::vector<double> times;
  if (steps + 1.0 <= double(max_frames)) {
    for (size_t k = 0; double(k) < steps; ++k) times.push_back(double(k) / fps);
    times.push_back(duration);
  } else if (max_frames == 1) {
    times.push_back(0.0);
  } else {
    for (size_t k = 0; k < max_frames; ++k) times.push_back(duration * double(k) / double(max_frames - 1));
  }
  // The output stores the times as floats, which glTF requires strictly increasing: a frame
  // that rounds onto the next one's float (a duration just past a whole frame, or many frames
  // in a short animation) is dropped; the last, the end of the animation, always stays.
  std::vector<double> kept;
  for (size_t k = 0; k < times.size(); ++k)
    if (k + 1 == times.size() || float(times[k]) < float(times[k + 1])) {
      if (!kept.empty() && float(kept.back()) >= float(times[k])) kept.pop_back();
      kept.push_back(times[k]);
    }
  return kept;
}

int run(const Arguments& args) {
  const auto start = Clock::now();
  auto progress = [&](const std::string& text) {
    if (!args.quiet) std::fprintf(stderr, "skelform-animate: %s\n", text.c_str());
  };
  const LoadedAsset loaded = skelform::samples::load_or_bake(
      args.input,
      [&](const char* stage, size_t deformable, size_t count) {
        progress("  mesh " + std::to_string(deformable + 1) + "/" + std::to_string(count) + ": " + stage);
      },
      [&] { progress("baking " + args.input + " (it has no " + kExtensionName + " extension)"); });
  for (const std::string& warning : loaded.warnings)
    std::fprintf(stderr, "skelform-animate: warning: %s\n", warning.c_str());
  const nlohmann::json document = skelform::samples::gltf_document(loaded.bytes, args.input);
  const GltfAnimation gltf = GltfAnimation::load_file(args.input);
  const AssetHandle& asset = loaded.asset;
  const double bake_seconds = loaded.bake_seconds;
  const uint32_t deformable_count = sf_asset_deformable_count(asset.asset);
  if (deformable_count == 0) fail(kExitInvalidInput, args.input + " has no skinned mesh to animate");

  const nlohmann::json* meshes =
      document.contains("meshes") && document["meshes"].is_array() ? &document["meshes"] : nullptr;
  std::vector<Character> characters(deformable_count);
  for (uint32_t d = 0; d < deformable_count; ++d) {
    Character& c = characters[d];
    c.skelform.deformable = c.lbs.deformable = d;
    if (sf_asset_deformable_info(asset.asset, d, &c.info) != SF_OK) fail(kExitInternal, "cannot describe a deformable");
    for (Instance* instance : {&c.skelform, &c.lbs}) {
      const sf_result created = sf_instance_create(asset.asset, d, &instance->handle);
      if (created != SF_OK)
        fail(exit_code_of(created),
             "cannot create an instance of deformable " + std::to_string(d) + " (" + sf_result_string(created) + ")");
    }
    if (!args.contacts) c.skelform.check(sf_instance_set_contacts(c.skelform.handle, 0), "sf_instance_set_contacts");
    c.frames.deformable = d;
    const size_t mesh = static_cast<size_t>(c.info.mesh);
    c.frames.mesh_name = "mesh " + std::to_string(mesh);
    if (meshes && mesh < meshes->size() && (*meshes)[mesh].contains("name") && (*meshes)[mesh]["name"].is_string() &&
        !(*meshes)[mesh]["name"].get<std::string>().empty())
      c.frames.mesh_name = (*meshes)[mesh]["name"].get<std::string>();
    if (c.info.skin >= 0 && gltf.joint_count(static_cast<size_t>(c.info.skin)) != c.info.joint_count)
      fail(kExitInvalidInput, "skin " + std::to_string(c.info.skin) + " has " +
                                  std::to_string(gltf.joint_count(static_cast<size_t>(c.info.skin))) +
                                  " joints in the glTF but " + std::to_string(c.info.joint_count) + " in the bake");

    // The morph bases: positions as stored, the runtime's rest normals (identity joint
    // matrices), the skeletal mesh S at rest.
    for (uint32_t p = 0; p < c.info.primitive_count; ++p) {
      sf_primitive_info primitive{};
      if (sf_asset_primitive_info(asset.asset, d, p, &primitive) != SF_OK)
        fail(kExitInternal, "cannot describe a primitive");
      c.primitives.push_back(primitive);
      PrimitiveFrames frames;
      frames.rest_positions = gltf.primitive_positions(mesh, static_cast<size_t>(primitive.gltf_primitive));
      frames.triangles = gltf.primitive_triangles(mesh, static_cast<size_t>(primitive.gltf_primitive));
      if (frames.rest_positions.size() != 3 * size_t{primitive.vertex_count})
        fail(kExitInvalidInput, "a baked primitive's vertex count differs from the glTF's");
      for (uint32_t index : frames.triangles)
        if (index >= primitive.vertex_count) fail(kExitInvalidInput, "a triangle index exceeds its primitive");
      c.frames.primitives.push_back(std::move(frames));
    }
    const std::vector<float> identity = identity_matrices(c.info.joint_count);
    sf_eval_options rest{};
    rest.flags = SF_EVAL_FROM_REST;
    if (c.info.skin >= 0) {
      c.skelform.check(sf_instance_set_joint_matrices(c.skelform.handle, identity.data(), c.info.joint_count, 0),
                       "sf_instance_set_joint_matrices");
      c.lbs.check(sf_instance_set_joint_matrices(c.lbs.handle, identity.data(), c.info.joint_count, 0),
                  "sf_instance_set_joint_matrices");
    }
    c.skelform.check(sf_instance_evaluate(c.skelform.handle, &rest), "sf_instance_evaluate");
    c.frames.skeletal_rest = skeletal_positions(c);
    c.frames.skeletal_triangles.assign(3 * size_t{c.info.control_triangle_count}, 0);
    if (sf_asset_control_triangles(asset.asset, d, c.frames.skeletal_triangles.data(),
                                   c.frames.skeletal_triangles.size()) != SF_OK)
      fail(kExitInternal, "cannot read the control triangles");
    sf_eval_options lbs_rest = rest;
    lbs_rest.method = SF_METHOD_LBS;
    c.lbs.check(sf_instance_evaluate(c.lbs.handle, &lbs_rest), "sf_instance_evaluate");
    std::vector<std::vector<float>> positions, normals;
    write_vertices(c.lbs, c, positions, normals);
    for (size_t p = 0; p < positions.size(); ++p) c.frames.primitives[p].rest_normals = std::move(normals[p]);
  }

  // Every animation's frames, in order.
  AnimationFile file;
  file.source = std::filesystem::path(args.input).filename().string();
  file.fps = args.fps;
  struct Source {
    std::string name;
    size_t animation;  // kStaticPose: the rest pose of a model without animations
    double start;
    std::vector<double> times;
  };
  std::vector<Source> sources;
  for (size_t a = 0; a < gltf.animations().size(); ++a) {
    const skelform::samples::AnimationInfo& info = gltf.animations()[a];
    sources.push_back({info.name, a, info.start, frame_times(info.duration(), args.fps, args.max_frames)});
  }
  if (sources.empty()) {
    progress(args.input + " has no animation: writing one frame, the rest pose");
    sources.push_back({"rest pose", skelform::samples::kStaticPose, 0.0, {0.0}});
  }

  double skelform_ms = 0, lbs_ms = 0;
  size_t evaluations = 0;
  float min_x = std::numeric_limits<float>::max(), max_x = -std::numeric_limits<float>::max();
  uint32_t next_target = 0;
  for (const Source& source : sources) {
    progress("animation '" + source.name + "': " + std::to_string(source.times.size()) + " frame(s)");
    for (size_t k = 0; k < source.times.size(); ++k) {
      sf_eval_options skelform_options{};  // the documented defaults
      if (k == 0) skelform_options.flags = SF_EVAL_FROM_REST;
      sf_eval_options lbs_options = skelform_options;
      lbs_options.method = SF_METHOD_LBS;
      for (Character& c : characters) {
        if (c.info.skin >= 0) {
          const std::vector<float> matrices =
              source.animation == skelform::samples::kStaticPose
                  ? identity_matrices(c.info.joint_count)
                  : gltf.joint_matrices(static_cast<size_t>(c.info.skin), source.animation,
                                        source.start + source.times[k]);
          c.skelform.check(sf_instance_set_joint_matrices(c.skelform.handle, matrices.data(), c.info.joint_count, 0),
                           "sf_instance_set_joint_matrices");
          c.lbs.check(sf_instance_set_joint_matrices(c.lbs.handle, matrices.data(), c.info.joint_count, 0),
                      "sf_instance_set_joint_matrices");
        }
        const auto t0 = Clock::now();
        c.skelform.check(sf_instance_evaluate(c.skelform.handle, &skelform_options), "sf_instance_evaluate");
        const auto t1 = Clock::now();
        c.lbs.check(sf_instance_evaluate(c.lbs.handle, &lbs_options), "sf_instance_evaluate");
        const auto t2 = Clock::now();
        skelform_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
        lbs_ms += std::chrono::duration<double, std::milli>(t2 - t1).count();
        ++evaluations;

        std::vector<std::vector<float>> positions, normals;
        for (int method = 0; method < 2; ++method) {
          write_vertices(method == 0 ? c.skelform : c.lbs, c, positions, normals);
          for (size_t p = 0; p < positions.size(); ++p) {
            for (size_t i = 0; i < positions[p].size(); i += 3) {
              min_x = std::min(min_x, positions[p][i]);
              max_x = std::max(max_x, positions[p][i]);
            }
            PrimitiveFrames& frames = c.frames.primitives[p];
            (method == 0 ? frames.skelform_positions : frames.lbs_positions).push_back(std::move(positions[p]));
            (method == 0 ? frames.skelform_normals : frames.lbs_normals).push_back(std::move(normals[p]));
          }
        }
        c.frames.skeletal_positions.push_back(skeletal_positions(c));
      }
    }
    file.animations.push_back({source.name, source.times, next_target});
    next_target += static_cast<uint32_t>(source.times.size());
  }
  // Side by side: LBS one and a third widths of the whole motion to the right.
  const float extent = max_x - min_x;
  file.offset = 1.3f * (extent > 0 ? extent : 1.0f);
  for (Character& c : characters) file.deformables.push_back(std::move(c.frames));

  progress("writing " + args.output);
  const std::string out = skelform::samples::animation_glb(file);
  try {
    skelform::samples::write_file_atomically(args.output, out);
  } catch (const std::runtime_error& e) {
    fail(kExitIo, e.what());
  }
  if (!args.quiet) {
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    std::string bake_note = bake_seconds > 0 ? ", baked in " + std::to_string(bake_seconds).substr(0, 4) + " s" : "";
    std::printf(
        "skelform-animate: %s -> %s: %u deformable(s), %zu animation(s), %u frames, %.1f MB%s; per frame "
        "skelform %.2f ms, LBS %.2f ms; %.1f s\n",
        args.input.c_str(), args.output.c_str(), deformable_count, file.animations.size(), next_target,
        double(out.size()) / 1e6, bake_note.c_str(), evaluations ? skelform_ms / double(evaluations) : 0.0,
        evaluations ? lbs_ms / double(evaluations) : 0.0, seconds);
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return skelform::cli::run_main(
      "skelform-animate", kUsage, argc, argv, [&] { return run(parse_arguments(argc, argv)); },
      skelform::samples::classify_sample_error);
}
