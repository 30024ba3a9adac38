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

void medial_normal_sums(const glm::vec3* positions, const glm::vec3* skeletal, size_t vertex_count, glm::vec3* sums) {
  size_t c = 0;
#if defined(__SSE2__)
  // Four vertices at a time, lanes = vertices: dss::medial_normal_sums's operations lane by
  // lane in its order (its reciprocals, products and square roots; its tests as a mask that
  // keeps A where the scalar code skips the vertex), so its bits; the scalar loop's three
  // square roots and three divisions per control vertex, one at a time, were its cost.
  using namespace lane4;
  const __m128 one = _mm_set1_ps(1.0f), tiny = _mm_set1_ps(1e-30f), largest = _mm_set1_ps(FLT_MAX);
  for (; c + 4 <= vertex_count; c += 4) {
    __m128 px = sse::load3(positions[c]), py = sse::load3(positions[c + 1]), pz = sse::load3(positions[c + 2]),
           pw = sse::load3(positions[c + 3]);
    __m128 sx = sse::load3(skeletal[c]), sy = sse::load3(skeletal[c + 1]), sz = sse::load3(skeletal[c + 2]),
           sw = sse::load3(skeletal[c + 3]);
    __m128 ax = sse::load3(sums[c]), ay = sse::load3(sums[c + 1]), az = sse::load3(sums[c + 2]),
           aw = sse::load3(sums[c + 3]);
    _MM_TRANSPOSE4_PS(px, py, pz, pw);
    _MM_TRANSPOSE4_PS(sx, sy, sz, sw);
    _MM_TRANSPOSE4_PS(ax, ay, az, aw);
    const __m128 mx = sub(px, sx), my = sub(py, sy), mz = sub(pz, sz);
    const __m128 medial_length = _mm_sqrt_ps(dot(mx, my, mz, mx, my, mz));
    const __m128 weight = _mm_sqrt_ps(dot(ax, ay, az, ax, ay, az));
    const __m128 inverse_weight = _mm_div_ps(one, weight), inverse_medial = _mm_div_ps(one, medial_length);
    const __m128 bx = add(mul(ax, inverse_weight), mul(mx, inverse_medial));
    const __m128 by = add(mul(ay, inverse_weight), mul(my, inverse_medial));
    const __m128 bz = add(mul(az, inverse_weight), mul(mz, inverse_medial));
    const __m128 bisector_length = _mm_sqrt_ps(dot(bx, by, bz, bx, by, bz));
    const __m128 scale = _mm_div_ps(weight, bisector_length);
    const __m128 keep =
        _mm_and_ps(_mm_and_ps(_mm_and_ps(_mm_cmpgt_ps(medial_length, tiny), _mm_cmpgt_ps(weight, tiny)),
                              _mm_and_ps(_mm_cmple_ps(medial_length, largest), _mm_cmple_ps(weight, largest))),
                   _mm_cmpgt_ps(bisector_length, tiny));
    __m128 rx = select(keep, mul(bx, scale), ax), ry = select(keep, mul(by, scale), ay),
           rz = select(keep, mul(bz, scale), az), rw = _mm_setzero_ps();
    _MM_TRANSPOSE4_PS(rx, ry, rz, rw);
    sse::store3(sums[c], rx);
    sse::store3(sums[c + 1], ry);
    sse::store3(sums[c + 2], rz);
    sse::store3(sums[c + 3], rw);
  }
#endif
  dss::medial_normal_sums(positions + c, skeletal + c, vertex_count - c, sums + c);
}

}  // namespace skelform::runtime
