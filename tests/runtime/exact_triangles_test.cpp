// The LBS guard's triangle test (runtime/src/exact_triangles.h): its AVX form against
// geometry::triangles_intersect, the metric's definition, on random, lattice, near-coplanar,
// overflowing, underflowing, mixed-scale and non-finite triangles: the same verdict on every
// input.
#include "exact_triangles.h"

#include "skelform/core/triangle_intersection.h"

#include <doctest/doctest.h>
#include <glm/vec3.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

using skelform::runtime::exact_triangle_test;
using skelform::runtime::ExactTriangleTest;

TEST_CASE("exact_triangle_test: every form gives geometry::triangles_intersect's verdict") {
  const ExactTriangleTest reference = &skelform::geometry::triangles_intersect;
  std::array<ExactTriangleTest, 2> forms = {exact_triangle_test(), nullptr};
#if defined(SKELFORM_EXACT_TRIANGLES_AVX)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx"))
    forms[1] = &skelform::runtime::detail::triangles_intersect_avx;
  else
    MESSAGE("this CPU has no AVX: only the dispatch is compared");
#endif
  std::mt19937 random(20261128);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::uniform_int_distribution<int> small(-2, 2);
  std::uniform_int_distribution<int> pick(0, 17), exponent(-70, 70), how_many(1, 3);
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  uint32_t met = 0, apart = 0;
  for (int kind = 0; kind < 7; ++kind)
    for (int i = 0; i < 40000; ++i) {
      std::array<glm::dvec3, 6> c;  // the guard's input: float positions widened
      for (glm::dvec3& v : c) {
        switch (kind) {
          case 0:  // uniform in a box
            v = glm::dvec3(glm::vec3(unit(random), unit(random), unit(random)));
            break;
          case 1:  // a small integer lattice: coplanar pairs, shared corners and edges, ties
            v = glm::dvec3(small(random), small(random), small(random));
            break;
          case 2:  // nearly coplanar: the face normals' verdicts are rounding
            v = glm::dvec3(glm::vec3(unit(random), unit(random), 1e-7f * unit(random)));
            break;
          case 3:  // huge: the products overflow to infinity and the differences to NaN
            v = 1e155 * glm::dvec3(glm::vec3(unit(random), unit(random), unit(random)));
            break;
          case 4:  // tiny: the products underflow
            v = 1e-160 * glm::dvec3(glm::vec3(unit(random), unit(random), unit(random)));
            break;
          case 5:  // on the lattice, with non-finite coordinates
            v = glm::dvec3(small(random), small(random), small(random));
            break;
          default:  // every coordinate at its own scale (floats, as the guard's)
            v = glm::dvec3(glm::vec3(std::ldexp(unit(random), exponent(random)),
                                     std::ldexp(unit(random), exponent(random)),
                                     std::ldexp(unit(random), exponent(random))));
            break;
        }
      }
      if (kind == 5)
        for (int k = how_many(random); k > 0; --k) {
          const int slot = pick(random);
          c[size_t(slot / 3)][slot % 3] = slot % 2 ? inf : (slot % 3 ? -inf : nan);
        }
      const bool expected = reference(c[0], c[1], c[2], c[3], c[4], c[5]);
      for (ExactTriangleTest form : forms) {
        if (!form) continue;
        if (form(c[0], c[1], c[2], c[3], c[4], c[5]) != expected) {
          FAIL_CHECK("kind " << kind << " case " << i << ": a form says " << !expected);
          return;
        }
      }
      (expected ? met : apart) += 1;
    }
  // Both verdicts are well represented, so agreement is not one constant answer.
  CHECK(met > 20000u);
  CHECK(apart > 20000u);
  MESSAGE("exact_triangle_test: " << met << " meeting and " << apart << " apart, the same verdict in every form");
}

