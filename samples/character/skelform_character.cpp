// skelform-character: writes the project's own procedural test character (torso, head, arms,
// legs as blended tubes; closed, genus 0), the default input of the README's main job.
//
//   skelform-character -o character.glb|character.obj [--height H] [--resolution R]
//
// .glb: the character rigged and animated in code (procedural_rig.h): 19 joints, computed
// skin weights and normals, a "walk" and a "bend" animation; a standard skinned glTF 2.0
// file that skelform-animate (or skelform-bake) takes. .obj: the bare surface.
#include "skelform/bake/output.h"
#include "skelform/bake/procedural.h"
#include "skelform/bake/procedural_rig.h"

#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

double parse_positive(const char* flag, const char* text) {
  char* end = nullptr;
  const double value = std::strtod(text, &end);
  if (*text == '\0' || *end != '\0' || !(value > 0.0) || value > 1e6) {
    std::fprintf(stderr, "skelform-character: error: %s expects a positive number, got '%s'\n", flag, text);
    std::exit(1);
  }
  return value;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace skelform::bake;
  CharacterOptions options;
  std::string output;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if ((arg == "-o" || arg == "--output") && has_value)
      output = argv[++i];
    else if (arg == "--height" && has_value)
      options.height = parse_positive("--height", argv[++i]);
    else if (arg == "--resolution" && has_value)
      options.resolution = parse_positive("--resolution", argv[++i]);
    else if (arg == "-h" || arg == "--help") {
      std::puts(
          "usage: skelform-character -o OUT.glb|OUT.obj [--height H (1.8)] [--resolution R (0.02)]\n"
          "\n"
          "  .glb  the character rigged (19 joints, computed skin weights, normals) and animated\n"
          "        in code: animations \"walk\" (1 s cycle) and \"bend\" (3 s, knees and elbows\n"
          "        at 120 degrees, spine twist); standard skinned glTF 2.0\n"
          "  .obj  the bare surface\n"
          "\n"
          "Exit codes: 0 success, 1 bad command line, 3 file could not be written.");
      return 0;
    } else {
      std::fprintf(stderr, "skelform-character: error: unexpected argument '%s' (see --help)\n", arg.c_str());
      return 1;
    }
  }
  if (output.empty()) {
    std::fputs("skelform-character: error: missing -o OUT.glb|OUT.obj (see --help)\n", stderr);
    return 1;
  }
  std::string extension = output.size() >= 4 ? output.substr(output.size() - 4) : "";
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (extension != ".glb" && extension != ".obj") {
    std::fputs("skelform-character: error: the output must be .glb or .obj\n", stderr);
    return 1;
  }
  if (options.resolution > options.height / 8) {
    std::fputs("skelform-character: error: --resolution must be at most height / 8\n", stderr);
    return 1;
  }
  try {
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
  } catch (const Error& e) {
    std::fprintf(stderr, "skelform-character: error: %s\n", e.what());
    return e.kind() == ErrorKind::usage ? 1 : 3;
  }
  return 0;
}
