// The LBS guard's first-round seed (runtime/src/guard_seed.h) on a torus moved unevenly: the
// positions are the blend of L and K, a vertex is moved exactly where they differ, every box
// holds its triangle, the triangles with a moved corner are listed and no other; and every
// form (portable, SSE2, AVX2, the chosen one) gives the portable loops' bits, flags and list,
// with tails after the last whole group of lanes.
#include "guard_seed.h"
#include "runtime/torus.h"

#include <doctest/doctest.h>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace skelform::runtime;
using skelform::test::Torus;

// L, K and the blend's weights on a torus, welded vertex w's representative n − 1 − w (the
// gathers do not read in order): some vertices at weight 0 (LBS; one with K infinite, one at
// −0), some with K = L, the rest moved by noise, λ 1, ½ or 0.
struct Scene : skelform::test::ReversedSkin {
  Torus torus;
  TriangleHierarchy hierarchy;
  Scene(const Torus& t, std::mt19937&& random)
      : ReversedSkin(t.vertex_count(),
                     [&](uint32_t w, glm::vec3& l, glm::vec3& k, float& weight, float& factor) {
                       std::normal_distribution<float> noise(0.0f, 0.01f);
                       l = t.positions[w] + glm::vec3(noise(random), noise(random), noise(random));
                       k = w % 5 == 0 ? l : l + glm::vec3(noise(random), noise(random), noise(random));
                       weight = w % 7 == 0 ? 0.0f : std::uniform_real_distribution<float>(0.0f, 1.0f)(random);
                       factor = w % 11 == 0 ? 0.0f : (w % 3 == 0 ? 0.5f : 1.0f);
                     }),
        torus(t),
        hierarchy(
            build_triangle_hierarchy(torus.positions.data(), torus.triangles.data(), torus.triangle_count(), {})) {
    // At weight 0 x is L itself: beside an infinite K (not L + 0·∞) and at L = −0 (not +0).
    skelform[representative[7]].x = std::numeric_limits<float>::infinity();
    lbs[representative[14]] = skelform[representative[14]] = glm::vec3(-0.0f);
  }
  explicit Scene(uint32_t seed) : Scene(Torus(47, 29, 1.0f, 0.3f, glm::vec3(0.5f, 2.0f, -1.0f)), std::mt19937(seed)) {}
  SeedSkin skin() const { return {representative.data(), lbs.data(), skelform.data(), weight.data(), factor.data()}; }
};

// One form's outputs, sized as make_guard_workspace sizes them.
struct Seeded {
  std::vector<glm::vec3> positions;
  std::vector<uint8_t> moved, tested, wanted;
  SlotBoxes boxes{AllocatorRef{}};
  Array<uint32_t> test_list{AllocatorRef{}};
  bool finite = true;
  explicit Seeded(const Scene& scene) {
    const uint32_t n = scene.torus.vertex_count(), t = scene.torus.triangle_count();
    positions.resize(n);
    moved.resize(n + 3);
    // Not the flags any form writes: each must write every one (those past the slots stay).
    tested.assign(t, 0xab);
    wanted.assign(scene.hierarchy.slot_stride(), 0xab);
    boxes.resize(scene.hierarchy);
    test_list.reserve(t);
  }
  SeedOutput out() { return {positions.data(), moved.data(), &boxes, tested.data(), wanted.data(), &test_list}; }
};

bool same_bits(const void* a, const void* b, size_t bytes) { return std::memcmp(a, b, bytes) == 0; }

void check_same(const Seeded& form, const Seeded& portable, const std::string& name) {
  INFO(name);
  CHECK(form.finite == portable.finite);
  CHECK(same_bits(form.positions.data(), portable.positions.data(), form.positions.size() * sizeof(glm::vec3)));
  CHECK(form.moved == portable.moved);
  CHECK(same_bits(form.boxes.planes.data(), portable.boxes.planes.data(), form.boxes.planes.size() * sizeof(float)));
  CHECK(form.tested == portable.tested);
  CHECK(form.wanted == portable.wanted);
  CHECK(std::vector<uint32_t>(form.test_list.begin(), form.test_list.end()) ==
        std::vector<uint32_t>(portable.test_list.begin(), portable.test_list.end()));
}

}  // namespace

