// runtime/src/lbs_guard.h, the volume step on a closed mesh whose answer is known: a unit sphere,
// LBS's result the sphere scaled by 0.97 (8.7 % of the volume lost), skelform's the sphere
// squashed along z (too little volume) or stretched (too much), taken whole or by half, at a
// pose of scale 1 or 2. The output must keep its volume error within LBS's. It does so by
// moving the corrected surface along its normals, which keeps skelform's shape, and not by
// taking the correction back towards LBS's sphere; when that move is capped below what is
// needed, the correction is scaled back as before, and the volume promise still holds.
#include "asset.h"
#include "contact.h"
#include "instance.h"
#include "lbs_guard.h"
#include "skelform/bake/procedural.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace {

using namespace skelform::runtime;

struct Sphere {
  std::vector<glm::vec3> rest;
  std::vector<uint32_t> triangles;
  Sphere() {
    const skelform::bake::TriangleMesh m = skelform::bake::make_icosphere(1.0, 2);
    for (const auto& p : m.positions) rest.emplace_back(float(p.x), float(p.y), float(p.z));
    for (const auto& t : m.triangles)
      for (int k = 0; k < 3; ++k) triangles.push_back(t[k]);
  }
  double volume(const std::vector<glm::vec3>& x) const {
    double v = 0;
    for (size_t t = 0; t < triangles.size(); t += 3) {
      const glm::dvec3 a(x[triangles[t]]), b(x[triangles[t + 1]]), c(x[triangles[t + 2]]);
      v += glm::dot(a, glm::cross(b, c)) / 6.0;
    }
    return v;
  }
};

struct Outcome {
  std::vector<glm::vec3> positions;
  float volume_share = 0;
};

// How the guard is called: skelform's result K is the sphere with z scaled by `squash`, LBS's L
// the sphere scaled by `lbs`, every vertex takes `weight` of skelform's correction, the pose's
// reference scale is `scale` (K and L scaled by it), and the mesh's largest move is scaled by
// `cap`.
struct Call {
  float squash = 0.7f, weight = 1.0f, scale = 1.0f, cap = 1.0f, lbs = 0.97f;
};

Outcome guard(const Sphere& sphere, const Call& call) {
  const uint32_t n = uint32_t(sphere.rest.size());
  Deformable d{AllocatorRef{}};
  d.vertex_count = n;
  d.skelform_weight.assign(n, call.weight);
  PrimitiveRecord primitive;
  primitive.vertex_count = n;
  primitive.triangle_count = uint32_t(sphere.triangles.size() / 3);
  primitive.has_normals = true;
  d.primitives.push_back(primitive);
  d.welded = build_contact_mesh(sphere.rest.data(), n, sphere.triangles.data(), sphere.triangles.size() / 3, {});
  REQUIRE(d.welded.closed);
  REQUIRE(d.welded.weld.size() == n);
  d.welded.cap *= call.cap;
  std::vector<glm::vec3> k(n), l(n), kn(n), ln(n);
  for (uint32_t v = 0; v < n; ++v) {
    const glm::vec3 p = sphere.rest[v];
    l[v] = call.scale * call.lbs * p;
    k[v] = call.scale * glm::vec3(p.x, p.y, call.squash * p.z);
    ln[v] = kn[v] = glm::normalize(p);
  }
  Outcome out{std::vector<glm::vec3>(n), 0.0f};
  std::vector<glm::vec3> on(n);
  GuardWorkspace ws = make_guard_workspace(d.welded, {});
  guard_and_blend(d, d.welded, call.scale, DenseOutput{k.data(), kn.data(), nullptr},
                  DenseOutput{l.data(), ln.data(), nullptr}, true,
                  DenseOutput{out.positions.data(), on.data(), nullptr}, ws);
  out.volume_share = ws.volume_share;
  return out;
}

// Height over width of the output.
float aspect(const std::vector<glm::vec3>& x) {
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const glm::vec3& p : x) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  return (hi.z - lo.z) / (hi.x - lo.x);
}

}  // namespace

TEST_CASE("guard volume: the corrected surface moves along its normals instead of giving the correction back") {
  const Sphere sphere;
  // Squashed (too little volume: the move inflates), stretched (too much: it deflates), with
  // half of skelform's correction taken, and at a pose scaled by 2 (Blender's armature scale
  // in small): the output's volume error is within LBS's, only just (the smallest move that
  // does), and the whole correction is kept, so the output has skelform's shape, not LBS's
  // sphere.
  for (const Call call :
       {Call{0.7f, 1.0f, 1.0f}, Call{1.5f, 1.0f, 1.0f}, Call{0.6f, 0.5f, 1.0f}, Call{0.7f, 1.0f, 2.0f}}) {
    CAPTURE(call.squash);
    CAPTURE(call.weight);
    CAPTURE(call.scale);
    const double cube = double(call.scale) * call.scale * call.scale;
    const double rest = sphere.volume(sphere.rest) * cube;
    std::vector<glm::vec3> lbs;
    for (const glm::vec3& p : sphere.rest) lbs.push_back(call.scale * 0.97f * p);
    const double lbs_error = std::fabs(sphere.volume(lbs) - rest);
    const Outcome moved = guard(sphere, call);
    for (const glm::vec3& p : moved.positions) REQUIRE(std::isfinite(p.x + p.y + p.z));
    const double error = std::fabs(sphere.volume(moved.positions) - rest);
    INFO("volume error " << error / rest << ", LBS's " << lbs_error / rest);
    CHECK(error <= lbs_error);
    CHECK(error >= 0.98 * lbs_error);
    CHECK(moved.volume_share == 1.0f);
    const float blended_squash = 0.97f + call.weight * (call.squash - 0.97f);
    const float unsquashed = 0.97f + call.weight * (1.0f - 0.97f);
    const float shape = blended_squash / unsquashed;  // K's aspect, before any move
    CAPTURE(aspect(moved.positions));
    // (Given back, the output would be nearly LBS's sphere: 1.)
    if (shape < 1.0f)
      CHECK(aspect(moved.positions) < 0.9f);
    else
      CHECK(aspect(moved.positions) > 1.1f);
  }

  // Allowed a hundredth of the move, the step cannot reach LBS's error and scales the
  // correction back. With L a little too large (1.03) and K far too small, part of the
  // correction is within LBS's error: the output goes part of the way to LBS's sphere, and its
  // volume holds.
  Call capped;
  capped.cap = 0.01f;
  capped.lbs = 1.03f;
  const double rest = sphere.volume(sphere.rest);
  std::vector<glm::vec3> lbs;
  for (const glm::vec3& p : sphere.rest) lbs.push_back(1.03f * p);
  const double lbs_error = std::fabs(sphere.volume(lbs) - rest);
  const Outcome scaled = guard(sphere, capped);
  const double scaled_error = std::fabs(sphere.volume(scaled.positions) - rest);
  CHECK(scaled_error <= lbs_error);
  CHECK(scaled.volume_share > 0.0f);
  CHECK(scaled.volume_share < 1.0f);
  CHECK(aspect(scaled.positions) > 0.7f);
  CHECK(aspect(scaled.positions) < 1.0f);
}
