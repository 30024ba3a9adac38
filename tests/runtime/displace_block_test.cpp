// displace.cpp's branch-free formula for a block of dense vertices (runtime/src/displace_block.h)
// in both compiled forms: the baseline's four lanes and, where the CPU has AVX2, eight. The same
// fast flags and the same bits on a block of random frames with degenerate lanes and a tail,
// and on the lanes the formula takes, a displaced point and unit vectors where the formula
// puts them (dss_frame.h's main branch, recomputed in double).
#include "displace_block.h"

#include "cpu.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstring>
#include <random>

namespace {

using skelform::runtime::displace_detail::Block;
using skelform::runtime::displace_detail::evaluate_block;
using skelform::runtime::displace_detail::kBlock;

// 61 random lanes (a tail after the groups of eight and four); lane 5's interpolated normal is 0
// and lane 9's edge lies along its normal: the formula's guards fail there (fast 0).
Block random_block(uint32_t count) {
  Block b{};
  std::mt19937 random(23);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  for (uint32_t i = 0; i < count; ++i) {
    for (int k = 0; k < 3; ++k) {
      b.q[k][i] = normal(random);
      b.m[k][i] = normal(random);
      b.e[k][i] = 0.1f * normal(random);
    }
    b.h[i] = 0.05f * normal(random), b.rt[i] = 0.01f * normal(random), b.rb[i] = 0.01f * normal(random);
    const glm::vec3 cn = glm::normalize(glm::vec3(normal(random), normal(random), normal(random)));
    const glm::vec3 ct = glm::normalize(glm::cross(cn, glm::vec3(normal(random), normal(random), normal(random))));
    for (int k = 0; k < 3; ++k) b.cn[k][i] = cn[k], b.ct[k][i] = ct[k];
  }
  for (int k = 0; k < 3; ++k) {
    b.m[k][5] = 0.0f;
    b.e[k][9] = 2.0f * b.m[k][9];
  }
  return b;
}

glm::vec3 row(const float (&rows)[3][kBlock], uint32_t i) { return {rows[0][i], rows[1][i], rows[2][i]}; }

}  // namespace

TEST_CASE("displacement block: both compiled forms give the same flags and bits, and the formula's frame") {
  constexpr uint32_t count = 61;
  const Block input = random_block(count);
  Block baseline = input, wide = input;
  evaluate_block(false, count, baseline);
  evaluate_block(true, count, wide);
  if (!skelform::runtime::cpu_has_avx2()) MESSAGE("no AVX2 on this CPU: both runs take the baseline form");
  CHECK(baseline.fast[5] == 0);
  CHECK(baseline.fast[9] == 0);
  uint32_t fast = 0;
  for (uint32_t i = 0; i < count; ++i) {
    INFO("lane " << i);
    CHECK(wide.fast[i] == baseline.fast[i]);
    if (!baseline.fast[i]) continue;  // the caller recomputes these lanes
    ++fast;
    for (int k = 0; k < 3; ++k) {
      CHECK(std::memcmp(&wide.position[k][i], &baseline.position[k][i], sizeof(float)) == 0);
      CHECK(std::memcmp(&wide.normal[k][i], &baseline.normal[k][i], sizeof(float)) == 0);
      CHECK(std::memcmp(&wide.tangent[k][i], &baseline.tangent[k][i], sizeof(float)) == 0);
    }
    // dss_frame.h's main branch in double: n the unit interpolated normal, t the unit part of
    // the edge in its tangent plane, s = n × t; the point q + h n + rt t + rb s.
    const glm::dvec3 n = glm::normalize(glm::dvec3(row(input.m, i)));
    const glm::dvec3 e(row(input.e, i));
    const glm::dvec3 t = glm::normalize(e - glm::dot(e, n) * n), s = glm::cross(n, t);
    const glm::dvec3 point =
        glm::dvec3(row(input.q, i)) + double(input.h[i]) * n + double(input.rt[i]) * t + double(input.rb[i]) * s;
    CHECK(glm::length(glm::dvec3(row(baseline.position, i)) - point) < 1e-5);
    const glm::dvec3 cn(row(input.cn, i));
    CHECK(glm::length(glm::dvec3(row(baseline.normal, i)) - (cn.x * t + cn.y * s + cn.z * n)) < 1e-5);
    CHECK(std::fabs(glm::length(row(baseline.tangent, i)) - 1.0f) < 1e-5f);
  }
  CHECK(fast == count - 2);
}
