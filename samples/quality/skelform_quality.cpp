// skelform-quality: measures skelform against linear blend skinning on real characters, the
// way DESIGN.md "Metrics" defines it, over every animation of every file given.
//
//   skelform-quality FILE|DIR... [--frames N] [--fps F] [--fresh | --cuts] [--json] [--check] [-j N]
//                    [--quiet]
//
// Each file is baked in memory when it has no SKELFORM_skeletal_deformation extension (the
// baker's defaults), then played through the C API as an engine plays it: per animation, the
// first frame from rest, then every 1/fps seconds incrementally; N evenly spaced frames of it
// (the first and last included) are measured against LBS evaluated on the same joint
// matrices. With --fresh, every measured frame is a fresh start instead (SF_EVAL_FROM_REST, as
// after a pose jump), and nothing is played between them. With --cuts, each animation's first
// frame follows the previous animation's last (the first animation's, the bind pose the tool
// evaluated first) without SF_EVAL_FROM_REST, as an engine that cuts without saying so: where
// the runtime detects the pose jump, a fresh start spread over evaluations. Everything is taken
// against the bind pose in world space (the skin's joint matrices with no animation applied,
// LBS there):
//   pairs added     intersecting pairs of non-adjacent triangles of the posed mesh that do not
//                   intersect at the bind pose (quality_metrics.h)
//   at junctions    of the pairs added, those between two parts of the mesh (connected pieces)
//                   that already intersect each other at the bind pose (quality_metrics.h
//                   Junctions); reported beside the pairs added, not instead of them
//   worse frames    measured frames where skelform adds more pairs than LBS
//   |ΔV|            |V(posed) − V(bind)| / V(bind), on closed meshes only
//   rigid           max distance of a single-influence vertex (largest weight ≥ 0.999) from
//                   its rigid motion (LBS's result), over the bind pose's bounding diagonal
//   rest, bind      max |skelform − stored| at identity joint matrices / the stored mesh's
//                   diagonal, and max |skelform − LBS| at the bind pose / the bind diagonal
// --check exits 5 when an acceptance line of DESIGN.md "Never worse than LBS" breaks.
#include "baked_asset.h"
#include "cli.h"
#include "gltf_animation.h"
#include "quality_metrics.h"
#include "skelform/bake/input.h"
#include "skelform/skelform.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace skelform::cli;
using namespace skelform::samples;

const char* const kUsage =
    "usage: skelform-quality FILE|DIR... [--frames N] [--fps F] [--json] [--check [--waive LINE]...]\n"
    "                        [-j N] [--quiet] [--skeleton S] [--reconstruction R] [--fairing F]\n"
    "                        [--fairing-iterations N] [--no-contacts] [--fresh | --cuts]\n"
    "\n"
    "Plays every animation of skinned glTF 2.0 models through skelform and through linear\n"
    "blend skinning (LBS) and prints, per character and animation, against the bind pose in\n"
    "world space: intersecting triangle pairs added (skelform / LBS; and of those, the pairs\n"
    "between parts modelled through each other), frames where skelform adds more than LBS,\n"
    "mean and worst |volume change| (closed meshes), the largest distance of single-influence\n"
    "vertices from their rigid motion, and the rest and bind pose errors.\n"
    "Files without the SKELFORM_skeletal_deformation extension are baked in memory first.\n"
    "Directories are searched recursively for .glb and .gltf files.\n"
    "\n"
    "Options:\n"
    "  --frames N     measured frames per animation, evenly spaced, ends included (default 9)\n"
    "  --fps F        rate at which animations are played between them (default 30)\n"
    "  --json         one JSON document on stdout instead of the table\n"
    "  --markdown     one Markdown table instead (then --check's lines): a row per pack (the\n"
    "                 files' folder) and the total\n"
    "  --check        exit 5 when an acceptance line breaks: a frame where skelform adds more\n"
    "                 pairs than LBS, skelform's summed pairs above 50 % of LBS's, a closed\n"
    "                 character whose mean |volume change| exceeds LBS's, a single-influence\n"
    "                 vertex further than 1e-6 of the diagonal from its rigid motion, a rest or\n"
    "                 bind error above 1e-5, or a file that could not be measured\n"
    "  --skeleton S   skelform's skeleton skinning: arcs (default), lbs or dqs\n"
    "  --reconstruction R  carried (default) or paper (the homotopy of eqs. (2), (3))\n"
    "  --fairing F    on (default), off, folds (flow (4) only) or intersections (flow (5) only)\n"
    "  --fairing-iterations N  fairing iterations per incremental evaluation (default 1)\n"
    "  --no-contacts  skelform with the runtime's contact pass off (sf_instance_set_contacts;\n"
    "                 on by default)\n"
    "  --fresh        every measured frame from rest (SF_EVAL_FROM_REST, as after a pose jump),\n"
    "                 nothing played between them (--fps unused): the quality of a fresh start\n"
    "  --cuts         each animation's first frame without SF_EVAL_FROM_REST, the instance going\n"
    "                 on from the previous animation: an undeclared cut (a pose jump where the\n"
    "                 runtime detects one)\n"
    "  --waive LINE   with --check: report acceptance line LINE (worse-frames, pair-share,\n"
    "                 volume, rigid, rest, bind, refused) without failing on it (repeatable)\n"
    "  -j N           files measured in parallel (default: the number of cores)\n"
    "  -q, --quiet    no progress on stderr\n"
    "  -h, --help     this text\n"
    "  --version      print the version\n"
    "\n"
    "Exit codes: 0 success, 1 bad command line, 2 invalid or unsupported input, 3 file could\n"
    "            not be read, 4 internal error, 5 --check found an acceptance line broken.\n";

