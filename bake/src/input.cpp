// Mesh input: format dispatch and the validation every format shares.
#include "skelform/bake/input.h"

#include "input_formats.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>

namespace skelform::bake {
namespace {

std::string lower_extension(const std::string& path) {
  size_t dot = path.find_last_of('.');
  size_t slash = path.find_last_of("/\\");
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

std::string too_large(const std::string& path) {
  return path + ": larger than " + std::to_string(kMaxInputFileBytes >> 20) +
         " MiB, the most skelform-bake reads (decimate or split the mesh first)";
}

// The total length a GLB header (magic "glTF", version, length) declares; 0 when `bytes`
// do not start with one.
uint64_t declared_glb_length(const std::vector<unsigned char>& bytes) {
  if (bytes.size() < 12 || std::memcmp(bytes.data(), "glTF", 4) != 0) return 0;
  return uint64_t{bytes[8]} | uint64_t{bytes[9]} << 8 | uint64_t{bytes[10]} << 16 | uint64_t{bytes[11]} << 24;
}

// Reads in chunks rather than trusting a size from seek/tell, which fails on pipes and
// reports nonsense for directories. At most kMaxInputFileBytes: a stream without an end
// (/dev/zero, a FIFO nobody closes) is refused once it passes the limit. A .glb is read no
// further than the length its header declares, so a stream carrying one needs no end.
std::vector<unsigned char> read_file(const std::string& path, bool glb) {
  struct Closer {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  std::error_code size_error;
  const uintmax_t size =
      std::filesystem::is_regular_file(path, size_error) ? std::filesystem::file_size(path, size_error) : 0;
  if (!size_error && size > kMaxInputFileBytes) throw Error(ErrorKind::unsupported, too_large(path));
  std::unique_ptr<std::FILE, Closer> file(std::fopen(path.c_str(), "rb"));
  if (!file) throw Error(ErrorKind::io, "cannot open " + path + ": " + std::strerror(errno));
  std::vector<unsigned char> bytes;
  if (!size_error) bytes.reserve(static_cast<size_t>(size));
  uint64_t wanted = kMaxInputFileBytes + 1;  // until the end, or until past the limit
  unsigned char chunk[1 << 16];
  for (;;) {
    // The first 12 bytes alone first, so that a GLB's declared length bounds the rest.
    const size_t request = static_cast<size_t>(
        std::min<uint64_t>(bytes.size() < 12 ? 12 - bytes.size() : sizeof chunk, wanted - bytes.size()));
    const size_t n = std::fread(chunk, 1, request, file.get());
    if (bytes.size() + n > kMaxInputFileBytes) throw Error(ErrorKind::unsupported, too_large(path));
    bytes.insert(bytes.end(), chunk, chunk + n);
    if (n < request) break;
    if (glb && bytes.size() == 12 && declared_glb_length(bytes) >= 12) {
      wanted = declared_glb_length(bytes);
      if (wanted > kMaxInputFileBytes) throw Error(ErrorKind::unsupported, too_large(path));
    }
    if (bytes.size() == wanted) break;
  }
  if (std::ferror(file.get())) throw Error(ErrorKind::io, "cannot read " + path + ": " + std::strerror(errno));
  return bytes;
}

// Checks the guarantees later stages rely on, whatever the format: at least one triangle,
// indices in range, finite positions, counts that fit the 32-bit indices.
void validate(const InputMesh& mesh, const std::string& name) {
  detail::check_input_limits(mesh.positions.size(), mesh.triangles.size(), name);
  if (mesh.positions.empty()) throw Error(ErrorKind::invalid_input, name + ": no vertices");
  if (mesh.triangles.empty()) throw Error(ErrorKind::invalid_input, name + ": no faces");
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3& p = mesh.positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw Error(ErrorKind::invalid_input, name + ": vertex " + std::to_string(i) + " has a non-finite coordinate");
  }
  const size_t vertex_count = mesh.positions.size();
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (uint32_t v : mesh.triangles[t]) {
      if (v >= vertex_count)
        throw Error(ErrorKind::invalid_input, name + ": triangle " + std::to_string(t) + " uses vertex " +
                                                  std::to_string(v) + " of " + std::to_string(vertex_count));
    }
  }
}

}  // namespace

InputMesh load_mesh_from_memory(const std::vector<unsigned char>& bytes, const std::string& extension,
                                const std::string& name, const LoadOptions& options) {
  std::string ext = extension;
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (!ext.empty() && ext.front() != '.') ext.insert(ext.begin(), '.');
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());

  InputMesh mesh;
  if (ext == ".gltf") {
    mesh = detail::load_gltf(bytes, false, name, options);
  } else if (ext == ".glb") {
    mesh = detail::load_gltf(bytes, true, name, options);
  } else if (ext == ".obj") {
    mesh = detail::load_obj(text, name);
  } else if (ext == ".ply") {
    mesh = detail::load_ply(bytes, name);
  } else if (ext == ".off") {
    mesh = detail::load_off(text, name);
  } else {
    throw Error(ErrorKind::unsupported,
                name + ": unsupported file type '" + extension + "' (expected .gltf, .glb, .obj, .ply or .off)");
  }
  mesh.source_path = name;
  validate(mesh, name);
  return mesh;
}

std::vector<unsigned char> read_input_file(const std::string& path) {
  return read_file(path, lower_extension(path) == ".glb");
}

InputMesh load_mesh(const std::string& path, const LoadOptions& options) {
  const std::string ext = lower_extension(path);
  if (ext != ".gltf" && ext != ".glb" && ext != ".obj" && ext != ".ply" && ext != ".off")
    throw Error(ErrorKind::unsupported,
                path + ": unsupported file type '" + ext + "' (expected .gltf, .glb, .obj, .ply or .off)");
  return load_mesh_from_memory(read_file(path, ext == ".glb"), ext, path, options);
}

}  // namespace skelform::bake
