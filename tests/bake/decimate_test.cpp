// Control-mesh decimation: size, topology and provenance of the control vertices.
#include "mesh_checks.h"
#include "skelform/bake/decimate.h"
#include "skelform/bake/procedural.h"
#include "skelform/bake/subdivision.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <map>

using namespace skelform::bake;

TEST_CASE("decimation reaches the target on a closed mesh and keeps it closed, genus 0") {
  const TriangleMesh dense = make_icosphere(2.0, 5);  // 20,480 triangles
  const DecimatedMesh control = decimate(dense, 2000);
  CHECK(control.decimated);
  CHECK(control.mesh.triangles.size() <= 2000);
  CHECK(control.mesh.triangles.size() >= 1500);
  const skelform::test::MeshReport report = skelform::test::analyze_mesh(control.mesh);
  CHECK_MESSAGE(report.manifold_problem.empty(), report.manifold_problem);
  CHECK(report.euler == 2);
  CHECK(report.components == 1);
  CHECK(report.volume > 0);
  // Edge collapse keeps survivors: every control vertex is exactly one input vertex.
  REQUIRE(control.source_vertex.size() == control.mesh.positions.size());
  for (size_t v = 0; v < control.mesh.positions.size(); ++v)
    CHECK(control.mesh.positions[v] == dense.positions[control.source_vertex[v]]);
}

TEST_CASE("a mesh already near the target is only compacted") {
  TriangleMesh mesh = make_capsule(1.0, 3.0, 16, 6, 4);
  mesh.positions.push_back({9, 9, 9});  // unreferenced: dropped by compaction
  const DecimatedMesh control = decimate(mesh, mesh.triangles.size());
  CHECK_FALSE(control.decimated);
  CHECK(control.mesh.triangles.size() == mesh.triangles.size());
  CHECK(control.mesh.positions.size() == mesh.positions.size() - 1);
}

// decimate.h: a control mesh at the target is bound at Loop level 0 unless the input has more
// than twice its triangles (choose_subdivision_level), so only those inputs are decimated, and
// their control mesh is then refined at least once.
TEST_CASE("a mesh up to twice the target is kept whole; beyond it, decimated and refined") {
  const TriangleMesh dense = make_icosphere(1.0, 4);  // 5,120 triangles
  const size_t n = dense.triangles.size();
  const DecimatedMesh kept = decimate(dense, n / 2);
  CHECK_FALSE(kept.decimated);
  CHECK(kept.mesh.triangles.size() == n);
  CHECK(choose_subdivision_level(n / 2, n) == 0);  // why: decimated to n / 2, it would stay at level 0
  for (const size_t target : {n / 2 - 1, n / 3, n / 8}) {
    CAPTURE(target);
    const DecimatedMesh control = decimate(dense, target);
    CHECK(control.decimated);
    CHECK(control.mesh.triangles.size() <= target);
    CHECK(choose_subdivision_level(control.mesh.triangles.size(), n) >= 1);
  }
}

TEST_CASE("open borders stay where they are") {
  TriangleMesh dense = make_icosphere(1.0, 5);
  // Cut a cap off: every triangle with a corner above z = 0.8 goes, leaving a border loop.
  std::vector<Triangle> kept;
  for (const Triangle& t : dense.triangles) {
    bool above = false;
    for (uint32_t v : t) above = above || dense.positions[v].z > 0.8;
    if (!above) kept.push_back(t);
  }
  dense.triangles = kept;
  std::vector<int> edge_use;
  std::map<std::pair<uint32_t, uint32_t>, int> edges;
  for (const Triangle& t : dense.triangles)
    for (int k = 0; k < 3; ++k) ++edges[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}];
  std::vector<bool> border(dense.positions.size(), false);
  for (const auto& [edge, uses] : edges)
    if (uses == 1) border[edge.first] = border[edge.second] = true;

  const DecimatedMesh control = decimate(dense, 1500);
  std::vector<bool> kept_vertex(dense.positions.size(), false);
  for (uint32_t source : control.source_vertex) kept_vertex[source] = true;
  for (size_t v = 0; v < border.size(); ++v)
    if (border[v]) CHECK(kept_vertex[v]);
}
