// The contact pass (runtime/src/contact.h) on scenes whose answer is known: an octahedron's
// tip pushed through the top face of a cube comes back out along the face normal and nothing
// else moves; no intersection, no change; welded copies move together; a non-finite position
// leaves the output alone; blended with LBS, the output's tip gets the whole push and a
// rigid one none. Through the C API: set_contacts' arguments, evaluation never
// allocates with the pass on, and the pass is output only (turned off again, an instance gives
// the bits of one that never had it). A blended part modelled into a rigid one follows it where
// they cross (junction anchors), and the guard keeps the pairs the model has. Inside the LBS guard (lbs_guard.h FirstRoundHook), the
// pass detects from the guard's first search, which lists every intersecting pair, and the
// guard's outcome is that of a guard run afresh on the moved result, bit for bit. The guard
// takes a pair back on the triangle further off LBS, and leaves the other's correction.
#include "contact.h"
#include "asset.h"
#include "asset_derive.h"
#include "brute_force_pairs.h"
#include "instance.h"
#include "lbs_guard.h"
#include "skin_blend.h"
#include "runtime/runtime_models.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

using skelform::runtime::build_contact_mesh;
using skelform::runtime::ContactMesh;
using skelform::runtime::ContactStats;
using skelform::runtime::ContactWorkspace;
using skelform::runtime::make_contact_workspace;

namespace {
// The pass's scratch with its own grid, as it runs outside the guard (the handle driver).
ContactWorkspace make_grid_workspace(const ContactMesh& mesh) {
  ContactWorkspace workspace = make_contact_workspace(mesh, {});
  skelform::runtime::add_contact_grid(mesh, workspace);
  return workspace;
}
}  // namespace
using skelform::runtime::resolve_contacts;

namespace {

// A unit cube [0, 1]³ and an octahedron of radius 0.5 about (0.5, 0.5, 1.5) whose lowest
// vertex is at height `tip` (1.0 would touch the cube's top face). Octahedron first: vertex 0
// is the tip. Both outward-facing. `duplicate_tip` adds a second vertex at the tip's position
// that two of the tip's triangles use instead (a glTF seam).
struct Scene {
  std::vector<glm::vec3> positions;
  std::vector<uint32_t> triangles;

  explicit Scene(float tip, bool duplicate_tip = false) {
    const glm::vec3 c(0.5f, 0.5f, 1.5f);
    positions = {glm::vec3(c.x, c.y, tip),   c + glm::vec3(0.5f, 0, 0),  c + glm::vec3(0, 0.5f, 0),
                 c + glm::vec3(-0.5f, 0, 0), c + glm::vec3(0, -0.5f, 0), c + glm::vec3(0, 0, 0.5f)};
    const uint32_t tip_copy = duplicate_tip ? 6u : 0u;
    if (duplicate_tip) positions.push_back(positions[0]);
    // Lower half (around the tip), then upper half (around vertex 5), outward.
    const uint32_t octahedron[] = {0, 2, 1, tip_copy, 3, 2, tip_copy, 4, 3, 0, 1, 4,
                                   5, 1, 2, 5,        2, 3, 5,        3, 4, 5, 4, 1};
    triangles.assign(std::begin(octahedron), std::end(octahedron));
    const uint32_t base = uint32_t(positions.size());
    for (int i = 0; i < 8; ++i) positions.emplace_back(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1));
    // Cube faces, outward: corners indexed by bits (x, y, z).
    const uint32_t cube[] = {0, 2, 3, 0, 3, 1,   // z = 0
                             4, 5, 7, 4, 7, 6,   // z = 1
                             0, 1, 5, 0, 5, 4,   // y = 0
                             2, 6, 7, 2, 7, 3,   // y = 1
                             0, 4, 6, 0, 6, 2,   // x = 0
                             1, 3, 7, 1, 7, 5};  // x = 1
    for (uint32_t i : cube) triangles.push_back(base + i);
  }

  // Intersecting pairs of non-adjacent triangles, with vertices at one rest position welded (a
  // seam's copies are one vertex: the triangles around it are adjacent).
  size_t pairs(const std::vector<glm::vec3>& at) const {
    std::vector<uint32_t> weld(positions.size());
    for (size_t v = 0; v < positions.size(); ++v) {
      weld[v] = uint32_t(v);
      for (size_t u = 0; u < v; ++u)
        if (positions[u] == positions[v]) {
          weld[v] = weld[u];
          break;
        }
    }
    std::vector<std::array<uint32_t, 3>> welded;
    for (size_t t = 0; t < triangles.size(); t += 3)
      welded.push_back({weld[triangles[t]], weld[triangles[t + 1]], weld[triangles[t + 2]]});
    return skelform::test::brute_force_pairs(welded, [&](uint32_t v) { return glm::dvec3(at[v]); }).size();
  }
};

// The scene's rest pose: the octahedron's tip (and its seam copy) lifted clear of the cube,
// by 0.35 of the cube's size. Pairs that intersect at rest are the modeller's, which the pass
// leaves alone (contact.h ContactMesh::rest_pairs).
std::vector<glm::vec3> rest_of(const Scene& scene) {
  std::vector<glm::vec3> rest = scene.positions;
  float lo = rest[0].x, hi = rest[0].x;
  for (const glm::vec3& p : rest) lo = std::min(lo, p.x), hi = std::max(hi, p.x);
  const glm::vec3 tip = rest[0];
  for (glm::vec3& p : rest)
    if (p == tip) p.z += 0.35f * (hi - lo);
  return rest;
}

