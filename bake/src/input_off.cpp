// OFF (Geomview object file format), ASCII: header, counts, vertex lines, face lines.
// Colour/normal/texture variants (COFF, NOFF, STOFF, ...) load too: only the first three
// numbers of a vertex line and the index list of a face line are read.
#include "input_formats.h"

#include <cmath>
#include <string>

namespace skelform::bake::detail {
namespace {

[[noreturn]] void fail(const std::string& name, size_t line, const std::string& what) {
  throw Error(ErrorKind::invalid_input, name + ":" + std::to_string(line) + ": " + what);
}

// Line scanning with '#' comments and blank lines skipped.
class OffScanner {
 public:
  explicit OffScanner(std::string_view text) : lines_(text) {}

  // Moves to the next line with data; false at the end of the text.
  bool next_data_line() {
    while (lines_.next_line()) {
      pending_ = lines_.token();
      if (!pending_.empty() && pending_.front() != '#') return true;
    }
    return false;
  }

  // The next token of the current line; empty at its end or at a comment.
  std::string_view token() {
    std::string_view t = pending_.empty() ? lines_.token() : pending_;
    pending_ = {};
    if (!t.empty() && t.front() == '#') {
      while (!lines_.token().empty()) continue;  // the rest of the line is the comment
      return {};
    }
    return t;
  }

  size_t line_number() const { return lines_.line_number(); }

 private:
  LineScanner lines_;
  std::string_view pending_;
};

}  // namespace

InputMesh load_off(std::string_view text, const std::string& name) {
  OffScanner scanner(text);
  if (!scanner.next_data_line()) throw Error(ErrorKind::invalid_input, name + ": empty file (no OFF header)");
  std::string_view keyword = scanner.token();
  const bool has_header = keyword.size() >= 3 && keyword.substr(keyword.size() - 3) == "OFF";
  if (!has_header)
    fail(name, scanner.line_number(), "not an OFF file (expected an 'OFF' header, found " + quote_token(keyword) + ")");
  if (keyword.find('4') != std::string_view::npos || keyword.find('n') != std::string_view::npos)
    throw Error(ErrorKind::unsupported,
                name + ": " + std::string(keyword) + " (4D or n-dimensional OFF) is not supported");

  // The counts may follow the keyword on the same line.
  std::string_view count_token = scanner.token();
  if (count_token.empty()) {
    if (!scanner.next_data_line())
      throw Error(ErrorKind::invalid_input, name + ": truncated after the OFF header (no counts line)");
    count_token = scanner.token();
  }
  int64_t vertex_count = -1;
  int64_t face_count = -1;
  const std::string_view face_token = scanner.token();
  if (!parse_int(count_token, vertex_count) || !parse_int(face_token, face_count) || vertex_count < 0 || face_count < 0)
    fail(name, scanner.line_number(),
         "bad counts " + quote_token(count_token) + " " + quote_token(face_token) +
             " (expected 'VERTICES FACES EDGES', non-negative integers)");
  // Each vertex and face needs at least a few bytes: a count beyond the file size is a lie,
  // and reserving it would exhaust memory.
  if (static_cast<uint64_t>(vertex_count) > text.size() || static_cast<uint64_t>(face_count) > text.size())
    fail(name, scanner.line_number(),
         "bad counts: " + std::to_string(vertex_count) + " vertices and " + std::to_string(face_count) +
             " faces cannot fit in " + std::to_string(text.size()) + " bytes");
  // Every face gives at least one triangle.
  check_input_limits(static_cast<size_t>(vertex_count), static_cast<size_t>(face_count), name);
  if (vertex_count == 0) throw Error(ErrorKind::invalid_input, name + ": no vertices (the counts line says 0)");
  if (face_count == 0) throw Error(ErrorKind::invalid_input, name + ": no faces (the counts line says 0)");

  InputMesh mesh;
  mesh.positions.reserve(static_cast<size_t>(vertex_count));
  for (int64_t i = 0; i < vertex_count; ++i) {
    if (!scanner.next_data_line())
      throw Error(ErrorKind::invalid_input, name + ": truncated: " + std::to_string(vertex_count) +
                                                " vertices declared, file ends after " + std::to_string(i));
    Vec3 p;
    for (int axis = 0; axis < 3; ++axis) {
      const std::string_view token = scanner.token();
      if (!parse_double(token, p[axis]))
        fail(name, scanner.line_number(), "vertex " + std::to_string(i) + ": bad coordinate " + quote_token(token));
      if (!std::isfinite(p[axis]))
        fail(name, scanner.line_number(),
             "vertex " + std::to_string(i) + ": non-finite coordinate " + quote_token(token));
    }
    mesh.positions.push_back(p);
  }

  std::vector<uint32_t> polygon;
  for (int64_t f = 0; f < face_count; ++f) {
    if (!scanner.next_data_line())
      throw Error(ErrorKind::invalid_input, name + ": truncated: " + std::to_string(face_count) +
                                                " faces declared, file ends after " + std::to_string(f));
    int64_t corners = 0;
    const std::string_view corner_token = scanner.token();
    if (!parse_int(corner_token, corners) || corners < 3)
      fail(name, scanner.line_number(),
           "face " + std::to_string(f) + ": bad vertex count " + quote_token(corner_token) + " (at least 3 needed)");
    polygon.clear();
    for (int64_t c = 0; c < corners; ++c) {
      const std::string_view token = scanner.token();
      int64_t index = -1;
      if (token.empty())
        fail(name, scanner.line_number(),
             "face " + std::to_string(f) + ": " + std::to_string(corners) + " vertices declared, " + std::to_string(c) +
                 " given");
      if (!parse_int(token, index))
        fail(name, scanner.line_number(), "face " + std::to_string(f) + ": bad vertex index " + quote_token(token));
      if (index < 0 || index >= vertex_count)
        fail(name, scanner.line_number(),
             "face " + std::to_string(f) + ": vertex index " + std::to_string(index) + " out of range (" +
                 std::to_string(vertex_count) + " vertices)");
      polygon.push_back(static_cast<uint32_t>(index));
    }
    append_fan(polygon, mesh.triangles, name);
  }

  add_whole_primitive(mesh, mesh.positions.size());
  return mesh;
}

}  // namespace skelform::bake::detail
