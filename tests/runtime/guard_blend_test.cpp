// The LBS guard's output blend (runtime/src/guard_blend.h): positions L + s·(K − L), normals
// blended and renormalised (LBS's where the blend has no length), LBS's vectors as they are
// where s = 0; tangents as the normals with LBS's handedness; and in place over K the same bits
// as into other buffers, over a range.
#include "guard_blend.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace {

using namespace skelform::runtime;

// n dense vertices welded onto n / 2 (vertex v onto v / 2), L and K random, their normals unit;
// every fifth vertex at weight 0, every seventh welded vertex at λ 0, and every ninth dense
// vertex with K's normal opposite L's at s = ½ (the blend has no length), every thirteenth's
// huge (its length overflows) and every seventeenth's NaN; K infinite at every tenth (weight
// 0: LBS's position, not 0·∞).
struct Scene {
  uint32_t n;
  std::vector<float> weight, factor;
  std::vector<uint32_t> weld;
  std::vector<glm::vec3> lbs_p, lbs_n, k_p, k_n;
  explicit Scene(uint32_t count) : n(count) {
    std::mt19937 random(17);
    std::normal_distribution<float> normal(0.0f, 1.0f);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    auto direction = [&] { return glm::normalize(glm::vec3(normal(random), normal(random), normal(random))); };
    for (uint32_t v = 0; v < n; ++v) {
      weld.push_back(v / 2);
      lbs_p.emplace_back(normal(random), normal(random), normal(random));
      k_p.push_back(lbs_p.back() + 0.1f * glm::vec3(normal(random), normal(random), normal(random)));
      if (v % 10 == 0) k_p.back().x = std::numeric_limits<float>::infinity();  // at weight 0: never read
      lbs_n.push_back(direction());
      k_n.push_back(v % 9 == 0 ? -lbs_n.back() : direction());
      if (v % 13 == 0) k_n.back() = glm::vec3(1e30f);  // the blend's length overflows
      if (v % 17 == 0) k_n.back().y = std::numeric_limits<float>::quiet_NaN();
      weight.push_back(v % 5 == 0 ? 0.0f : (v % 9 == 0 ? 1.0f : unit(random)));
    }
    for (uint32_t w = 0; w < (n + 1) / 2; ++w) factor.push_back(w % 7 == 0 ? 0.0f : (w % 9 == 0 ? 0.5f : 1.0f));
    for (uint32_t v = 0; v < n; v += 9) factor[v / 2] = v % 5 == 0 ? factor[v / 2] : 0.5f;
  }
  BlendInput input(std::vector<glm::vec3>& kp, std::vector<glm::vec3>& kn) {
    return {weight.data(),
            factor.empty() ? nullptr : factor.data(),
            weld.data(),
            {kp.data(), kn.data(), nullptr},
            {lbs_p.data(), lbs_n.data(), nullptr}};
  }
};

[[maybe_unused]] bool same_bits(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(glm::vec3)) == 0;
}

}  // namespace

TEST_CASE("guard blend: the blend, its renormalised normals and LBS where s = 0") {
  Scene scene(301);
  std::vector<glm::vec3> p(scene.n), nrm(scene.n);
  blend_output(0, scene.n, scene.input(scene.k_p, scene.k_n), true, false, {p.data(), nrm.data(), nullptr});
  uint32_t lbs_count = 0, fallback_count = 0;
  for (uint32_t v = 0; v < scene.n; ++v) {
    const float s = scene.weight[v] * scene.factor[scene.weld[v]];
    if (s == 0.0f) {
      CHECK(p[v] == scene.lbs_p[v]);
      CHECK(nrm[v] == scene.lbs_n[v]);
      ++lbs_count;
      continue;
    }
    CHECK(glm::length(p[v] - (scene.lbs_p[v] + s * (scene.k_p[v] - scene.lbs_p[v]))) <= 1e-6f);
    const glm::vec3 blend = scene.lbs_n[v] + s * (scene.k_n[v] - scene.lbs_n[v]);
    const float length = std::sqrt(glm::dot(blend, blend));
    if (!(length > 1e-30f && std::isfinite(length))) {
      CHECK(nrm[v] == scene.lbs_n[v]);
      ++fallback_count;
    } else {
      CHECK(std::fabs(glm::length(nrm[v]) - 1.0f) <= 1e-6f);
      CHECK(glm::dot(nrm[v], blend) > 0.0f);
    }
  }
  CHECK(lbs_count > 0);
  CHECK(fallback_count >= 3);  // the opposite, huge and NaN normals
}

TEST_CASE("guard blend: tangents blend as the normals do and keep LBS's handedness") {
  // Tangents whose directions are the normals': their blended directions must be the blended
  // normals bit for bit, their w LBS's (K's is garbage), LBS's tangent itself where s = 0.
  Scene scene(301);
  std::vector<glm::vec4> lbs_t, k_t;
  for (uint32_t v = 0; v < scene.n; ++v) {
    lbs_t.emplace_back(scene.lbs_n[v], v % 2 ? 1.0f : -1.0f);
    k_t.emplace_back(scene.k_n[v], 7.0f);
  }
  BlendInput in = scene.input(scene.k_p, scene.k_n);
  in.skelform.tangents = k_t.data();
  in.lbs.tangents = lbs_t.data();
  std::vector<glm::vec3> p(scene.n), nrm(scene.n);
  std::vector<glm::vec4> tangents(scene.n, glm::vec4(-5.0f));
  blend_output(0, scene.n, in, true, true, {p.data(), nrm.data(), tangents.data()});
  uint32_t blended = 0;
  for (uint32_t v = 0; v < scene.n; ++v) {
    const glm::vec3 direction(tangents[v]);
    CHECK(std::memcmp(&direction, &nrm[v], sizeof direction) == 0);
    CHECK(tangents[v].w == lbs_t[v].w);
    blended += scene.weight[v] * scene.factor[scene.weld[v]] != 0.0f ? 1 : 0;
  }
  CHECK(blended > scene.n / 2);
}

TEST_CASE("guard blend: in place over K, the bits of a blend into other buffers") {
  Scene scene(301);
  const std::vector<float> factor = scene.factor;
  const uint32_t first = 5;
  for (uint32_t stop : {scene.n, scene.n - 3}) {
    for (int variant = 0; variant < 4; ++variant) {
      const bool normals = variant & 1;
      scene.factor = variant & 2 ? factor : std::vector<float>{};  // or not welded: λ = 1 (factor null)
      std::vector<glm::vec3> p(scene.n), n(scene.n);
      blend_output(first, stop, scene.input(scene.k_p, scene.k_n), normals, false, {p.data(), n.data(), nullptr});
      // In place: K's buffers receive the output, and only over [first, stop).
      std::vector<glm::vec3> kp = scene.k_p, kn = scene.k_n;
      blend_output(first, stop, scene.input(kp, kn), normals, false, {kp.data(), kn.data(), nullptr});
      std::vector<glm::vec3> expected_p = scene.k_p, expected_n = scene.k_n;
      std::copy(p.begin() + first, p.begin() + stop, expected_p.begin() + first);
      if (normals) std::copy(n.begin() + first, n.begin() + stop, expected_n.begin() + first);
      CHECK(same_bits(kp, expected_p));
      CHECK(same_bits(kn, expected_n));
    }
  }
}