// The scene open (the cube's bottom face dropped: the octahedron's 8 triangles come first), so
// that the guard's volume step, which would check a result afresh, stays out of it: a
// deformable of one primitive whose every vertex takes all of skelform's result, welded at
// `rest`.
struct OpenScene {
  std::vector<uint32_t> triangles;
  skelform::runtime::Deformable d{skelform::runtime::AllocatorRef{}};
  ContactMesh mesh{skelform::runtime::AllocatorRef{}};
  OpenScene(const Scene& scene, const std::vector<glm::vec3>& rest) : triangles(scene.triangles) {
    triangles.erase(triangles.begin() + 24, triangles.begin() + 30);
    const uint32_t n = uint32_t(rest.size());
    d.vertex_count = n;
    d.skelform_weight.assign(n, 1.0f);
    skelform::runtime::PrimitiveRecord primitive;
    primitive.vertex_count = n;
    primitive.triangle_count = uint32_t(triangles.size() / 3);
    primitive.has_normals = true;
    d.primitives.push_back(primitive);
    mesh = build_contact_mesh(rest.data(), n, triangles.data(), triangles.size() / 3, {});
  }
};

struct Pass {
  std::vector<glm::vec3> rest;
  ContactMesh mesh;
  ContactWorkspace workspace;
  explicit Pass(const Scene& scene)
      : rest(rest_of(scene)),
        mesh(build_contact_mesh(rest.data(), uint32_t(rest.size()), scene.triangles.data(), scene.triangles.size() / 3,
                                {})),
        workspace(make_grid_workspace(mesh)) {}
  ContactStats run(std::vector<glm::vec3>& x) {
    return resolve_contacts(mesh, 1.0f, x.data(), uint32_t(x.size()), workspace);
  }
};

}  // namespace

TEST_CASE("contact: a tip pushed through a face comes back out along the face normal, nothing else moves") {
  const Scene scene(0.9f);  // 0.1 below the cube's top face
  std::vector<glm::vec3> x = scene.positions;
  const size_t before = scene.pairs(x);
  REQUIRE(before > 0);
  Pass pass(scene);
  CHECK(pass.mesh.vertex_count == 14);
  const ContactStats stats = pass.run(x);
  MESSAGE("pairs " << before << " -> " << scene.pairs(x) << ", tip at z = " << x[0].z);
  CHECK(stats.pairs_before == before);
  CHECK(stats.moved == 1);
  CHECK(scene.pairs(x) == 0);
  // The tip left along the top face's normal (+z), at least to the face, by at most the cap.
  CHECK(x[0].x == scene.positions[0].x);
  CHECK(x[0].y == scene.positions[0].y);
  CHECK(x[0].z > 1.0f);
  CHECK(x[0].z - scene.positions[0].z <= pass.mesh.cap * 1.0001f);
  for (size_t v = 1; v < x.size(); ++v) CHECK(std::memcmp(&x[v], &scene.positions[v], sizeof(glm::vec3)) == 0);
}

// After its first sweep the pass passes over an active vertex that did not move when it last
// looked at it and near which nothing has moved since (resolve_contacts). That must change
// nothing but the work: the same scene with the skipping off (no room for its looks) gives the
// same bits, and spends more of the budget. The tip moves in the first sweep, so a second
// runs; there the cube's corners, which did not move and saw no move after their look, are
// passed over.
TEST_CASE("contact: passing over vertices near which nothing moved changes nothing but the work") {
  for (const float tip : {0.9f, 0.75f}) {
    CAPTURE(tip);
    const Scene scene(tip);
    std::vector<glm::vec3> skipping = scene.positions, looking = scene.positions;
    Pass with(scene), without(scene);
    without.workspace.seen.clear();  // no room: every active vertex is looked at in every sweep
    const ContactStats a = with.run(skipping), b = without.run(looking);
    CHECK(a.pairs_before == b.pairs_before);
    CHECK(a.moved == b.moved);
    CHECK(a.moved > 0);
    CHECK(std::memcmp(skipping.data(), looking.data(), skipping.size() * sizeof(glm::vec3)) == 0);
    MESSAGE("budget left " << with.workspace.budget.left << " with the skipping, " << without.workspace.budget.left
                           << " without");
    CHECK(with.workspace.budget.left > without.workspace.budget.left);
  }
}

