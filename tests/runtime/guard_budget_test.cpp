// runtime/src/lbs_guard.h's work bound, on the guard itself: a pose whose surface is tangled
// over itself (every triangle's box meets nearly every other's, as corrupt or degenerate data
// gives) ends the search at pair_visit_budget (triangle_bvh.h) candidate pairs and outputs
// exactly LBS; a tangle within the budget is resolved as always, to no pair LBS lacks. The
// contact mesh's rest-pair search (at load) has the same bound, and the contact pass a
// multiple of it; a pass that runs out of it on the guard's search gives the search's boxes
// back as it found them.
#include "asset.h"
#include "brute_force_pairs.h"
#include "contact.h"
#include "instance.h"
#include "lbs_guard.h"
#include "runtime/one_primitive.h"
#include "skelform/core/triangle_intersection.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <array>
#include <cstdint>
#include <random>
#include <vector>

namespace {

using namespace skelform::runtime;

// `count` separate triangles: at rest (and under LBS) each alone in a cell of a wide grid, so
// LBS has no pair; skelform's result throws them all into the unit cube, where most boxes meet.
struct Tangle {
  explicit Tangle(uint32_t count) : d(AllocatorRef{}), mesh(AllocatorRef{}) {
    std::mt19937 random(5);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (uint32_t t = 0; t < count; ++t) {
      const glm::vec3 cell(float(t % 40) * 10.0f, float(t / 40) * 10.0f, 0.0f);
      for (const glm::vec3& corner : {glm::vec3(0, 0, 0), glm::vec3(1, 0, 0), glm::vec3(0, 1, 0)}) {
        rest.push_back(cell + corner);
        thrown.emplace_back(unit(random), unit(random), unit(random));
        triangles.push_back(uint32_t(triangles.size()));
      }
    }
    const uint32_t vertices = 3 * count;
    normals.assign(vertices, glm::vec3(0, 0, 1));
    skelform::test::make_one_primitive(d, vertices, count);
    mesh = build_contact_mesh(rest.data(), vertices, triangles.data(), count, AllocatorRef{});
  }

  // The guard's blend of skelform = `thrown` and LBS = `rest`, into `out`; the workspace after.
  GuardWorkspace blend(std::vector<glm::vec3>& out) {
    GuardWorkspace ws = make_guard_workspace(mesh, AllocatorRef{});
    std::vector<glm::vec3> k = thrown, l = rest, kn = normals, ln = normals, on(normals.size());
    out.assign(rest.size(), glm::vec3(0.0f));
    guard_and_blend(d, mesh, 1.0f, DenseOutput{k.data(), kn.data(), nullptr}, DenseOutput{l.data(), ln.data(), nullptr},
                    true, DenseOutput{out.data(), on.data(), nullptr}, ws);
    return ws;
  }

  std::vector<glm::vec3> rest, thrown, normals;
  std::vector<uint32_t> triangles;
  Deformable d;
  ContactMesh mesh;
};

// Intersecting pairs of separate triangles at `p`, by brute force.
size_t pairs_at(const std::vector<glm::vec3>& p) {
  std::vector<std::array<uint32_t, 3>> soup(p.size() / 3);
  for (uint32_t s = 0; s < soup.size(); ++s) soup[s] = {3 * s, 3 * s + 1, 3 * s + 2};
  return skelform::test::brute_force_pairs(soup, [&](uint32_t v) { return glm::dvec3(p[v]); }).size();
}

}  // namespace

TEST_CASE("guard: a tangle within the work budget is resolved to no pair LBS lacks") {
  Tangle tangle(60);  // 1,770 candidate pairs at most: far below the floor
  REQUIRE(pairs_at(tangle.thrown) > 100);
  std::vector<glm::vec3> out;
  const GuardWorkspace ws = tangle.blend(out);
  CHECK(!ws.over_budget);
  CHECK(pairs_at(out) == 0);  // LBS (the rest grid) has none
  size_t kept = 0;            // and the guard kept what it could of skelform's result
  for (size_t v = 0; v < out.size(); ++v) kept += out[v] != tangle.rest[v] ? 1 : 0;
  CHECK(kept > 0);
}

TEST_CASE("guard: a tangle beyond the work budget stops the search and is LBS, bit for bit") {
  const uint32_t count = 1200;  // ~720,000 candidate pairs
  REQUIRE(pair_visit_budget(count) < uint64_t(count) * (count - 1) / 4);
  Tangle tangle(count);
  std::vector<glm::vec3> out;
  const GuardWorkspace ws = tangle.blend(out);
  CHECK(ws.over_budget);
  CHECK(ws.budget.left == 0);  // it spent the budget and no more
  CHECK(ws.corrected == tangle.mesh.vertex_count);
  size_t differ = 0;
  for (size_t v = 0; v < out.size(); ++v) differ += out[v] != tangle.rest[v] ? 1 : 0;
  CHECK(differ == 0);
}

