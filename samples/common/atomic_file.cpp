#include "atomic_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>

namespace skelform::samples {

void write_file_atomically(const std::string& path, const std::string& contents) {
  // A random suffix keeps two concurrent writers of the same output from sharing a temporary.
  std::random_device entropy;
  char suffix[32];
  std::snprintf(suffix, sizeof(suffix), ".tmp%08x", static_cast<unsigned>(entropy()));
  const std::string temporary = path + suffix;
  std::FILE* file = std::fopen(temporary.c_str(), "wb");
  if (!file) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
  const bool written = std::fwrite(contents.data(), 1, contents.size(), file) == contents.size();
  const bool flushed = std::fflush(file) == 0;
  const int saved_errno = errno;
  const bool closed = std::fclose(file) == 0;
  std::error_code ignored;
  if (!written || !flushed || !closed) {
    std::filesystem::remove(temporary, ignored);
    throw std::runtime_error("cannot write " + path + ": " + std::strerror(saved_errno ? saved_errno : EIO));
  }
  std::error_code renamed;
  std::filesystem::rename(temporary, path, renamed);
  if (renamed) {
    std::filesystem::remove(temporary, ignored);
    throw std::runtime_error("cannot write " + path + ": " + renamed.message());
  }
}

}  // namespace skelform::samples
