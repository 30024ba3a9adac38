// What this CPU runs, checked once: the runtime's AVX2 kernels are compiled for AVX2 alone
// (target attributes) and chosen at run time, with an SSE2 or portable path beside each. Only on
// x86-64, where float and double are evaluated in their own type (no x87 excess precision), so
// that a kernel's lanes and the portable loop beside it round alike.
#pragma once

#include <cstdint>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && defined(__FLT_EVAL_METHOD__) && \
    __FLT_EVAL_METHOD__ == 0
#  define SKELFORM_HAS_AVX2_KERNELS 1
#endif

namespace skelform::runtime {

#if defined(SKELFORM_HAS_AVX2_KERNELS)
inline bool cpu_has_avx2() {
  static const bool has = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return has;
}
#else
inline bool cpu_has_avx2() { return false; }
#endif

// Whether elements 0 .. count − 1 of an array of three floats (or doubles) each can be gathered
// by int32 offsets: 3·(count − 1) + 2 < 2^31.
inline bool gather_offsets_fit(uint64_t count) { return count <= uint64_t(INT32_MAX) / 3; }

}  // namespace skelform::runtime
