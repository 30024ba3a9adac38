#include "cli.h"

#include "gltf_animation.h"

#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <new>

namespace skelform::samples {

void fail(int exit_code, const std::string& message) { throw Failure{exit_code, message}; }

int exit_code_of(sf_result result) {
  switch (result) {
    case SF_ERROR_IO:
      return kExitIo;
    case SF_ERROR_INVALID_ARGUMENT:
    case SF_ERROR_INVALID_DATA:
    case SF_ERROR_VERSION_MISMATCH:
    case SF_ERROR_UNSUPPORTED:
      return kExitInvalidInput;
    default:
      return kExitInternal;
  }
}

unsigned long parse_integer(const std::string& option, const std::string& text, unsigned long lo, unsigned long hi) {
  char* end = nullptr;
  errno = 0;
  const unsigned long value = std::strtoul(text.c_str(), &end, 10);
  if (text.empty() || text[0] == '-' || *end != '\0' || errno == ERANGE || value < lo || value > hi)
    fail(kExitUsage, option + " expects an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" +
                         text + "'");
  return value;
}

double parse_positive(const std::string& option, const std::string& text, double hi) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !(value > 0.0) || value > hi) {
    char range[64];
    std::snprintf(range, sizeof range, "(0, %g]", hi);
    fail(kExitUsage, option + " expects a number in " + range + ", got '" + text + "'");
  }
  return value;
}

std::string lowercase_extension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension;
}

int run_main(const char* name, const char* usage, int argc, char** argv, const std::function<int()>& run) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      std::fputs(usage, stdout);
      return kExitOk;
    }
    if (arg == "--version") {
      const uint32_t v = sf_version();
      std::printf("%s %u.%u.%u\n", name, v / 10000, v / 100 % 100, v % 100);
      return kExitOk;
    }
  }
  try {
    return run();
  } catch (const Failure& failure) {
    std::fprintf(stderr, "%s: error: %s\n", name, failure.message.c_str());
    return failure.exit_code;
  } catch (const GltfError& e) {
    std::fprintf(stderr, "%s: error: %s\n", name, e.what());
    return kExitInvalidInput;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s: error: out of memory\n", name);
    return kExitInternal;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: internal error: %s\n", name, e.what());
    return kExitInternal;
  }
}

}  // namespace skelform::samples
