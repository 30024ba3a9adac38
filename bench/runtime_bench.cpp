// skelform-bench: per-frame cost (DESIGN.md "Metrics"): wall time of one evaluation on one
// core, in one process, on the same dense meshes and poses, for
//   skelform    sf_instance_evaluate with default options (incremental, fairing at its default
//               budget), then sf_instance_write of positions and normals for every primitive
//   skelform_unfaired  the same with fairing off (SF_FAIR_OFF): the difference is the
//               fairing's share
//   skelform_semi_implicit  the same with the semi-implicit fairing steps (SF_FAIR_SEMI_IMPLICIT)
//   skelform_no_contacts  the default evaluation with the contact pass turned off
//               (sf_instance_set_contacts; on by default): the difference is the pass's share
//   lbs_optimised  linear blend skinning as a game engine does it (bench/fast_lbs.h: AVX2/FMA
//               when the CPU has it, positions and renormalised normals written straight
//               into an interleaved vertex buffer): the speed baseline; at start-up it is
//               checked against SF_METHOD_LBS on the first poses (stderr gives the largest
//               difference, in diagonals) and the run fails if they differ by over 1e-6
//   lbs, dqs    the runtime's baselines (SF_METHOD_LBS / SF_METHOD_DQS), same calls
//   lbs_range   SF_METHOD_LBS as an engine's skinning job calls it: sf_instance_skin_range of
//               every primitive straight into an interleaved vertex buffer like lbs_optimised's
//               (checked at start-up to give SF_METHOD_LBS's floats bit for bit)
//   delta_mush  Delta Mush with 10 smoothing iterations (bench/delta_mush.h), positions only
// on CesiumMan (3,273 vertices), CesiumMan Loop-subdivided twice (~75K triangles), each posed by
// CesiumMan's own animation, and the Quaternius Horse (a quadruped as it ships, skipped when
// the corpus is absent) galloping; sampled at 30 fps, frame after frame as a game plays it,
// wrapping around at the end (samples/common/gltf_animation.h).
//
//   skelform-bench [Google Benchmark flags]     Google Benchmark tables
//   skelform-bench --crowd N [--smoke]          N instances of CesiumMan_loop1 (~10K vertices),
//                                               each on its own pose, over every core: wall ms
//                                               of a whole frame, skelform and lbs_optimised
//   skelform-bench --frames MESH N              N evaluations of skelform on MESH (CesiumMan,
//                                               CesiumMan_loop1, CesiumMan_loop2, Horse, or the
//                                               path of a skinned .glb/.gltf with an animation,
//                                               baked with the defaults, its first animation
//                                               played), untimed: for a profiler
//                                               (bench/instructions.sh); 0 = load and set up only
//   skelform-bench --frames MESH N --runs R     then R passes of N more frames, timed: the best
//                                               and median thread CPU µs per evaluation
//   skelform-bench --markdown [--runs N]        the README's speed table (CPU time, the median
//                                               of N runs, ratios against lbs_optimised)
//   skelform-bench --json [--smoke] [--cpu] [--runs N]  one JSON line per mesh:
//     {"mesh": name, "vertices": n, "ms": {"skelform": .., "skelform_unfaired": ..,
//      "skelform_semi_implicit": .., "skelform_no_contacts": .., "lbs_optimised": ..,
//      "lbs": .., "lbs_range": .., "dqs": .., "delta_mush": ..}}
//     each figure the median of timed evaluations, the methods taking turns frame by frame
//     (--smoke: a handful, for CI), with --runs N the median of N such medians; wall time, or
//     with --cpu the thread's CPU time (the fairer figure on a loaded machine)
//
// Baked models are cached in $TMPDIR/skelform-bench-cache (bench_models.h). Without the
// shared data (SKELFORM_DATA_DIR) it prints a message and exits 0.
#include "bench_models.h"
#include "delta_mush.h"
#include "fast_lbs.h"
#include "gltf_animation.h"
#include "skelform/bake/input.h"
#include "skelform/skelform.h"

#include <benchmark/benchmark.h>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <mutex>
#include <exception>
#include <filesystem>
#include <functional>
#include <vector>

