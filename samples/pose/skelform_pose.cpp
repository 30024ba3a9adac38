// skelform-pose: one posed frame of a baked asset, for pipelines and checks.
//
//   skelform-pose BAKED.glb (--rest | --bind | --static | --anim I --time T | --handles H.json)
//                 [--method skelform|lbs|dqs] [--deformable K] -o OUT.obj|OUT.glb
//
// Everything goes through the runtime's C API (skelform.h) as an engine would use it: load
// the asset, one instance per deformable, joint matrices (identity for --rest, sampled from
// the file's own animation by the samples' glTF helper for --anim) or free-form handles,
// evaluate from rest, write. The output is the posed dense mesh: every baked primitive of the
// chosen deformables concatenated in file order (mesh order, then primitive order), with the
// primitives' own triangles. Failures print one line "skelform-pose: error: ..." and exit
// non-zero (codes in --help); the output is written atomically.
#include "atomic_file.h"
#include "cli.h"
#include "gltf_animation.h"
#include "handle_file.h"
#include "skelform/bake/glb_builder.h"
#include "skelform/skelform.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace skelform::cli;  // exit codes, fail, option parsing
using skelform::samples::GltfAnimation;
using skelform::samples::HandleSet;
using skelform::samples::read_handles;

const char* const kUsage =
    "usage: skelform-pose BAKED.glb (--rest | --bind | --static | --anim I --time T | --handles H.json)\n"
    "                     [--method skelform|lbs|dqs] [--deformable K] -o OUT.obj|OUT.glb\n"
    "\n"
    "Poses a model baked by skelform-bake through the skelform runtime and writes the posed\n"
    "dense mesh: every baked primitive concatenated in file order (mesh order, then primitive\n"
    "order), positions, normals and the primitives' triangles.\n"
    "\n"
    "Pose (exactly one):\n"
    "  --rest              the runtime's rest pose: identity joint matrices, the mesh exactly\n"
    "                      as stored in the file\n"
    "  --bind              the bind pose in the scene: every joint matrix the one transform\n"
    "                      that places the mesh as stored (the static node pose when all its\n"
    "                      joints agree, else the skinned node's world transform); differs\n"
    "                      from --rest by the armature's rotation and scale (CesiumMan's Z-up\n"
    "                      to Y-up turn, Blender's scale of 100), which --anim frames include\n"
    "  --static            the skeleton at its static node transforms, no animation (a posed\n"
    "                      skeleton in some exports)\n"
    "  --anim I --time T   animation I of the file (0-based) at T seconds, glTF time, clamped\n"
    "                      to the animation's range\n"
    "  --handles H.json    free-form handles (docs/handles-json.md):\n"
    "                      {\"handles\":[{\"vertex\":123,\"target\":[x,y,z]}], \"pinned\":[1,2,3]}\n"
    "                      vertex indices count over the deformable's baked primitives\n"
    "\n"
    "Options:\n"
    "  -o, --output FILE   output .obj (v, vn, f) or .glb (one mesh: POSITION, NORMAL, indices)\n"
    "  --method M          skelform (default), lbs or dqs (the baselines, same call path)\n"
    "  --deformable K      only deformable K (default: all; --handles needs exactly one)\n"
    "  -q, --quiet         no summary line\n"
    "  -h, --help          this text\n"
    "  --version           print the version\n"
    "\n"
    "Exit codes: 0 success, 1 bad command line, 2 invalid or unsupported input,\n"
    "            3 file could not be read or written, 4 internal error.\n";

struct Arguments {
  std::string input;
  std::string output;
  bool rest = false;
  bool bind = false;
  bool static_pose = false;
  std::optional<size_t> animation;
  std::optional<double> time;
  std::string handles;
  uint32_t method = SF_METHOD_SKELFORM;
  std::optional<uint32_t> deformable;
  bool quiet = false;
};

