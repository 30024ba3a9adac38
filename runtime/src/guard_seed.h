// The LBS guard's first-round seed (lbs_guard.cpp GuardPass::seed_all), every welded vertex and
// triangle of the mesh on every evaluation: the guarded positions x = L + w·λ·(K − L) at the
// representatives (blend_with_lbs), which of them moved off L, and each triangle's box at x,
// slot by slot in the hierarchy's box planes, with the triangles that have a moved corner
// listed for the search (tested, wanted, the test list).
//
// seed_positions() and seed_boxes() take the fastest form this CPU runs: AVX2 eight vertices or
// slots at a time (their data gathered), SSE2 four slots at a time, or the portable loops. Each
// lane does the portable loop's operations in its order, so every form gives the same bits,
// flags and list (tests/runtime/guard_seed_test.cpp).
#pragma once

#include "avx2_lanes.h"
#include "contact.h"
#include "cpu.h"
#include "memory.h"
#include "triangle_bvh.h"

#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif

namespace skelform::runtime {

inline void triangle_box(const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2, float* b) {
  const glm::vec3 lo = glm::min(glm::min(p0, p1), p2), hi = glm::max(glm::max(p0, p1), p2);
  b[0] = lo.x, b[1] = lo.y, b[2] = lo.z, b[3] = hi.x, b[4] = hi.y, b[5] = hi.z;
}

// The blend's inputs per welded vertex w: its representative r (a dense vertex), and L, K and
// the skelform weight w there (dense), λ at w.
struct SeedSkin {
  const uint32_t* representative;
  const glm::vec3* lbs;
  const glm::vec3* skelform;
  const float* weight;
  const float* factor;
};

// Where the seed goes: x and the moved flags per welded vertex (seed_boxes's AVX2 form reads
// four bytes at a flag: it runs where `moved` has three after the last vertex's), and per slot
// the box planes and the listing.
struct SeedOutput {
  glm::vec3* positions;
  uint8_t* moved;
  SlotBoxes* boxes;
  uint8_t* tested;  // per triangle
  uint8_t* wanted;  // per slot
  Array<uint32_t>* test_list;
};

// Welded vertices [first, end): x, moved (x ≠ L, a NaN counting as moved), and `finite` cleared
// where L's and x's coordinates do not sum to a finite number.
inline void seed_positions_portable(uint32_t first, uint32_t end, const SeedSkin& skin, const SeedOutput& out,
                                    bool& finite) {
  for (uint32_t v = first; v < end; ++v) {
    const uint32_t r = skin.representative[v];
    const glm::vec3 l = skin.lbs[r];
    const glm::vec3 x = blend_with_lbs(l, skin.skelform[r], skin.weight[r] * skin.factor[v]);
    out.positions[v] = x;
    out.moved[v] = x != l;
    finite &= std::isfinite(l.x + l.y + l.z + x.x + x.y + x.z);
  }
}

// The triangle in `slot` is listed (tested, wanted, on the test list) where `listed`: where one
// of its corners moved.
inline void seed_listing(const TriangleHierarchy& h, uint32_t slot, bool listed, const SeedOutput& out) {
  const uint32_t t = h.order[slot];
  out.tested[t] = listed;
  out.wanted[slot] = listed;
  if (listed) out.test_list->push_back(t);  // capacity for every triangle: no allocation
}

// Slots [first, end) (each holding a triangle): boxes at x and the listing.
inline void seed_boxes_portable(uint32_t first, uint32_t end, const TriangleHierarchy& h, const SeedOutput& out) {
  const size_t stride = h.slot_stride();
  const uint32_t* corners = h.corners.data();
  for (uint32_t i = first; i < end; ++i) {
    const uint32_t c[3] = {corners[i], corners[stride + i], corners[2 * stride + i]};
    float box[6];
    triangle_box(out.positions[c[0]], out.positions[c[1]], out.positions[c[2]], box);
    out.boxes->set(i, box);
    seed_listing(h, i, out.moved[c[0]] || out.moved[c[1]] || out.moved[c[2]], out);
  }
}

namespace detail {

#if defined(__SSE2__)
// seed_boxes_portable four slots at a time from `first`; returns where it stopped. Stored as
// lanes of the box planes: triangle_box's glm::min (y < x ? y : x) and glm::max (x < y ? y : x)
// are _mm_min_ps(y, x) and _mm_max_ps(y, x).
inline uint32_t seed_boxes_sse2(uint32_t first, uint32_t end, const TriangleHierarchy& h, const SeedOutput& out) {
  const size_t stride = h.slot_stride(), planes_stride = out.boxes->stride;
  const uint32_t* corners = h.corners.data();
  const glm::vec3* x = out.positions;
  float* planes = out.boxes->planes.data();
  uint32_t i = first;
  for (; i + 4 <= end; i += 4) {
    __m128 lo[3], hi[3];
    for (size_t k = 0; k < 3; ++k) {
      const uint32_t* c = corners + k * stride + i;
      for (int axis = 0; axis < 3; ++axis) {
        const __m128 p = _mm_setr_ps(x[c[0]][axis], x[c[1]][axis], x[c[2]][axis], x[c[3]][axis]);
        lo[axis] = k == 0 ? p : _mm_min_ps(p, lo[axis]);
        hi[axis] = k == 0 ? p : _mm_max_ps(p, hi[axis]);
      }
    }
    for (size_t axis = 0; axis < 3; ++axis) {
      _mm_storeu_ps(planes + axis * planes_stride + i, lo[axis]);
      _mm_storeu_ps(planes + (3 + axis) * planes_stride + i, hi[axis]);
    }
    for (uint32_t j = i; j < i + 4; ++j)
      seed_listing(h, j, out.moved[corners[j]] || out.moved[corners[stride + j]] || out.moved[corners[2 * stride + j]],
                   out);
  }
  return i;
}
#endif

#if defined(SKELFORM_HAS_AVX2_KERNELS)
// seed_positions_portable over welded vertices [0, 8·⌊count/8⌋), eight at a time; returns
// where it stopped. The representatives' arrays must take int32 gather offsets
// (gather_offsets_fit).
__attribute__((target("avx2"))) inline uint32_t seed_positions_avx2(uint32_t count, const SeedSkin& skin,
                                                                    const SeedOutput& out, bool& finite) {
  const __m256 zero = _mm256_setzero_ps();
  __m256 all_finite = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
  uint32_t v = 0;
  for (; v + 8 <= count; v += 8) {
    const __m256i r = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(skin.representative + v));
    const __m256i r3 = _mm256_add_epi32(r, _mm256_add_epi32(r, r));
    const __m256 s = _mm256_mul_ps(avx2::gather_ps(skin.weight, r), _mm256_loadu_ps(skin.factor + v));
    const __m256 keep = _mm256_cmp_ps(s, zero, _CMP_EQ_OQ);  // blend_with_lbs: s == 0 gives L itself
    __m256 l[3], x[3], differs = zero;
    for (int axis = 0; axis < 3; ++axis) {
      l[axis] = avx2::gather_axis(skin.lbs, axis, r3);
      const __m256 k = avx2::gather_axis(skin.skelform, axis, r3);
      x[axis] = _mm256_blendv_ps(_mm256_add_ps(l[axis], _mm256_mul_ps(s, _mm256_sub_ps(k, l[axis]))), l[axis], keep);
      differs = _mm256_or_ps(differs, _mm256_cmp_ps(x[axis], l[axis], _CMP_NEQ_UQ));
    }
    const __m256 sum =
        _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_add_ps(l[0], l[1]), l[2]), x[0]), x[1]), x[2]);
    all_finite = _mm256_and_ps(all_finite, _mm256_cmp_ps(_mm256_sub_ps(sum, sum), zero, _CMP_EQ_OQ));
    const int bits = _mm256_movemask_ps(differs);
    avx2::store_vec3(x, out.positions + v);
    for (uint32_t j = 0; j < 8; ++j) out.moved[v + j] = uint8_t((bits >> j) & 1);
  }
  if (_mm256_movemask_ps(all_finite) != 0xff) finite = false;
  return v;
}