// A vertex of high valence: the pass tells a star's triangles from their neighbours by a mask
// of 32 bits (Grid::gather), and a star of more triangles goes through the corner test for the
// rest. A cone of 40 triangles whose apex is pushed 0.1 through the cube's top face, with a
// cap of 40 more: the apex comes back out, nothing else moves.
TEST_CASE("contact: an apex with 40 triangles around it is pushed out like a tip of four") {
  constexpr uint32_t kRing = 40;
  std::vector<glm::vec3> x{glm::vec3(0.5f, 0.5f, 0.9f)};  // the apex
  for (uint32_t i = 0; i < kRing; ++i) {
    const float angle = 6.2831853f * float(i) / float(kRing);
    x.emplace_back(0.5f + 0.4f * std::cos(angle), 0.5f + 0.4f * std::sin(angle), 1.5f);
  }
  x.emplace_back(0.5f, 0.5f, 1.5f);  // the cap's centre
  std::vector<uint32_t> triangles;
  for (uint32_t i = 0; i < kRing; ++i) {
    const uint32_t a = 1 + i, b = 1 + (i + 1) % kRing;
    triangles.insert(triangles.end(), {0, a, b, kRing + 1, b, a});
  }
  const uint32_t base = uint32_t(x.size());
  for (int i = 0; i < 8; ++i) x.emplace_back(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1));
  for (uint32_t i :
       {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4, 2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5})
    triangles.push_back(base + i);
  std::vector<glm::vec3> rest = x;
  rest[0].z = 1.2f;  // apart at rest
  std::vector<std::array<uint32_t, 3>> indexed;
  for (size_t t = 0; t < triangles.size(); t += 3)
    indexed.push_back({triangles[t], triangles[t + 1], triangles[t + 2]});
  auto pairs = [&](const std::vector<glm::vec3>& at) {
    return skelform::test::brute_force_pairs(indexed, [&](uint32_t v) { return glm::dvec3(at[v]); }).size();
  };
  const ContactMesh mesh = build_contact_mesh(rest.data(), uint32_t(rest.size()), triangles.data(), indexed.size(), {});
  ContactWorkspace workspace = make_grid_workspace(mesh);
  REQUIRE(mesh.incident_offsets[1] - mesh.incident_offsets[0] == kRing);
  const std::vector<glm::vec3> posed = x;
  const size_t before = pairs(x);
  REQUIRE(before >= kRing);  // every triangle around the apex crosses the top face
  const ContactStats stats = resolve_contacts(mesh, 1.0f, x.data(), uint32_t(x.size()), workspace);
  MESSAGE("pairs " << before << " -> " << pairs(x) << ", apex at z = " << x[0].z);
  // (Detection passes over cells of near-parallel triangles, Grid::for_each_pair: it needs only
  // one pair per vertex to resolve.)
  CHECK(stats.pairs_before > 0);
  CHECK(stats.pairs_before <= before);
  CHECK(stats.moved == 1);
  CHECK(pairs(x) == 0);
  CHECK(x[0].z > 1.0f);
  for (size_t v = 1; v < x.size(); ++v) CHECK(std::memcmp(&x[v], &posed[v], sizeof(glm::vec3)) == 0);
}

TEST_CASE("contact: no intersection, no change; welded copies move together; non-finite input is left alone") {
  SUBCASE("apart") {
    const Scene scene(1.1f);
    std::vector<glm::vec3> x = scene.positions;
    REQUIRE(scene.pairs(x) == 0);
    Pass pass(scene);
    const ContactStats stats = pass.run(x);
    CHECK(stats.pairs_before == 0);
    CHECK(stats.moved == 0);
    CHECK(std::memcmp(x.data(), scene.positions.data(), x.size() * sizeof(glm::vec3)) == 0);
  }
  SUBCASE("a seam at the tip") {
    const Scene scene(0.9f, true);
    std::vector<glm::vec3> x = scene.positions;
    Pass pass(scene);
    CHECK(pass.mesh.vertex_count == 14);  // the copy welds to the tip
    CHECK(pass.mesh.weld[6] == pass.mesh.weld[0]);
    REQUIRE(scene.pairs(x) > 0);
    pass.run(x);
    CHECK(scene.pairs(x) == 0);
    CHECK(x[0].z > 1.0f);
    CHECK(std::memcmp(&x[0], &x[6], sizeof(glm::vec3)) == 0);
  }
  SUBCASE("NaN") {
    const Scene scene(0.9f);
    std::vector<glm::vec3> x = scene.positions;
    x[3].y = std::numeric_limits<float>::quiet_NaN();
    const std::vector<glm::vec3> given = x;
    Pass pass(scene);
    const ContactStats stats = pass.run(x);
    CHECK(stats.moved == 0);
    CHECK(std::memcmp(x.data(), given.data(), x.size() * sizeof(glm::vec3)) == 0);
  }
  SUBCASE("scale") {
    // Lengths are relative to the mean rest edge: ×1024 (exact in float) gives the same bits ×1024.
    const Scene scene(0.9f);
    Scene scaled(0.9f);
    for (glm::vec3& p : scaled.positions) p *= 1024.0f;
    std::vector<glm::vec3> x = scene.positions, y = scaled.positions;
    Pass(scene).run(x);
    Pass(scaled).run(y);
    for (size_t v = 0; v < x.size(); ++v) CHECK(std::memcmp(&y[v], &(x[v] *= 1024.0f), sizeof(glm::vec3)) == 0);
  }
}