TEST_CASE("triangles_surely_apart: only where geometry::triangles_intersect says apart") {
  // The guard's float pre-test (exact_triangles.h) may only say "apart" where the exact test
  // does, in every form this build has, on the guard's inputs (floats): random, lattice,
  // near-coplanar and nearly touching pairs, overflowing, underflowing, mixed-scale and
  // non-finite ones. And it must decide most of the pairs a plane separates by a margin, or it
  // saves nothing.
  using skelform::runtime::triangles_surely_apart;
  using skelform::runtime::detail::triangles_surely_apart_portable;
  std::mt19937 random(20261129);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::uniform_int_distribution<int> small(-2, 2);
  std::uniform_int_distribution<int> pick(0, 17), exponent(-70, 70);
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  uint32_t sure = 0, exact_apart = 0, lifted_sure = 0, lifted = 0;
  for (int kind = 0; kind < 11; ++kind)
    for (int i = 0; i < 40000; ++i) {
      std::array<glm::vec3, 6> c;
      for (size_t k = 0; k < 6; ++k) {
        glm::vec3& v = c[k];
        switch (kind) {
          case 0:  // uniform in a box
            v = glm::vec3(unit(random), unit(random), unit(random));
            break;
          case 1:  // a small integer lattice: coplanar pairs, shared corners and edges, ties
            v = glm::vec3(float(small(random)), float(small(random)), float(small(random)));
            break;
          case 2:  // nearly coplanar: the planes' sides are rounding
            v = glm::vec3(unit(random), unit(random), 1e-7f * unit(random));
            break;
          case 3:  // huge: the products overflow
            v = 1e19f * glm::vec3(unit(random), unit(random), unit(random));
            break;
          case 4:  // tiny: the products underflow
            v = 1e-20f * glm::vec3(unit(random), unit(random), unit(random));
            break;
          case 5:  // on the lattice, with a non-finite coordinate
            v = glm::vec3(float(small(random)), float(small(random)), float(small(random)));
            break;
          case 6:  // every coordinate at its own scale
            v = glm::vec3(std::ldexp(unit(random), exponent(random)), std::ldexp(unit(random), exponent(random)),
                          std::ldexp(unit(random), exponent(random)));
            break;
          case 7:  // a flat triangle and one lifted off its plane by 1/4 to 1/64 of their extent
            v = k < 3 ? glm::vec3(unit(random), unit(random), 0.0f)
                      : glm::vec3(unit(random), unit(random), std::ldexp(1.0f, -(i % 5) - 2));
            break;
          case 8:  // large, R³ from FLT_MAX / 64 to past FLT_MAX: the pre-test's upper bound
            v = std::ldexp(1.0f, 40 + i % 4) * glm::vec3(unit(random), unit(random), unit(random));
            break;
          case 9:  // small, R³ about 1e-30 to 1e-24: its lower bound
            v = 1e-9f * std::ldexp(1.0f, -(i % 4)) * glm::vec3(unit(random), unit(random), unit(random));
            break;
          default:  // nearly coplanar at the margin: lifted by 1e-4 of the extent cubed, ± 20 %
            v = k < 3 ? glm::vec3(unit(random), unit(random), 0.0f)
                      : glm::vec3(unit(random), unit(random), 8e-4f * (1.0f + 0.2f * unit(random)));
            break;
        }
      }
      if (kind == 5) {
        const int slot = pick(random);
        c[size_t(slot / 3)][slot % 3] = slot % 2 ? inf : (slot % 3 ? -inf : nan);
      }
      const bool meet = skelform::geometry::triangles_intersect(glm::dvec3(c[0]), glm::dvec3(c[1]), glm::dvec3(c[2]),
                                                                glm::dvec3(c[3]), glm::dvec3(c[4]), glm::dvec3(c[5]));
      const bool fast = triangles_surely_apart(c[0], c[1], c[2], c[3], c[4], c[5]);
      const bool portable = triangles_surely_apart_portable(c[0], c[1], c[2], c[3], c[4], c[5]);
      if ((fast && meet) || (portable && meet)) {
        FAIL_CHECK("kind " << kind << " case " << i << ": surely apart (" << fast << " / " << portable
                           << ") where the exact test says they meet");
        return;
      }
      exact_apart += meet ? 0 : 1;
      sure += fast ? 1 : 0;
      if (kind == 7) {
        lifted += meet ? 0 : 1;
        lifted_sure += fast ? 1 : 0;
      }
    }
  // Its range: a triangle over another, half their size above it, is decided at every scale
  // where R³ lies within [kSureScaleMin, kSureScaleMax] (where no sum overflows and no product's
  // underflow matters), and left to the exact test beyond (R³ near FLT_MAX: a sum could round
  // to infinity whatever its sign).
  for (const float size : {1e-11f, 1e-9f, 1.0f, 1e12f, 6e12f}) {
    const glm::vec3 p0(0.0f), p1(size, 0.0f, 0.0f), p2(0.0f, size, 0.0f);
    const glm::vec3 lift(0.0f, 0.0f, 0.5f * size);
    const float cube = size * size * size;  // R³: the pair's largest extent is `size`
    const bool in_range = cube >= skelform::runtime::kSureScaleMin && cube <= skelform::runtime::kSureScaleMax;
    INFO("size " << size);
    CHECK(in_range == (size >= 1e-9f && size <= 1e12f));
    CHECK(triangles_surely_apart(p0, p1, p2, p0 + lift, p1 + lift, p2 + lift) == in_range);
    CHECK(triangles_surely_apart_portable(p0, p1, p2, p0 + lift, p1 + lift, p2 + lift) == in_range);
  }
  // Lifted by far more than the margin (kSureMargin of the pair's extent cubed), it decides
  // (not where a triangle is thin: its normal, and d with it, is then short).
  CHECK(lifted_sure > lifted / 2);
  CHECK(sure > exact_apart / 8);
  MESSAGE("triangles_surely_apart: " << sure << " decided of " << exact_apart << " apart");
}
