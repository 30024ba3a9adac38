#include "cli.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <new>

namespace skelform::cli {

const char* const kExitCodeHelp =
    "Exit codes: 0 success, 1 bad command line, 2 invalid or unsupported input,\n"
    "            3 file could not be read or written, 4 internal error.\n";

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

double parse_finite(const std::string& option, const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(value))
    fail(kExitUsage, option + " expects a finite number, got '" + text + "'");
  return value;
}

size_t parse_choice(const std::string& option, const std::string& text, std::initializer_list<const char*> choices) {
  size_t index = 0;
  std::string expected;
  for (const char* choice : choices) {
    if (text == choice) return index;
    expected += (index == 0 ? "" : index + 1 == choices.size() ? " or " : ", ") + std::string(choice);
    ++index;
  }
  fail(kExitUsage, option + " expects " + expected + ", got '" + text + "'");
}

std::string lowercase_extension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension;
}

std::string ArgumentCursor::value() {
  if (i_ + 1 >= argc_) fail(kExitUsage, arg_ + " needs a value");
  return argv_[++i_];
}

void ArgumentCursor::unknown() const { fail(kExitUsage, "unknown option " + arg_); }

int run_main(const char* name, const std::string& usage, int argc, char** argv, const std::function<int()>& run,
             const std::function<int(const std::exception&)>& classify) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      std::fputs(usage.c_str(), stdout);
      return kExitOk;
    }
    if (arg == "--version") {
      const uint32_t v = sf_version();
      std::printf("%s %u.%u.%u\n", name, v / 10000, v / 100 % 100, v % 100);
      return kExitOk;
    }
  }
  auto report = [&](int code, const char* message) {
    if (code == kExitUsage)
      std::fprintf(stderr, "%s: error: %s (see %s --help)\n", name, message, name);
    else
      std::fprintf(stderr, "%s: error: %s\n", name, message);
    return code;
  };
  try {
    return run();
  } catch (const Failure& failure) {
    return report(failure.exit_code, failure.message.c_str());
  } catch (const std::bad_alloc&) {
    return report(kExitInternal, "out of memory");
  } catch (const std::exception& e) {
    const int code = classify ? classify(e) : -1;
    if (code >= 0) return report(code, e.what());
    std::fprintf(stderr, "%s: internal error: %s\n", name, e.what());
    return kExitInternal;
  }
}

}  // namespace skelform::cli
