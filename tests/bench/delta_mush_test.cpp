// bench/delta_mush: the Delta Mush baseline reproduces the rest mesh at the rest pose and is
// invariant under a rigid motion of the whole skeleton (smoothing and frames commute with it).
#include "delta_mush.h"

#include <glm/gtc/constants.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

using skelform::bench::DeltaMush;

namespace {

// A closed tube: `rings` rings of `segments` vertices along x, capped; split vertices at one
// seam (duplicated positions) as glTF exports have them. Two joints blend along x.
struct Tube {
  std::vector<float> positions;
  std::vector<uint32_t> triangles;
  std::vector<uint16_t> joints;
  std::vector<float> weights;
};

Tube make_tube(int rings = 8, int segments = 12) {
  Tube tube;
  const double pi = glm::pi<double>();
  auto add_vertex = [&](double x, double y, double z) {
    tube.positions.insert(tube.positions.end(), {float(x), float(y), float(z)});
    const float w = static_cast<float>(std::fmin(1.0, std::fmax(0.0, x / (rings - 1))));
    tube.joints.insert(tube.joints.end(), {0, 1, 0, 0});
    tube.weights.insert(tube.weights.end(), {1.0f - w, w, 0.0f, 0.0f});
    return static_cast<uint32_t>(tube.positions.size() / 3 - 1);
  };
  std::vector<std::vector<uint32_t>> ring(rings);
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s <= segments; ++s) {  // s == segments duplicates s == 0: a seam
      const double angle = 2 * pi * (s % segments) / segments;
      ring[r].push_back(add_vertex(r, std::cos(angle) * (1.0 + 0.1 * r), std::sin(angle)));
    }
  for (int r = 0; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const uint32_t a = ring[r][s], b = ring[r][s + 1], c = ring[r + 1][s], d = ring[r + 1][s + 1];
      tube.triangles.insert(tube.triangles.end(), {a, c, b, b, c, d});
    }
  const uint32_t start = add_vertex(-0.5, 0, 0), end = add_vertex(rings - 0.5, 0, 0);
  for (int s = 0; s < segments; ++s) {
    tube.triangles.insert(tube.triangles.end(), {start, ring[0][s], ring[0][s + 1]});
    tube.triangles.insert(tube.triangles.end(), {end, ring[rings - 1][s + 1], ring[rings - 1][s]});
  }
  return tube;
}

}  // namespace

TEST_SUITE("delta_mush") {
  TEST_CASE("the rest pose reproduces the rest mesh, seams included") {
    const Tube tube = make_tube();
    DeltaMush mush(tube.positions, tube.triangles, tube.joints, tube.weights, 4);
    CHECK(mush.vertex_count() == tube.positions.size() / 3);
    CHECK(mush.welded_vertex_count() < mush.vertex_count());  // the seam was welded
    const float identity[32] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,
                                1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    std::vector<float> out(tube.positions.size());
    mush.deform(identity, 2, out.data());
    double worst = 0;
    for (size_t i = 0; i < out.size(); ++i) worst = std::fmax(worst, std::fabs(out[i] - tube.positions[i]));
    CHECK(worst < 1e-5);
  }

  TEST_CASE("a rigid motion of the whole skeleton moves the result rigidly") {
    const Tube tube = make_tube();
    DeltaMush mush(tube.positions, tube.triangles, tube.joints, tube.weights, 4);
    // 30 degrees about z, then a translation, on both joints.
    const float c = static_cast<float>(std::cos(0.5235987755982988)),
                s = static_cast<float>(std::sin(0.5235987755982988));
    const float m[16] = {c, s, 0, 0, -s, c, 0, 0, 0, 0, 1, 0, 2, -1, 3, 1};
    float matrices[32];
    for (int i = 0; i < 32; ++i) matrices[i] = m[i % 16];
    std::vector<float> out(tube.positions.size());
    mush.deform(matrices, 2, out.data());
    double worst = 0;
    for (size_t v = 0; v < out.size() / 3; ++v) {
      const float* p = &tube.positions[3 * v];
      const float expected[3] = {c * p[0] - s * p[1] + 2, s * p[0] + c * p[1] - 1, p[2] + 3};
      for (int k = 0; k < 3; ++k) worst = std::fmax(worst, std::fabs(out[3 * v + k] - expected[k]));
    }
    CHECK(worst < 1e-4);
  }

  TEST_CASE("a bend differs from LBS only by the smoothed correction, and stays finite") {
    const Tube tube = make_tube();
    DeltaMush mush(tube.positions, tube.triangles, tube.joints, tube.weights, 4);
    // Joint 1 turns 60 degrees about z around (3.5, 0, 0).
    const double angle = 1.0471975511965976;
    const float c = static_cast<float>(std::cos(angle)), s = static_cast<float>(std::sin(angle));
    const float px = 3.5f;
    const float matrices[32] = {1, 0, 0, 0, 0,  1, 0, 0, 0, 0, 1, 0, 0,           0,       0, 1,
                                c, s, 0, 0, -s, c, 0, 0, 0, 0, 1, 0, px - c * px, -s * px, 0, 1};
    std::vector<float> out(tube.positions.size());
    mush.deform(matrices, 2, out.data());
    bool finite = true;
    for (float v : out) finite = finite && std::isfinite(v);
    CHECK(finite);
    // The far cap follows joint 1 (fully weighted there, smoothing keeps it near).
    const size_t end = tube.positions.size() / 3 - 1;
    const float* p = &tube.positions[3 * end];
    const double x = c * (p[0] - px) - s * p[1] + px, y = s * (p[0] - px) + c * p[1];
    CHECK(std::hypot(out[3 * end] - x, out[3 * end + 1] - y) < 0.5);
  }

  TEST_CASE("inconsistent input is refused") {
    const Tube tube = make_tube();
    std::vector<uint32_t> bad = tube.triangles;
    bad[0] = 100000;
    CHECK_THROWS_AS(DeltaMush(tube.positions, bad, tube.joints, tube.weights, 4), std::invalid_argument);
    CHECK_THROWS_AS(DeltaMush(tube.positions, tube.triangles, tube.joints, tube.weights, 3), std::invalid_argument);
  }

}  // TEST_SUITE