constexpr int kExitCheckFailed = 5;
constexpr double kSingleInfluence = 0.999;
constexpr double kMaxRigidDeviation = 1e-6;
constexpr double kMaxPoseError = 1e-5;
constexpr double kMaxPairShare = 0.5;

struct Arguments {
  std::vector<std::string> inputs;
  size_t frames = 9;
  double fps = 30.0;
  bool json = false;
  bool markdown = false;
  bool check = false;
  bool quiet = false;
  unsigned jobs = 0;
  sf_eval_options options{};        // skelform's evaluation options (--skeleton, --reconstruction, --fairing)
  bool contacts = true;             // skelform with the contact pass on (the default)
  bool fresh = false;               // every measured frame from rest (--fresh)
  bool cuts = false;                // each animation's first frame an undeclared cut (--cuts)
  std::vector<std::string> waived;  // acceptance lines --check reports but does not enforce
};

// The acceptance lines, by the names --waive takes.
const char* const kLines[] = {"worse-frames", "pair-share", "volume", "rigid", "rest", "bind", "refused"};

Arguments parse_arguments(int argc, char** argv) {
  Arguments args;
  skelform::cli::ArgumentCursor cursor(argc, argv);
  while (cursor.next()) {
    const std::string& arg = cursor.arg();
    if (arg == "--frames")
      args.frames = parse_integer(arg, cursor.value(), 2, 10000);
    else if (arg == "--fps")
      args.fps = parse_positive(arg, cursor.value(), 1000.0);
    else if (arg == "-j")
      args.jobs = unsigned(parse_integer(arg, cursor.value(), 1, 256));
    else if (arg == "--skeleton") {
      constexpr sf_skeleton_skinning kSkinnings[] = {SF_SKELETON_ARCS, SF_SKELETON_LBS, SF_SKELETON_DQS};
      args.options.skeleton_skinning = kSkinnings[parse_choice(arg, cursor.value(), {"arcs", "lbs", "dqs"})];
    } else if (arg == "--reconstruction") {
      constexpr sf_reconstruction kReconstructions[] = {SF_RECONSTRUCTION_CARRIED, SF_RECONSTRUCTION_PAPER};
      args.options.reconstruction = kReconstructions[parse_choice(arg, cursor.value(), {"carried", "paper"})];
    } else if (arg == "--fairing") {
      constexpr uint32_t kFairings[] = {0, SF_FAIR_OFF, SF_FAIR_NO_INTERSECTION_FLOW, SF_FAIR_NO_FOLD_FLOW};
      args.options.fairing_flags =
          kFairings[parse_choice(arg, cursor.value(), {"on", "off", "folds", "intersections"})];
    } else if (arg == "--fairing-iterations") {
      args.options.fairing_iterations = uint32_t(parse_integer(arg, cursor.value(), 1, 1000));
    } else if (arg == "--no-contacts")
      args.contacts = false;
    else if (arg == "--fresh")
      args.fresh = true;
    else if (arg == "--cuts")
      args.cuts = true;
    else if (arg == "--waive") {
      const std::string line = cursor.value();
      if (std::find_if(std::begin(kLines), std::end(kLines), [&](const char* l) { return line == l; }) ==
          std::end(kLines))
        fail(kExitUsage,
             "--waive expects one of worse-frames, pair-share, volume, rigid, rest, bind, refused; got '" + line + "'");
      args.waived.push_back(line);
    } else if (arg == "--json")
      args.json = true;
    else if (arg == "--markdown")
      args.markdown = true;
    else if (arg == "--check")
      args.check = true;
    else if (arg == "-q" || arg == "--quiet")
      args.quiet = true;
    else if (cursor.is_option())
      cursor.unknown();
    else
      args.inputs.push_back(arg);
  }
  if (args.inputs.empty()) fail(kExitUsage, "expected at least one file or directory");
  if (args.fresh && args.cuts) fail(kExitUsage, "--fresh and --cuts exclude each other");
  return args;
}

