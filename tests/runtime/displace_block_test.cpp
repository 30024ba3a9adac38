// displace.cpp's work on a block of dense vertices (runtime/src/displace_block.h) in both of its
// compiled forms: the baseline's four lanes and, where the CPU has AVX2, eight. The interpolation
// gives the scalar loop's bits; the branch-free formula the same fast flags and the same bits on
// a block of random frames with degenerate lanes and a tail, and on the lanes the formula takes,
// a displaced point and unit vectors where the formula puts them (dss_frame.h's main branch,
// recomputed in double).
#include "displace_block.h"

#include "cpu.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

namespace {

using skelform::runtime::displace_detail::Block;
using skelform::runtime::displace_detail::evaluate_block;
using skelform::runtime::displace_detail::interpolate_block;
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

TEST_CASE("displacement block: the interpolation gives the scalar loop's bits") {
  // 200 refined vertices (padded by one, as instance.h pads them) and 64 bindings to random
  // triangles of them, barycentric coordinates inside and a little outside.
  std::mt19937 random(29);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::uniform_int_distribution<uint32_t> vertex(0, 199);
  std::uniform_real_distribution<float> coordinate(-0.1f, 0.7f);
  std::vector<glm::vec3> refined(201), refined_normal(201);
  for (uint32_t r = 0; r < 200; ++r) {
    refined[r] = glm::vec3(normal(random), normal(random), normal(random));
    refined_normal[r] = glm::vec3(normal(random), normal(random), normal(random));
  }
  std::vector<uint32_t> corners;
  std::vector<glm::vec2> barycentric;
  for (uint32_t i = 0; i < kBlock; ++i) {
    corners.insert(corners.end(), {vertex(random), vertex(random), vertex(random)});
    barycentric.emplace_back(coordinate(random), coordinate(random));
  }
  for (const uint32_t count : {kBlock, 61u, 5u}) {
    Block b{};
    interpolate_block(corners.data(), barycentric.data(), refined.data(), refined_normal.data(), count, b);
    bool same = true;
    for (uint32_t i = 0; i < count; ++i) {
      const uint32_t* c = corners.data() + 3 * size_t{i};
      const float b1 = barycentric[i].x, b2 = barycentric[i].y, b0 = 1.0f - b1 - b2;
      for (int k = 0; k < 3; ++k) {
        const float q = b0 * refined[c[0]][k] + b1 * refined[c[1]][k] + b2 * refined[c[2]][k];
        const float m = b0 * refined_normal[c[0]][k] + b1 * refined_normal[c[1]][k] + b2 * refined_normal[c[2]][k];
        const float e = refined[c[1]][k] - refined[c[0]][k];
        same = same && std::memcmp(&b.q[k][i], &q, sizeof q) == 0 && std::memcmp(&b.m[k][i], &m, sizeof m) == 0 &&
               std::memcmp(&b.e[k][i], &e, sizeof e) == 0;
      }
    }
    CHECK(same);
  }
}
