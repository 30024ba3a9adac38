// skelform-bake: the offline half of skelform.
//
//   skelform-bake IN.glb -o OUT.glb [options]        bake a glTF: the input plus the
//                                                     SKELFORM_skeletal_deformation extension
//   skelform-bake skeleton IN -o OUT.obj [options]   the Voronoi skeletal mesh of a mesh
//
// Every failure prints one line "skelform-bake: error: ..." and exits non-zero (codes in
// --help); outputs are written atomically, so a failed run never leaves a partial file.
#include "cli_bake.h"
#include "progress.h"
#include "skelform/bake/bake.h"
#include "skelform/bake/gltf_writer.h"
#include "skelform/bake/input.h"
#include "skelform/bake/metrics.h"
#include "skelform/bake/output.h"
#include "skelform/bake/skeleton.h"
#include "skelform/bake/tangent_flow.h"
#include "skelform/bake/weld.h"
#include "skelform/core/gltf_read.h"
#include "skelform/skelform.h"

#include <algorithm>
#include <cctype>
#include <initializer_list>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

using namespace skelform::bake;

using skelform::cli::kExitOk;

const char* const kUsage =
    "usage: skelform-bake IN.glb|IN.gltf -o OUT.glb|OUT.gltf [options]\n"
    "       skelform-bake skeleton IN -o OUT.obj [options]\n"
    "\n"
    "Commands:\n"
    "  IN -o OUT                Bake a glTF 2.0 model: OUT is IN unchanged plus the\n"
    "                           SKELFORM_skeletal_deformation extension (control mesh,\n"
    "                           skeletal mesh, subdivision stencils, DSS binding, skin\n"
    "                           weights) for every skinned mesh. The output container\n"
    "                           follows OUT's extension (.glb or .gltf + .bin).\n"
    "  skeleton IN -o OUT.obj   Extract the Voronoi-based skeletal mesh of IN (paper, section 2):\n"
    "                           one skeletal vertex per welded input vertex, in the welded\n"
    "                           vertex order (an already-welded OBJ/PLY/OFF keeps its order),\n"
    "                           with the input's faces.\n"
    "\n"
    "Inputs: .gltf, .glb (every triangle primitive of every skinned mesh); skeleton also\n"
    "        takes .obj, .ply, .off.\n"
    "\n"
    "Options:\n"
    "  -o, --output FILE           output file (required; never the input file)\n"
    "  --target-triangles N        control-mesh triangles (default %TARGET%; meshes with at most\n"
    "                              twice as many are kept whole)\n"
    "  --level K                   Loop subdivision level (default: 4^K x control ~ input)\n"
    "  --tangent-flow-steps N      bilaplacian tangent flow steps before extraction (default 100)\n"
    "  --voronoi-points FILE       skeleton: also write the kept inner Voronoi vertices as points\n"
    "  --all-meshes                glTF: also use meshes no skinned node references\n"
    "  -v, --verbose               more statistics\n"
    "  -q, --quiet                 no summary line, no progress display\n"
    "  -h, --help                  this text\n"
    "  --version                   print the version\n"
    "\n"
    "\n";

// The --help text: the limits come from the constants that enforce them.
std::string usage() {
  const std::string limits =
      "Limits (beyond them the input is refused, exit 2; decimate or split the mesh first):\n"
      "  input file        " +
      std::to_string(kMaxInputFileBytes >> 20) +
      " MiB (a pipe or device is read until it passes this)\n"
      "  input mesh        " +
      std::to_string(kMaxInputTriangles) + " triangles, " + std::to_string(kMaxInputVertices) +
      " vertices\n"
      "  glTF              JSON nested at most " +
      std::to_string(skelform::gltf::kMaxJsonNesting) + " deep; at most " + std::to_string(kMaxInfluenceSets) +
      " JOINTS_n sets per primitive\n"
      "  PLY               the rows of all elements together fit in the body's bytes\n"
      "  skeleton          " +
      std::to_string(kMaxSkeletonVertices) +
      " vertices: the welded input of the skeleton\n"
      "                    command; the control mesh of a bake (lower --target-triangles)\n"
      "\n";
  // The control mesh's default comes from BakeOptions, where the library's is set.
  std::string text = kUsage;
  const std::string placeholder = "%TARGET%";
  if (const size_t at = text.find(placeholder); at != std::string::npos)
    text.replace(at, placeholder.size(), std::to_string(skelform::bake::BakeOptions{}.target_triangles));
  return text + limits + skelform::cli::kExitCodeHelp;
}

struct Arguments {
  std::string command;
  std::string input;
  std::string output;
  std::string voronoi_points;
  int tangent_flow_steps = 100;
  int target_triangles = static_cast<int>(skelform::bake::BakeOptions{}.target_triangles);
  int level = -1;
  bool all_meshes = false;
  bool verbose = false;
  bool quiet = false;
};

