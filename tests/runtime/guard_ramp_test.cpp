// runtime/src/lbs_guard.h's ramp, checked again: the vertices the ramp lowers move towards LBS,
// and the guard searches again around them only, in the node boxes of its earlier search grown
// around their triangles' new boxes. A triangle the ramp carries out of its earlier leaf box,
// into another part of the mesh, must still be found there.
#include "brute_force_pairs.h"
#include "contact.h"
#include "instance.h"
#include "lbs_guard.h"
#include "runtime/one_primitive.h"

#include <doctest/doctest.h>
#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace {

using namespace skelform::runtime;

// A flat 9 × 9 grid. At skelform's result K its centre vertex v pokes up through a small sheet
// B above it (LBS leaves it flat: a pair LBS lacks), so the guard lowers v; its ramp then lowers
// v's ring (K = L there: they do not move) and the ring after, where vertex u has K in the grid
// and L 8 below it: u moves 3/16 of the way down, to z = -1.5. There, a small triangle C (K
// under u, L far away: moved, but not lowered by the first search, which found it apart from
// everything) meets u's triangles; at L and at rest C is 100 away. Before the ramp, u's node
// boxes were flat (z in [0, 1]) and C's at z = -1.45.
struct RampScene {
  RampScene() : d(AllocatorRef{}), mesh(AllocatorRef{}) {
    constexpr uint32_t n = 9;
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) add(glm::vec3(float(i), float(j), 0.0f), glm::vec3(float(i), float(j), 0.0f));
    for (uint32_t j = 0; j + 1 < n; ++j)
      for (uint32_t i = 0; i + 1 < n; ++i) {
        const uint32_t a = j * n + i, b = a + 1, c = a + n, e = c + 1;
        triangles.insert(triangles.end(), {a, b, e, a, e, c});
      }
    v = 4 * n + 4;
    u = 6 * n + 4;
    k[v].z = 1.0f;         // the poke through B
    l[u].z = -8.0f;        // where the ramp moves u towards
    const float s = 0.8f;  // B: wider than the poke's cross-section at its height
    const uint32_t b0 = add(glm::vec3(4 - s, 4 - s, 0.5f)), b1 = add(glm::vec3(4 + s, 4 - s, 0.5f)),
                   b2 = add(glm::vec3(4 + s, 4 + s, 0.5f)), b3 = add(glm::vec3(4 - s, 4 + s, 0.5f));
    triangles.insert(triangles.end(), {b0, b1, b2, b0, b2, b3});
    // C: an equilateral triangle of circumradius 0.1 under u, at 1.45 below the grid, the first
    // of a row of such triangles 100 away (the others there at K too). The row is a third of
    // the mesh, so the hierarchy (built at rest) keeps it in its own subtree: C's node boxes
    // reach from the row to under u at z = -1.45, and miss the grid's until the ramp.
    const glm::vec3 corners[3] = {glm::vec3(0.0f, 0.1f, 0.0f), glm::vec3(-0.0866f, -0.05f, 0.0f),
                                  glm::vec3(0.0866f, -0.05f, 0.0f)};
    c_first = uint32_t(k.size());
    for (uint32_t r = 0; r < 70; ++r)
      for (const glm::vec3& corner : corners) {
        const glm::vec3 at = glm::vec3(4.0f, 6.0f + 0.3f * float(r), -1.45f) + corner;
        const glm::vec3 away = at + glm::vec3(100.0f, 0.0f, 0.0f);
        add(r == 0 ? at : away, away);
        triangles.push_back(uint32_t(k.size() - 1));
      }
    const uint32_t vertices = uint32_t(k.size());
    normals.assign(vertices, glm::vec3(0, 0, 1));
    skelform::test::make_one_primitive(d, vertices, uint32_t(triangles.size() / 3));
    // The rest pose is LBS's here.
    mesh = build_contact_mesh(l.data(), vertices, triangles.data(), triangles.size() / 3, AllocatorRef{});
  }

  uint32_t add(const glm::vec3& at_k, const glm::vec3& at_l) {
    k.push_back(at_k);
    l.push_back(at_l);
    return uint32_t(k.size() - 1);
  }
  uint32_t add(const glm::vec3& p) { return add(p, p); }

  std::vector<std::pair<uint32_t, uint32_t>> pairs(const std::vector<glm::vec3>& p) const {
    std::vector<std::array<uint32_t, 3>> soup(triangles.size() / 3);
    for (size_t t = 0; t < soup.size(); ++t) soup[t] = {triangles[3 * t], triangles[3 * t + 1], triangles[3 * t + 2]};
    return skelform::test::brute_force_pairs(soup, [&](uint32_t i) { return glm::dvec3(p[i]); });
  }

  std::vector<glm::vec3> k, l, normals;
  std::vector<uint32_t> triangles;
  uint32_t v = 0, u = 0, c_first = 0;
  Deformable d;
  ContactMesh mesh;
};

}  // namespace

TEST_CASE("guard: a triangle the ramp carries out of its leaf box is checked where it lands") {
  RampScene scene;
  REQUIRE(scene.mesh.vertex_count == scene.k.size());  // nothing welded
  REQUIRE(scene.pairs(scene.l).empty());               // LBS, and rest, have no pair
  REQUIRE(!scene.pairs(scene.k).empty());              // K pokes through B
  GuardWorkspace ws = make_guard_workspace(scene.mesh, AllocatorRef{});
  std::vector<glm::vec3> k = scene.k, l = scene.l, kn = scene.normals, ln = scene.normals;
  std::vector<glm::vec3> out(k.size()), on(k.size());
  guard_and_blend(scene.d, scene.mesh, 1.0f, DenseOutput{k.data(), kn.data(), nullptr},
                  DenseOutput{l.data(), ln.data(), nullptr}, true, DenseOutput{out.data(), on.data(), nullptr}, ws);
  REQUIRE(!ws.over_budget);
  // The scene does what it is for: v was lowered below B, and the ramp moved u down to C.
  CHECK(out[scene.v].z < 0.5f);
  CHECK(out[scene.u].z < -1.0f);
  // u's triangles met C there, and the guard took it back (C is the one further off LBS).
  CHECK(out[scene.c_first] != scene.k[scene.c_first]);
  CHECK(scene.pairs(out).empty());
}