TEST_CASE("contact: a mesh of very unequal triangles is bucketed whole, and its contact resolved") {
  // Three nested octahedra of radius 1, 0.9 and 0.8 (24 large triangles, each box an eighth of
  // the whole) around a 10³ lattice of triangles a thousandth of that size: even at 4 cells
  // per triangle, cells sized by the mean triangle give the large ones more entries than the
  // grid reserves for all (8 per triangle). Before the grid coarsened to fit them, every
  // triangle past the reserve (here 1,004, nearly all the small ones) was tested against every
  // triangle: over a million pair visits, where bucketed whole the pass needs a few thousand.
  std::vector<glm::vec3> rest;
  std::vector<uint32_t> triangles;
  for (float r : {1.0f, 0.9f, 0.8f}) {
    const uint32_t o = uint32_t(rest.size());
    for (const glm::vec3& axis : {glm::vec3(1, 0, 0), glm::vec3(0, 1, 0), glm::vec3(0, 0, 1)}) {
      rest.push_back(r * axis);
      rest.push_back(-r * axis);
    }
    for (uint32_t x : {0u, 1u})
      for (uint32_t y : {2u, 3u})
        for (uint32_t z : {4u, 5u}) {
          const bool outward = (x == 0) == (y == 2) ? z == 4 : z == 5;  // winding of an outward face
          for (uint32_t k : outward ? std::array<uint32_t, 3>{x, y, z} : std::array<uint32_t, 3>{x, z, y})
            triangles.push_back(o + k);
        }
  }
  constexpr int kSide = 10;
  for (int n = 0; n < kSide * kSide * kSide; ++n) {
    const glm::vec3 at =
        glm::vec3(float(n % kSide), float(n / kSide % kSide), float(n / (kSide * kSide))) * (0.5f / (kSide - 1)) -
        glm::vec3(0.25f);
    const uint32_t first = uint32_t(rest.size());
    rest.push_back(at);
    rest.push_back(at + glm::vec3(0.0f, 1e-3f, 0.0f));
    rest.push_back(at + glm::vec3(1e-3f, 0.0f, 0.0f));  // facing -z
    for (uint32_t k = 0; k < 3; ++k) triangles.push_back(first + k);
  }
  const ContactMesh mesh =
      build_contact_mesh(rest.data(), uint32_t(rest.size()), triangles.data(), triangles.size() / 3, {});
  REQUIRE(mesh.rest_pairs.empty());
  ContactWorkspace workspace = make_grid_workspace(mesh);
  // The first small triangle moved onto the second and through it, tilted and facing up.
  std::vector<glm::vec3> x = rest;
  const uint32_t moved = 18, into = 21;
  const glm::vec3 p = rest[into] + glm::vec3(2e-4f, 2e-4f, 0.0f);
  x[moved] = p + glm::vec3(0.0f, 0.0f, -2e-4f);
  x[moved + 1] = p + glm::vec3(5e-4f, 0.0f, 2e-4f);
  x[moved + 2] = p + glm::vec3(0.0f, 5e-4f, 2e-4f);
  std::vector<std::array<uint32_t, 3>> corners;
  for (size_t t = 0; t < triangles.size(); t += 3)
    corners.push_back({triangles[t], triangles[t + 1], triangles[t + 2]});
  auto pairs = [&] { return skelform::test::brute_force_pairs(corners, [&](uint32_t v) { return glm::dvec3(x[v]); }); };
  REQUIRE(pairs().size() == 1);
  const ContactStats stats = resolve_contacts(mesh, 1.0f, x.data(), uint32_t(x.size()), workspace);
  const uint64_t visits =
      skelform::runtime::PairBudget(mesh.triangle_count, skelform::runtime::kContactBudgetPasses).left -
      workspace.budget.left;
  MESSAGE("pair visits: " << visits);
  CHECK(visits < uint64_t(mesh.triangle_count) * mesh.triangle_count / 16);
  CHECK(stats.pairs_before == 1);
  CHECK(stats.moved > 0);
  CHECK(pairs().empty());
}