namespace {

using skelform::bench::DeltaMush;
using skelform::bench::FastLbs;

constexpr double kFramesPerSecond = 30.0;

enum class Method {
  skelform,
  skelform_unfaired,
  skelform_semi_implicit,
  skelform_no_contacts,
  lbs_optimised,
  lbs,
  lbs_range,
  dqs,
  delta_mush
};
constexpr std::array<Method, 9> kMethods = {Method::skelform,
                                            Method::skelform_unfaired,
                                            Method::skelform_semi_implicit,
                                            Method::skelform_no_contacts,
                                            Method::lbs_optimised,
                                            Method::lbs,
                                            Method::lbs_range,
                                            Method::dqs,
                                            Method::delta_mush};
// Methods that run through the C API (an sf_instance each).
bool through_api(Method method) { return method != Method::lbs_optimised && method != Method::delta_mush; }

const char* method_name(Method method) {
  switch (method) {
    case Method::skelform:
      return "skelform";
    case Method::skelform_unfaired:
      return "skelform_unfaired";
    case Method::skelform_semi_implicit:
      return "skelform_semi_implicit";
    case Method::skelform_no_contacts:
      return "skelform_no_contacts";
    case Method::lbs_optimised:
      return "lbs_optimised";
    case Method::lbs:
      return "lbs";
    case Method::lbs_range:
      return "lbs_range";
    case Method::dqs:
      return "dqs";
    case Method::delta_mush:
      return "delta_mush";
  }
  return "?";
}

struct MeshCase {
  const char* name;
  int loop_levels;        // Loop subdivisions of CesiumMan, when data_file is null
  const char* data_file;  // else this file of the data directory, as it ships
  const char* animation;  // the animation played: the first whose name contains this, else the first
};
constexpr std::array<MeshCase, 3> kMeshes = {
    MeshCase{"CesiumMan", 0, nullptr, ""}, MeshCase{"CesiumMan_loop2", 2, nullptr, ""},
    MeshCase{"Horse", 0, "quaternius/animals_pack/Horse.glb", "Gallop"}};  // a Quaternius quadruped
constexpr MeshCase kCrowdMesh{"CesiumMan_loop1", 1, nullptr, ""};

// The case's file is there (the Quaternius corpus may be absent where CesiumMan is not).
bool available(const MeshCase& mesh_case) {
  return !mesh_case.data_file || std::filesystem::exists(skelform::bench::data_dir() / mesh_case.data_file);
}

// Why a run must skip: "FILE not found under DIR (set SKELFORM_DATA_DIR)" for CesiumMan, which
// every run needs, or else for `mesh_case`'s file; empty when the data is there.
std::string missing_data(const MeshCase* mesh_case = nullptr) {
  const char* file = !skelform::bench::cesium_man_path()   ? "CesiumMan/CesiumMan.glb"
                     : mesh_case && !available(*mesh_case) ? mesh_case->data_file
                                                           : nullptr;
  if (!file) return {};
  return std::string(file) + " not found under " + skelform::bench::data_dir().string() + " (set SKELFORM_DATA_DIR)";
}

void check(sf_result result, const char* call, const sf_instance* instance = nullptr) {
  if (result != SF_OK)
    throw std::runtime_error(std::string(call) + ": " + sf_result_string(result) +
                             (instance ? std::string(" ") + sf_instance_last_error(instance) : std::string()));
}

// A baked CesiumMan (Loop-subdivided `loop_levels` times) loaded through the C API, its
// animation's poses at 30 fps, and the skin of its original vertices (the baker's loader gives
// them in sf_instance_write's order: primitives concatenated in file order).
struct Model {
  explicit Model(const MeshCase& mesh_case) {
    const std::string unbaked = mesh_case.data_file
                                    ? (skelform::bench::data_dir() / mesh_case.data_file).string()
                                    : skelform::bench::cesium_man_subdivided(mesh_case.loop_levels).string();
    const std::string baked = skelform::bench::baked_file(unbaked, mesh_case.name).string();
    char message[512] = "";
    sf_load_options load_options{};
    load_options.error_message = message;
    load_options.error_message_capacity = sizeof(message);
    if (sf_asset_load_file(baked.c_str(), &load_options, &asset) != SF_OK)
      throw std::runtime_error(baked + ": " + message);
    if (sf_asset_deformable_count(asset) != 1) throw std::runtime_error(baked + ": expected one deformable");
    check(sf_asset_deformable_info(asset, 0, &info), "sf_asset_deformable_info");
    for (uint32_t p = 0; p < info.primitive_count; ++p) {
      sf_primitive_info primitive{};
      check(sf_asset_primitive_info(asset, 0, p, &primitive), "sf_asset_primitive_info");
      primitives.push_back(primitive);
    }
    // Poses: the chosen animation at 30 fps (a subdivided CesiumMan carries the original's).
    const skelform::samples::GltfAnimation gltf = skelform::samples::GltfAnimation::load_file(unbaked);
    if (gltf.animations().empty()) throw std::runtime_error(unbaked + " has no animation");
    size_t chosen = 0;
    for (size_t a = gltf.animations().size(); a-- > 0;)
      if (gltf.animations()[a].name.find(mesh_case.animation) != std::string::npos) chosen = a;
    const skelform::samples::AnimationInfo& animation = gltf.animations()[chosen];
    const int frames = static_cast<int>(animation.duration() * kFramesPerSecond) + 1;
    for (int i = 0; i < frames; ++i)
      poses.push_back(
          gltf.joint_matrices(static_cast<size_t>(info.skin), chosen, animation.start + i / kFramesPerSecond));
    input = skelform::bake::load_mesh(unbaked);
    if (input.positions.size() != info.vertex_count)
      throw std::runtime_error(unbaked + ": vertex count differs between the loader and the runtime");
    const size_t sets = input.joint_sets.size();
    influences = 4 * sets;
    joints.resize(input.positions.size() * influences);
    weights.resize(joints.size());
    for (size_t v = 0; v < input.positions.size(); ++v)
      for (size_t s = 0; s < sets; ++s)
        for (size_t k = 0; k < 4; ++k) {
          joints[(v * sets + s) * 4 + k] = input.joint_sets[s][v][k];
          weights[(v * sets + s) * 4 + k] = input.weight_sets[s][v][k];
        }
    // Weights summing to 1, as an engine's importer leaves them (exporters write sums a few
    // 1e-5 off; the runtime normalises them too).
    for (size_t v = 0; v < input.positions.size(); ++v) {
      float sum = 0.0f;
      for (size_t k = 0; k < influences; ++k) sum += weights[v * influences + k];
      if (sum > 0.0f)
        for (size_t k = 0; k < influences; ++k) weights[v * influences + k] /= sum;
    }
  }
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;
  ~Model() { sf_asset_destroy(asset); }