// The files to measure: each argument, or the .glb/.gltf files under it, sorted.
std::vector<std::string> collect_files(const std::vector<std::string>& inputs) {
  std::vector<std::string> files;
  for (const std::string& input : inputs) {
    std::error_code error;
    if (std::filesystem::is_directory(input, error)) {
      std::vector<std::string> found;
      for (auto it = std::filesystem::recursive_directory_iterator(input, error);
           !error && it != std::filesystem::recursive_directory_iterator(); it.increment(error)) {
        const std::string extension = lowercase_extension(it->path().string());
        if (it->is_regular_file() && (extension == ".glb" || extension == ".gltf"))
          found.push_back(it->path().string());
      }
      if (error) fail(kExitIo, "cannot list " + input + ": " + error.message());
      std::sort(found.begin(), found.end());
      files.insert(files.end(), found.begin(), found.end());
    } else if (std::filesystem::is_regular_file(input, error)) {
      files.push_back(input);
    } else {
      fail(kExitIo, "cannot read " + input + ": no such file or directory");
    }
  }
  if (files.empty()) fail(kExitUsage, "no .glb or .gltf file found");
  return files;
}

// ---- Measurement of one file ------------------------------------------------------------------

struct FrameResult {
  size_t skelform_added = 0, lbs_added = 0;
  size_t skelform_junction = 0, lbs_junction = 0;  // of those, between parts joined as modelled
  double skelform_volume = 0, lbs_volume = 0;      // |ΔV| / V(bind); 0 for open meshes
  double rigid = 0;
};

struct AnimationResult {
  std::string name;
  std::vector<FrameResult> frames;
};

struct FileResult {
  std::string path, pack, name;
  std::string refused;                // the failure message; the rest is empty then
  std::vector<std::string> warnings;  // exporter defects the in-memory bake repaired
  size_t vertices = 0, triangles = 0, rigid_vertices = 0, bind_pairs = 0;
  bool closed = true;
  double rest_error = 0, bind_error = 0;
  std::vector<AnimationResult> animations;
  double seconds = 0;
};

// Owns one instance; a failed call throws a Failure naming the call.
struct Instance {
  sf_instance* handle = nullptr;
  Instance() = default;
  Instance(const Instance&) = delete;
  Instance& operator=(const Instance&) = delete;
  ~Instance() { sf_instance_destroy(handle); }
  void check(sf_result result, const char* call) const {
    if (result != SF_OK)
      fail(exit_code_of(result),
           std::string(call) + ": " + sf_instance_last_error(handle) + " (" + sf_result_string(result) + ")");
  }
};

// One deformable of the file: its two instances, topology and references.
struct Character {
  sf_deformable_info info{};
  std::vector<sf_primitive_info> primitives;
  Instance skelform, lbs;
  DenseTopology topology;
  std::vector<uint8_t> rigid;  // per dense vertex: single influence
  std::vector<TrianglePair> bind_pairs;
  Junctions junctions;  // parts that intersect each other at the bind pose
  double bind_volume = 0, diagonal = 1;
};

std::vector<float> identity_matrices(size_t joint_count) {
  std::vector<float> matrices(16 * joint_count, 0.0f);
  for (size_t j = 0; j < joint_count; ++j)
    for (size_t i = 0; i < 16; i += 5) matrices[16 * j + i] = 1.0f;
  return matrices;
}

std::vector<float> dense_positions(const Instance& instance, const Character& c) {
  std::vector<float> positions(3 * size_t{c.info.vertex_count});
  for (uint32_t p = 0; p < c.primitives.size(); ++p) {
    sf_vertex_output output{};
    output.positions = positions.data() + 3 * size_t{c.primitives[p].first_vertex};
    output.vertex_capacity = c.primitives[p].vertex_count;
    instance.check(sf_instance_write(instance.handle, p, &output), "sf_instance_write");
  }
  return positions;
}

double max_distance(const std::vector<float>& a, const std::vector<float>& b, const std::vector<uint8_t>* only) {
  double worst = 0;
  for (size_t v = 0; 3 * v + 2 < a.size(); ++v) {
    if (only && !(*only)[v]) continue;
    const double dx = double(a[3 * v]) - b[3 * v], dy = double(a[3 * v + 1]) - b[3 * v + 1],
                 dz = double(a[3 * v + 2]) - b[3 * v + 2];
    worst = std::max(worst, std::sqrt(dx * dx + dy * dy + dz * dz));
  }
  return worst;
}