TEST_CASE("contact: with a blend, the pass resolves what the output shows and moves only what skelform may") {
  // LBS L holds the tip 0.1 above the cube's top face, skelform's K far below it, and the tip
  // takes a twentieth of skelform's result: the output L + w·(K − L) has it 0.1 inside (z 0.9).
  // The cube's corners are rigid (w = 0; K = L there). At rest the tip is clear of the cube.
  constexpr float w = 0.05f;
  const Scene scene(1.1f - 0.2f / w), rest_scene(0.9f);
  std::vector<glm::vec3> lbs = scene.positions;
  lbs[0].z = 1.1f;
  std::vector<float> weight(scene.positions.size(), 0.0f);
  auto blended = [&](const std::vector<glm::vec3>& k) {
    std::vector<glm::vec3> out(k.size());
    for (size_t v = 0; v < k.size(); ++v) out[v] = lbs[v] + weight[v] * (k[v] - lbs[v]);
    return out;
  };
  SUBCASE("the tip takes a twentieth") {
    for (size_t v = 0; v < 6; ++v) weight[v] = w;
    std::vector<glm::vec3> k = scene.positions;
    REQUIRE(blended(k)[0].z == doctest::Approx(0.9f));
    REQUIRE(scene.pairs(blended(k)) > 0);
    Pass pass(rest_scene);
    const ContactStats stats =
        resolve_contacts(pass.mesh, 1.0f, k.data(), uint32_t(k.size()), pass.workspace, {lbs.data(), weight.data()});
    const std::vector<glm::vec3> out = blended(k);
    MESSAGE("output tip z = " << out[0].z << ", K tip z = " << k[0].z << ", cap " << pass.mesh.cap);
    CHECK(stats.moved == 1);
    CHECK(scene.pairs(out) == 0);
    // The whole push reaches the output (on K it is twenty times as long), within the cap.
    CHECK(out[0].z > 1.0f);
    CHECK(out[0].z - 0.9f <= pass.mesh.cap * 1.0001f);
    CHECK(k[0].z - scene.positions[0].z == doctest::Approx((out[0].z - 0.9f) / w));
    for (size_t v = 1; v < k.size(); ++v) CHECK(std::memcmp(&k[v], &scene.positions[v], sizeof(glm::vec3)) == 0);
    // The same pass on K alone moves K's tip by at most a cap, a twentieth of which reaches
    // the output: still inside.
    std::vector<glm::vec3> on_k = scene.positions;
    Pass(rest_scene).run(on_k);
    CHECK(scene.pairs(blended(on_k)) > 0);
  }
  SUBCASE("against a rigid part, the whole push") {
    // The cube cannot move (w = 0): nothing takes the other half of each pair's push, so the tip
    // takes it whole, (gap − distance) per pair, all along the face's normal; with the cap out
    // of the way it lands there in one move.
    for (size_t v = 0; v < 6; ++v) weight[v] = w;
    std::vector<glm::vec3> k = scene.positions;
    Pass pass(rest_scene);
    pass.mesh.cap *= 100.0f;
    const ContactStats stats =
        resolve_contacts(pass.mesh, 1.0f, k.data(), uint32_t(k.size()), pass.workspace, {lbs.data(), weight.data()});
    REQUIRE(stats.moved == 1);
    const float expected = float(stats.pairs_before) * (pass.mesh.gap + 0.1f);
    CHECK(blended(k)[0].z - 0.9f == doctest::Approx(expected).epsilon(1e-3));
  }
  SUBCASE("a seam between a blended and a rigid copy of the tip stays closed") {
    // The tip's copy (a glTF seam) takes none of skelform's result: moving the welded tip would
    // leave that copy behind, so it does not move.
    const Scene seamed(1.1f - 0.2f / w, true), seamed_rest(0.9f, true);
    std::vector<glm::vec3> seam_lbs = seamed.positions;
    seam_lbs[0].z = seam_lbs[6].z = 1.1f;
    std::vector<float> seam_weight(seamed.positions.size(), 0.0f);
    for (size_t v = 0; v < 6; ++v) seam_weight[v] = w;  // vertex 6, the copy, stays at 0
    std::vector<glm::vec3> k = seamed.positions;
    k[6] = seam_lbs[6];  // K = L where w = 0
    const std::vector<glm::vec3> given = k;
    Pass pass(seamed_rest);
    REQUIRE(pass.mesh.weld[6] == pass.mesh.weld[0]);
    const ContactStats stats = resolve_contacts(pass.mesh, 1.0f, k.data(), uint32_t(k.size()), pass.workspace,
                                                {seam_lbs.data(), seam_weight.data()});
    CHECK(stats.pairs_before > 0);
    CHECK(stats.moved == 0);
    CHECK(std::memcmp(k.data(), given.data(), k.size() * sizeof(glm::vec3)) == 0);
  }
  SUBCASE("a rigid tip stays where LBS puts it") {
    // w = 0 at the tip: the output is L, which the pass leaves alone even where K is deep in.
    std::vector<glm::vec3> k = scene.positions;
    lbs[0].z = 0.95f;
    REQUIRE(scene.pairs(blended(k)) > 0);
    Pass pass(rest_scene);
    const ContactStats stats =
        resolve_contacts(pass.mesh, 1.0f, k.data(), uint32_t(k.size()), pass.workspace, {lbs.data(), weight.data()});
    CHECK(stats.pairs_before > 0);
    CHECK(stats.moved == 0);
    CHECK(std::memcmp(k.data(), scene.positions.data(), k.size() * sizeof(glm::vec3)) == 0);
  }
}

TEST_CASE("contact: sf_instance_set_contacts - arguments; the pass is output only") {
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  sf_instance *with = nullptr, *without = nullptr;
  REQUIRE(sf_instance_create(model.asset, 0, &with) == SF_OK);
  REQUIRE(sf_instance_create(model.asset, 0, &without) == SF_OK);
  CHECK(sf_instance_set_contacts(nullptr, 1) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_set_contacts(with, 2) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(std::strstr(sf_instance_last_error(with), "not 0 or 1") != nullptr);
  REQUIRE(sf_instance_set_contacts(with, 1) == SF_OK);  // on by default: no change
  REQUIRE(sf_instance_set_contacts(with, 1) == SF_OK);  // again: no change
  // Off: the next evaluation equals the one of an instance turned off from the start, bit for
  // bit (the pass never fed the fairing's warm start); on again, it equals a fresh instance's.
  REQUIRE(sf_instance_set_contacts(without, 0) == SF_OK);
  REQUIRE(sf_instance_set_contacts(with, 0) == SF_OK);
  const std::vector<glm::mat4> pose = skelform::test::bend_pose(model, 1, 2.3f, glm::vec3(1, 0, 0));
  auto evaluate = [&](sf_instance* i) {
    REQUIRE(sf_instance_set_joint_matrices(i, &pose[0][0][0], pose.size(), 0) == SF_OK);
    REQUIRE(sf_instance_evaluate(i, nullptr) == SF_OK);
    return skelform::test::write_all(i, model.asset);
  };
  auto same = [](const skelform::test::Evaluated& a, const skelform::test::Evaluated& b) {
    return std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(glm::vec3)) == 0 &&
           std::memcmp(a.normals.data(), b.normals.data(), a.normals.size() * sizeof(glm::vec3)) == 0;
  };
  CHECK(same(evaluate(with), evaluate(without)));
  sf_instance* fresh = nullptr;
  REQUIRE(sf_instance_create(model.asset, 0, &fresh) == SF_OK);
  REQUIRE(sf_instance_set_contacts(with, 1) == SF_OK);
  REQUIRE(sf_instance_set_contacts(without, 1) == SF_OK);
  const skelform::test::Evaluated on = evaluate(fresh);
  CHECK(same(evaluate(with), on));
  CHECK(same(evaluate(without), on));
  // The pass's own grid exists only where it runs without the guard: with a handle set.
  CHECK(!fresh->contact.grid);
  uint32_t handle = 0;
  REQUIRE(sf_instance_set_handle_set(fresh, &handle, 1, nullptr, 0) == SF_OK);
  CHECK(fresh->contact.grid);
  REQUIRE(sf_instance_set_contacts(fresh, 0) == SF_OK);
  CHECK(fresh->contact.entries.empty());
  REQUIRE(sf_instance_set_contacts(fresh, 1) == SF_OK);
  CHECK(fresh->contact.grid);
  sf_instance_destroy(fresh);
  sf_instance_destroy(with);
  sf_instance_destroy(without);
}