Arguments parse_arguments(int argc, char** argv) {
  Arguments args;
  std::vector<std::string> positional;
  skelform::cli::ArgumentCursor cursor(argc, argv);
  constexpr unsigned long kLargestIndex = 0x7fffffffUL;
  while (cursor.next()) {
    const std::string& arg = cursor.arg();
    if (arg == "-o" || arg == "--output")
      args.output = cursor.value();
    else if (arg == "--rest")
      args.rest = true;
    else if (arg == "--bind")
      args.bind = true;
    else if (arg == "--static")
      args.static_pose = true;
    else if (arg == "--anim")
      args.animation = skelform::cli::parse_integer(arg, cursor.value(), 0, kLargestIndex);
    else if (arg == "--time")
      args.time = skelform::cli::parse_finite(arg, cursor.value());
    else if (arg == "--handles")
      args.handles = cursor.value();
    else if (arg == "--deformable")
      args.deformable = static_cast<uint32_t>(skelform::cli::parse_integer(arg, cursor.value(), 0, kLargestIndex));
    else if (arg == "--method") {
      constexpr uint32_t kMethods[] = {SF_METHOD_SKELFORM, SF_METHOD_LBS, SF_METHOD_DQS};
      args.method = kMethods[skelform::cli::parse_choice(arg, cursor.value(), {"skelform", "lbs", "dqs"})];
    } else if (arg == "-q" || arg == "--quiet")
      args.quiet = true;
    else if (cursor.is_option())
      cursor.unknown();
    else
      positional.push_back(arg);
  }
  if (positional.size() != 1)
    fail(kExitUsage, "expected one baked input file, got " + std::to_string(positional.size()));
  args.input = positional[0];
  const int poses = int(args.rest) + int(args.bind) + int(args.static_pose) + int(args.animation.has_value()) +
                    int(!args.handles.empty());
  if (poses != 1)
    fail(kExitUsage, "choose exactly one of --rest, --bind, --static, --anim I --time T, --handles H.json");
  if (args.animation.has_value() != args.time.has_value()) fail(kExitUsage, "--anim and --time go together");
  if (args.output.empty()) fail(kExitUsage, "missing -o OUTPUT");
  const std::string extension = lowercase_extension(args.output);
  if (extension != ".obj" && extension != ".glb") fail(kExitUsage, "the output must be .obj or .glb");
  std::error_code ignored;
  if (std::filesystem::equivalent(args.input, args.output, ignored))
    fail(kExitUsage, "refusing to overwrite the input file " + args.input);
  return args;
}

// Owns the C API objects so every exit path releases them.
struct Instance {
  sf_instance* handle = nullptr;
  uint32_t deformable = 0;
  sf_deformable_info info{};
  Instance() = default;
  Instance(const Instance&) = delete;
  Instance& operator=(const Instance&) = delete;
  Instance(Instance&& other) noexcept : handle(other.handle), deformable(other.deformable), info(other.info) {
    other.handle = nullptr;
  }
  ~Instance() { sf_instance_destroy(handle); }

  void check(sf_result result, const char* call) const {
    if (result != SF_OK)
      fail(exit_code_of(result), std::string(call) + " failed for deformable " + std::to_string(deformable) + ": " +
                                     sf_instance_last_error(handle) + " (" + sf_result_string(result) + ")");
  }
};

struct AssetHandle {
  sf_asset* asset = nullptr;
  ~AssetHandle() { sf_asset_destroy(asset); }
};

// The posed dense mesh of the chosen deformables.
struct PosedMesh {
  std::vector<float> positions;  // x, y, z per vertex
  std::vector<float> normals;
  std::vector<uint32_t> triangles;
};

std::string obj_text(const PosedMesh& mesh, const std::string& comment) {
  std::string out = "# " + comment + "\n";
  char line[128];
  const size_t n = mesh.positions.size() / 3;
  for (size_t i = 0; i < n; ++i) {
    std::snprintf(line, sizeof(line), "v %.9g %.9g %.9g\n", mesh.positions[3 * i], mesh.positions[3 * i + 1],
                  mesh.positions[3 * i + 2]);
    out += line;
  }
  for (size_t i = 0; i < n; ++i) {
    std::snprintf(line, sizeof(line), "vn %.9g %.9g %.9g\n", mesh.normals[3 * i], mesh.normals[3 * i + 1],
                  mesh.normals[3 * i + 2]);
    out += line;
  }
  for (size_t t = 0; t + 2 < mesh.triangles.size(); t += 3) {
    const uint32_t a = mesh.triangles[t] + 1, b = mesh.triangles[t + 1] + 1, c = mesh.triangles[t + 2] + 1;
    std::snprintf(line, sizeof(line), "f %u//%u %u//%u %u//%u\n", a, a, b, b, c, c);
    out += line;
  }
  return out;
}

