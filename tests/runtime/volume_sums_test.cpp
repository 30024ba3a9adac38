// The LBS guard's volume kernels (runtime/src/volume_sums.h) on a closed torus whose volume is
// known: the sums give its volume, scale by the cube of a uniform scaling, the cubic in μ is that
// scaling's and its v[0] is the sums' at_zero bit for bit; the points are the guard's blend.
#include "runtime/torus.h"
#include "volume_sums.h"

#include <doctest/doctest.h>
#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
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

}  // namespace

TEST_CASE("volume sums: the torus's volume, scaled by the cube of a uniform scaling") {
  const float R = 2.0f, r = 0.5f;
  const Torus torus(63, 31, R, r, glm::vec3(0.0f));
  std::vector<glm::dvec3> base, delta;
  std::vector<double> norm;
  for (const glm::vec3& p : torus.positions) {
    base.emplace_back(p);
    delta.push_back(0.25 * glm::dvec3(p));  // base + delta = 1.25 base
    const glm::dvec3 b = glm::abs(base.back()), c = glm::abs(delta.back());
    norm.push_back(b.x + b.y + b.z + c.x + c.y + c.z);
  }
  const VolumeSums sums =
      volume_sums(torus.triangles.data(), torus.triangle_count(), base.data(), delta.data(), norm.data());
  // The polygonal torus's volume approaches 2π²Rr² (inscribed: a little below).
  const double exact = 2.0 * kPi * kPi * double(R) * double(r) * double(r);
  CHECK(sums.at_zero / 6.0 < exact);
  CHECK(sums.at_zero / 6.0 > 0.99 * exact);
  CHECK(std::fabs(sums.at_one - 1.953125 * sums.at_zero) <= 1e-12 * sums.scale);  // 1.25³
  CHECK(sums.scale > std::fabs(sums.at_zero));

  // The cubic's v[0] sums the same determinants in the same order (volume_within's e₀ = 0).
  double v[4];
  volume_cubic_sums(torus.triangles.data(), torus.triangle_count(), base.data(), delta.data(), v);
  CHECK(v[0] == sums.at_zero);
}

TEST_CASE("volume points: base and delta are the guard's blend about the centre, norm their L1 sum") {
  // Off the origin and moved unevenly, as a posed character is.
  const Torus torus(43, 54, 1.5f, 0.4f, glm::vec3(3.0f, -40.0f, 7.5f));
  std::mt19937 random(7);
  std::normal_distribution<float> normal(0.0f, 0.05f);
  std::vector<glm::vec3> move;
  for (uint32_t w = 0; w < torus.vertex_count(); ++w) move.emplace_back(normal(random), normal(random), normal(random));
  Points points(torus, move, std::mt19937(11));
  const glm::dvec3 centre(3.1, -39.9, 7.4);
  volume_points(torus.vertex_count(), points.representative.data(), points.lbs.data(), points.skelform.data(),
                points.weight.data(), points.factor.data(), centre, points.base.data(), points.delta.data(),
                points.norm.data());
  for (uint32_t w = 0; w < torus.vertex_count(); ++w) {
    const uint32_t r = points.representative[w];
    const double s = double(points.weight[r]) * double(points.factor[w]);
    // x = L + s·(K − L), the guard's blend (here in double); base + delta is x about the centre.
    const glm::dvec3 x = glm::dvec3(points.lbs[r]) + s * (glm::dvec3(points.skelform[r]) - glm::dvec3(points.lbs[r]));
    CHECK(points.base[w] == glm::dvec3(points.lbs[r]) - centre);
    CHECK(glm::length(points.base[w] + points.delta[w] - (x - centre)) <= 1e-12);
    const glm::dvec3 b = glm::abs(points.base[w]), d = glm::abs(points.delta[w]);
    CHECK(points.norm[w] == b.x + b.y + b.z + d.x + d.y + d.z);
  }
}

TEST_CASE("volume cubic: a uniform scaling's cubic") {
  // base + μ·delta = (1 + μ/4)·base: the volume is V·(1 + μ/4)³, V·(1, 3/4, 3/16, 1/64).
  const Torus torus(63, 31, 2.0f, 0.5f, glm::vec3(0.0f));
  std::vector<glm::dvec3> base, delta;
  for (const glm::vec3& p : torus.positions) base.emplace_back(p), delta.push_back(0.25 * glm::dvec3(p));
  double v[4];
  volume_cubic_sums(torus.triangles.data(), torus.triangle_count(), base.data(), delta.data(), v);
  const double exact = 2.0 * kPi * kPi * 2.0 * 0.25;
  CHECK(v[0] / 6.0 < exact);
  CHECK(v[0] / 6.0 > 0.99 * exact);
  const double expected[4] = {1.0, 0.75, 0.1875, 0.015625};
  for (int i = 1; i < 4; ++i) CHECK(std::fabs(v[i] - expected[i] * v[0]) <= 1e-12 * v[0]);
}