TEST_CASE("contact: pairs that intersect at rest are the modeller's and stay") {
  // The tip 0.1 inside the cube both at rest and now: nothing to resolve.
  const Scene scene(0.9f);
  std::vector<glm::vec3> x = scene.positions;
  ContactMesh mesh = build_contact_mesh(scene.positions.data(), uint32_t(scene.positions.size()),
                                        scene.triangles.data(), scene.triangles.size() / 3, {});
  REQUIRE(scene.pairs(x) > 0);
  CHECK(mesh.rest_pairs.size() == scene.pairs(x));
  ContactWorkspace workspace = make_grid_workspace(mesh);
  const ContactStats stats = resolve_contacts(mesh, 1.0f, x.data(), uint32_t(x.size()), workspace);
  CHECK(stats.moved == 0);
  CHECK(std::memcmp(x.data(), scene.positions.data(), x.size() * sizeof(glm::vec3)) == 0);
}

// A vertex the pass moves for a new pair must not be pushed out of the pairs the model has at
// rest. The tip, modelled 0.1 deep in the cube's top face, swings out through the side face
// x = 1 (the top face's pairs are the rest's): the pass clears the side's pairs with a push
// along the side's normal and the tip stays below the top face's plane, where pushing out of
// the rest pairs too lifted it 0.2 above it. (Leaving the rest pairs out of the counts as well
// is measured on the corpus, docs/tuning.md; this scene does not tell the counts apart.)
TEST_CASE("contact: a vertex modelled into a part is moved for its new pairs only") {
  const Scene scene(0.9f);
  std::vector<glm::vec3> x = scene.positions;
  x[0] = glm::vec3(1.1f, 0.5f, 0.9f);
  const ContactMesh mesh = build_contact_mesh(scene.positions.data(), uint32_t(scene.positions.size()),
                                              scene.triangles.data(), scene.triangles.size() / 3, {});
  REQUIRE(!mesh.rest_pairs.empty());
  const size_t before = scene.pairs(x);
  REQUIRE(before > mesh.rest_pairs.size());  // new pairs, with the side face
  ContactWorkspace workspace = make_grid_workspace(mesh);
  const ContactStats stats = resolve_contacts(mesh, 1.0f, x.data(), uint32_t(x.size()), workspace);
  MESSAGE("pairs " << before << " -> " << scene.pairs(x) << " (" << mesh.rest_pairs.size()
                   << " at rest), tip at z = " << x[0].z);
  CHECK(stats.moved == 1);
  CHECK(scene.pairs(x) <= mesh.rest_pairs.size());
  CHECK(x[0].z > 0.9f);  // it moved,
  CHECK(x[0].z < 1.0f);  // and stays under the face it was modelled into
  for (size_t v = 1; v < x.size(); ++v) CHECK(std::memcmp(&x[v], &scene.positions[v], sizeof(glm::vec3)) == 0);
}

namespace {

// The contact pass as the evaluation runs it inside the guard (api_evaluate.cpp ContactHook),
// keeping what the guard gave it.
class RecordingHook final : public skelform::runtime::FirstRoundHook {
 public:
  RecordingHook(const ContactMesh& mesh, std::vector<glm::vec3>& k, const std::vector<glm::vec3>& l,
                const std::vector<float>& w)
      : mesh_(mesh), k_(k), l_(l), w_(w), workspace_(make_contact_workspace(mesh, {})) {}
  const skelform::runtime::Array<uint32_t>& after_first_search(const skelform::runtime::ContactPairs& pairs) override {
    keys.assign(pairs.keys, pairs.keys + pairs.count);
    calls += 1;
    stats = resolve_contacts(mesh_, 1.0f, k_.data(), uint32_t(k_.size()), workspace_, {l_.data(), w_.data()}, &pairs);
    return workspace_.moved;
  }
  std::vector<uint64_t> keys;
  int calls = 0;
  ContactStats stats;

