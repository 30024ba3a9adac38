#include "skelform/bake/output.h"

#include <charconv>
#include <cstdio>
#include <filesystem>
#include <system_error>

#include <unistd.h>

namespace skelform::bake {
namespace {

void append_double(std::string& out, double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out.append(buffer, result.ptr);
}

void append_comment(std::string& out, const std::vector<std::string>& comment) {
  for (const std::string& line : comment) out += "# " + line + "\n";
}

void append_vertices(std::string& out, const std::vector<Vec3>& points) {
  for (const Vec3& p : points) {
    out += "v ";
    append_double(out, p.x);
    out += ' ';
    append_double(out, p.y);
    out += ' ';
    append_double(out, p.z);
    out += '\n';
  }
}

}  // namespace

void write_file_atomically(const std::string& path, const std::string& contents) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  if (target.empty()) throw Error(ErrorKind::io, "empty output path");
  std::error_code ec;
  if (fs::is_directory(target, ec)) throw Error(ErrorKind::io, "output path is a directory: " + path);

  // The temporary file lives in the destination directory so the rename cannot cross
  // file systems; the pid keeps two concurrent bakes from sharing it.
  fs::path temporary = target;
  temporary += ".tmp-skelform-" + std::to_string(::getpid());
  std::FILE* file = std::fopen(temporary.c_str(), "wb");
  if (!file) throw Error(ErrorKind::io, "cannot create " + temporary.string() + " (is the directory writable?)");
  const bool written = std::fwrite(contents.data(), 1, contents.size(), file) == contents.size();
  const bool flushed = std::fflush(file) == 0 && ::fsync(::fileno(file)) == 0;
  const bool closed = std::fclose(file) == 0;
  if (!written || !flushed || !closed) {
    fs::remove(temporary, ec);
    throw Error(ErrorKind::io, "cannot write " + path + " (disk full?)");
  }
  fs::rename(temporary, target, ec);
  if (ec) {
    fs::remove(temporary, ec);
    throw Error(ErrorKind::io, "cannot rename the temporary file to " + path);
  }
}

std::string obj_text(const TriangleMesh& mesh, const std::vector<std::string>& comment) {
  std::string out;
  out.reserve(mesh.positions.size() * 64 + mesh.triangles.size() * 24);
  append_comment(out, comment);
  append_vertices(out, mesh.positions);
  for (const Triangle& t : mesh.triangles) {
    out += "f " + std::to_string(t[0] + 1) + ' ' + std::to_string(t[1] + 1) + ' ' + std::to_string(t[2] + 1) + '\n';
  }
  return out;
}

std::string obj_points_text(const std::vector<Vec3>& points, const std::vector<std::string>& comment) {
  std::string out;
  append_comment(out, comment);
  append_vertices(out, points);
  for (size_t i = 0; i < points.size(); ++i) out += "p " + std::to_string(i + 1) + '\n';
  return out;
}

bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  return std::filesystem::equivalent(a, b, ec) && !ec;
}

}  // namespace skelform::bake
