// Internal to the input stage: one loader per file format, plus the text-scanning helpers
// the line-based formats (OBJ, PLY ASCII, OFF) share. input.cpp dispatches and validates.
#pragma once

#include "skelform/bake/input.h"
#include "skelform/bake/mesh.h"

#include <charconv>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace skelform::bake::detail {

// Each loader fills positions, triangles and primitives; `name` is the file name used in
// messages. They throw Error on malformed input. load_mesh_from_memory runs the shared
// validation (indices in range, finite positions, no empty mesh) afterwards, so a loader
// only needs to check what it alone can name precisely (a line, an element).
InputMesh load_obj(std::string_view text, const std::string& name);
InputMesh load_ply(const std::vector<unsigned char>& bytes, const std::string& name);
InputMesh load_off(std::string_view text, const std::string& name);
InputMesh load_gltf(const std::vector<unsigned char>& bytes, bool binary, const std::string& name,
                    const LoadOptions& options);

// Refuses a mesh grown past kMaxInputVertices or kMaxInputTriangles (input.h). Loaders call
// it as they append, so a file is refused before it takes more memory than those allow.
inline void check_input_limits(size_t vertices, size_t triangles, const std::string& name) {
  if (triangles > kMaxInputTriangles)
    throw Error(ErrorKind::unsupported, name + ": more than " + std::to_string(kMaxInputTriangles) +
                                            " triangles, the most skelform-bake reads (decimate the mesh first)");
  if (vertices > kMaxInputVertices)
    throw Error(ErrorKind::unsupported, name + ": more than " + std::to_string(kMaxInputVertices) +
                                            " vertices, the most skelform-bake reads (decimate the mesh first)");
}

// Fan-triangulates one polygon (v0, vi, vi+1), the convention OBJ/PLY/OFF writers expect for
// the convex polygons they emit; checks the triangle limit first.
inline void append_fan(const std::vector<uint32_t>& polygon, std::vector<Triangle>& triangles,
                       const std::string& name) {
  check_input_limits(0, triangles.size() + (polygon.size() < 2 ? 0 : polygon.size() - 2), name);
  for (size_t i = 1; i + 1 < polygon.size(); ++i) triangles.push_back(Triangle{polygon[0], polygon[i], polygon[i + 1]});
}

// The one primitive of a single-mesh file (OBJ, PLY, OFF): all `vertex_count` vertices and
// every triangle, indexed.
inline void add_whole_primitive(InputMesh& mesh, size_t vertex_count) {
  InputPrimitive whole;
  whole.vertex_count = static_cast<uint32_t>(vertex_count);
  whole.triangle_count = static_cast<uint32_t>(mesh.triangles.size());
  whole.indexed = true;
  mesh.primitives.push_back(whole);
}

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// Splits text into lines (any of \n, \r\n) and each line into whitespace-separated tokens,
// without copying. Line numbers are 1-based for messages.
class LineScanner {
 public:
  explicit LineScanner(std::string_view text) : text_(text) {}

  // Advances to the next line; false at the end of the text.
  bool next_line() {
    if (next_ >= text_.size()) return false;
    size_t end = text_.find('\n', next_);
    if (end == std::string_view::npos) end = text_.size();
    line_ = text_.substr(next_, end - next_);
    next_ = end + 1;
    cursor_ = 0;
    ++line_number_;
    return true;
  }

  // The next token of the current line, empty at its end.
  std::string_view token() {
    while (cursor_ < line_.size() && is_space(line_[cursor_])) ++cursor_;
    size_t start = cursor_;
    while (cursor_ < line_.size() && !is_space(line_[cursor_])) ++cursor_;
    return line_.substr(start, cursor_ - start);
  }

  std::string_view line() const { return line_; }
  size_t line_number() const { return line_number_; }

 private:
  std::string_view text_;
  std::string_view line_;
  size_t next_ = 0;
  size_t cursor_ = 0;
  size_t line_number_ = 0;
};

// Whole-token number parsing; false if the token is not entirely one number.
// A leading '+' is accepted because some exporters write it and from_chars does not.
inline bool parse_double(std::string_view token, double& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
}

inline bool parse_int(std::string_view token, int64_t& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
}

// Shortens a token for an error message so a garbage file cannot produce a huge line.
inline std::string quote_token(std::string_view token) {
  std::string out = "'";
  for (char c : token.substr(0, 32)) out += (static_cast<unsigned char>(c) < 32 || c == 127) ? '?' : c;
  if (token.size() > 32) out += "...";
  out += "'";
  return out;
}

}  // namespace skelform::bake::detail
