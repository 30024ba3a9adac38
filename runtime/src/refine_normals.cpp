// The refined mesh's vertex normals (refine.h), every frame: dss::refined_vertex_normals's
// arithmetic (the baker's), rearranged for speed only. Each triangle still adds
// (p1 - p0) × (p2 - p0) to its corners in triangle order, then each sum is divided by its
// length (zero at length ≤ 1e-30). The normalisation (normalise_vectors, which displace.cpp's
// dense face normals share) runs in blocks of structure-of-arrays scratch so the compiler
// vectorises its square roots and divisions (correctly rounded in
// every lane: the same bits as the scalar loop; tests/runtime/asset_test.cpp checks). Compiled
// with -fno-math-errno where the compiler understands it (runtime/CMakeLists.txt), like
// displace.cpp, without which GCC keeps sqrt scalar.
#include "refine.h"

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

void refined_normals(const Deformable& deformable, const glm::vec3* refined, glm::vec3* normals) {
  const size_t vertex_count = deformable.refined_vertex_count;
  for (size_t v = 0; v < vertex_count; ++v) normals[v] = glm::vec3(0.0f);
  dss::add_face_normals(refined, deformable.refined_indices.data(), deformable.refined_indices.size() / 3, normals);
  normalise_vectors(normals, vertex_count);
}

}  // namespace skelform::runtime