  // sf_instance_write of every primitive into whole-mesh arrays (3 floats per vertex).
  void write(sf_instance* instance, float* positions, float* normals) const {
    for (uint32_t p = 0; p < primitives.size(); ++p) {
      sf_vertex_output output{};
      output.positions = positions + 3 * size_t{primitives[p].first_vertex};
      output.normals = normals + 3 * size_t{primitives[p].first_vertex};
      output.vertex_capacity = primitives[p].vertex_count;
      check(sf_instance_write(instance, p, &output), "sf_instance_write", instance);
    }
  }

  // The optimised LBS on these vertices. Its rest normals are the runtime's rest pose
  // (identity joint matrices give the stored mesh), evaluated through `scratch` with LBS.
  std::unique_ptr<FastLbs> make_fast_lbs(sf_instance* scratch) const {
    std::vector<float> identity(16 * size_t{info.joint_count}, 0.0f);
    for (uint32_t j = 0; j < info.joint_count; ++j)
      for (size_t k = 0; k < 4; ++k) identity[16 * size_t{j} + 5 * k] = 1.0f;
    check(sf_instance_set_joint_matrices(scratch, identity.data(), info.joint_count, 0),
          "sf_instance_set_joint_matrices", scratch);
    sf_eval_options options{};
    options.method = SF_METHOD_LBS;
    check(sf_instance_evaluate(scratch, &options), "sf_instance_evaluate", scratch);
    std::vector<float> positions(3 * size_t{info.vertex_count}), normals(positions.size());
    write(scratch, positions.data(), normals.data());
    return std::make_unique<FastLbs>(positions, normals, joints, weights, influences);
  }

  sf_asset* asset = nullptr;
  sf_deformable_info info{};
  std::vector<sf_primitive_info> primitives;
  std::vector<std::vector<float>> poses;
  skelform::bake::InputMesh input;
  std::vector<uint16_t> joints;  // `influences` per vertex
  std::vector<float> weights;
  size_t influences = 0;
};

// One mesh ready to evaluate: the model, an instance per runtime method, Delta Mush, the
// optimised LBS and the output buffers.
class Scene {
 public:
  explicit Scene(const MeshCase& mesh_case) : name_(mesh_case.name), model_(mesh_case) {
    const sf_deformable_info& info = model_.info;
    positions_.resize(3 * size_t{info.vertex_count});
    normals_.resize(3 * size_t{info.vertex_count});
    for (Method method : kMethods)
      if (through_api(method))
        check(sf_instance_create(model_.asset, 0, &instances_[size_t(method)]), "sf_instance_create");
    sf_instance* contacts = instances_[static_cast<size_t>(Method::skelform_no_contacts)];
    check(sf_instance_set_contacts(contacts, 0), "sf_instance_set_contacts", contacts);

    // Delta Mush on the same original vertices.
    const skelform::bake::InputMesh& input = model_.input;
    std::vector<float> rest(3 * input.positions.size());
    for (size_t v = 0; v < input.positions.size(); ++v)
      for (int c = 0; c < 3; ++c) rest[3 * v + c] = static_cast<float>(input.positions[v][c]);
    std::vector<uint32_t> triangles;
    for (const auto& t : input.triangles) triangles.insert(triangles.end(), t.begin(), t.end());
    delta_mush_ = std::make_unique<DeltaMush>(rest, triangles, model_.joints, model_.weights, model_.influences);

    lbs_optimised_ = model_.make_fast_lbs(instances_[static_cast<size_t>(Method::lbs)]);
    vertex_buffer_.resize(kVertexStride * size_t{info.vertex_count});
    range_buffer_.resize(kVertexStride * size_t{info.vertex_count});
    check_lbs_optimised();
    check_lbs_range();
  }
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;
  ~Scene() {
    for (sf_instance* instance : instances_) sf_instance_destroy(instance);
  }

