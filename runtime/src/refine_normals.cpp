// Area-weighted vertex normals (refine.h), every frame: dss_frame.h's arithmetic (the
// baker's), rearranged for speed only. Each triangle still adds (p1 - p0) × (p2 - p0) to its
// corners in triangle order (add_face_normals: the control mesh's normal sums that
// refine_surface refines, and the dense face normals of displace.cpp), then each sum is
// divided by its length (zero at length ≤ 1e-30). The normalisation (normalise_vectors) runs
// in blocks of structure-of-arrays scratch so the compiler vectorises its square roots and
// divisions (correctly rounded in
// every lane: the same bits as the scalar loop; tests/runtime/asset_test.cpp checks). Compiled
// with -fno-math-errno where the compiler understands it (runtime/CMakeLists.txt), like
// displace.cpp, without which GCC keeps sqrt scalar.
#include "refine.h"
#include "vec3_sse.h"

#include <cfloat>
#include <cstring>

namespace skelform::runtime {

namespace {

constexpr size_t kBlock = 64;  // vertices per normalisation block: 768 bytes of stack

// `value` where `mask` is all ones, +0 where it is zero.
inline float masked(float value, uint32_t mask) {
  uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  bits &= mask;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

}  // namespace

void normalise_vectors(glm::vec3* vectors, size_t count, uint8_t* usable) {
  float x[kBlock], y[kBlock], z[kBlock];
  uint32_t finite_length[kBlock];
  for (size_t start = 0; start < count; start += kBlock) {
    const size_t block = count - start < kBlock ? count - start : kBlock;
    glm::vec3* n = vectors + start;
    for (size_t i = 0; i < block; ++i) {
      x[i] = n[i].x;
      y[i] = n[i].y;
      z[i] = n[i].z;
    }
    for (size_t i = 0; i < block; ++i) {
      // glm::dot's order: (x x + y y) + z z.
      const float length = std::sqrt(x[i] * x[i] + y[i] * y[i] + z[i] * z[i]);
      // Branch-free (a branch, or a select on a float comparison, keeps GCC from
      // vectorising): divide in every lane, then clear the bits of the lanes whose length is
      // not usable, leaving +0 as the scalar loop's zero vector.
      const uint32_t keep = 0u - static_cast<uint32_t>(length > 1e-30f);
      finite_length[i] = static_cast<uint32_t>(length <= FLT_MAX) & keep;
      x[i] = masked(x[i] / length, keep);
      y[i] = masked(y[i] / length, keep);
      z[i] = masked(z[i] / length, keep);
    }
    for (size_t i = 0; i < block; ++i) n[i] = glm::vec3(x[i], y[i], z[i]);
    if (usable)
      for (size_t i = 0; i < block; ++i) usable[start + i] = static_cast<uint8_t>(finite_length[i]);
  }
}

void add_face_normals(const glm::vec3* positions, size_t vertex_count, const uint32_t* indices, size_t triangle_count,
                      glm::vec3* sums) {
#if defined(__SSE2__)
  // One triangle's vectors in the low three lanes of an __m128 (vec3_sse.h): glm::cross(e1, e2)
  // as (e1 · e2.yzx − e1.yzx · e2).yzx, whose lanes are glm's x, y, z products and differences
  // in glm's order; each corner's sum loaded, added to and stored as 12 bytes.
  const sse::Vec3Reader read(positions, vertex_count);
  for (size_t t = 0; t < triangle_count; ++t) {
    const uint32_t i0 = indices[3 * t], i1 = indices[3 * t + 1], i2 = indices[3 * t + 2];
    const __m128 p0 = read(i0);
    const __m128 e1 = _mm_sub_ps(read(i1), p0), e2 = _mm_sub_ps(read(i2), p0);
    const __m128 e1_yzx = _mm_shuffle_ps(e1, e1, _MM_SHUFFLE(3, 0, 2, 1));
    const __m128 e2_yzx = _mm_shuffle_ps(e2, e2, _MM_SHUFFLE(3, 0, 2, 1));
    const __m128 zxy = _mm_sub_ps(_mm_mul_ps(e1, e2_yzx), _mm_mul_ps(e1_yzx, e2));
    const __m128 face = _mm_shuffle_ps(zxy, zxy, _MM_SHUFFLE(3, 0, 2, 1));
    sse::store3(sums[i0], _mm_add_ps(sse::load3(sums[i0]), face));
    sse::store3(sums[i1], _mm_add_ps(sse::load3(sums[i1]), face));
    sse::store3(sums[i2], _mm_add_ps(sse::load3(sums[i2]), face));
  }
#else
  static_cast<void>(vertex_count);
  dss::add_face_normals(positions, indices, triangle_count, sums);
#endif
}

}  // namespace skelform::runtime