TEST_CASE("contact mesh: the rest pairs are found within the budget, and a mesh tangled at rest is left alone") {
  SUBCASE("a small tangle at rest: every modelled pair, as brute force finds them") {
    const Tangle tangle(60);
    const ContactMesh mesh =
        build_contact_mesh(tangle.thrown.data(), uint32_t(tangle.thrown.size()), tangle.triangles.data(), 60, {});
    CHECK(!mesh.tangled_at_rest);
    CHECK(mesh.rest_pairs.size() == pairs_at(tangle.thrown));
  }
  SUBCASE("a tangle beyond the budget: no rest pairs kept, and the contact pass moves nothing") {
    const uint32_t count = 1200;
    const Tangle tangle(count);
    const ContactMesh mesh =
        build_contact_mesh(tangle.thrown.data(), uint32_t(tangle.thrown.size()), tangle.triangles.data(), count, {});
    CHECK(mesh.tangled_at_rest);
    CHECK(mesh.rest_pairs.empty());
    ContactWorkspace ws = make_contact_workspace(mesh, AllocatorRef{});
    add_contact_grid(mesh, ws);
    std::vector<glm::vec3> positions = tangle.thrown;
    const ContactStats stats = resolve_contacts(mesh, 1.0f, positions.data(), uint32_t(positions.size()), ws);
    CHECK(stats.moved == 0);
    CHECK(positions == tangle.thrown);
  }
}

TEST_CASE("contact pass: a tangle beyond the work budget stops and leaves the output as it was") {
  const uint32_t count = 1200;
  const Tangle tangle(count);  // not tangled at rest: its rest pairs are found, none
  REQUIRE(!tangle.mesh.tangled_at_rest);
  ContactWorkspace ws = make_contact_workspace(tangle.mesh, AllocatorRef{});
  add_contact_grid(tangle.mesh, ws);
  std::vector<glm::vec3> positions = tangle.thrown;
  const ContactStats stats = resolve_contacts(tangle.mesh, 1.0f, positions.data(), uint32_t(positions.size()), ws);
  CHECK(stats.over_budget);
  CHECK(ws.budget.left == 0);
  CHECK(stats.moved == 0);
  CHECK(positions == tangle.thrown);
}

TEST_CASE("contact pass: on the guard's search, a pass beyond the budget gives the search's boxes back") {
  // Inside the guard the pass grows the search's triangle boxes around the vertices it moves
  // (ContactPairs); when it runs out of budget it takes its moves back, and must take those
  // boxes back with them: the guard reads them as the triangles' boxes at x.
  const uint32_t count = 1200;
  const Tangle tangle(count);
  REQUIRE(!tangle.mesh.tangled_at_rest);
  const TriangleHierarchy& h = tangle.mesh.hierarchy;
  auto box_at = [&](uint32_t t, float* b) {
    const glm::vec3* p = tangle.thrown.data() + 3 * size_t(t);  // separate triangles: corners 3t..3t+2
    const glm::vec3 lo = glm::min(glm::min(p[0], p[1]), p[2]), hi = glm::max(glm::max(p[0], p[1]), p[2]);
    b[0] = lo.x, b[1] = lo.y, b[2] = lo.z, b[3] = hi.x, b[4] = hi.y, b[5] = hi.z;
  };
  SlotBoxes boxes(AllocatorRef{});
  boxes.resize(h);
  for (uint32_t slot = 0; slot < count; ++slot) {
    float b[6];
    box_at(h.order[slot], b);
    boxes.set(slot, b);
  }
  std::vector<float> node_boxes(6 * h.nodes.size());
  refit_triangle_hierarchy(h, boxes, node_boxes.data());
  // The search's pairs: every intersecting pair (LBS, the rest grid, has none).
  std::vector<std::array<uint32_t, 3>> soup(count);
  for (uint32_t s = 0; s < count; ++s) soup[s] = {3 * s, 3 * s + 1, 3 * s + 2};
  std::vector<uint64_t> keys;
  for (const auto& pair :
       skelform::test::brute_force_pairs(soup, [&](uint32_t v) { return glm::dvec3(tangle.thrown[v]); }))
    keys.push_back(pair_key(pair.first, pair.second));
  REQUIRE(keys.size() > 10000);
  const ContactPairs search{keys.data(), keys.size(), &h, node_boxes.data(), &boxes};
  ContactWorkspace ws = make_contact_workspace(tangle.mesh, AllocatorRef{});
  std::vector<glm::vec3> positions = tangle.thrown;
  const ContactStats stats =
      resolve_contacts(tangle.mesh, 1.0f, positions.data(), uint32_t(positions.size()), ws, ContactBlend(), &search);
  CHECK(stats.over_budget);
  CHECK(stats.moved == 0);
  CHECK(positions == tangle.thrown);
  size_t grown = 0;  // slot boxes that are not the triangle's box at x
  for (uint32_t slot = 0; slot < count; ++slot) {
    float expected[6], got[6];
    box_at(h.order[slot], expected);
    boxes.get(slot, got);
    for (int k = 0; k < 6; ++k) grown += got[k] != expected[k] ? 1 : 0;
  }
  CHECK(grown == 0);
  // Every node box still holds its triangles' boxes.
  size_t outside = 0;
  for (uint32_t slot = 0; slot < count; ++slot) {
    float b[6];
    boxes.get(slot, b);
    const float* node = node_boxes.data() + 6 * size_t(h.leaf[slot]);
    for (int k = 0; k < 3; ++k) outside += (b[k] < node[k] || b[3 + k] > node[3 + k]) ? 1 : 0;
  }
  CHECK(outside == 0);
}