  const std::string& name() const { return name_; }
  size_t vertex_count() const { return model_.info.vertex_count; }
  size_t pose_count() const { return model_.poses.size(); }

  // One frame of `method` at pose `pose`: what an engine pays per character per frame.
  void evaluate(Method method, size_t pose) {
    const std::vector<float>& matrices = model_.poses[pose % model_.poses.size()];
    if (method == Method::delta_mush) {
      delta_mush_->deform(matrices.data(), model_.info.joint_count, positions_.data());
      return;
    }
    if (method == Method::lbs_optimised) {
      lbs_optimised_->skin(matrices.data(), vertex_buffer_.data(), kVertexStride);
      return;
    }
    evaluate_api(method, matrices);
  }

  const float* positions() const { return positions_.data(); }

 private:
  static constexpr size_t kVertexStride = 8;  // floats per vertex: position, normal, uv

  void evaluate_api(Method method, const std::vector<float>& matrices) {
    sf_instance* instance = instances_[static_cast<size_t>(method)];
    check(sf_instance_set_joint_matrices(instance, matrices.data(), model_.info.joint_count, 0),
          "sf_instance_set_joint_matrices", instance);
    if (method == Method::lbs_range) {
      // An engine's skinning job through the API: every primitive straight into the
      // interleaved vertex buffer, as lbs_optimised writes it.
      for (uint32_t p = 0; p < model_.primitives.size(); ++p) {
        const sf_primitive_info& primitive = model_.primitives[p];
        sf_vertex_output output{};
        output.positions = range_buffer_.data() + kVertexStride * size_t{primitive.first_vertex};
        output.position_stride = kVertexStride * sizeof(float);
        output.normals = output.positions + 3;
        output.normal_stride = output.position_stride;
        output.vertex_capacity = primitive.vertex_count;
        check(sf_instance_skin_range(instance, SF_METHOD_LBS, p, 0, primitive.vertex_count, &output),
              "sf_instance_skin_range");
      }
      return;
    }
    sf_eval_options options{};  // defaults (fairing as the runtime ships it), incremental
    options.method = method == Method::lbs ? SF_METHOD_LBS : method == Method::dqs ? SF_METHOD_DQS : SF_METHOD_SKELFORM;
    if (method == Method::skelform_unfaired) options.fairing_flags = SF_FAIR_OFF;
    if (method == Method::skelform_semi_implicit) options.fairing_flags = SF_FAIR_SEMI_IMPLICIT;
    check(sf_instance_evaluate(instance, &options), "sf_instance_evaluate", instance);
    model_.write(instance, positions_.data(), normals_.data());
  }

  // The optimised LBS gives SF_METHOD_LBS's result: on the first poses, the largest
  // difference of a position (in diagonals of the posed mesh) and of a normal must stay under
  // 1e-6 and 1e-5 (float rounding: the two sum in different orders, one with FMA).
  void check_lbs_optimised() {
    const size_t n = model_.info.vertex_count;
    double position_error = 0.0, normal_error = 0.0;
    for (size_t pose = 0; pose < std::min<size_t>(model_.poses.size(), 8); ++pose) {
      evaluate_api(Method::lbs, model_.poses[pose]);
      lbs_optimised_->skin(model_.poses[pose].data(), vertex_buffer_.data(), kVertexStride);
      glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
      for (size_t v = 0; v < n; ++v)
        for (size_t c = 0; c < 3; ++c) {
          lo[int(c)] = std::min(lo[int(c)], positions_[3 * v + c]);
          hi[int(c)] = std::max(hi[int(c)], positions_[3 * v + c]);
        }
      const double diagonal = double(glm::length(hi - lo));
      for (size_t v = 0; v < n; ++v)
        for (size_t c = 0; c < 3; ++c) {
          const float* out = vertex_buffer_.data() + kVertexStride * v;
          position_error =
              std::max(position_error, std::fabs(double(out[c]) - double(positions_[3 * v + c])) / diagonal);
          normal_error = std::max(normal_error, std::fabs(double(out[3 + c]) - double(normals_[3 * v + c])));
        }
    }
    std::fprintf(stderr,
                 "skelform-bench: %s: lbs_optimised (%s) differs from SF_METHOD_LBS by %.2g diagonals "
                 "(positions), %.2g (normals)\n",
                 name_.c_str(), lbs_optimised_->kernel(), position_error, normal_error);
    if (!(position_error <= 1e-6 && normal_error <= 1e-5))
      throw std::runtime_error(name_ + ": lbs_optimised does not match SF_METHOD_LBS");
  }