TEST_CASE("guard seed: the blend, its moved vertices, the boxes and the listed triangles") {
  const Scene scene(3);
  const uint32_t n = scene.torus.vertex_count(), triangles = scene.torus.triangle_count();
  REQUIRE(n % 8 == 3);  // tails after the groups of eight and four
  REQUIRE(triangles % 8 == 6);
  Seeded portable(scene);
  seed_positions_portable(0, n, scene.skin(), portable.out(), portable.finite);
  seed_boxes_portable(0, triangles, scene.hierarchy, portable.out());
  CHECK(portable.finite);
  uint32_t moved_count = 0, listed_count = 0;
  for (uint32_t w = 0; w < n; ++w) {
    const uint32_t r = scene.representative[w];
    const float s = scene.weight[r] * scene.factor[w];
    const glm::vec3 expected = s == 0.0f ? scene.lbs[r] : scene.lbs[r] + s * (scene.skelform[r] - scene.lbs[r]);
    CHECK(portable.positions[w] == expected);
    CHECK(std::memcmp(&portable.positions[w], &expected, sizeof(glm::vec3)) == 0);  // −0 too
    CHECK(bool(portable.moved[w]) == (expected != scene.lbs[r]));
    moved_count += portable.moved[w];
  }
  for (uint32_t slot = 0; slot < triangles; ++slot) {
    const uint32_t t = scene.hierarchy.order[slot];
    const uint32_t* c = scene.torus.triangles.data() + 3 * size_t(t);
    float box[6];
    portable.boxes.get(slot, box);
    for (int k = 0; k < 3; ++k)
      for (int axis = 0; axis < 3; ++axis) {
        CHECK(box[axis] <= portable.positions[c[k]][axis]);
        CHECK(portable.positions[c[k]][axis] <= box[3 + axis]);
      }
    const bool moved = portable.moved[c[0]] || portable.moved[c[1]] || portable.moved[c[2]];
    CHECK(portable.tested[t] == uint8_t(moved));
    CHECK(portable.wanted[slot] == uint8_t(moved));
    listed_count += moved;
  }
  CHECK(portable.test_list.size() == listed_count);
  // The scene has both kinds.
  CHECK(moved_count > n / 2);
  CHECK(moved_count < n);
  CHECK(listed_count < triangles);
}

TEST_CASE("guard seed: every form gives the portable loops' bits, flags and list") {
  // 0: finite; 1: K infinite at a vertex in the groups of eight; 2: L NaN at the last vertex
  // (in the tail).
  for (int not_finite : {0, 1, 2}) {
    Scene scene(5);
    const uint32_t n = scene.torus.vertex_count(), triangles = scene.torus.triangle_count();
    REQUIRE(scene.weight[scene.representative[12]] * scene.factor[12] > 0.0f);
    if (not_finite == 1) scene.skelform[scene.representative[12]].y = std::numeric_limits<float>::infinity();
    if (not_finite == 2) scene.lbs[scene.representative[n - 1]].x = std::numeric_limits<float>::quiet_NaN();
    Seeded portable(scene);
    seed_positions_portable(0, n, scene.skin(), portable.out(), portable.finite);
    seed_boxes_portable(0, triangles, scene.hierarchy, portable.out());
    CHECK(portable.finite == (not_finite == 0));

    std::vector<std::pair<std::string, std::function<void(Seeded&)>>> forms;
    forms.emplace_back("chosen", [&](Seeded& s) {
      s.finite = seed_positions(n, n, scene.skin(), s.out());
      seed_boxes(n, s.moved.size(), scene.hierarchy, s.out());
    });
#if defined(__SSE2__)
    forms.emplace_back("sse2", [&](Seeded& s) {
      seed_positions_portable(0, n, scene.skin(), s.out(), s.finite);
      const uint32_t done = detail::seed_boxes_sse2(0, triangles, scene.hierarchy, s.out());
      CHECK(done == triangles - triangles % 4);
      seed_boxes_portable(done, triangles, scene.hierarchy, s.out());
    });
#endif
#if defined(SKELFORM_HAS_AVX2_KERNELS)
    if (cpu_has_avx2())
      forms.emplace_back("avx2", [&](Seeded& s) {
        uint32_t done = detail::seed_positions_avx2(n, scene.skin(), s.out(), s.finite);
        CHECK(done == n - n % 8);
        seed_positions_portable(done, n, scene.skin(), s.out(), s.finite);
        done = detail::seed_boxes_avx2(0, triangles, scene.hierarchy, s.out());
        CHECK(done == triangles - triangles % 8);
        seed_boxes_portable(done, triangles, scene.hierarchy, s.out());
      });
    else
      MESSAGE("no AVX2 on this CPU: its form is not tested");
#endif
    for (auto& form : forms) {
      const std::string& name = form.first;  // (a structured binding: doctest's lambdas cannot capture it)
      Seeded seeded(scene);
      form.second(seeded);
      if (not_finite) {  // the caller stops at a position that is not finite: only the flag counts
        CHECK_MESSAGE(!seeded.finite, name);
        continue;
      }
      check_same(seeded, portable, name);
    }
  }
}
