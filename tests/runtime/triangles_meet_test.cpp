// The contact pass's triangle test (runtime/src/triangles_meet.h): the verdicts of known
// configurations, and the SSE2 form against the portable one on random, degenerate,
// mixed-scale and non-finite triangles: the same verdict on every input.
#include "triangles_meet.h"

#include <doctest/doctest.h>
#include <glm/vec3.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

using skelform::runtime::triangles_meet;
using skelform::runtime::detail::triangles_meet_portable;

namespace {

using Triangle = std::array<glm::vec3, 3>;

bool meet_portable(const Triangle& p, const Triangle& q) {
  return triangles_meet_portable(p[0], p[1], p[2], q[0], q[1], q[2]);
}

// Every form this build has, and the dispatching one, agree; returns their verdict.
bool meet_all(const Triangle& p, const Triangle& q) {
  const bool portable = meet_portable(p, q);
#if defined(SKELFORM_TRIANGLES_MEET_SSE2)
  CHECK(skelform::runtime::detail::triangles_meet_sse2(p[0], p[1], p[2], q[0], q[1], q[2]) == portable);
#endif
  CHECK(triangles_meet(p[0], p[1], p[2], q[0], q[1], q[2]) == portable);
  return portable;
}

}  // namespace

TEST_CASE("triangles_meet: known configurations") {
  const Triangle flat = {glm::vec3(0, 0, 0), glm::vec3(2, 0, 0), glm::vec3(0, 2, 0)};
  // A triangle through flat's interior, standing on z.
  CHECK(meet_all(flat, {glm::vec3(0.5f, 0.5f, -1), glm::vec3(0.5f, 0.5f, 1), glm::vec3(1.5f, -1, 0.5f)}));
  // The same, lifted above flat's plane: the early out.
  CHECK_FALSE(meet_all(flat, {glm::vec3(0.5f, 0.5f, 1), glm::vec3(0.5f, 0.5f, 3), glm::vec3(1.5f, -1, 2)}));
  // Touching at a corner counts.
  CHECK(meet_all(flat, {glm::vec3(2, 0, 0), glm::vec3(3, 0, 1), glm::vec3(3, 1, -1)}));
  // Coplanar: overlapping, and apart (only an in-plane edge normal separates these).
  CHECK(meet_all(flat, {glm::vec3(0.5f, 0.5f, 0), glm::vec3(3, 0.5f, 0), glm::vec3(0.5f, 3, 0)}));
  CHECK_FALSE(meet_all(flat, {glm::vec3(1.5f, 1.5f, 0), glm::vec3(3, 1.5f, 0), glm::vec3(1.5f, 3, 0)}));
  // Crosswise through each other's planes but past flat's hypotenuse: both planes cut both
  // triangles, so only an edge × edge axis (or an in-plane normal) tells them apart.
  CHECK_FALSE(meet_all(flat, {glm::vec3(1.6f, 1.6f, -1), glm::vec3(1.6f, 1.6f, 1), glm::vec3(3, 3, 0)}));
  CHECK(meet_all(flat, {glm::vec3(0.9f, 0.9f, -1), glm::vec3(0.9f, 0.9f, 1), glm::vec3(3, 3, 0)}));
  // A degenerate (zero-area) triangle: its normal splits nothing; a segment through flat meets it.
  CHECK(meet_all(flat, {glm::vec3(0.5f, 0.5f, -1), glm::vec3(0.5f, 0.5f, 1), glm::vec3(0.5f, 0.5f, 1)}));
  CHECK_FALSE(meet_all(flat, {glm::vec3(2, 2, -1), glm::vec3(2, 2, 1), glm::vec3(2, 2, 1)}));
}

TEST_CASE("triangles_meet: the SSE2 form gives the portable verdict on every input") {
  std::mt19937 random(20261128);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::uniform_int_distribution<int> small(-2, 2);
  std::uniform_int_distribution<int> pick(0, 17), exponent(-70, 70), how_many(1, 3);
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  uint32_t met = 0, apart = 0, cases = 0;
  for (int kind = 0; kind < 7; ++kind)
    for (int i = 0; i < 40000; ++i) {
      Triangle p, q;
      for (glm::vec3* v : {&p[0], &p[1], &p[2], &q[0], &q[1], &q[2]}) {
        switch (kind) {
          case 0:  // uniform in a box: both verdicts, mostly by the early outs
            *v = glm::vec3(unit(random), unit(random), unit(random));
            break;
          case 1:  // a small integer lattice: coplanar pairs, shared corners and edges, ties
            *v = glm::vec3(float(small(random)), float(small(random)), float(small(random)));
            break;
          case 2:  // nearly coplanar: the plane tests' signs are rounding
            *v = glm::vec3(unit(random), unit(random), 1e-7f * unit(random));
            break;
          case 3:  // huge: the products overflow to infinity and the differences to NaN
            *v = 1e19f * glm::vec3(unit(random), unit(random), unit(random));
            break;
          case 4:  // tiny: the products underflow
            *v = 1e-20f * glm::vec3(unit(random), unit(random), unit(random));
            break;
          case 5:  // on the lattice, with non-finite coordinates
            *v = glm::vec3(float(small(random)), float(small(random)), float(small(random)));
            break;
          default:  // every coordinate at its own scale
            *v = glm::vec3(std::ldexp(unit(random), exponent(random)), std::ldexp(unit(random), exponent(random)),
                           std::ldexp(unit(random), exponent(random)));
            break;
        }
      }
      if (kind == 5)
        for (int k = how_many(random); k > 0; --k) {
          const int slot = pick(random);
          float& c = (slot < 9 ? p[size_t(slot / 3)] : q[size_t(slot / 3 - 3)])[slot % 3];
          c = slot % 2 ? inf : (slot % 3 ? -inf : nan);
        }
      const bool portable = meet_portable(p, q);
#if defined(SKELFORM_TRIANGLES_MEET_SSE2)
      const bool sse2 = skelform::runtime::detail::triangles_meet_sse2(p[0], p[1], p[2], q[0], q[1], q[2]);
      if (sse2 != portable) {
        FAIL_CHECK("kind " << kind << " case " << i << ": SSE2 " << sse2 << ", portable " << portable);
        return;
      }
#endif
      ++cases;
      (portable ? met : apart) += 1;
    }
  CHECK(cases == 280000u);
  // Both verdicts are well represented, so agreement is not one constant answer.
  CHECK(met > 20000u);
  CHECK(apart > 20000u);
  MESSAGE("triangles_meet: " << met << " meeting and " << apart << " apart, the same verdict in both forms");
}