  // lbs_range gives SF_METHOD_LBS's floats bit for bit, on the first poses.
  void check_lbs_range() {
    const size_t n = model_.info.vertex_count;
    for (size_t pose = 0; pose < std::min<size_t>(model_.poses.size(), 8); ++pose) {
      evaluate_api(Method::lbs, model_.poses[pose]);
      evaluate_api(Method::lbs_range, model_.poses[pose]);
      for (size_t v = 0; v < n; ++v)
        if (std::memcmp(&range_buffer_[kVertexStride * v], &positions_[3 * v], 3 * sizeof(float)) != 0 ||
            std::memcmp(&range_buffer_[kVertexStride * v + 3], &normals_[3 * v], 3 * sizeof(float)) != 0)
          throw std::runtime_error(name_ + ": lbs_range differs from SF_METHOD_LBS");
    }
  }

  std::string name_;
  Model model_;
  std::array<sf_instance*, kMethods.size()> instances_{};  // indexed by Method (null where not through_api)
  std::unique_ptr<DeltaMush> delta_mush_;
  std::unique_ptr<FastLbs> lbs_optimised_;
  std::vector<float> positions_, normals_;
  std::vector<float> vertex_buffer_;  // the optimised LBS's interleaved output
  std::vector<float> range_buffer_;   // lbs_range's, laid out alike
};

// Scenes are expensive (bake on first use): built once per process.
Scene& scene(const MeshCase& mesh_case) {
  static std::map<std::string, std::unique_ptr<Scene>> scenes;
  std::unique_ptr<Scene>& slot = scenes[mesh_case.name];
  if (!slot) slot = std::make_unique<Scene>(mesh_case);
  return *slot;
}

// Milliseconds of wall time, or of this thread's CPU time.
double now_ms(bool cpu_time) {
  if (cpu_time) {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
  }
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Median time of `samples` single evaluations of each method, after one warm-up pass over
// the poses per method (the incremental evaluation then runs in its steady state). The
// methods take turns frame by frame (sample i of every method, then sample i + 1), so a
// machine whose speed drifts during the run (a shared VM, a CPU changing its clock) slows
// every method alike and the ratios between them hold.
std::array<double, kMethods.size()> median_ms(Scene& s, int samples, bool cpu_time) {
  for (Method method : kMethods)
    for (size_t pose = 0; pose < s.pose_count(); ++pose) s.evaluate(method, pose);
  std::array<std::vector<double>, kMethods.size()> times;
  for (int i = 0; i < samples; ++i)
    for (size_t m = 0; m < kMethods.size(); ++m) {
      const double start = now_ms(cpu_time);
      s.evaluate(kMethods[m], static_cast<size_t>(i));
      times[m].push_back(now_ms(cpu_time) - start);
      benchmark::DoNotOptimize(s.positions());
    }
  std::array<double, kMethods.size()> medians{};
  for (size_t m = 0; m < kMethods.size(); ++m) {
    std::nth_element(times[m].begin(), times[m].begin() + times[m].size() / 2, times[m].end());
    medians[m] = times[m][times[m].size() / 2];
  }
  return medians;
}

// The machine, for the Markdown table: the CPU's model name (Linux) and the cores.
std::string machine_name() {
  std::string model = "unknown CPU";
  if (FILE* f = std::fopen("/proc/cpuinfo", "r")) {
    char line[512];
    while (std::fgets(line, sizeof(line), f))
      if (std::strncmp(line, "model name", 10) == 0) {
        const char* colon = std::strchr(line, ':');
        if (colon) model = std::string(colon + 2, std::strcspn(colon + 2, "\n"));
        break;
      }
    std::fclose(f);
  }
  return model + ", " + std::to_string(std::thread::hardware_concurrency()) + " cores";
}

// `runs` repetitions of median_ms per mesh, and the median of each method over them: one JSON
// line per mesh, or (markdown) the README's table, every ratio against lbs_optimised.
int run_json(bool smoke, bool cpu_time, int runs, bool markdown) {
  if (const std::string missing = missing_data(); !missing.empty()) {
    std::fprintf(stderr, "skelform-bench: skipped: %s\n", missing.c_str());
    return 0;
  }
  const int samples = smoke ? 5 : 101;
  if (markdown) {
    std::printf(
        "ms per evaluation, %s time of one thread, median of %d runs of %d frames (`skelform-bench --markdown "
        "--runs %d`), %s; in brackets: × lbs_optimised\n\n",
        cpu_time ? "CPU" : "wall", runs, samples, runs, machine_name().c_str());
    std::printf("| mesh | vertices |");
    for (Method method : kMethods) std::printf(" %s |", method_name(method));
    std::printf("\n| --- | ---: |");
    for (size_t m = 0; m < kMethods.size(); ++m) std::printf(" ---: |");
    std::printf("\n");
  }
  for (const MeshCase& mesh_case : kMeshes) {
    if (!available(mesh_case)) {
      std::fprintf(stderr, "skelform-bench: %s skipped: %s not found under %s\n", mesh_case.name, mesh_case.data_file,
                   skelform::bench::data_dir().string().c_str());
      continue;
    }
    Scene& s = scene(mesh_case);
    std::array<std::vector<double>, kMethods.size()> per_run;
    for (int run = 0; run < runs; ++run) {
      const std::array<double, kMethods.size()> medians = median_ms(s, samples, cpu_time);
      for (size_t m = 0; m < kMethods.size(); ++m) per_run[m].push_back(medians[m]);
    }
    std::array<double, kMethods.size()> medians{};
    for (size_t m = 0; m < kMethods.size(); ++m) {
      std::sort(per_run[m].begin(), per_run[m].end());
      medians[m] = per_run[m][per_run[m].size() / 2];
    }
    if (markdown) {
      const double base = medians[static_cast<size_t>(Method::lbs_optimised)];
      std::printf("| %s | %zu |", s.name().c_str(), s.vertex_count());
      for (size_t m = 0; m < kMethods.size(); ++m)
        std::printf(" %.3f (%.1f×) |", medians[m], base > 0.0 ? medians[m] / base : 0.0);
      std::printf("\n");
      std::fflush(stdout);
      continue;
    }
    std::string ms;
    for (size_t m = 0; m < kMethods.size(); ++m) {
      char item[96];
      std::snprintf(item, sizeof(item), "%s\"%s\": %.4f", ms.empty() ? "" : ", ", method_name(kMethods[m]), medians[m]);
      ms += item;
    }
    std::printf("{\"mesh\": \"%s\", \"vertices\": %zu, \"ms\": {%s}}\n", s.name().c_str(), s.vertex_count(),
                ms.c_str());
    std::fflush(stdout);
  }
  return 0;
}

// --crowd N: N instances of one asset (CesiumMan Loop-subdivided once, ~10K vertices), each
// on its own pose (the animation's frames, staggered per instance), evaluated frame after
// frame over `threads` worker threads (an engine's job system: each takes every threads-th
// instance). Reports the median wall time of a whole frame (all N) for skelform (defaults)
// and for lbs_optimised on the same threads. Instances are independent objects on one shared
// asset (skelform.h: assets are immutable and shareable; an instance belongs to one thread at
// a time).
class Crowd {
 public:
  Crowd(size_t count, unsigned threads) : threads_(threads), model_(kCrowdMesh) {
    members_.resize(count);
    for (Member& m : members_) {
      check(sf_instance_create(model_.asset, 0, &m.instance), "sf_instance_create");
      m.positions.resize(3 * size_t{model_.info.vertex_count});
      m.normals.resize(3 * size_t{model_.info.vertex_count});
      m.vertex_buffer.resize(8 * size_t{model_.info.vertex_count});
    }
    lbs_ = model_.make_fast_lbs(members_[0].instance);
  }
  Crowd(const Crowd&) = delete;
  Crowd& operator=(const Crowd&) = delete;
  ~Crowd() {
    for (Member& m : members_) sf_instance_destroy(m.instance);
  }

  size_t vertex_count() const { return model_.info.vertex_count; }

  // Wall milliseconds of one frame of every instance, skelform (lbs = false) or lbs_optimised.
  double frame_ms(size_t frame, bool lbs) {
    const auto start = std::chrono::steady_clock::now();
    std::vector<std::thread> workers;
    std::exception_ptr failure;
    std::mutex failure_mutex;
    for (unsigned t = 0; t < threads_; ++t)
      workers.emplace_back([&, t] {
        try {
          for (size_t i = t; i < members_.size(); i += threads_) {
            Member& m = members_[i];
            const std::vector<float>& pose = model_.poses[(frame + 7 * i) % model_.poses.size()];
            if (lbs) {
              lbs_->skin(pose.data(), m.vertex_buffer.data(), 8);
              continue;
            }
            check(sf_instance_set_joint_matrices(m.instance, pose.data(), model_.info.joint_count, 0),
                  "sf_instance_set_joint_matrices", m.instance);
            check(sf_instance_evaluate(m.instance, nullptr), "sf_instance_evaluate", m.instance);
            model_.write(m.instance, m.positions.data(), m.normals.data());
          }
        } catch (...) {
          std::lock_guard<std::mutex> lock(failure_mutex);
          failure = std::current_exception();
        }
      });
    for (std::thread& w : workers) w.join();
    if (failure) std::rethrow_exception(failure);
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }

 private:
  struct Member {
    sf_instance* instance = nullptr;
    std::vector<float> positions, normals, vertex_buffer;
  };

  unsigned threads_;
  Model model_;
  std::vector<Member> members_;
  std::unique_ptr<FastLbs> lbs_;
};

int run_crowd(size_t count, bool smoke) {
  if (const std::string missing = missing_data(); !missing.empty()) {
    std::fprintf(stderr, "skelform-bench: skipped: %s\n", missing.c_str());
    return 0;
  }
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  Crowd crowd(count, threads);
  const size_t frames = smoke ? 3 : 31;
  for (size_t f = 0; f < 3; ++f) crowd.frame_ms(f, false), crowd.frame_ms(f, true);  // warm-up
  std::vector<double> skelform, lbs;
  for (size_t f = 0; f < frames; ++f) {
    skelform.push_back(crowd.frame_ms(f, false));
    lbs.push_back(crowd.frame_ms(f, true));
  }
  auto median = [](std::vector<double>& v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  std::printf(
      "{\"crowd\": %zu, \"mesh\": \"CesiumMan_loop1\", \"vertices\": %zu, \"threads\": %u, \"frames\": %zu, "
      "\"ms_per_frame\": {\"skelform\": %.3f, \"lbs_optimised\": %.3f}}\n",
      count, crowd.vertex_count(), threads, frames, median(skelform), median(lbs));
  return 0;
}

// --frames MESH N: N evaluations of `skelform` on one of the bench's meshes, frame after frame
// from its animation's first pose, and one line out: for a profiler. bench/instructions.sh
// runs it under callgrind with N, 1 and 0 frames: the difference of N and 1 over N − 1 is the
// instructions of a warm evaluation (setup and the first, converging one cancel out), that of
// 1 and 0 the first evaluation's (a fresh start, as after a pose jump).
// With `runs` > 0, then `runs` timed passes of N more frames each, and the best and the median
// thread CPU time per evaluation over the passes: a change's speed on this machine, whose speed
// moves within a session, is judged by the best of such passes taken in turns with the build
// before. The passes go on with the animation (a replayed window would start each pass with a
// pose jump), so each plays its own stretch of it, the same stretches for every build: compare
// builds at the same N and R.
int run_frames(const std::string& mesh, long frames, int runs) {
  const MeshCase* chosen = nullptr;
  for (const MeshCase& mesh_case : kMeshes)
    if (mesh == mesh_case.name) chosen = &mesh_case;
  if (mesh == kCrowdMesh.name) chosen = &kCrowdMesh;
  // Any other skinned file, by its path: cached under its stem and a hash of its absolute path
  // (two files may share a stem). The data directory joined with an absolute path is that path.
  static std::string file, cache_name;
  static MeshCase file_case{};
  std::error_code error;
  if (!chosen && std::filesystem::is_regular_file(mesh, error)) {
    file = std::filesystem::absolute(mesh).lexically_normal().string();
    char hash[32];
    std::snprintf(hash, sizeof(hash), "%016zx", std::hash<std::string>{}(file));
    cache_name = "file_" + std::filesystem::path(file).stem().string() + "_" + hash;
    file_case = MeshCase{cache_name.c_str(), 0, file.c_str(), ""};
    chosen = &file_case;
  }
  if (!chosen) {
    std::fprintf(stderr,
                 "skelform-bench: error: --frames: unknown mesh %s (CesiumMan, CesiumMan_loop1, "
                 "CesiumMan_loop2, Horse, or the path of a skinned glTF file)\n",
                 mesh.c_str());
    return 1;
  }
  // (A file given by its path needs no shared data.)
  if (const std::string missing = chosen == &file_case ? std::string() : missing_data(chosen); !missing.empty()) {
    std::fprintf(stderr, "skelform-bench: skipped: %s\n", missing.c_str());
    return 0;
  }
  Scene& s = scene(*chosen);
  for (long f = 0; f < frames; ++f) s.evaluate(Method::skelform, size_t(f));
  if (runs == 0) {
    std::printf("{\"mesh\": \"%s\", \"vertices\": %zu, \"frames\": %ld}\n", chosen->name, s.vertex_count(), frames);
    return 0;
  }
  std::vector<double> pass_us;
  for (int r = 1; r <= runs; ++r) {
    const double start = now_ms(true);
    for (long f = 0; f < frames; ++f) s.evaluate(Method::skelform, size_t(r * frames + f));
    pass_us.push_back((now_ms(true) - start) * 1e3 / double(frames));
  }
  std::sort(pass_us.begin(), pass_us.end());
  const double best = pass_us.front(), median = pass_us[pass_us.size() / 2];
  std::printf(
      "{\"mesh\": \"%s\", \"vertices\": %zu, \"frames\": %ld, \"runs\": %d, \"us_best\": %.1f, "
      "\"us_median\": %.1f}\n",
      chosen->name, s.vertex_count(), frames, runs, best, median);
  return 0;
}

void register_benchmarks() {
  for (const MeshCase& mesh_case : kMeshes)
    for (Method method : kMethods) {
      const std::string name = std::string("evaluate/") + mesh_case.name + "/" + method_name(method);
      benchmark::RegisterBenchmark(name.c_str(), [mesh_case, method](benchmark::State& state) {
        if (const std::string missing = missing_data(&mesh_case); !missing.empty()) {
          state.SkipWithError(missing.c_str());
          return;
        }
        Scene& s = scene(mesh_case);
        for (size_t pose = 0; pose < s.pose_count(); ++pose) s.evaluate(method, pose);  // warm-up
        size_t pose = 0;
        for (auto _ : state) {
          s.evaluate(method, pose++);
          benchmark::DoNotOptimize(s.positions());
        }
        state.counters["vertices"] = static_cast<double>(s.vertex_count());
      })->Unit(benchmark::kMillisecond);
    }
}

}  // namespace

int main(int argc, char** argv) {
  bool json = false, markdown = false, smoke = false, cpu_time = false;
  int runs = 1;
  long crowd = 0, frames = 0;
  bool frames_given = false, runs_given = false;
  std::string frames_mesh;
  std::vector<char*> passed{argv[0]};
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--json") == 0)
      json = true;
    else if (std::strcmp(argv[i], "--markdown") == 0)
      markdown = cpu_time = true;
    else if (std::strcmp(argv[i], "--smoke") == 0)
      smoke = true;
    else if (std::strcmp(argv[i], "--cpu") == 0)
      cpu_time = true;
    else if (std::strcmp(argv[i], "--runs") == 0 && i + 1 < argc) {
      char* end = nullptr;
      const long n = std::strtol(argv[++i], &end, 10);
      if (*end != '\0' || n < 1 || n > 99) {
        std::fprintf(stderr, "skelform-bench: error: --runs takes 1 to 99, got %s\n", argv[i]);
        return 1;
      }
      runs = int(n);
      runs_given = true;
    } else if (std::strcmp(argv[i], "--crowd") == 0 && i + 1 < argc) {
      char* end = nullptr;
      crowd = std::strtol(argv[++i], &end, 10);
      if (*end != '\0' || crowd < 1 || crowd > 10000) {
        std::fprintf(stderr, "skelform-bench: error: --crowd takes 1 to 10000 instances, got %s\n", argv[i]);
        return 1;
      }
    } else if (std::strcmp(argv[i], "--frames") == 0 && i + 2 < argc) {
      if (frames_given) {
        std::fprintf(stderr, "skelform-bench: error: --frames given twice\n");
        return 1;
      }
      frames_given = true;
      frames_mesh = argv[++i];
      char* end = nullptr;
      frames = std::strtol(argv[++i], &end, 10);
      if (*end != '\0' || frames < 0 || frames > 100000) {
        std::fprintf(stderr, "skelform-bench: error: --frames MESH N takes 0 to 100000 frames, got %s\n", argv[i]);
        return 1;
      }
    } else
      passed.push_back(argv[i]);
  }
  try {
    if (frames_given) {
      if (passed.size() > 1 || json || markdown || cpu_time || smoke || crowd > 0) {
        std::fprintf(stderr, "skelform-bench: error: --frames MESH N takes only --runs R\n");
        return 1;
      }
      if (runs_given && frames == 0) {
        std::fprintf(stderr, "skelform-bench: error: --frames MESH 0 times nothing: --runs needs N > 0\n");
        return 1;
      }
      return run_frames(frames_mesh, frames, runs_given ? runs : 0);
    }
    if (crowd > 0) {
      if (passed.size() > 1 || json || markdown || cpu_time || runs != 1) {
        std::fprintf(stderr, "skelform-bench: error: --crowd N takes only --smoke\n");
        return 1;
      }
      return run_crowd(size_t(crowd), smoke);
    }
    if (json || markdown) {
      if (passed.size() > 1) {
        std::fprintf(stderr,
                     "skelform-bench: error: --json and --markdown take only --smoke, --cpu and --runs N, got %s\n",
                     passed[1]);
        return 1;
      }
      return run_json(smoke, cpu_time, runs, markdown);
    }
    if (cpu_time || runs != 1) {
      std::fprintf(
          stderr,
          "skelform-bench: error: --cpu and --runs belong to --json and --markdown (--runs also to --frames)\n");
      return 1;
    }
    static char min_time[] = "--benchmark_min_time=0.01";
    if (smoke) passed.push_back(min_time);
    int count = static_cast<int>(passed.size());
    benchmark::Initialize(&count, passed.data());
    if (benchmark::ReportUnrecognizedArguments(count, passed.data())) return 1;
    register_benchmarks();
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "skelform-bench: error: %s\n", e.what());
    return 1;
  }
}
