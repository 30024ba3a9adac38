// Helpers shared by the tests: locating third-party models and scratch files.
#pragma once

#include <doctest/doctest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace skelform::test {

// Directory of the third-party models (../shared/data); $SKELFORM_DATA_DIR overrides.
inline std::filesystem::path data_dir() {
  if (const char* env = std::getenv("SKELFORM_DATA_DIR")) return env;
  return SKELFORM_DATA_DIR;
}

// Path of a model under the data directory, or an empty path when it is absent.
inline std::filesystem::path data_file(const std::string& relative) {
  std::filesystem::path p = data_dir() / relative;
  return std::filesystem::exists(p) ? p : std::filesystem::path();
}

// A per-test scratch directory under the build tree.
inline std::filesystem::path scratch_dir(const std::string& name) {
  std::filesystem::path p = std::filesystem::path(SKELFORM_TEST_TMP_DIR) / name;
  std::filesystem::create_directories(p);
  return p;
}

}  // namespace skelform::test

// Skips the rest of a test case, with a message in the log, when a model is absent.
#define SKELFORM_REQUIRE_DATA(var, relative)                                               \
  const std::filesystem::path var = ::skelform::test::data_file(relative);                 \
  if (var.empty()) {                                                                       \
    MESSAGE("skipped: " << relative << " not found under " << ::skelform::test::data_dir() \
                        << " (set SKELFORM_DATA_DIR)");                                    \
    return;                                                                                \
  }
