// A counting sf_allocator for the tests that check the runtime's memory contract (every
// allocation through the caller's callbacks, none during evaluation or output, everything
// freed): blocks are counted so a test sees leaks and double frees, and allocation number
// `fail_after` and every later one can be made to fail.
#pragma once

#include "skelform/skelform.h"

#include <doctest/doctest.h>

#include <atomic>
#include <cstdlib>

namespace skelform::test {

struct CountingHeap {
  std::atomic<long> allocations{0};
  std::atomic<long> frees{0};
  std::atomic<long> live{0};
  long fail_after = -1;  // >= 0: the allocation with this index (and later ones) fail

  static void* alloc(void* user, size_t size, size_t align) {
    auto* heap = static_cast<CountingHeap*>(user);
    const long index = heap->allocations.fetch_add(1);
    if (heap->fail_after >= 0 && index >= heap->fail_after) {
      heap->allocations.fetch_sub(1);
      return nullptr;
    }
    CHECK(align >= 1);
    CHECK((align & (align - 1)) == 0);
    void* p = std::aligned_alloc(align, (size + align - 1) / align * align);
    if (p) ++heap->live;
    return p;
  }
  static void free(void* user, void* ptr) {
    if (!ptr) return;
    auto* heap = static_cast<CountingHeap*>(user);
    ++heap->frees;
    --heap->live;
    std::free(ptr);
  }

  // The callbacks, with this heap as their user pointer.
  sf_allocator callbacks() { return sf_allocator{alloc, free, this}; }
};

}  // namespace skelform::test