// Per original vertex of the deformable: true when one joint carries ≥ kSingleInfluence of
// its weight (repeated joint indices summed).
std::vector<uint8_t> single_influence(const skelform::bake::InputMesh& input, const Character& c) {
  std::vector<uint8_t> rigid(c.info.vertex_count, 0);
  for (const sf_primitive_info& p : c.primitives) {
    const auto source = std::find_if(input.primitives.begin(), input.primitives.end(), [&](const auto& q) {
      return q.mesh == c.info.mesh && q.primitive == p.gltf_primitive;
    });
    if (source == input.primitives.end() || source->vertex_count != p.vertex_count) continue;
    for (uint32_t v = 0; v < p.vertex_count; ++v) {
      std::map<uint16_t, double> per_joint;
      double total = 0;
      for (size_t s = 0; s < input.joint_sets.size(); ++s)
        for (int k = 0; k < 4; ++k) {
          const double w = input.weight_sets[s][source->first_vertex + v][k];
          if (!(w > 0.0)) continue;
          per_joint[input.joint_sets[s][source->first_vertex + v][k]] += w;
          total += w;
        }
      double largest = 0;
      for (const auto& entry : per_joint) largest = std::max(largest, entry.second);
      rigid[p.first_vertex + v] = total > 0 && largest / total >= kSingleInfluence;
    }
  }
  return rigid;
}

FrameResult measure_frame(Character& c) {
  const std::vector<float> skelform = dense_positions(c.skelform, c);
  const std::vector<float> lbs = dense_positions(c.lbs, c);
  FrameResult frame;
  const std::vector<TrianglePair> skelform_pairs = intersecting_pairs(c.topology, skelform);
  const std::vector<TrianglePair> lbs_pairs = intersecting_pairs(c.topology, lbs);
  frame.skelform_added = pairs_added(skelform_pairs, c.bind_pairs);
  frame.lbs_added = pairs_added(lbs_pairs, c.bind_pairs);
  frame.skelform_junction = pairs_added_at_junctions(skelform_pairs, c.bind_pairs, c.junctions);
  frame.lbs_junction = pairs_added_at_junctions(lbs_pairs, c.bind_pairs, c.junctions);
  if (c.topology.closed && c.bind_volume != 0.0) {
    frame.skelform_volume = std::fabs(enclosed_volume(c.topology, skelform) - c.bind_volume) / std::fabs(c.bind_volume);
    frame.lbs_volume = std::fabs(enclosed_volume(c.topology, lbs) - c.bind_volume) / std::fabs(c.bind_volume);
  }
  frame.rigid = max_distance(skelform, lbs, &c.rigid) / c.diagonal;
  return frame;
}

