// The LBS guard's volume kernels (runtime/src/volume_sums.h) on a closed torus whose volume is
// known: the sums give its volume, scale by the cube of a uniform scaling, the cubic in μ is that
// scaling's, and the AVX2 forms agree with the portable loops (the points and the cubic bit for
// bit, the test's sums within the rounding bound the guard allows them).
#include "runtime/torus.h"
#include "cpu.h"
#include "volume_sums.h"

#include <doctest/doctest.h>
#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

namespace {

using namespace skelform::runtime;
using skelform::test::kPi;
using skelform::test::Torus;

// The guard's inputs for the torus as "L", K = L moved by `move` per vertex (ReversedSkin), and
// the volume test's per-vertex points.
struct Points : skelform::test::ReversedSkin {
  std::vector<glm::dvec3> base, delta;
  std::vector<double> norm;
  Points(const Torus& torus, const std::vector<glm::vec3>& move, std::mt19937&& random)
      : ReversedSkin(torus.vertex_count(),
                     [&](uint32_t w, glm::vec3& l, glm::vec3& k, float& weight, float& factor) {
                       l = torus.positions[w];
                       k = torus.positions[w] + move[w];
                       weight = std::uniform_real_distribution<float>(0.0f, 1.0f)(random);
                       factor = w % 5 == 0 ? 0.5f : 1.0f;
                     }),
        base(torus.vertex_count()),
        delta(torus.vertex_count()),
        norm(torus.vertex_count()) {}
};

[[maybe_unused]] bool same_bits(const void* a, const void* b, size_t bytes) { return std::memcmp(a, b, bytes) == 0; }

}  // namespace

TEST_CASE("volume sums: the torus's volume, scaled by the cube of a uniform scaling") {
  const float R = 2.0f, r = 0.5f;
  const Torus torus(63, 31, R, r, glm::vec3(0.0f));  // 3,906 triangles: a tail of 2 after the fours
  REQUIRE(torus.triangle_count() % 4 == 2);
  std::vector<glm::dvec3> base, delta;
  std::vector<double> norm;
  for (const glm::vec3& p : torus.positions) {
    base.emplace_back(p);
    delta.push_back(0.25 * glm::dvec3(p));  // base + delta = 1.25 base
    const glm::dvec3 b = glm::abs(base.back()), c = glm::abs(delta.back());
    norm.push_back(b.x + b.y + b.z + c.x + c.y + c.z);
  }
  const VolumeSums sums = volume_sums(torus.triangles.data(), torus.triangle_count(), torus.vertex_count(), base.data(),
                                      delta.data(), norm.data());
  // The polygonal torus's volume approaches 2π²Rr² (inscribed: a little below).
  const double exact = 2.0 * kPi * kPi * double(R) * double(r) * double(r);
  CHECK(sums.at_zero / 6.0 < exact);
  CHECK(sums.at_zero / 6.0 > 0.99 * exact);
  CHECK(std::fabs(sums.at_one - 1.953125 * sums.at_zero) <= 1e-12 * sums.scale);  // 1.25³
  CHECK(sums.scale > std::fabs(sums.at_zero));

  VolumeSums portable;
  volume_sums_portable(torus.triangles.data(), 0, torus.triangle_count(), base.data(), delta.data(), norm.data(),
                       portable);
  const double bound = 4.0 * (double(torus.triangle_count()) + 32.0) * std::ldexp(1.0, -52) * portable.scale;
  CHECK(std::fabs(sums.at_zero - portable.at_zero) <= bound);
  CHECK(std::fabs(sums.at_one - portable.at_one) <= bound);
  CHECK(std::fabs(sums.scale - portable.scale) <= 1e-12 * portable.scale);
}