bool has_extension(const std::string& path, std::initializer_list<const char*> extensions) {
  const std::string extension = skelform::cli::lowercase_extension(path);
  return std::any_of(extensions.begin(), extensions.end(), [&](const char* e) { return extension == e; });
}

Arguments parse_arguments(int argc, char** argv) {
  Arguments args;
  std::vector<std::string> positional;
  skelform::cli::ArgumentCursor cursor(argc, argv);
  auto integer = [&](unsigned long lo, unsigned long hi) {
    return static_cast<int>(skelform::cli::parse_integer(cursor.arg(), cursor.value(), lo, hi));
  };
  while (cursor.next()) {
    const std::string& arg = cursor.arg();
    if (arg == "-o" || arg == "--output")
      args.output = cursor.value();
    else if (arg == "--tangent-flow-steps")
      args.tangent_flow_steps = integer(0, 100000);
    else if (arg == "--target-triangles")
      args.target_triangles = integer(16, 10000000);
    else if (arg == "--level")
      args.level = integer(0, 6);
    else if (arg == "--voronoi-points")
      args.voronoi_points = cursor.value();
    else if (arg == "--all-meshes")
      args.all_meshes = true;
    else if (arg == "-v" || arg == "--verbose")
      args.verbose = true;
    else if (arg == "-q" || arg == "--quiet")
      args.quiet = true;
    else if (cursor.is_option())
      cursor.unknown();
    else
      positional.push_back(arg);
  }
  if (positional.empty()) throw Error(ErrorKind::usage, "missing command");
  if (positional[0] == "skeleton") {
    args.command = "skeleton";
    if (positional.size() != 2) throw Error(ErrorKind::usage, "skeleton takes exactly one input file");
    args.input = positional[1];
  } else {
    args.command = "bake";
    if (positional.size() != 1)
      throw Error(ErrorKind::usage, "expected one input file, got " + std::to_string(positional.size()));
    args.input = positional[0];
    if (!args.voronoi_points.empty()) throw Error(ErrorKind::usage, "--voronoi-points belongs to the skeleton command");
    if (!has_extension(args.input, {".gltf", ".glb"}))
      throw Error(ErrorKind::usage, "baking needs a .gltf or .glb input (the skeleton command takes OBJ/PLY/OFF)");
    if (!has_extension(args.output, {".gltf", ".glb"}))
      throw Error(ErrorKind::usage, "the baked output must be .gltf or .glb");
  }
  if (args.output.empty()) throw Error(ErrorKind::usage, "missing -o OUTPUT");
  for (const std::string& out : {args.output, args.voronoi_points}) {
    if (!out.empty() && same_file(out, args.input))
      throw Error(ErrorKind::usage, "refusing to overwrite the input file " + args.input);
  }
  return args;
}

// Wall-clock time of each stage, for the summary line.
class StageTimer {
 public:
  void start() { begin_ = std::chrono::steady_clock::now(); }
  void stop(const char* stage) {
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin_).count();
    stages_.push_back({stage, ms});
  }
  std::string summary() const {
    std::string out;
    for (const auto& [name, ms] : stages_) {
      char buffer[64];
      std::snprintf(buffer, sizeof(buffer), "%s%s %.0f ms", out.empty() ? "" : ", ", name, ms);
      out += buffer;
    }
    return out;
  }

 private:
  std::chrono::steady_clock::time_point begin_;
  std::vector<std::pair<const char*, double>> stages_;
};

