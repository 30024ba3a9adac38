// fair_stage's record of the local shapes (runtime/src/fair_shapes.h): the AVX2 form,
// where this CPU and build have it, and the dispatching one give the portable loop's bits and
// the same pose-jump count, on random frames and vectors with vertices without a one-ring,
// shapes that change by more and by less than the jump, mean edges under 1e-30 and a NaN.
#include "fair_shapes.h"

#include <doctest/doctest.h>
#include <glm/gtc/quaternion.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

using namespace skelform::runtime;

namespace {

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

struct Scene {
  explicit Scene(uint32_t n) : count(n) {
    REQUIRE(n > 13);
    std::mt19937 random(20261129 + n);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), edge(0.01f, 0.2f);
    offsets.push_back(0);
    for (uint32_t v = 0; v < n; ++v) {
      // Every fifth vertex, the one at 13 and the block of eight at 48 have no one-ring.
      const bool ringless = v % 5 == 2 || v == 13 || (v >= 48 && v < 56);
      offsets.push_back(offsets.back() + (ringless ? 0u : 3u + v % 4));
      const glm::quat q = glm::normalize(glm::quat(unit(random), unit(random), unit(random), unit(random) + 2.0f));
      frames.push_back(glm::mat3_cast(q));
      const glm::vec3 u(unit(random), unit(random), unit(random));
      umbrella.push_back(0.05f * u);
      mean_edge.push_back(edge(random));
      rest_umbrella.push_back(0.05f * u + 0.01f * glm::vec3(unit(random), unit(random), unit(random)));
      // Half the old shapes near this evaluation's, half far from it.
      shape.push_back(v % 2 ? glm::vec3(unit(random), unit(random), unit(random))
                            : glm::transpose(frames.back()) * umbrella.back() / mean_edge.back());
      rest_change.push_back(-3.0f);
    }
    mean_edge[6] = 1e-31f;  // below the floor
    mean_edge[8] = 0.0f;
    umbrella[9].y = std::numeric_limits<float>::quiet_NaN();
    mean_edge[11] = std::numeric_limits<float>::quiet_NaN();  // std::max keeps it
  }
  ShapeRecord record() {
    return {offsets.data(),       frames.data(), umbrella.data(),   mean_edge.data(),
            rest_umbrella.data(), shape.data(),  rest_change.data()};
  }
  uint32_t count;
  std::vector<uint32_t> offsets;
  std::vector<glm::mat3> frames;
  std::vector<glm::vec3> umbrella, rest_umbrella, shape;
  std::vector<float> mean_edge, rest_change;
};

}  // namespace

TEST_CASE("fair shapes: every form of the shape record gives the portable loop's bits and count") {
  const bool avx2 = cpu_has_avx2();
  const std::string form = avx2 ? "compared" : "not on this CPU/build: the chosen form is the portable one";
  MESSAGE("AVX2 form " << form);
  for (const uint32_t n : {16u, 21u, 67u}) {
    CAPTURE(n);
    Scene portable(n);
    const uint32_t want = record_shapes_portable(portable.record(), 0, n, 0.25f);
    // Both kinds of vertex, and the NaN counted.
    CHECK(want > 1);
    CHECK(want < n);
    CHECK(std::isnan(portable.rest_change[9]));
    CHECK(std::isnan(portable.rest_change[11]));
    CHECK(portable.rest_change[2] == -3.0f);  // no one-ring: untouched

    Scene chosen(n);
    CHECK(record_shapes(chosen.record(), n, 0.25f) == want);
    CHECK(same_bits(chosen.shape, portable.shape));
    CHECK(same_bits(chosen.rest_change, portable.rest_change));
#if defined(SKELFORM_HAS_AVX2_KERNELS)
    if (avx2) {
      Scene lanes(n);
      uint32_t changed = 0;
      const uint32_t done = detail::record_shapes_avx2(lanes.record(), n, 0.25f, changed);
      CHECK(done == n - n % 8);
      CHECK(changed + record_shapes_portable(lanes.record(), done, n, 0.25f) == want);
      CHECK(same_bits(lanes.shape, portable.shape));
      CHECK(same_bits(lanes.rest_change, portable.rest_change));
    }
#endif
  }
}
