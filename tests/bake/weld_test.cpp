// Welding: exact-position merge, first-occurrence order, degenerate/duplicate removal,
// and the maps between original and welded vertices.
#include "skelform/bake/input.h"
#include "skelform/bake/weld.h"

#include "test_support.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

using namespace skelform::bake;

namespace {

// A unit cube with every face owning its own 4 corners (as a glTF exporter splits vertices
// at normal seams): 24 vertices, 12 triangles.
InputMesh split_cube() {
  InputMesh mesh;
  const int faces[6][4][3] = {
      {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}}, {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}},
      {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}}, {{0, 1, 0}, {0, 1, 1}, {1, 1, 1}, {1, 1, 0}},
      {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}, {0, 1, 0}}, {{1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {1, 0, 1}},
  };
  for (const auto& face : faces) {
    const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
    for (const auto& c : face) mesh.positions.push_back(Vec3(c[0], c[1], c[2]));
    mesh.triangles.push_back({base, base + 1, base + 2});
    mesh.triangles.push_back({base, base + 2, base + 3});
  }
  return mesh;
}

// Every original vertex lands on a welded vertex with the very same position, and the
// inverse map points at the first original vertex of each welded one.
void check_maps(const InputMesh& input, const WeldedMesh& welded) {
  REQUIRE(welded.welded_of_original.size() == input.positions.size());
  REQUIRE(welded.original_of_welded.size() == welded.mesh.positions.size());
  bool all_identical = true;
  for (size_t i = 0; i < input.positions.size(); ++i) {
    const uint32_t w = welded.welded_of_original[i];
    if (w >= welded.mesh.positions.size() || welded.mesh.positions[w] != input.positions[i]) all_identical = false;
  }
  CHECK(all_identical);
  bool first_occurrence = true;
  for (size_t w = 0; w < welded.original_of_welded.size(); ++w) {
    const uint32_t o = welded.original_of_welded[w];
    if (welded.welded_of_original[o] != w) first_occurrence = false;
    // No earlier original vertex may map to w.
    for (uint32_t e = 0; e < o && first_occurrence; ++e)
      if (welded.welded_of_original[e] == w) first_occurrence = false;
    if (w > 0 && o <= welded.original_of_welded[w - 1]) first_occurrence = false;
  }
  CHECK(first_occurrence);
  REQUIRE(welded.original_triangle.size() == welded.mesh.triangles.size());
  bool triangles_consistent = true;
  for (size_t t = 0; t < welded.mesh.triangles.size(); ++t) {
    const Triangle& original = input.triangles[welded.original_triangle[t]];
    for (int c = 0; c < 3; ++c)
      if (welded.mesh.triangles[t][c] != welded.welded_of_original[original[c]]) triangles_consistent = false;
    if (t > 0 && welded.original_triangle[t] <= welded.original_triangle[t - 1]) triangles_consistent = false;
  }
  CHECK(triangles_consistent);
}

}  // namespace

TEST_CASE("weld: a cube split at its 6 face seams (24 vertices) welds to 8 vertices, 12 triangles") {
  const InputMesh cube = split_cube();
  const WeldedMesh welded = weld(cube);
  CHECK(welded.mesh.positions.size() == 8);
  CHECK(welded.mesh.triangles.size() == 12);
  CHECK(welded.degenerate_triangles_removed == 0);
  CHECK(welded.duplicate_triangles_removed == 0);
  check_maps(cube, welded);
  // Closed: every undirected edge is used by exactly two triangles.
  std::map<std::pair<uint32_t, uint32_t>, int> edge_use;
  for (const Triangle& t : welded.mesh.triangles)
    for (int c = 0; c < 3; ++c) ++edge_use[{std::min(t[c], t[(c + 1) % 3]), std::max(t[c], t[(c + 1) % 3])}];
  CHECK(edge_use.size() == 18);
  CHECK(std::all_of(edge_use.begin(), edge_use.end(), [](const auto& e) { return e.second == 2; }));
}