 private:
  const ContactMesh& mesh_;
  std::vector<glm::vec3>& k_;
  const std::vector<glm::vec3>& l_;
  const std::vector<float>& w_;
  ContactWorkspace workspace_;
};

}  // namespace

// The tip 0.1 deep in the cube (K), which the pass takes out, and the same with the pass's move
// capped at a hundredth of its own, which leaves it in: after the pass, the guard must drop the
// first search's verdicts on the moved tip in the one case and find its pairs again in the other.
TEST_CASE("contact: inside the guard, the pass detects from its search and the guard ends as if run afresh") {
  using namespace skelform::runtime;
  for (const float cap : {1.0f, 0.01f}) {
    CAPTURE(cap);
    const Scene scene(0.9f);
    const std::vector<glm::vec3> rest = rest_of(scene);  // LBS: the tip clear of the cube
    OpenScene open(scene, rest);
    const std::vector<uint32_t>& triangles = open.triangles;
    const Deformable& d = open.d;
    ContactMesh& mesh = open.mesh;
    const uint32_t n = uint32_t(rest.size());
    REQUIRE(mesh.weld.size() == n);
    REQUIRE(!mesh.closed);
    mesh.cap *= cap;
    const std::vector<float> w(n, 1.0f);
    const std::vector<glm::vec3> normals(n, glm::vec3(0, 0, 1));

    struct Result {
      std::vector<glm::vec3> positions, normals;
    };
    auto guard = [&](std::vector<glm::vec3>& k, FirstRoundHook* hook) {
      std::vector<glm::vec3> l = rest, kn = normals, ln = normals;
      Result out{std::vector<glm::vec3>(n), std::vector<glm::vec3>(n)};
      GuardWorkspace ws = make_guard_workspace(mesh, {});
      guard_and_blend(d, mesh, 1.0f, DenseOutput{k.data(), kn.data(), nullptr},
                      DenseOutput{l.data(), ln.data(), nullptr}, true,
                      DenseOutput{out.positions.data(), out.normals.data(), nullptr}, ws, hook);
      return out;
    };

    std::vector<glm::vec3> k = scene.positions;
    RecordingHook hook(mesh, k, rest, w);
    const Result inside = guard(k, &hook);
    REQUIRE(hook.calls == 1);
    // The guard handed over every intersecting pair at λ = 1 (here all have the moved tip as a
    // corner), as brute force finds them.
    std::vector<std::array<uint32_t, 3>> welded;
    for (size_t t = 0; t < triangles.size(); t += 3)
      welded.push_back({mesh.weld[triangles[t]], mesh.weld[triangles[t + 1]], mesh.weld[triangles[t + 2]]});
    auto pairs_at = [&](const std::vector<glm::vec3>& x) {
      return skelform::test::brute_force_pairs(welded,
                                               [&](uint32_t v) { return glm::dvec3(x[mesh.representative[v]]); });
    };
    std::vector<uint64_t> expected;
    for (const auto& [s, t] : pairs_at(scene.positions)) expected.push_back(uint64_t(s) << 32 | t);
    std::vector<uint64_t> keys = hook.keys;
    std::sort(keys.begin(), keys.end());
    CHECK(!expected.empty());
    CHECK(keys == expected);
    CHECK(hook.stats.pairs_before == expected.size());
    CHECK(hook.stats.moved > 0);  // the pass moved the tip: the guard re-searched around it

    // The same guard, with no pass, on the result the pass left: the same bits.
    std::vector<glm::vec3> moved = k;
    const Result afresh = guard(moved, nullptr);
    CHECK(std::memcmp(inside.positions.data(), afresh.positions.data(), n * sizeof(glm::vec3)) == 0);
    CHECK(std::memcmp(inside.normals.data(), afresh.normals.data(), n * sizeof(glm::vec3)) == 0);
    // Which case this is: the pass alone cleared the tip, but not with its move capped.
    CHECK(pairs_at(k).empty() == (cap == 1.0f));
  }
}

