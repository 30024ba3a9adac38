// Flow (4)'s block gather (runtime/src/hull_block.h): the AVX2 form gives the portable loop's
// bits on random control triangles with non-finite positions, centres and radii and with tails,
// and the portable loop gives the centroid and the differences ball_hull_distance takes.
#include "hull_block.h"

#include "cpu.h"

#include <doctest/doctest.h>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace {

using namespace skelform::runtime::fair_detail;

// A random control mesh: 400 vertices, 300 triangles; a few coordinates and radii are NaN or
// infinite, and one position is so large that a centroid's sum overflows.
struct Mesh {
  std::vector<uint32_t> corners;
  std::vector<glm::vec3> skeletal, x;
  std::vector<float> radius;
  std::vector<uint32_t> triangles;  // a block's triangles, in no order

  Mesh() {
    std::mt19937 random(31);
    std::normal_distribution<float> normal(0.0f, 1.0f);
    std::uniform_int_distribution<uint32_t> vertex(0, 399), triangle(0, 299);
    for (uint32_t v = 0; v < 400; ++v) {
      x.emplace_back(normal(random), normal(random), normal(random));
      skeletal.push_back(0.8f * x.back());
      radius.push_back(0.2f + 0.05f * normal(random));
    }
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    x[3].y = nan, x[17].z = inf, x[40].x = -inf;
    x[41] = x[42] = glm::vec3(3e38f, 0.0f, 0.0f);
    skeletal[5].x = nan, skeletal[60].z = -inf, radius[7] = nan, radius[8] = inf;
    for (uint32_t t = 0; t < 300; ++t) {
      const uint32_t a = vertex(random);
      corners.insert(corners.end(), {a, vertex(random), vertex(random)});
    }
    // Triangles naming every special vertex, and the two overflowing corners together.
    const uint32_t special[] = {3, 17, 40, 5, 60, 7, 8};
    for (uint32_t k = 0; k < 7; ++k) corners[3 * (10 * k + 1) + k % 3] = special[k];
    corners[3 * 2] = 41, corners[3 * 2 + 1] = 42;
    triangles.push_back(2);
    for (uint32_t k = 0; k < 7; ++k) triangles.push_back(10 * k + 1);
    while (triangles.size() < kHullBlock) triangles.push_back(triangle(random));
  }
  HullSources sources() const { return {corners.data(), skeletal.data(), radius.data(), x.data()}; }
};

[[maybe_unused]] bool same_block(const HullBlock& a, const HullBlock& b, uint32_t count) {
  const float* fa[] = {a.w0x, a.w0y, a.w0z, a.e1x, a.e1y, a.e1z, a.e2x, a.e2y, a.e2z, a.r0, a.d1, a.d2};
  const float* fb[] = {b.w0x, b.w0y, b.w0z, b.e1x, b.e1y, b.e1z, b.e2x, b.e2y, b.e2z, b.r0, b.d1, b.d2};
  bool same = std::memcmp(a.centroid, b.centroid, count * sizeof(glm::vec3)) == 0;
  for (int k = 0; k < 12; ++k) same = same && std::memcmp(fa[k], fb[k], count * sizeof(float)) == 0;
  for (uint32_t i = 0; i < count; ++i) same = same && a.usable[i] == b.usable[i];
  return same;
}

}  // namespace

TEST_CASE("hull block: the centroids and ball_hull_distance's differences, zeros where not usable") {
  const Mesh mesh;
  HullBlock b;
  gather_block_portable(mesh.sources(), mesh.triangles.data(), 0, kHullBlock, b);
  uint32_t unusable = 0;
  for (uint32_t i = 0; i < kHullBlock; ++i) {
    const uint32_t* c = mesh.corners.data() + 3 * size_t{mesh.triangles[i]};
    const glm::vec3 centroid = (mesh.x[c[0]] + mesh.x[c[1]] + mesh.x[c[2]]) / 3.0f;
    bool finite = true;
    for (const glm::vec3& p : {centroid, mesh.skeletal[c[0]], mesh.skeletal[c[1]], mesh.skeletal[c[2]]})
      finite = finite && std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
    CHECK(b.usable[i] == finite);
    unusable += !finite;
    const glm::vec3 s0 = finite ? mesh.skeletal[c[0]] : glm::vec3(0.0f);
    const glm::vec3 w0 = finite ? centroid - s0 : glm::vec3(0.0f);
    const glm::vec3 e2 = finite ? mesh.skeletal[c[2]] - s0 : glm::vec3(0.0f);
    CHECK(std::memcmp(&b.centroid[i], &centroid, sizeof centroid) == 0);
    CHECK((b.w0x[i] == w0.x && b.w0y[i] == w0.y && b.w0z[i] == w0.z));
    CHECK((b.e2x[i] == e2.x && b.e2y[i] == e2.y && b.e2z[i] == e2.z));
    const float d2 = mesh.radius[c[2]] - mesh.radius[c[0]];
    CHECK(std::memcmp(&b.d2[i], &d2, sizeof d2) == 0);
  }
  CHECK(unusable == 6);  // the NaN, infinite and overflowing positions and centres; not the radii
}

TEST_CASE("hull block: the AVX2 gather gives the portable loop's bits") {
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (!skelform::runtime::cpu_has_avx2()) {
    MESSAGE("skipped: this CPU has no AVX2");
    return;
  }
  const Mesh mesh;
  for (const uint32_t count : {kHullBlock, 61u, 15u, 7u}) {  // tails of 5 and 7 after eights
    HullBlock lanes, portable;
    std::memset(&lanes, 0x5a, sizeof lanes);
    std::memset(&portable, 0x5a, sizeof portable);
    const uint32_t done = gather_block_avx2(mesh.sources(), mesh.triangles.data(), count, lanes);
    CHECK(done == count / 8 * 8);
    gather_block_portable(mesh.sources(), mesh.triangles.data(), done, count, lanes);
    gather_block_portable(mesh.sources(), mesh.triangles.data(), 0, count, portable);
    CHECK(same_block(lanes, portable, count));
  }
  // The dispatching entry, as triangle_forces calls it.
  HullBlock chosen, portable;
  gather_block(mesh.sources(), 400, 300, mesh.triangles.data(), kHullBlock, chosen);
  gather_block_portable(mesh.sources(), mesh.triangles.data(), 0, kHullBlock, portable);
  CHECK(same_block(chosen, portable, kHullBlock));
#else
  MESSAGE("skipped: no AVX2 form on this target");
#endif
}
