// Allocation through the caller's sf_allocator (or malloc/free): every array the runtime owns
// is an Array<T>, so assets and instances honour the allocator given at load time.
#pragma once

#include "skelform/skelform.h"

#include <cstddef>
#include <cstdlib>
#include <new>
#include <vector>

namespace skelform::runtime {

// The allocator in effect for one asset and its instances. A zero sf_allocator means
// malloc/free (aligned_alloc for alignments above the default).
struct AllocatorRef {
  sf_allocator callbacks{};

  void* allocate(size_t size, size_t align) const {
    if (callbacks.alloc) return callbacks.alloc(callbacks.user, size, align);
    if (align <= alignof(std::max_align_t)) return std::malloc(size);
    return std::aligned_alloc(align, (size + align - 1) / align * align);
  }
  void release(void* ptr) const {
    if (callbacks.alloc) {
      if (callbacks.free) callbacks.free(callbacks.user, ptr);
    } else {
      std::free(ptr);
    }
  }
};

template <class T>
struct CallbackAllocator {
  using value_type = T;
  AllocatorRef ref;

  CallbackAllocator() = default;
  // Implicit, so that an Array member is initialised from the allocator alone: `x(allocator)`.
  CallbackAllocator(const AllocatorRef& r) : ref(r) {}
  template <class U>
  CallbackAllocator(const CallbackAllocator<U>& other) : ref(other.ref) {}

  T* allocate(size_t n) {
    void* p = ref.allocate(n * sizeof(T), alignof(T) < 16 ? 16 : alignof(T));
    if (!p) throw std::bad_alloc();
    return static_cast<T*>(p);
  }
  void deallocate(T* p, size_t) { ref.release(p); }

  template <class U>
  bool operator==(const CallbackAllocator<U>& o) const {
    return ref.callbacks.alloc == o.ref.callbacks.alloc && ref.callbacks.free == o.ref.callbacks.free &&
           ref.callbacks.user == o.ref.callbacks.user;
  }
  template <class U>
  bool operator!=(const CallbackAllocator<U>& o) const {
    return !(*this == o);
  }
};

template <class T>
using Array = std::vector<T, CallbackAllocator<T>>;

// Vertex buffers that the SSE2 kernels read a vector at a time with whole 16-byte loads
// (vec3_sse.h PaddedVec3Reader: refine_surface's control positions and normal sums, displace's
// refined surface) hold this many glm::vec3 past their last vertex: the load of the last
// vertex reads one float beyond it, and that float is then inside the buffer. The padding's
// value is never used.
constexpr size_t kVec3ReadPadding = 1;

// Objects created with the callback allocator (sf_asset, sf_instance).
template <class T, class... Args>
T* create_object(const AllocatorRef& ref, Args&&... args) {
  void* p = ref.allocate(sizeof(T), alignof(T) < 16 ? 16 : alignof(T));
  if (!p) throw std::bad_alloc();
  try {
    return new (p) T(std::forward<Args>(args)...);
  } catch (...) {
    ref.release(p);
    throw;
  }
}

template <class T>
void destroy_object(const AllocatorRef& ref, T* object) {
  if (!object) return;
  object->~T();
  ref.release(object);
}

}  // namespace skelform::runtime
