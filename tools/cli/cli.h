// What every skelform command-line tool shares (skelform-bake, skelform-pose,
// skelform-animate, skelform-quality, skelform-character): the exit codes, the one-line
// failure they report, option parsing, and main()'s handling of --help, --version and errors,
// so every tool answers the same way.
#pragma once

#include "skelform/skelform.h"

#include <functional>
#include <initializer_list>
#include <string>

namespace skelform::cli {

enum ExitCode { kExitOk = 0, kExitUsage = 1, kExitInvalidInput = 2, kExitIo = 3, kExitInternal = 4 };

// The exit-code lines of every tool's --help.
extern const char* const kExitCodeHelp;

// A failure with the exit code it maps to; the message is one line.
struct Failure {
  int exit_code;
  std::string message;
};

[[noreturn]] void fail(int exit_code, const std::string& message);

// The exit code of a failed C API call: I/O, invalid input (argument, data, version,
// unsupported), else internal.
int exit_code_of(sf_result result);

// The value of a command-line option: an integer in [lo, hi], a number in (0, hi], any finite
// number, or one of `choices` (its index). Anything else fails with kExitUsage and a message
// naming the option and what it expects.
unsigned long parse_integer(const std::string& option, const std::string& text, unsigned long lo, unsigned long hi);
double parse_positive(const std::string& option, const std::string& text, double hi);
double parse_finite(const std::string& option, const std::string& text);
size_t parse_choice(const std::string& option, const std::string& text, std::initializer_list<const char*> choices);

// The file extension of `path`, lowercase, with its dot ("" when none).
std::string lowercase_extension(const std::string& path);

// argv[1..] one argument at a time: `while (args.next())` then args.arg(); args.value() takes
// the option's value (the next argument), failing with kExitUsage when there is none.
class ArgumentCursor {
 public:
  ArgumentCursor(int argc, char** argv) : argc_(argc), argv_(argv) {}
  bool next() { return ++i_ < argc_ && (arg_ = argv_[i_], true); }
  const std::string& arg() const { return arg_; }
  std::string value();
  // An option-like argument ("-x", "--xyz") this tool does not know: fails with kExitUsage.
  [[noreturn]] void unknown() const;
  bool is_option() const { return arg_.size() > 1 && arg_[0] == '-'; }

 private:
  int argc_;
  char** argv_;
  int i_ = 0;
  std::string arg_;
};

// The body of main(): "-h"/"--help" anywhere prints `usage` and "--version" prints
// "<name> X.Y.Z" (exit 0); otherwise returns run()'s exit code. A failure from run() prints
// one line "<name>: error: ..." on stderr (a usage error ends "(see <name> --help)") and
// returns its exit code: a Failure its own; another exception the code `classify` gives it
// (a tool's domain errors; -1 or no classify: an unexpected exception, "<name>: internal
// error: ...", kExitInternal); std::bad_alloc kExitInternal ("out of memory").
int run_main(const char* name, const std::string& usage, int argc, char** argv, const std::function<int()>& run,
             const std::function<int(const std::exception&)>& classify = {});

}  // namespace skelform::cli
