// What this CPU runs, checked once: the runtime's AVX2 kernels are compiled for AVX2 alone
// (target attributes) and chosen at run time, with an SSE2 or portable path beside each.
#pragma once

#if defined(__SSE2__) && (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
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

}  // namespace skelform::runtime