int run_skeleton(const Arguments& args) {
  StageTimer timer;
  timer.start();
  LoadOptions load_options;
  load_options.all_meshes = args.all_meshes;
  const InputMesh input = load_mesh(args.input, load_options);
  // Repaired exporter defects are reported even with --quiet: the output differs from what
  // a strict reading would give.
  for (const std::string& warning : input.warnings)
    std::fprintf(stderr, "skelform-bake: warning: %s\n", warning.c_str());
  timer.stop("load");

  timer.start();
  const WeldedMesh welded = weld(input);
  timer.stop("weld");
  // extract_skeleton refuses it too, but only after the tangent flow's work.
  if (welded.mesh.positions.size() > kMaxSkeletonVertices)
    throw Error(ErrorKind::unsupported, args.input + ": " + std::to_string(welded.mesh.positions.size()) +
                                            " welded vertices, more than the " + std::to_string(kMaxSkeletonVertices) +
                                            " the skeleton command takes (decimate the mesh first)");

  timer.start();
  TriangleMesh control = welded.mesh;
  TangentFlowOptions flow_options;
  flow_options.steps = args.tangent_flow_steps;
  apply_tangent_flow(control, flow_options);
  timer.stop("tangent flow");

  timer.start();
  const SkeletalMesh skeleton = extract_skeleton(control);
  timer.stop("voronoi skeleton");

  // The DESIGN.md metric: skeletal vertices inside the (closed) input, by winding number.
  timer.start();
  const double inside = inside_fraction(welded.mesh, skeleton.skeletal_positions);
  timer.stop("inside check");

  timer.start();
  TriangleMesh skeletal_mesh{skeleton.skeletal_positions, welded.mesh.triangles};
  write_file_atomically(args.output, obj_text(skeletal_mesh, {"skelform skeletal mesh of " + args.input,
                                                              "one vertex per welded input vertex, same order"}));
  if (!args.voronoi_points.empty()) {
    write_file_atomically(args.voronoi_points, obj_points_text(skeleton.kept_voronoi_vertices,
                                                               {"kept inner Voronoi vertices of " + args.input}));
  }
  timer.stop("write");

  if (!args.quiet) {
    std::printf("skelform-bake: skeleton of %s: %zu vertices, %zu faces, %.2f%% inside; %s -> %s\n", args.input.c_str(),
                skeletal_mesh.positions.size(), skeletal_mesh.triangles.size(), 100.0 * inside, timer.summary().c_str(),
                args.output.c_str());
  }
  if (args.verbose) {
    std::vector<double> radius = skeleton.medial_radius;
    const double diagonal = bounds_of(welded.mesh.positions).diagonal();
    std::nth_element(radius.begin(), radius.begin() + radius.size() / 2, radius.end());
    std::printf("  input: %zu original vertices, %zu triangles; weld removed %zu degenerate, %zu duplicate\n",
                input.positions.size(), input.triangles.size(), welded.degenerate_triangles_removed,
                welded.duplicate_triangles_removed);
    std::printf("  skeleton: %zu kept Voronoi vertices, %zu vertices without candidates, median d / diagonal %.4f\n",
                skeleton.kept_voronoi_vertices.size(), skeleton.vertices_without_candidates,
                diagonal > 0 ? radius[radius.size() / 2] / diagonal : 0.0);
  }
  return kExitOk;
}

int run_bake(const Arguments& args) {
  const auto start = std::chrono::steady_clock::now();
  skelform::tools::ProgressDisplay progress(!args.quiet);
  progress.step("loading " + args.input);
  LoadOptions load_options;
  load_options.all_meshes = args.all_meshes;
  const InputMesh input = load_mesh(args.input, load_options);
  // Repaired exporter defects are reported even with --quiet: the output differs from what
  // a strict reading would give.
  for (const std::string& warning : input.warnings)
    std::fprintf(stderr, "skelform-bake: warning: %s\n", warning.c_str());

  BakeOptions options;
  options.target_triangles = static_cast<size_t>(args.target_triangles);
  options.subdivision_level = args.level;
  options.tangent_flow_steps = args.tangent_flow_steps;
  options.progress = [&](const char* stage, size_t deformable, size_t count) {
    progress.step("mesh " + std::to_string(deformable + 1) + "/" + std::to_string(count) + ": " + stage);
  };
  const BakeResult result = bake_model(input, options);
  progress.step("writing " + args.output);
  write_baked_gltf(args.input, result.deformables, args.output);
  progress.step("");

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!args.quiet) {
    std::printf("skelform-bake: %s -> %s: %zu deformable(s), %.2f s\n", args.input.c_str(), args.output.c_str(),
                result.deformables.size(), seconds);
    for (const DeformableReport& r : result.reports) {
      char skeleton[64];
      if (r.flat)
        std::snprintf(skeleton, sizeof(skeleton), "flat mesh, zero-radius skeleton");
      else
        std::snprintf(skeleton, sizeof(skeleton), "skeleton %.2f%% inside", 100.0 * r.skeleton_inside);
      std::printf(
          "  mesh %d: %zu vertices (%zu welded), %zu triangles -> control %zu triangles%s, level %d "
          "(%zu triangles); %s; tangential residual on %.2f%% of vertices; rest error %.2g of diagonal; "
          "skelform weight above 0 on %.1f%% of vertices\n",
          r.mesh, r.dense_vertices, r.welded_vertices, r.dense_triangles, r.control_triangles,
          r.decimated ? "" : " (not decimated)", r.subdivision_level, r.refined_triangles, skeleton,
          100.0 * r.residual_share, r.rest_error, 100.0 * r.skelform_share);
    }
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return skelform::cli::run_main(
      "skelform-bake", usage(), argc, argv,
      [&] {
        const Arguments args = parse_arguments(argc, argv);
        return args.command == "skeleton" ? run_skeleton(args) : run_bake(args);
      },
      skelform::cli::classify_bake_error);
}
