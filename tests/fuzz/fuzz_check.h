// What the fuzzers share: a finding aborts with one line, so that libFuzzer keeps the input
// as a crash; a contract of the API that does not hold is as much a finding as a memory error.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>

namespace skelform::fuzz {

[[noreturn]] inline void finding(const char* what) {
  std::fprintf(stderr, "skelform fuzz finding: %s\n", what);
  std::abort();
}

inline void require(bool condition, const char* what) {
  if (!condition) finding(what);
}

inline bool all_finite(const float* values, size_t count) {
  for (size_t i = 0; i < count; ++i)
    if (!std::isfinite(values[i])) return false;
  return true;
}

}  // namespace skelform::fuzz