// Junction anchors (lbs_guard.h anchor_junctions): the scene's octahedron, blended between two
// joints, is modelled with its tip 0.1 deep in the cube, which one joint carries rigidly. The
// second joint lifts the octahedron: LBS takes the tip half-way out of the cube, which slides the
// curve where the two cross over other triangles. Anchored, the tip's triangles follow the cube,
// so the pairs the model has at rest stay those pairs, and the guard lets them be.
TEST_CASE("contact: a blended part modelled into a rigid one keeps its crossing with it") {
  using namespace skelform::runtime;
  const Scene scene(0.9f);
  const std::vector<glm::vec3>& rest = scene.positions;
  const uint32_t n = uint32_t(rest.size());
  // Open (the cube's bottom face dropped), so that the guard's volume step stays out of it: the
  // anchors stretch the octahedron, which changes its volume where LBS keeps it.
  std::vector<uint32_t> triangles = scene.triangles;
  triangles.erase(triangles.begin() + 24, triangles.begin() + 30);
  Deformable d{AllocatorRef{}};
  d.vertex_count = n;
  d.joint_count = 2;
  d.influences = 4;
  d.rest_positions.assign(rest.begin(), rest.end());
  d.dense_triangles.assign(triangles.begin(), triangles.end());
  d.dense_joints.assign(4 * size_t{n}, 0);
  d.dense_weights.assign(4 * size_t{n}, 0.0f);
  for (uint32_t v = 0; v < n; ++v) {
    const bool octahedron = v < 6;
    d.dense_joints[4 * v + 1] = 1;
    d.dense_weights[4 * v] = octahedron ? 0.5f : 1.0f;
    d.dense_weights[4 * v + 1] = octahedron ? 0.5f : 0.0f;
    d.skelform_weight.push_back(octahedron ? 1.0f : 0.0f);
  }
  PrimitiveRecord primitive;
  primitive.vertex_count = n;
  primitive.triangle_count = uint32_t(triangles.size() / 3);
  primitive.has_normals = true;
  d.primitives.push_back(primitive);
  d.welded = build_contact_mesh(rest.data(), n, triangles.data(), triangles.size() / 3, {});
  REQUIRE(!d.welded.rest_pairs.empty());
  REQUIRE(!d.welded.closed);
  loader::derive_junction_anchors(d);
  // The tip (vertex 0) and its ring cross the cube's top face: they follow a cube vertex.
  REQUIRE(!d.anchor_vertices.empty());
  CHECK(d.anchor_vertices[0] == 0);
  for (size_t k = 0; k < d.anchor_vertices.size(); ++k) {
    CHECK(d.anchor_vertices[k] < 6);
    CHECK(d.anchor_hosts[k] >= 6);
  }

  const glm::mat4 matrices[2] = {glm::mat4(1.0f), glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.0f, 1.0f))};
  std::vector<glm::vec3> l(n), k(n);
  for (uint32_t v = 0; v < n; ++v) {
    glm::mat4 m(0.0f);
    for (uint32_t j = 0; j < 2; ++j) m += d.dense_weights[4 * v + j] * matrices[d.dense_joints[4 * v + j]];
    l[v] = k[v] = glm::vec3(m * glm::vec4(rest[v], 1.0f));  // skelform's own result: LBS here
  }
  JointAffine affine[2];
  JointDualQuaternion dual_quaternion[2];
  for (int j = 0; j < 2; ++j) prepare_joint(matrices[j], affine[j], dual_quaternion[j]);
  anchor_junctions(d, affine, l.data(), k.data());
  std::vector<uint8_t> anchored(n, 0);
  for (uint32_t v : d.anchor_vertices) anchored[v] = 1;
  for (uint32_t v = 0; v < n; ++v) CHECK(glm::length(k[v] - (anchored[v] ? rest[v] : l[v])) < 1e-6f);

  const std::vector<glm::vec3> normals(n, glm::vec3(0, 0, 1));
  std::vector<glm::vec3> kn = normals, ln = normals, out(n), on(n);
  GuardWorkspace ws = make_guard_workspace(d.welded, {});
  guard_and_blend(d, d.welded, 1.0f, DenseOutput{k.data(), kn.data(), nullptr},
                  DenseOutput{l.data(), ln.data(), nullptr}, true, DenseOutput{out.data(), on.data(), nullptr}, ws);
  // The crossing is the model's: the guard keeps the anchors (LBS has no pair there).
  CHECK(scene.pairs(l) == 0);
  CHECK(scene.pairs(out) == scene.pairs(rest));
  for (uint32_t v = 0; v < n; ++v) CHECK(glm::length(out[v] - k[v]) < 1e-6f);
}

// The guard (lbs_guard.h) takes a pair back on the side that moved into it: the octahedron's tip
// pushed 0.35 down into the cube (K; L has it clear above), the cube's top face lifted by 0.01
// (a correction of its own, which does not clear the contact). Only the tip's share is lowered:
// the cube keeps its correction whole, and the output has no pair.
TEST_CASE("contact: the guard lowers the triangle further off LBS, and keeps the other's correction") {
  using namespace skelform::runtime;
  const Scene scene(0.9f);
  const std::vector<glm::vec3> rest = rest_of(scene);
  const OpenScene open(scene, rest);
  const Deformable& d = open.d;
  const ContactMesh& mesh = open.mesh;
  const uint32_t n = uint32_t(rest.size());
  REQUIRE(!mesh.closed);
  std::vector<glm::vec3> l = rest, k = scene.positions;
  std::vector<uint8_t> lifted(n, 0);
  for (uint32_t v = 6; v < n; ++v)
    if (k[v].z == 1.0f) {
      k[v].z += 0.01f;
      lifted[v] = 1;
    }
  REQUIRE(std::count(lifted.begin(), lifted.end(), 1) == 4);
  REQUIRE(scene.pairs(l) == 0);
  REQUIRE(scene.pairs(k) > 0);
  const std::vector<glm::vec3> normals(n, glm::vec3(0, 0, 1));
  std::vector<glm::vec3> kn = normals, ln = normals, out(n), on(n);
  GuardWorkspace ws = make_guard_workspace(mesh, {});
  guard_and_blend(d, mesh, 1.0f, DenseOutput{k.data(), kn.data(), nullptr}, DenseOutput{l.data(), ln.data(), nullptr},
                  true, DenseOutput{out.data(), on.data(), nullptr}, ws);
  CHECK(scene.pairs(out) == 0);
  for (uint32_t v = 6; v < n; ++v) CHECK(out[v] == k[v]);  // the whole cube, its lifted top included
  CHECK(out[0] != k[0]);                                   // the tip gave its share back
  CHECK(out[0].z > 1.01f);
}
