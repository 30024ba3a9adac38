// Bounded reading of an asset file (file_read.h).
#include "file_read.h"

#include "asset_load.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace skelform::runtime {
namespace {

constexpr size_t kGlbHeaderBytes = 12;  // magic, version, total length

[[noreturn]] void refuse(sf_result result, const std::string& path, const std::string& problem) {
  throw LoadError(result, path + ": " + problem);
}

[[noreturn]] void beyond_limit(const std::string& path, size_t limit) {
  refuse(SF_ERROR_UNSUPPORTED, path,
         "larger than " + std::to_string(limit) + " bytes, the most sf_asset_load_file reads");
}

// Appends up to `count` bytes of `in` to `bytes`; false when the stream ended first.
bool read_into(std::ifstream& in, size_t count, std::vector<unsigned char>& bytes) {
  const size_t start = bytes.size();
  bytes.resize(start + count);
  in.read(reinterpret_cast<char*>(bytes.data() + start), static_cast<std::streamsize>(count));
  bytes.resize(start + static_cast<size_t>(in.gcount()));
  return bytes.size() == start + count;
}

// A glTF JSON document starts with an object, after optional whitespace or a UTF-8 BOM.
bool may_start_json(unsigned char byte) {
  return byte == '{' || byte == ' ' || byte == '\t' || byte == '\n' || byte == '\r' || byte == 0xEF;
}

std::vector<unsigned char> read_regular(std::ifstream& in, const std::string& path, uintmax_t size, size_t limit) {
  if (size > limit) beyond_limit(path, limit);
  std::vector<unsigned char> bytes;
  read_into(in, static_cast<size_t>(size), bytes);  // a file that shrank meanwhile: what is left
  return bytes;
}

std::vector<unsigned char> read_stream(std::ifstream& in, const std::string& path, size_t limit) {
  std::vector<unsigned char> bytes;
  read_into(in, std::min(kGlbHeaderBytes, limit), bytes);
  if (bytes.empty()) return bytes;
  if (bytes.size() == kGlbHeaderBytes && std::memcmp(bytes.data(), "glTF", 4) == 0) {
    uint32_t length;
    std::memcpy(&length, bytes.data() + 8, sizeof length);  // little-endian, as the GLB header
    if (length > limit) beyond_limit(path, limit);
    if (length > kGlbHeaderBytes) read_into(in, length - kGlbHeaderBytes, bytes);
    return bytes;
  }
  if (!may_start_json(bytes[0]))
    refuse(SF_ERROR_INVALID_DATA, path, "neither a GLB nor a glTF JSON document (a stream of another kind)");
  constexpr size_t kChunk = size_t{1} << 20;
  while (in) {
    if (bytes.size() == limit) {
      if (in.peek() == std::char_traits<char>::eof()) break;
      beyond_limit(path, limit);
    }
    read_into(in, std::min(kChunk, limit - bytes.size()), bytes);
  }
  return bytes;
}

}  // namespace

std::vector<unsigned char> read_asset_file(const std::string& path, size_t limit) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (std::filesystem::is_directory(status)) refuse(SF_ERROR_IO, path, "is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) refuse(SF_ERROR_IO, path, "cannot open the file");
  uintmax_t size = 0;
  const bool sized =
      std::filesystem::is_regular_file(status) && (size = std::filesystem::file_size(path, error), !error);
  std::vector<unsigned char> bytes = sized ? read_regular(in, path, size, limit) : read_stream(in, path, limit);
  if (in.bad()) refuse(SF_ERROR_IO, path, "read error");
  if (bytes.empty()) refuse(SF_ERROR_INVALID_DATA, path, "empty file");
  return bytes;
}

}  // namespace skelform::runtime
