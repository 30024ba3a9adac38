// Wavefront OBJ: only `v` and `f` matter for the bake; every other statement (vt, vn, g, o,
// usemtl, s, l, ...) is skipped, so an OBJ written by any tool loads as its triangle mesh.
#include "input_formats.h"

#include <cmath>
#include <string>

namespace skelform::bake::detail {
namespace {

[[noreturn]] void fail(const std::string& name, size_t line, const std::string& what) {
  throw Error(ErrorKind::invalid_input, name + ":" + std::to_string(line) + ": " + what);
}

}  // namespace

InputMesh load_obj(std::string_view text, const std::string& name) {
  InputMesh mesh;
  // Positive indices may point forward (some exporters write faces first), so they are
  // checked once the whole file is read; this remembers each triangle's line for that message.
  std::vector<uint32_t> triangle_line;
  std::vector<uint32_t> polygon;
  LineScanner scanner(text);
  while (scanner.next_line()) {
    const std::string_view keyword = scanner.token();
    if (keyword == "v") {
      Vec3 p;
      for (int axis = 0; axis < 3; ++axis) {
        const std::string_view token = scanner.token();
        if (token.empty()) fail(name, scanner.line_number(), "vertex has fewer than 3 coordinates");
        if (!parse_double(token, p[axis]))
          fail(name, scanner.line_number(), "bad vertex coordinate " + quote_token(token));
        if (!std::isfinite(p[axis]))
          fail(name, scanner.line_number(), "non-finite vertex coordinate " + quote_token(token));
      }
      mesh.positions.push_back(p);
      check_input_limits(mesh.positions.size(), mesh.triangles.size(), name);
    } else if (keyword == "f") {
      polygon.clear();
      for (std::string_view token = scanner.token(); !token.empty(); token = scanner.token()) {
        // Only the position index counts: v, v/vt, v//vn and v/vt/vn all start with it.
        const std::string_view position_part = token.substr(0, token.find('/'));
        int64_t index = 0;
        if (!parse_int(position_part, index)) fail(name, scanner.line_number(), "bad face index " + quote_token(token));
        const int64_t defined = static_cast<int64_t>(mesh.positions.size());
        if (index == 0) fail(name, scanner.line_number(), "face index 0 (OBJ indices start at 1)");
        if (index < 0) {
          // Relative index: -1 is the most recent vertex.
          if (defined + index < 0)
            fail(name, scanner.line_number(),
                 "face index " + std::to_string(index) + " out of range (" + std::to_string(defined) +
                     " vertices defined so far)");
          index = defined + index;
        } else {
          if (index > int64_t{0xffffffff})
            fail(name, scanner.line_number(), "face index " + std::to_string(index) + " out of range");
          index -= 1;
        }
        polygon.push_back(static_cast<uint32_t>(index));
      }
      if (polygon.size() < 3)
        fail(name, scanner.line_number(),
             "face with " + std::to_string(polygon.size()) + " vertices (at least 3 needed)");
      append_fan(polygon, mesh.triangles, name);
      triangle_line.resize(mesh.triangles.size(), static_cast<uint32_t>(scanner.line_number()));
    }
  }

  const size_t vertex_count = mesh.positions.size();
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (uint32_t v : mesh.triangles[t]) {
      if (v >= vertex_count)
        fail(name, triangle_line[t],
             "face index " + std::to_string(uint64_t{v} + 1) + " out of range (" + std::to_string(vertex_count) +
                 " vertices in the file)");
    }
  }
  if (vertex_count == 0) throw Error(ErrorKind::invalid_input, name + ": no vertices (no 'v' lines); not an OBJ mesh?");
  if (mesh.triangles.empty()) throw Error(ErrorKind::invalid_input, name + ": no faces (no 'f' lines)");

  add_whole_primitive(mesh, vertex_count);
  return mesh;
}

}  // namespace skelform::bake::detail
