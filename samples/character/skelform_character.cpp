// skelform-character: writes the project's own procedural test character (torso, head, arms,
// legs as blended tubes; closed, genus 0), the default input of the README's main job.
//
//   skelform-character -o character.glb|character.obj [--height H] [--resolution R]
//
// .glb: the character rigged and animated in code (procedural_rig.h): 19 joints, computed
// skin weights and normals, a "walk" and a "bend" animation; a standard skinned glTF 2.0
// file that skelform-animate (or skelform-bake) takes. .obj: the bare surface.
#include "cli_bake.h"
#include "skelform/bake/output.h"
#include "skelform/bake/procedural.h"
#include "skelform/bake/procedural_rig.h"

#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

using skelform::cli::fail;
using skelform::cli::kExitUsage;

const char* const kUsage =
    "usage: skelform-character -o OUT.glb|OUT.obj [--height H (1.8)] [--resolution R (0.02)]\n"
    "\n"
    "  .glb  the character rigged (19 joints, computed skin weights, normals) and animated\n"
    "        in code: animations \"walk\" (1 s cycle) and \"bend\" (3 s, knees and elbows\n"
    "        at 120 degrees, spine twist); standard skinned glTF 2.0\n"
    "  .obj  the bare surface\n"
    "\n"
    "Exit codes: 0 success, 1 bad command line, 3 file could not be written.\n";

int run(int argc, char** argv) {
  using namespace skelform::bake;
  CharacterOptions options;
  std::string output;
  skelform::cli::ArgumentCursor cursor(argc, argv);
  while (cursor.next()) {
    const std::string& arg = cursor.arg();
    if (arg == "-o" || arg == "--output")
      output = cursor.value();
    else if (arg == "--height")
      options.height = skelform::cli::parse_positive(arg, cursor.value(), 1e6);
    else if (arg == "--resolution")
      options.resolution = skelform::cli::parse_positive(arg, cursor.value(), 1e6);
    else if (cursor.is_option())
      cursor.unknown();
    else
      fail(kExitUsage, "unexpected argument '" + arg + "'");
  }
  if (output.empty()) fail(kExitUsage, "missing -o OUT.glb|OUT.obj");
  const std::string extension = skelform::cli::lowercase_extension(output);
  if (extension != ".glb" && extension != ".obj") fail(kExitUsage, "the output must be .glb or .obj");
  if (options.resolution > options.height / 8) fail(kExitUsage, "--resolution must be at most height / 8");
  {
    const auto start = std::chrono::steady_clock::now();
    if (extension == ".glb") {
      const RiggedCharacter character = make_rigged_character(options);
      const std::string bytes = rigged_character_glb(character);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      write_file_atomically(output, bytes);
      std::string names;
      for (const RigAnimation& animation : character.animations)
        names += (names.empty() ? "" : ", ") + animation.name + " " +
                 std::to_string(int(animation.times.back() * 1000.0 + 0.5)) + " ms";
      std::printf("skelform-character: %zu vertices, %zu triangles, %zu joints, animations: %s; %.0f ms -> %s\n",
                  character.mesh.positions.size(), character.mesh.triangles.size(), character.joints.size(),
                  names.c_str(), ms, output.c_str());
    } else {
      const TriangleMesh character = make_test_character(options);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      write_file_atomically(output, obj_text(character, {"skelform procedural test character"}));
      std::printf("skelform-character: %zu vertices, %zu triangles, %.0f ms -> %s\n", character.positions.size(),
                  character.triangles.size(), ms, output.c_str());
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return skelform::cli::run_main(
      "skelform-character", kUsage, argc, argv, [&] { return run(argc, argv); }, skelform::cli::classify_bake_error);
}
