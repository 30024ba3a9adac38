// Validated glTF reading (gltf_read.h). tinygltf 2.7 leaves most range checks to its caller,
// so nothing here indexes a tinygltf vector or a buffer before checking it.
#include "skelform/core/gltf_read.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <exception>
#include <filesystem>
#include <limits>
#include <new>
#include <string>

namespace skelform::gltf {
namespace {

using detail::invalid;
using detail::read_u32_le;

// tinygltf reports several problems separated by newlines; our messages are one line.
std::string one_line(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) text.pop_back();
  std::string out;
  for (char c : text) {
    if (c == '\n')
      out += "; ";
    else if (c != '\r')
      out += c;
  }
  return out;
}

bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

// Checks the GLB container so tinygltf only ever sees a consistent one; returns the number
// of bytes the header declares.
size_t check_glb_container(const unsigned char* bytes, size_t size, const std::string& name) {
  if (size < 12) invalid(name, "truncated .glb (" + std::to_string(size) + " bytes; the header alone needs 12)");
  if (std::memcmp(bytes, "glTF", 4) != 0) invalid(name, "not a binary glTF file (bad magic)");
  const uint32_t version = read_u32_le(bytes + 4);
  if (version != 2)
    throw GltfError(GltfError::unsupported,
                    name + ": binary glTF version " + std::to_string(version) + " (only 2 is supported)");
  const uint64_t length = read_u32_le(bytes + 8);
  if (length > size)
    invalid(name,
            "truncated .glb (header says " + std::to_string(length) + " bytes, file has " + std::to_string(size) + ")");
  if (length < 20)
    invalid(name, "malformed .glb (declared length " + std::to_string(length) + " leaves no room for the JSON chunk)");
  const uint64_t json_length = read_u32_le(bytes + 12);
  if (read_u32_le(bytes + 16) != 0x4E4F534Au) invalid(name, "malformed .glb (first chunk is not JSON)");
  if (json_length == 0) invalid(name, "malformed .glb (empty JSON chunk)");
  if (20 + json_length > length)
    invalid(name, "truncated .glb (JSON chunk of " + std::to_string(json_length) + " bytes does not fit)");
  uint64_t offset = 20 + json_length;
  while (offset < length) {
    if (length - offset < 8)
      invalid(name, "truncated .glb (chunk header cut off at byte " + std::to_string(offset) + ")");
    const uint64_t chunk_length = read_u32_le(bytes + offset);
    if (chunk_length > length - offset - 8)
      invalid(name, "truncated .glb (chunk at byte " + std::to_string(offset) + " declares " +
                        std::to_string(chunk_length) + " bytes, " + std::to_string(length - offset - 8) + " remain)");
    offset += 8 + chunk_length;
  }
  return static_cast<size_t>(length);
}

// check_before_parsing; returns the number of bytes tinygltf is to parse (a GLB's declared
// length, which may be less than `size`).
size_t checked_length(const unsigned char* bytes, size_t size, bool binary, const std::string& name) {
  if (!binary) {
    check_json_nesting(bytes, size, name);
    return size;
  }
  const size_t length = check_glb_container(bytes, size, name);
  check_json_nesting(bytes + 20, read_u32_le(bytes + 12), name);
  return length;
}

std::string directory_of(const std::string& path) {
  const size_t slash = path.find_last_of("/\\");
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

bool requires_extension(const tinygltf::Model& model, const std::string& extension) {
  return std::find(model.extensionsRequired.begin(), model.extensionsRequired.end(), extension) !=
         model.extensionsRequired.end();
}

// File access for tinygltf. Its default ExpandFilePath runs wordexp() on POSIX, which
// interprets $VARIABLES and ~ in a URI the asset's author chose; paths here are taken
// literally. The first file that could not be read (or was refused) is remembered so the
// caller can tell an unreadable external buffer from a malformed document.
struct FileAccess {
  ExternalFiles policy = ExternalFiles::read;
  std::string first_failure;  // path of the first external file not read
};

std::string literal_path(const std::string& path, void*) { return path; }

bool file_exists(const std::string& path, void* user) {
  auto* access = static_cast<FileAccess*>(user);
  if (access->policy != ExternalFiles::refuse && tinygltf::FileExists(path, nullptr)) return true;
  if (access->first_failure.empty()) access->first_failure = path;
  return false;
}

// tinygltf sizes its read by seeking to the end: only a regular file has an end to seek to,
// and one larger than a .glb can be (2^32 - 1 bytes) is no buffer this reader could use.
bool readable_external_file(const std::string& path) {
  std::error_code error;
  return std::filesystem::is_regular_file(path, error) &&
         std::filesystem::file_size(path, error) <= std::numeric_limits<uint32_t>::max() && !error;
}

bool read_whole_file(std::vector<unsigned char>* out, std::string* error, const std::string& path, void* user) {
  auto* access = static_cast<FileAccess*>(user);
  if (access->policy != ExternalFiles::refuse && readable_external_file(path) &&
      tinygltf::ReadWholeFile(out, error, path, nullptr))
    return true;
  if (access->first_failure.empty()) access->first_failure = path;
  if (error && access->policy == ExternalFiles::refuse) *error += "external file refused: " + path + "\n";
  return false;
}

bool never_write(std::string* error, const std::string&, const std::vector<unsigned char>&, void*) {
  if (error) *error += "writing is not supported\n";
  return false;
}

}  // namespace

bool is_glb(const unsigned char* bytes, size_t size) { return size >= 4 && std::memcmp(bytes, "glTF", 4) == 0; }

void check_json_nesting(const unsigned char* json, size_t size, const std::string& name) {
  size_t depth = 0;
  bool in_string = false;
  for (size_t i = 0; i < size; ++i) {
    const unsigned char c = json[i];
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonNesting)
        invalid(name, "JSON nested deeper than " + std::to_string(kMaxJsonNesting) + " arrays and objects (at byte " +
                          std::to_string(i) + "); glTF needs 6");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

void check_before_parsing(const unsigned char* bytes, size_t size, bool binary, const std::string& name) {
  checked_length(bytes, size, binary, name);
}

void parse_model(const unsigned char* bytes, size_t size, bool binary, const std::string& name, tinygltf::Model& model,
                 ExternalFiles external) {
  if (!bytes || size == 0) invalid(name, "empty file");
  if (size > std::numeric_limits<unsigned int>::max())
    throw GltfError(GltfError::unsupported, name + ": file larger than 4 GiB");
  FileAccess access;
  access.policy = external;
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(skip_image, nullptr);
  loader.SetFsCallbacks(tinygltf::FsCallbacks{file_exists, literal_path, read_whole_file, never_write, &access});
  std::string error;
  std::string warning;
  bool ok = false;
  // With no directory in `name` (memory), tinygltf would resolve relative URIs against the
  // process's working directory; "refuse" keeps it from reading anything.
  const std::string base_dir = external == ExternalFiles::refuse ? std::string() : directory_of(name);
  const auto length = static_cast<unsigned int>(checked_length(bytes, size, binary, name));
  try {
    ok = binary ? loader.LoadBinaryFromMemory(&model, &error, &warning, bytes, length, base_dir)
                : loader.LoadASCIIFromString(&model, &error, &warning, reinterpret_cast<const char*>(bytes), length,
                                             base_dir);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception&) {
    // tinygltf 2.7 reports most problems in `error` but indexes with at() in places: an
    // inconsistent file, not a failure of the loader. Its exception's text (a standard
    // library's internals) would tell the user nothing.
    invalid(name,
            "not a valid glTF 2.0 file: the glTF parser failed on inconsistent data (for example a buffer "
            "whose byteLength is 0)");
  }
  // Images are optional to tinygltf (a failed image read is a warning), so a remembered
  // failure only explains a failed parse.
  if (!ok && !access.first_failure.empty() && external == ExternalFiles::refuse)
    throw GltfError(GltfError::unsupported, name + ": references external file '" +
                                                access.first_failure.substr(0, 200) +
                                                "', which loading from memory does not read (embed buffers as data "
                                                "URIs or a .glb, or load from a file)");
  if (!ok && !access.first_failure.empty() && external == ExternalFiles::read_io_errors)
    throw GltfError(GltfError::io, name + ": cannot read external file '" + access.first_failure.substr(0, 200) + "'");
  if (!ok)
    invalid(name, "not a valid glTF 2.0 file: " + (error.empty() ? std::string("parse failed") : one_line(error)));
  for (const char* extension : {"KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_mesh_quantization"}) {
    if (requires_extension(model, extension))
      throw GltfError(GltfError::unsupported, name + ": requires " + extension +
                                                  ", which skelform does not decode (export uncompressed geometry)");
  }
}

}  // namespace skelform::gltf
