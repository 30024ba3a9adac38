// Software prefetch for the per-frame kernels that walk a multi-megabyte array front to back.
// A hint only: it never faults (also past the end of an array) and changes no result; it
// compiles to nothing where the compiler lacks __builtin_prefetch.
#pragma once

#include <cstddef>
#include <cstdint>

namespace skelform::runtime {

// Asks for the cache line `bytes` bytes after `p` (address arithmetic on an integer, so no
// pointer is formed past the end of the array).
inline void prefetch_ahead(const void* p, size_t bytes) {
#if defined(__GNUC__)
  __builtin_prefetch(reinterpret_cast<const void*>(reinterpret_cast<uintptr_t>(p) + bytes));
#else
  static_cast<void>(p), static_cast<void>(bytes);
#endif
}

}  // namespace skelform::runtime