TEST_CASE("weld: welded order is first occurrence so an already-welded mesh keeps its order and unused vertices") {
  InputMesh mesh;
  mesh.positions = {Vec3(5, 0, 0), Vec3(0, 0, 0), Vec3(9, 9, 9) /* unreferenced */, Vec3(0, 1, 0)};
  mesh.triangles = {{1, 0, 3}};
  const WeldedMesh welded = weld(mesh);
  CHECK(welded.mesh.positions == mesh.positions);
  CHECK(welded.mesh.triangles == mesh.triangles);
  CHECK(welded.welded_of_original == std::vector<uint32_t>{0, 1, 2, 3});
  CHECK(welded.original_of_welded == std::vector<uint32_t>{0, 1, 2, 3});
  check_maps(mesh, welded);
}

TEST_CASE("weld: -0.0 and +0.0 are the same position but nearly equal positions are not") {
  InputMesh mesh;
  mesh.positions = {Vec3(-0.0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.0, -0.0, 0.0),
                    Vec3(std::nextafter(1.0, 2.0), 0, 0)};
  mesh.triangles = {{0, 1, 2}, {3, 4, 2}};
  const WeldedMesh welded = weld(mesh);
  CHECK(welded.mesh.positions.size() == 4);
  CHECK(welded.welded_of_original[3] == 0);
  CHECK(welded.welded_of_original[4] == 3);
  CHECK(welded.mesh.triangles.size() == 2);
  check_maps(mesh, welded);
}

TEST_CASE("weld: degenerate and duplicate triangles are removed, counted, and the first copy kept") {
  InputMesh mesh = split_cube();
  const size_t cube_triangles = mesh.triangles.size();
  // Vertex 0 and 8 are both the corner (0,0,0): welded, this triangle repeats a corner.
  mesh.triangles.push_back({0, 8, 1});
  mesh.triangles.push_back({5, 5, 6});  // repeated index even before welding
  // The first cube triangle again, rotated, then reversed, then through split copies.
  const Triangle first = mesh.triangles[0];
  mesh.triangles.push_back({first[1], first[2], first[0]});
  mesh.triangles.push_back({first[2], first[1], first[0]});
  // (0,0,0),(1,1,0),(0,1,0) again, reversed, through the split copies of faces 4 and 3.
  mesh.triangles.push_back({16, 15, 12});
  const WeldedMesh welded = weld(mesh);
  const WeldedMesh cube_only = weld(split_cube());
  CHECK(welded.degenerate_triangles_removed == 2);
  CHECK(welded.duplicate_triangles_removed == 3);
  CHECK(welded.mesh.triangles.size() == cube_triangles);
  CHECK(welded.mesh.triangles == cube_only.mesh.triangles);
  CHECK(welded.mesh.triangles[0] == cube_only.mesh.triangles[0]);  // the first copy survives
  CHECK(welded.original_triangle[0] == 0);
  check_maps(mesh, welded);
}

TEST_CASE("weld: a non-manifold edge and two separate components are kept as they are") {
  InputMesh mesh;
  // Three triangles sharing edge (0,1): a fin, non-manifold.
  mesh.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1),
                    // second component, a separate triangle far away, plus a copy of vertex 0
                    Vec3(10, 0, 0), Vec3(11, 0, 0), Vec3(10, 1, 0), Vec3(0, 0, 0)};
  mesh.triangles = {{0, 1, 2}, {1, 0, 3}, {8, 1, 4}, {5, 6, 7}};
  const WeldedMesh welded = weld(mesh);
  CHECK(welded.mesh.positions.size() == 8);
  CHECK(welded.mesh.triangles.size() == 4);
  CHECK(welded.degenerate_triangles_removed == 0);
  CHECK(welded.duplicate_triangles_removed == 0);
  CHECK(welded.mesh.triangles[2] == Triangle{0, 1, 4});
  check_maps(mesh, welded);
}

TEST_CASE("weld: an empty input gives an empty welded mesh") {
  const WeldedMesh welded = weld(InputMesh{});
  CHECK(welded.mesh.positions.empty());
  CHECK(welded.mesh.triangles.empty());
  CHECK(welded.welded_of_original.empty());
}
