// displace.cpp's per-vertex work in blocks: the structure-of-arrays scratch of one block of
// dense vertices, and (for tests) its interpolation and its branch-free formula in each form.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>

namespace skelform::runtime::displace_detail {

constexpr uint32_t kBlock = 64;  // dense vertices per block: ~11 KB of stack scratch

// Structure-of-arrays scratch of one block. [k][i]: component k of vertex i of the block.
struct Block {
  float q[3][kBlock];  // the bound point b0 p0 + b1 p1 + b2 p2 of the refined triangle
  float m[3][kBlock];  // the interpolated normal b0 n0 + b1 n1 + b2 n2, unnormalised
  float e[3][kBlock];  // the edge p1 - p0
  float h[kBlock], rt[kBlock], rb[kBlock];
  float cn[3][kBlock], ct[3][kBlock];  // rest normal / tangent in rest-frame coordinates
  float position[3][kBlock], normal[3][kBlock], tangent[3][kBlock];
  int32_t fast[kBlock];  // 1: the main branch holds, the outputs above are the vertex's
};

// The first stage of a block, over its first `count` vertices: each vertex's bound point q,
// interpolated normal m and edge e from the corners of its refined triangle (`corners`, 3 per
// vertex; the refined buffers padded as instance.h pads them) and its barycentric coordinates
// (b1, b2). Four vertices at a time at x86-64's baseline, with the scalar loop's bits.
void interpolate_block(const uint32_t* corners, const glm::vec2* barycentric, const glm::vec3* refined,
                       const glm::vec3* refined_normal, uint32_t count, Block& b);

// The formula over the block's first `count` vertices, with normals and tangents, as displace.cpp
// compiles it: four lanes wide (x86-64's baseline), or with `avx2` eight where the build has
// AVX2 kernels and the CPU runs them (else four). Both give the same bits.
void evaluate_block(bool avx2, uint32_t count, Block& b);

}  // namespace skelform::runtime::displace_detail