// A minimal standard GLB: one node, one mesh, one primitive (POSITION, NORMAL, uint32 indices).
std::string glb_bytes(const PosedMesh& mesh, const std::string& generator) {
  using skelform::bake::GlbBuilder;
  GlbBuilder glb;
  const int position = glb.add_floats(mesh.positions, "VEC3", 3, GlbBuilder::kArrayBuffer, true);
  const int normal = glb.add_floats(mesh.normals, "VEC3", 3, GlbBuilder::kArrayBuffer, false);
  const int indices = glb.add_indices(mesh.triangles);
  glb.document["asset"] = {{"version", "2.0"}, {"generator", generator}};
  glb.document["scene"] = 0;
  glb.document["scenes"] = {{{"nodes", {0}}}};
  glb.document["nodes"] = {{{"mesh", 0}}};
  glb.document["meshes"] = {
      {{"primitives",
        {{{"attributes", {{"POSITION", position}, {"NORMAL", normal}}}, {"indices", indices}, {"mode", 4}}}}}};
  return glb.finish();
}

int run(const Arguments& args) {
  const auto start = std::chrono::steady_clock::now();
  AssetHandle asset;
  char message[512] = "";
  sf_load_options load_options{};
  load_options.error_message = message;
  load_options.error_message_capacity = sizeof(message);
  const sf_result loaded = sf_asset_load_file(args.input.c_str(), &load_options, &asset.asset);
  if (loaded != SF_OK) {
    // The runtime's message usually names the file already.
    const std::string text = message[0] ? message : sf_result_string(loaded);
    fail(exit_code_of(loaded), text.rfind(args.input, 0) == 0 ? text : args.input + ": " + text);
  }
  const uint32_t deformable_count = sf_asset_deformable_count(asset.asset);
  if (deformable_count == 0) fail(kExitInvalidInput, args.input + " has no baked deformable (run skelform-bake first)");
  if (args.deformable && *args.deformable >= deformable_count)
    fail(kExitUsage, "--deformable " + std::to_string(*args.deformable) + " out of range: the asset has " +
                         std::to_string(deformable_count));

  // The glTF itself, for the triangles and (--anim) the animation.
  const GltfAnimation gltf = GltfAnimation::load_file(args.input);
  if (args.animation && *args.animation >= gltf.animations().size())
    fail(kExitUsage, "--anim " + std::to_string(*args.animation) + " out of range: " + args.input + " has " +
                         std::to_string(gltf.animations().size()) + " animation(s)");

  std::vector<Instance> instances;
  for (uint32_t d = 0; d < deformable_count; ++d) {
    if (args.deformable && d != *args.deformable) continue;
    Instance instance;
    instance.deformable = d;
    const sf_result info = sf_asset_deformable_info(asset.asset, d, &instance.info);
    if (info != SF_OK) fail(exit_code_of(info), "cannot describe deformable " + std::to_string(d));
    const sf_result created = sf_instance_create(asset.asset, d, &instance.handle);
    if (created != SF_OK)
      fail(exit_code_of(created),
           "cannot create an instance of deformable " + std::to_string(d) + " (" + sf_result_string(created) + ")");
    instances.push_back(std::move(instance));
  }
  if (!args.handles.empty() && instances.size() != 1)
    fail(kExitUsage, "--handles poses one deformable; the asset has " + std::to_string(instances.size()) +
                         ", choose one with --deformable K");

  std::string pose_name;
  for (Instance& instance : instances) {
    const sf_deformable_info& info = instance.info;
    if (!args.handles.empty()) {
      const HandleSet set = read_handles(args.handles);
      instance.check(sf_instance_set_handle_set(instance.handle, set.vertices.data(), set.vertices.size(),
                                                set.pinned.data(), set.pinned.size()),
                     "sf_instance_set_handle_set");
      instance.check(sf_instance_set_handle_targets(instance.handle, set.targets.data(), set.vertices.size(), 0),
                     "sf_instance_set_handle_targets");
      pose_name = std::to_string(set.vertices.size()) + " handles";
    } else if (info.skin < 0) {
      if (args.animation || args.bind || args.static_pose)
        fail(kExitInvalidInput,
             "deformable " + std::to_string(instance.deformable) + " has no skin: pose it with --handles");
      pose_name = "rest";  // an unskinned deformable is created at rest
    } else {
      std::vector<float> matrices;
      if (args.rest) {
        matrices.assign(16 * size_t{info.joint_count}, 0.0f);
        for (size_t j = 0; j < info.joint_count; ++j)
          for (size_t i = 0; i < 16; i += 5) matrices[16 * j + i] = 1.0f;
        pose_name = "rest";
      } else if (args.bind) {
        matrices = gltf.bind_pose_joint_matrices(static_cast<size_t>(info.skin));
        pose_name = "bind";
      } else if (args.static_pose) {
        matrices = gltf.joint_matrices(static_cast<size_t>(info.skin), skelform::samples::kStaticPose, 0.0);
        pose_name = "static";
      } else {
        matrices = gltf.joint_matrices(static_cast<size_t>(info.skin), *args.animation, *args.time);
        pose_name = "'" + gltf.animations()[*args.animation].name + "' at " + std::to_string(*args.time) + " s";
      }
      if (matrices.size() != 16 * size_t{info.joint_count})
        fail(kExitInvalidInput, "skin " + std::to_string(info.skin) + " has " + std::to_string(matrices.size() / 16) +
                                    " joints in the glTF but " + std::to_string(info.joint_count) + " in the bake");
      instance.check(sf_instance_set_joint_matrices(instance.handle, matrices.data(), info.joint_count, 0),
                     "sf_instance_set_joint_matrices");
    }
    sf_eval_options options{};
    options.method = args.method;
    options.flags = SF_EVAL_FROM_REST;  // one frame, no history: run to convergence
    instance.check(sf_instance_evaluate(instance.handle, &options), "sf_instance_evaluate");
  }

  PosedMesh mesh;
  for (const Instance& instance : instances) {
    for (uint32_t p = 0; p < instance.info.primitive_count; ++p) {
      sf_primitive_info primitive{};
      const sf_result described = sf_asset_primitive_info(asset.asset, instance.deformable, p, &primitive);
      if (described != SF_OK) fail(exit_code_of(described), "cannot describe a baked primitive");
      const size_t first = mesh.positions.size() / 3;
      mesh.positions.resize(mesh.positions.size() + 3 * size_t{primitive.vertex_count});
      mesh.normals.resize(mesh.positions.size());
      sf_vertex_output output{};
      output.positions = mesh.positions.data() + 3 * first;
      output.normals = mesh.normals.data() + 3 * first;
      output.vertex_capacity = primitive.vertex_count;
      instance.check(sf_instance_write(instance.handle, p, &output), "sf_instance_write");
      const std::vector<uint32_t> triangles = gltf.primitive_triangles(static_cast<size_t>(instance.info.mesh),
                                                                       static_cast<size_t>(primitive.gltf_primitive));
      for (uint32_t index : triangles) {
        if (index >= primitive.vertex_count) fail(kExitInvalidInput, "a triangle index exceeds its primitive");
        mesh.triangles.push_back(static_cast<uint32_t>(first) + index);
      }
    }
  }

  static const char* const kMethodNames[] = {"skelform", "lbs", "dqs"};
  const std::string description =
      "skelform-pose " + args.input + ": " + pose_name + ", method " + kMethodNames[args.method];
  try {
    skelform::samples::write_file_atomically(args.output, lowercase_extension(args.output) == ".obj"
                                                              ? obj_text(mesh, description)
                                                              : glb_bytes(mesh, "skelform-pose"));
  } catch (const std::runtime_error& e) {
    fail(kExitIo, e.what());
  }
  if (!args.quiet) {
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    std::printf("skelform-pose: %s (%s, %s) -> %s: %zu vertices, %zu triangles, %zu deformable(s), %.0f ms\n",
                args.input.c_str(), pose_name.c_str(), kMethodNames[args.method], args.output.c_str(),
                mesh.positions.size() / 3, mesh.triangles.size() / 3, instances.size(), ms);
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return skelform::cli::run_main(
      "skelform-pose", kUsage, argc, argv, [&] { return run(parse_arguments(argc, argv)); },
      skelform::samples::classify_gltf_error);
}