FileResult measure_file(const std::string& path, const Arguments& args) {
  const auto start = std::chrono::steady_clock::now();
  FileResult result;
  result.path = path;
  result.name = std::filesystem::path(path).stem().string();
  result.pack = std::filesystem::path(path).parent_path().filename().string();
  try {
    LoadedAsset loaded = load_or_bake(path);
    result.warnings = loaded.warnings;
    const skelform::bake::InputMesh input =
        skelform::bake::load_mesh_from_memory(std::vector<unsigned char>(loaded.bytes.begin(), loaded.bytes.end()),
                                              loaded.bytes.compare(0, 4, "glTF") == 0 ? ".glb" : ".gltf", path);
    const GltfAnimation gltf = GltfAnimation::load_file(path);
    const uint32_t count = sf_asset_deformable_count(loaded.asset.asset);
    std::vector<Character> characters(count);
    for (uint32_t d = 0; d < count; ++d) {
      Character& c = characters[d];
      if (sf_asset_deformable_info(loaded.asset.asset, d, &c.info) != SF_OK) fail(kExitInternal, "deformable info");
      if (c.info.skin < 0) continue;  // nothing drives it: not a character
      for (Instance* instance : {&c.skelform, &c.lbs}) {
        const sf_result created = sf_instance_create(loaded.asset.asset, d, &instance->handle);
        if (created != SF_OK)
          fail(exit_code_of(created), std::string("sf_instance_create: ") + sf_result_string(created));
      }
      if (!args.contacts) c.skelform.check(sf_instance_set_contacts(c.skelform.handle, 0), "sf_instance_set_contacts");
      std::vector<float> stored(3 * size_t{c.info.vertex_count});
      std::vector<uint32_t> triangles;
      for (uint32_t p = 0; p < c.info.primitive_count; ++p) {
        sf_primitive_info primitive{};
        if (sf_asset_primitive_info(loaded.asset.asset, d, p, &primitive) != SF_OK)
          fail(kExitInternal, "primitive info");
        c.primitives.push_back(primitive);
        const std::vector<float> positions =
            gltf.primitive_positions(size_t(c.info.mesh), size_t(primitive.gltf_primitive));
        if (positions.size() != 3 * size_t{primitive.vertex_count})
          fail(kExitInvalidInput, "a baked primitive's vertex count differs from the glTF's");
        std::copy(positions.begin(), positions.end(), stored.begin() + 3 * size_t{primitive.first_vertex});
        for (uint32_t index : gltf.primitive_triangles(size_t(c.info.mesh), size_t(primitive.gltf_primitive)))
          triangles.push_back(primitive.first_vertex + index);
      }
      c.topology = dense_topology(stored, triangles);
      c.rigid = single_influence(input, c);
      result.vertices += c.info.vertex_count;
      result.triangles += c.topology.triangles.size();
      result.rigid_vertices += size_t(std::count(c.rigid.begin(), c.rigid.end(), 1));
      result.closed = result.closed && c.topology.closed;

      sf_eval_options from_rest = args.options;
      from_rest.flags |= SF_EVAL_FROM_REST;
      sf_eval_options lbs_options{};
      lbs_options.method = SF_METHOD_LBS;
      // Rest pose: identity joint matrices give the mesh as stored.
      const std::vector<float> identity = identity_matrices(c.info.joint_count);
      c.skelform.check(sf_instance_set_joint_matrices(c.skelform.handle, identity.data(), c.info.joint_count, 0),
                       "sf_instance_set_joint_matrices");
      c.skelform.check(sf_instance_evaluate(c.skelform.handle, &from_rest), "sf_instance_evaluate");
      const double stored_diagonal = std::max(bounding_diagonal(stored), 1e-30);
      result.rest_error =
          std::max(result.rest_error, max_distance(dense_positions(c.skelform, c), stored, nullptr) / stored_diagonal);
      // Bind pose: the reference of every metric.
      const std::vector<float> bind = gltf.bind_pose_joint_matrices(size_t(c.info.skin));
      for (Instance* instance : {&c.skelform, &c.lbs})
        instance->check(sf_instance_set_joint_matrices(instance->handle, bind.data(), c.info.joint_count, 0),
                        "sf_instance_set_joint_matrices");
      c.skelform.check(sf_instance_evaluate(c.skelform.handle, &from_rest), "sf_instance_evaluate");
      c.lbs.check(sf_instance_evaluate(c.lbs.handle, &lbs_options), "sf_instance_evaluate");
      const std::vector<float> bind_lbs = dense_positions(c.lbs, c);
      c.diagonal = std::max(bounding_diagonal(bind_lbs), 1e-30);
      result.bind_error =
          std::max(result.bind_error, max_distance(dense_positions(c.skelform, c), bind_lbs, nullptr) / c.diagonal);
      c.bind_pairs = intersecting_pairs(c.topology, bind_lbs);
      c.junctions = find_junctions(c.topology, c.bind_pairs);
      result.bind_pairs += c.bind_pairs.size();
      c.bind_volume = c.topology.closed ? enclosed_volume(c.topology, bind_lbs) : 0.0;
    }

    for (size_t a = 0; a < gltf.animations().size(); ++a) {
      const AnimationInfo& info = gltf.animations()[a];
      AnimationResult animation;
      animation.name = info.name;
      double played = info.start;
      for (size_t k = 0; k < args.frames; ++k) {
        const double target = info.start + info.duration() * double(k) / double(args.frames - 1);
        // Played as a game plays it: every 1/fps from the previous measured frame, then the
        // measured one; the first frame of the animation from rest.
        std::vector<double> times;
        if (k > 0 && !args.fresh) {
          const double span = target - played;
          const size_t steps = size_t(std::max(1.0, std::ceil(span * args.fps - 1e-9)));
          for (size_t s = 1; s < steps; ++s) times.push_back(played + span * double(s) / double(steps));
        }
        times.push_back(target);
        played = target;
        FrameResult total;
        bool first = true;
        for (Character& c : characters) {
          if (c.info.skin < 0) continue;
          for (size_t t = 0; t < times.size(); ++t) {
            const std::vector<float> matrices = gltf.joint_matrices(size_t(c.info.skin), a, times[t]);
            c.skelform.check(sf_instance_set_joint_matrices(c.skelform.handle, matrices.data(), c.info.joint_count, 0),
                             "sf_instance_set_joint_matrices");
            sf_eval_options options = args.options;
            if ((k == 0 && !args.cuts) || args.fresh) options.flags |= SF_EVAL_FROM_REST;
            c.skelform.check(sf_instance_evaluate(c.skelform.handle, &options), "sf_instance_evaluate");
            if (t + 1 == times.size()) {
              c.lbs.check(sf_instance_set_joint_matrices(c.lbs.handle, matrices.data(), c.info.joint_count, 0),
                          "sf_instance_set_joint_matrices");
              sf_eval_options lbs_options{};
              lbs_options.method = SF_METHOD_LBS;
              c.lbs.check(sf_instance_evaluate(c.lbs.handle, &lbs_options), "sf_instance_evaluate");
            }
          }
          const FrameResult frame = measure_frame(c);
          total.skelform_added += frame.skelform_added;
          total.lbs_added += frame.lbs_added;
          total.skelform_junction += frame.skelform_junction;
          total.lbs_junction += frame.lbs_junction;
          total.skelform_volume =
              first ? frame.skelform_volume : std::max(total.skelform_volume, frame.skelform_volume);
          total.lbs_volume = first ? frame.lbs_volume : std::max(total.lbs_volume, frame.lbs_volume);
          total.rigid = std::max(total.rigid, frame.rigid);
          first = false;
        }
        animation.frames.push_back(total);
      }
      result.animations.push_back(std::move(animation));
    }
  } catch (const Failure& failure) {
    result.refused = failure.message;
  } catch (const skelform::bake::Error& error) {
    result.refused = error.what();
  } catch (const GltfError& error) {
    result.refused = error.what();
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

// ---- Summaries --------------------------------------------------------------------------------

struct Summary {
  size_t frames = 0, skelform_added = 0, lbs_added = 0, worse = 0, skelform_junction = 0, lbs_junction = 0;
  double skelform_volume_sum = 0, lbs_volume_sum = 0, skelform_volume_worst = 0, lbs_volume_worst = 0;
  double rigid = 0;
  void add(const FrameResult& f) {
    ++frames;
    skelform_added += f.skelform_added;
    lbs_added += f.lbs_added;
    skelform_junction += f.skelform_junction;
    lbs_junction += f.lbs_junction;
    worse += f.skelform_added > f.lbs_added;
    skelform_volume_sum += f.skelform_volume;
    lbs_volume_sum += f.lbs_volume;
    skelform_volume_worst = std::max(skelform_volume_worst, f.skelform_volume);
    lbs_volume_worst = std::max(lbs_volume_worst, f.lbs_volume);
    rigid = std::max(rigid, f.rigid);
  }
  void add(const Summary& s) {
    frames += s.frames;
    skelform_added += s.skelform_added;
    lbs_added += s.lbs_added;
    skelform_junction += s.skelform_junction;
    lbs_junction += s.lbs_junction;
    worse += s.worse;
    skelform_volume_sum += s.skelform_volume_sum;
    lbs_volume_sum += s.lbs_volume_sum;
    skelform_volume_worst = std::max(skelform_volume_worst, s.skelform_volume_worst);
    lbs_volume_worst = std::max(lbs_volume_worst, s.lbs_volume_worst);
    rigid = std::max(rigid, s.rigid);
  }
  double skelform_volume_mean() const { return frames ? skelform_volume_sum / double(frames) : 0.0; }
  double lbs_volume_mean() const { return frames ? lbs_volume_sum / double(frames) : 0.0; }
};

Summary summarize(const AnimationResult& a) {
  Summary s;
  for (const FrameResult& f : a.frames) s.add(f);
  return s;
}

Summary summarize(const FileResult& file) {
  Summary s;
  for (const AnimationResult& a : file.animations) s.add(summarize(a));
  return s;
}

nlohmann::json summary_json(const Summary& s, bool closed) {
  nlohmann::json j;
  j["frames"] = s.frames;
  j["pairs_added"] = {{"skelform", s.skelform_added}, {"lbs", s.lbs_added}};
  j["pairs_added_at_junctions"] = {{"skelform", s.skelform_junction}, {"lbs", s.lbs_junction}};
  j["frames_worse"] = s.worse;
  if (closed)
    j["volume_change"] = {{"mean", {{"skelform", s.skelform_volume_mean()}, {"lbs", s.lbs_volume_mean()}}},
                          {"worst", {{"skelform", s.skelform_volume_worst}, {"lbs", s.lbs_volume_worst}}}};
  j["rigid_deviation"] = s.rigid;
  return j;
}

std::string percent(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f%%", 100.0 * v);
  return text;
}

// a / b as a percentage, "-" when b is 0.
std::string share(size_t a, size_t b) { return b ? percent(double(a) / double(b)) : "-"; }

std::string scientific(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1e", v);
  return text;
}

// An acceptance line that breaks: its name (kLines) and what broke.
struct Broken {
  std::string line, message;
};

// The acceptance lines that break (empty: all hold).
std::vector<Broken> broken_lines(const std::vector<FileResult>& files) {
  std::vector<Broken> broken;
  Summary all;
  for (const FileResult& f : files) {
    if (!f.refused.empty()) {
      broken.push_back({"refused", f.path + ": not measured: " + f.refused});
      continue;
    }
    const Summary s = summarize(f);
    all.add(s);
    if (s.worse > 0)
      broken.push_back({"worse-frames",
                        f.path + ": " + std::to_string(s.worse) + " frame(s) where skelform adds more pairs than LBS"});
    if (f.closed && s.skelform_volume_mean() > s.lbs_volume_mean())
      broken.push_back({"volume", f.path + ": mean |volume change| " + percent(s.skelform_volume_mean()) +
                                      " above LBS's " + percent(s.lbs_volume_mean())});
    if (s.rigid > kMaxRigidDeviation)
      broken.push_back({"rigid", f.path + ": a single-influence vertex is " + scientific(s.rigid) +
                                     " of the diagonal from its rigid motion"});
    if (f.rest_error > kMaxPoseError) broken.push_back({"rest", f.path + ": rest error " + scientific(f.rest_error)});
    if (f.bind_error > kMaxPoseError) broken.push_back({"bind", f.path + ": bind error " + scientific(f.bind_error)});
  }
  if (double(all.skelform_added) > kMaxPairShare * double(all.lbs_added))
    broken.push_back(
        {"pair-share", "skelform adds " + std::to_string(all.skelform_added) + " pairs over all files, more than " +
                           percent(kMaxPairShare) + " of LBS's " + std::to_string(all.lbs_added) + " (" +
                           percent(double(all.skelform_added) / double(std::max<size_t>(all.lbs_added, 1))) + ")"});
  return broken;
}

void print_table(const std::vector<FileResult>& files) {
  std::printf("%-28s %-26s %6s %17s %6s %17s %17s %8s\n", "file", "animation", "frames", "pairs added sk/LBS", "worse",
              "mean |dV| sk/LBS", "worst |dV| sk/LBS", "rigid");
  std::map<std::string, Summary> packs;
  std::map<std::string, bool> pack_order;
  Summary all;
  for (const FileResult& f : files) {
    if (!f.refused.empty()) {
      std::printf("%-28s refused: %s\n", f.name.c_str(), f.refused.c_str());
      continue;
    }
    for (const AnimationResult& a : f.animations) {
      const Summary s = summarize(a);
      std::printf(
          "%-28s %-26.26s %6zu %8zu / %-6zu %6zu %17s %17s %8s\n", f.name.c_str(), a.name.c_str(), s.frames,
          s.skelform_added, s.lbs_added, s.worse,
          f.closed ? (percent(s.skelform_volume_mean()) + " / " + percent(s.lbs_volume_mean())).c_str() : "open",
          f.closed ? (percent(s.skelform_volume_worst) + " / " + percent(s.lbs_volume_worst)).c_str() : "",
          scientific(s.rigid).c_str());
    }
    const Summary s = summarize(f);
    std::printf("%-28s %-26s %6zu %8zu / %-6zu %6zu %17s %17s %8s   rest %s bind %s, %zu pairs at bind, %.1f s\n",
                f.name.c_str(), "(all)", s.frames, s.skelform_added, s.lbs_added, s.worse,
                f.closed ? (percent(s.skelform_volume_mean()) + " / " + percent(s.lbs_volume_mean())).c_str() : "open",
                f.closed ? (percent(s.skelform_volume_worst) + " / " + percent(s.lbs_volume_worst)).c_str() : "",
                scientific(s.rigid).c_str(), scientific(f.rest_error).c_str(), scientific(f.bind_error).c_str(),
                f.bind_pairs, f.seconds);
    for (const std::string& warning : f.warnings) std::printf("%-28s repaired: %s\n", f.name.c_str(), warning.c_str());
    packs[f.pack].add(s);
    all.add(s);
  }
  std::printf("\n%-28s %6s %17s %6s %17s\n", "pack", "frames", "pairs added sk/LBS", "worse", "at junctions");
  for (const auto& [pack, s] : packs)
    std::printf("%-28s %6zu %8zu / %-6zu %6zu %8zu / %-6zu\n", pack.c_str(), s.frames, s.skelform_added, s.lbs_added,
                s.worse, s.skelform_junction, s.lbs_junction);
  std::printf("%-28s %6zu %8zu / %-6zu %6zu %8zu / %-6zu   (%s of LBS's pairs; %s elsewhere)\n", "total", all.frames,
              all.skelform_added, all.lbs_added, all.worse, all.skelform_junction, all.lbs_junction,
              share(all.skelform_added, all.lbs_added).c_str(),
              share(all.skelform_added - all.skelform_junction, all.lbs_added - all.lbs_junction).c_str());
}

// The summary of a pack (the files of one folder), or of every file.
struct PackSummary {
  size_t files = 0, refused = 0, animations = 0;
  Summary frames;         // every measured frame
  Summary closed_frames;  // the frames of closed characters (volume)
  double rest_error = 0, bind_error = 0;
  void add(const FileResult& f) {
    ++files;
    if (!f.refused.empty()) {
      ++refused;
      return;
    }
    animations += f.animations.size();
    const Summary s = summarize(f);
    frames.add(s);
    if (f.closed) closed_frames.add(s);
    rest_error = std::max(rest_error, f.rest_error);
    bind_error = std::max(bind_error, f.bind_error);
  }
};

void print_markdown(const std::vector<FileResult>& files) {
  std::map<std::string, PackSummary> packs;
  PackSummary all;
  for (const FileResult& f : files) {
    packs[f.pack].add(f);
    all.add(f);
  }
  std::printf(
      "| pack | characters | animations | frames | pairs added, skelform / LBS | of which at junctions | "
      "frames skelform adds more | closed characters: mean \\|ΔV\\|, skelform / LBS | largest rigid deviation | "
      "largest rest / bind error |\n");
  std::printf("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  auto row = [&](const std::string& name, const PackSummary& p) {
    const Summary& s = p.frames;
    const std::string pair_share = s.lbs_added ? " (" + share(s.skelform_added, s.lbs_added) + ")" : "";
    const std::string volume = p.closed_frames.frames ? percent(p.closed_frames.skelform_volume_mean()) + " / " +
                                                            percent(p.closed_frames.lbs_volume_mean())
                                                      : "(none closed)";
    std::printf("| %s | %zu%s | %zu | %zu | %zu / %zu%s | %zu / %zu | %zu | %s | %s | %s / %s |\n", name.c_str(),
                p.files, p.refused ? (" (" + std::to_string(p.refused) + " refused)").c_str() : "", p.animations,
                s.frames, s.skelform_added, s.lbs_added, pair_share.c_str(), s.skelform_junction, s.lbs_junction,
                s.worse, volume.c_str(), scientific(s.rigid).c_str(), scientific(p.rest_error).c_str(),
                scientific(p.bind_error).c_str());
  };
  for (const auto& [pack, p] : packs) row(pack, p);
  row("**total**", all);
}

nlohmann::json report_json(const std::vector<FileResult>& files, const std::vector<Broken>& broken) {
  nlohmann::json report;
  report["files"] = nlohmann::json::array();
  Summary all;
  for (const FileResult& f : files) {
    nlohmann::json j;
    j["file"] = f.path;
    j["pack"] = f.pack;
    if (!f.refused.empty()) {
      j["refused"] = f.refused;
      report["files"].push_back(j);
      continue;
    }
    j["warnings"] = f.warnings;
    j["vertices"] = f.vertices;
    j["triangles"] = f.triangles;
    j["closed"] = f.closed;
    j["single_influence_vertices"] = f.rigid_vertices;
    j["bind_pairs"] = f.bind_pairs;
    j["rest_error"] = f.rest_error;
    j["bind_error"] = f.bind_error;
    j["seconds"] = f.seconds;
    j["animations"] = nlohmann::json::array();
    for (const AnimationResult& a : f.animations) {
      nlohmann::json aj = summary_json(summarize(a), f.closed);
      aj["name"] = a.name;
      nlohmann::json frames = nlohmann::json::array();
      for (const FrameResult& fr : a.frames) frames.push_back({fr.skelform_added, fr.lbs_added});
      aj["pairs_added_per_frame"] = frames;
      j["animations"].push_back(aj);
    }
    const Summary s = summarize(f);
    j["total"] = summary_json(s, f.closed);
    all.add(s);
    report["files"].push_back(j);
  }
  report["total"] = summary_json(all, false);
  report["broken"] = nlohmann::json::array();
  for (const Broken& b : broken) report["broken"].push_back({{"line", b.line}, {"message", b.message}});
  return report;
}

int run(const Arguments& args) {
  const std::vector<std::string> files = collect_files(args.inputs);
  std::vector<FileResult> results(files.size());
  std::atomic<size_t> next{0};
  std::mutex print_mutex;
  const unsigned jobs = std::max(
      1u, std::min<unsigned>(args.jobs ? args.jobs : std::thread::hardware_concurrency(), unsigned(files.size())));
  auto worker = [&]() {
    for (size_t i = next++; i < files.size(); i = next++) {
      results[i] = measure_file(files[i], args);
      if (!args.quiet) {
        std::lock_guard<std::mutex> lock(print_mutex);
        std::fprintf(stderr, "skelform-quality: %s: %s (%.1f s)\n", files[i].c_str(),
                     results[i].refused.empty() ? "measured" : "refused", results[i].seconds);
      }
    }
  };
  std::vector<std::thread> threads;
  for (unsigned t = 1; t < jobs; ++t) threads.emplace_back(worker);
  worker();
  for (std::thread& t : threads) t.join();

  const std::vector<Broken> broken = broken_lines(results);
  auto waived = [&](const Broken& b) {
    return std::find(args.waived.begin(), args.waived.end(), b.line) != args.waived.end();
  };
  const bool failed = std::any_of(broken.begin(), broken.end(), [&](const Broken& b) { return !waived(b); });
  if (args.json) {
    std::printf("%s\n", report_json(results, broken).dump(1).c_str());
  } else {
    if (args.markdown)
      print_markdown(results);
    else
      print_table(results);
    if (args.check) {
      std::printf("\nacceptance: %s\n", broken.empty() ? "every line holds"
                                        : failed       ? "broken"
                                                       : "holds but for waived lines");
      for (const Broken& b : broken) std::printf("  %s%s\n", waived(b) ? "(waived) " : "", b.message.c_str());
    }
  }
  return args.check && failed ? kExitCheckFailed : kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return skelform::cli::run_main(
      "skelform-quality", kUsage, argc, argv, [&] { return run(parse_arguments(argc, argv)); },
      skelform::samples::classify_sample_error);
}
