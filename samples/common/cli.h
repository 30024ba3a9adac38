// What the sample command-line tools (skelform-pose, skelform-animate) share: their exit
// codes, the one-line failure they report, and main()'s handling of --help, --version and
// errors, so every tool answers the same way.
#pragma once

#include "skelform/skelform.h"

#include <functional>
#include <string>

namespace skelform::samples {

enum ExitCode { kExitOk = 0, kExitUsage = 1, kExitInvalidInput = 2, kExitIo = 3, kExitInternal = 4 };

// A failure with the exit code it maps to; the message is one line.
struct Failure {
  int exit_code;
  std::string message;
};

[[noreturn]] void fail(int exit_code, const std::string& message);

// The exit code of a failed C API call: I/O, invalid input (argument, data, version,
// unsupported), else internal.
int exit_code_of(sf_result result);

// The value of a command-line option: an integer in [lo, hi], or a number in (0, hi] (fps).
// Anything else fails with kExitUsage and a message naming the option and the range.
unsigned long parse_integer(const std::string& option, const std::string& text, unsigned long lo, unsigned long hi);
double parse_positive(const std::string& option, const std::string& text, double hi);

// The file extension of `path`, lowercase, with its dot ("" when none).
std::string lowercase_extension(const std::string& path);

// The body of main(): "-h"/"--help" anywhere prints `usage` and "--version" prints
// "<name> X.Y.Z" (exit 0); otherwise returns run()'s exit code. A Failure, GltfError,
// std::bad_alloc or other exception from run() prints one line "<name>: error: ..." (for an
// unexpected exception "<name>: internal error: ...") on stderr and returns its exit code.
int run_main(const char* name, const char* usage, int argc, char** argv, const std::function<int()>& run);

}  // namespace skelform::samples