// seed_boxes_portable eight slots at a time from `first`, each lane's box as the SSE2 form
// takes it; returns where it stopped. The positions must take int32 gather offsets
// (gather_offsets_fit), and the moved flags three bytes after the last vertex's.
__attribute__((target("avx2"))) inline uint32_t seed_boxes_avx2(uint32_t first, uint32_t end,
                                                                const TriangleHierarchy& h, const SeedOutput& out) {
  const size_t stride = h.slot_stride(), planes_stride = out.boxes->stride;
  const uint32_t* corners = h.corners.data();
  float* planes = out.boxes->planes.data();
  uint32_t i = first;
  for (; i + 8 <= end; i += 8) {
    __m256 lo[3], hi[3];
    __m256i moved = _mm256_setzero_si256();
    for (size_t k = 0; k < 3; ++k) {
      const __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(corners + k * stride + i));
      const __m256i c3 = _mm256_add_epi32(c, _mm256_add_epi32(c, c));
      moved = _mm256_or_si256(moved, avx2::gather_bytes(out.moved, c));
      for (int axis = 0; axis < 3; ++axis) {
        const __m256 p = avx2::gather_axis(out.positions, axis, c3);
        lo[axis] = k == 0 ? p : _mm256_min_ps(p, lo[axis]);
        hi[axis] = k == 0 ? p : _mm256_max_ps(p, hi[axis]);
      }
    }
    for (size_t axis = 0; axis < 3; ++axis) {
      _mm256_storeu_ps(planes + axis * planes_stride + i, lo[axis]);
      _mm256_storeu_ps(planes + (3 + axis) * planes_stride + i, hi[axis]);
    }
    const int bits = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(moved, _mm256_setzero_si256())));
    for (uint32_t j = 0; j < 8; ++j) seed_listing(h, i + j, (bits >> j) & 1, out);
  }
  return i;
}
#endif

}  // namespace detail

// Every welded vertex's x and moved flag (all written); false when a sum is not finite.
// `dense_count`: the length of the arrays the representatives index.
inline bool seed_positions(uint32_t vertex_count, uint32_t dense_count, const SeedSkin& skin, const SeedOutput& out) {
  bool finite = true;
  uint32_t done = 0;
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (cpu_has_avx2() && gather_offsets_fit(dense_count))
    done = detail::seed_positions_avx2(vertex_count, skin, out, finite);
#else
  (void)dense_count;
#endif
  seed_positions_portable(done, vertex_count, skin, out, finite);
  return finite;
}

// Every slot's box and listing, from seed_positions' x and flags; `moved_size`: the flags'
// length (the AVX2 form, which reads three bytes past the last vertex's, needs
// vertex_count + 3).
inline void seed_boxes(uint32_t vertex_count, size_t moved_size, const TriangleHierarchy& h, const SeedOutput& out) {
  const uint32_t triangles = uint32_t(h.order.size());
  uint32_t done = 0;
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (cpu_has_avx2() && gather_offsets_fit(vertex_count) && moved_size >= size_t(vertex_count) + 3)
    done = detail::seed_boxes_avx2(0, triangles, h, out);
#else
  (void)vertex_count, (void)moved_size;
#endif
#if defined(__SSE2__)
  done = detail::seed_boxes_sse2(done, triangles, h, out);
#endif
  seed_boxes_portable(done, triangles, h, out);
}

}  // namespace skelform::runtime
