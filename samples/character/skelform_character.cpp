// skelform-character: writes the project's own procedural test character (torso, head, arms,
// legs as blended tubes; closed, genus 0), the default input of the README's main job.
//
//   skelform-character -o character.obj [--height H] [--resolution R]
#include "skelform/bake/output.h"
#include "skelform/bake/procedural.h"

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
    if ((arg == "-o" || arg == "--output") && has_value) output = argv[++i];
    else if (arg == "--height" && has_value) options.height = parse_positive("--height", argv[++i]);
    else if (arg == "--resolution" && has_value) options.resolution = parse_positive("--resolution", argv[++i]);
    else if (arg == "-h" || arg == "--help") {
      std::puts("usage: skelform-character -o OUT.obj [--height H (1.8)] [--resolution R (0.02)]");
      return 0;
    } else {
      std::fprintf(stderr, "skelform-character: error: unexpected argument '%s' (see --help)\n", arg.c_str());
      return 1;
    }
  }
  if (output.empty()) {
    std::fputs("skelform-character: error: missing -o OUT.obj (see --help)\n", stderr);
    return 1;
  }
  if (options.resolution > options.height / 8) {
    std::fputs("skelform-character: error: --resolution must be at most height / 8\n", stderr);
    return 1;
  }
  try {
    const auto start = std::chrono::steady_clock::now();
    const TriangleMesh character = make_test_character(options);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    write_file_atomically(output, obj_text(character, {"skelform procedural test character"}));
    std::printf("skelform-character: %zu vertices, %zu triangles, %.0f ms -> %s\n", character.positions.size(),
                character.triangles.size(), ms, output.c_str());
  } catch (const Error& e) {
    std::fprintf(stderr, "skelform-character: error: %s\n", e.what());
    return 3;
  }
  return 0;
}
