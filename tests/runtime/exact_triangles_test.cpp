// The LBS guard's triangle test (runtime/src/exact_triangles.h): its AVX form against
// geometry::triangles_intersect, the metric's definition, on random, lattice, near-coplanar,
// overflowing, underflowing, mixed-scale and non-finite triangles: the same verdict on every
// input.
#include "exact_triangles.h"

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