TEST_CASE("volume sums: the AVX2 forms give the portable loops' points bit for bit and their sums to rounding") {
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (!cpu_has_avx2()) {
    MESSAGE("skipped: this CPU has no AVX2");
    return;
  }
  // Off the origin and moved unevenly, as a posed character is; 2,322 vertices: a tail of 2.
  const Torus torus(43, 54, 1.5f, 0.4f, glm::vec3(3.0f, -40.0f, 7.5f));
  REQUIRE(torus.vertex_count() % 4 == 2);
  std::mt19937 random(7);
  std::normal_distribution<float> normal(0.0f, 0.05f);
  std::vector<glm::vec3> move;
  for (uint32_t w = 0; w < torus.vertex_count(); ++w) move.emplace_back(normal(random), normal(random), normal(random));
  Points fast(torus, move, std::mt19937(11)), slow(torus, move, std::mt19937(11));
  const glm::dvec3 centre(3.1, -39.9, 7.4);
  for (double* norm : {fast.norm.data(), static_cast<double*>(nullptr)}) {
    const uint32_t done = detail::volume_points_avx2(torus.vertex_count(), fast.representative.data(), fast.lbs.data(),
                                                     fast.skelform.data(), fast.weight.data(), fast.factor.data(),
                                                     centre, fast.base.data(), fast.delta.data(), norm);
    CHECK(done == torus.vertex_count() - 2);
    volume_points_portable(done, torus.vertex_count(), fast.representative.data(), fast.lbs.data(),
                           fast.skelform.data(), fast.weight.data(), fast.factor.data(), centre, fast.base.data(),
                           fast.delta.data(), norm);
    volume_points_portable(0, torus.vertex_count(), slow.representative.data(), slow.lbs.data(), slow.skelform.data(),
                           slow.weight.data(), slow.factor.data(), centre, slow.base.data(), slow.delta.data(),
                           norm ? slow.norm.data() : nullptr);
    CHECK(same_bits(fast.base.data(), slow.base.data(), fast.base.size() * sizeof(glm::dvec3)));
    CHECK(same_bits(fast.delta.data(), slow.delta.data(), fast.delta.size() * sizeof(glm::dvec3)));
    CHECK(same_bits(fast.norm.data(), slow.norm.data(), fast.norm.size() * sizeof(double)));
  }
  VolumeSums lanes, portable;
  const uint32_t done = detail::volume_sums_avx2(torus.triangles.data(), torus.triangle_count(), fast.base.data(),
                                                 fast.delta.data(), fast.norm.data(), lanes);
  CHECK(done == torus.triangle_count());  // 4,644 triangles: fours only
  volume_sums_portable(torus.triangles.data(), 0, torus.triangle_count(), slow.base.data(), slow.delta.data(),
                       slow.norm.data(), portable);
  const double bound = 4.0 * (double(torus.triangle_count()) + 32.0) * std::ldexp(1.0, -52) * portable.scale;
  CHECK(lanes.at_zero != 0.0);
  CHECK(std::fabs(lanes.at_zero - portable.at_zero) <= bound);
  CHECK(std::fabs(lanes.at_one - portable.at_one) <= bound);
  CHECK(std::fabs(lanes.scale - portable.scale) <= 1e-12 * portable.scale);
  // Exactly: lane j sums the portable loop's terms of the triangles t ≡ j (mod 4) in order, and
  // the lanes add as (0 + 1) + (2 + 3).
  double sum[3][4] = {};
  for (uint32_t t = 0; t < torus.triangle_count(); ++t) {
    VolumeSums one;
    volume_sums_portable(torus.triangles.data(), t, t + 1, slow.base.data(), slow.delta.data(), slow.norm.data(), one);
    sum[0][t % 4] += one.at_zero, sum[1][t % 4] += one.at_one, sum[2][t % 4] += one.scale;
  }
  CHECK(lanes.at_zero == (sum[0][0] + sum[0][1]) + (sum[0][2] + sum[0][3]));
  CHECK(lanes.at_one == (sum[1][0] + sum[1][1]) + (sum[1][2] + sum[1][3]));
  CHECK(lanes.scale == (sum[2][0] + sum[2][1]) + (sum[2][2] + sum[2][3]));
#else
  MESSAGE("skipped: no AVX2 form on this target");
#endif
}

TEST_CASE("volume cubic: a uniform scaling's cubic, and the AVX2 form's bits are the portable loop's") {
  // base + μ·delta = (1 + μ/4)·base: the volume is V·(1 + μ/4)³, V·(1, 3/4, 3/16, 1/64).
  const Torus torus(63, 31, 2.0f, 0.5f, glm::vec3(0.0f));  // a tail of 2 after the fours
  std::vector<glm::dvec3> base, delta;
  for (const glm::vec3& p : torus.positions) base.emplace_back(p), delta.push_back(0.25 * glm::dvec3(p));
  double v[4];
  volume_cubic_sums(torus.triangles.data(), torus.triangle_count(), torus.vertex_count(), base.data(), delta.data(), v);
  const double exact = 2.0 * kPi * kPi * 2.0 * 0.25;
  CHECK(v[0] / 6.0 < exact);
  CHECK(v[0] / 6.0 > 0.99 * exact);
  const double expected[4] = {1.0, 0.75, 0.1875, 0.015625};
  for (int i = 1; i < 4; ++i) CHECK(std::fabs(v[i] - expected[i] * v[0]) <= 1e-12 * v[0]);

#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (!cpu_has_avx2()) {
    MESSAGE("skipped: this CPU has no AVX2");
    return;
  }
  // Posed: off the origin and moved unevenly (the points of the test above); the counts below
  // leave tails of 0, 2 and 3 after the fours.
  const Torus posed(43, 54, 1.5f, 0.4f, glm::vec3(3.0f, -40.0f, 7.5f));
  std::mt19937 random(5);
  std::normal_distribution<float> normal(0.0f, 0.05f);
  std::vector<glm::vec3> move;
  for (uint32_t w = 0; w < posed.vertex_count(); ++w) move.emplace_back(normal(random), normal(random), normal(random));
  Points points(posed, move, std::mt19937(3));
  volume_points_portable(0, posed.vertex_count(), points.representative.data(), points.lbs.data(),
                         points.skelform.data(), points.weight.data(), points.factor.data(),
                         glm::dvec3(3.1, -39.9, 7.4), points.base.data(), points.delta.data(), nullptr);
  for (const uint32_t count : {posed.triangle_count(), posed.triangle_count() - 2, 7u}) {
    double lanes[4] = {0.5, -1.0, 2.0, 0.25}, portable[4] = {0.5, -1.0, 2.0, 0.25};  // added to, in order
    const uint32_t done =
        detail::volume_cubic_avx2(posed.triangles.data(), count, points.base.data(), points.delta.data(), lanes);
    CHECK(done == count / 4 * 4);
    volume_cubic_portable(posed.triangles.data(), done, count, points.base.data(), points.delta.data(), lanes);
    volume_cubic_portable(posed.triangles.data(), 0, count, points.base.data(), points.delta.data(), portable);
    CHECK(lanes[0] != 0.5);
    CHECK(same_bits(lanes, portable, sizeof lanes));
  }
#else
  MESSAGE("skipped: no AVX2 form on this target");
#endif
}
