// Checks bake/src/topology.cpp: one-rings, open borders and area-weighted normals.
#include "skelform/bake/procedural.h"
#include "skelform/bake/topology.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace skelform::bake;

namespace {

std::vector<uint32_t> one_ring(const VertexAdjacency& adjacency, uint32_t v) {
  return {adjacency.neighbours.begin() + adjacency.offsets[v], adjacency.neighbours.begin() + adjacency.offsets[v + 1]};
}

}  // namespace

TEST_CASE("topology: an empty mesh has no vertices and no normals") {
  const TriangleMesh empty;
  const VertexAdjacency adjacency = build_adjacency(empty);
  CHECK(adjacency.vertex_count() == 0);
  CHECK(adjacency.neighbours.empty());
  CHECK(area_weighted_normals(empty).empty());
}

TEST_CASE("topology: a closed tetrahedron gives every vertex the other three, sorted, and no border") {
  TriangleMesh tetrahedron;
  tetrahedron.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  tetrahedron.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  const VertexAdjacency adjacency = build_adjacency(tetrahedron);
  REQUIRE(adjacency.vertex_count() == 4);
  CHECK(one_ring(adjacency, 0) == std::vector<uint32_t>{1, 2, 3});
  CHECK(one_ring(adjacency, 1) == std::vector<uint32_t>{0, 2, 3});
  CHECK(one_ring(adjacency, 2) == std::vector<uint32_t>{0, 1, 3});
  CHECK(one_ring(adjacency, 3) == std::vector<uint32_t>{0, 1, 2});
  for (uint32_t v = 0; v < 4; ++v) CHECK_FALSE(adjacency.on_border[v]);
}

TEST_CASE("topology: border vertices of an open quad; an isolated vertex has no neighbours") {
  // Two triangles sharing the diagonal 0-2, plus vertex 4 referenced by nothing, and vertex 5
  // in the middle of a fan closed around it.
  TriangleMesh quad;
  quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {5, 5, 5}};
  quad.triangles = {{0, 1, 2}, {0, 2, 3}};
  const VertexAdjacency adjacency = build_adjacency(quad);
  CHECK(adjacency.degree(0) == 3);
  CHECK(adjacency.degree(1) == 2);
  CHECK(adjacency.degree(4) == 0);
  for (uint32_t v = 0; v < 4; ++v) CHECK(adjacency.on_border[v]);
  CHECK_FALSE(adjacency.on_border[4]);
}

TEST_CASE("topology: interior vertices of an open fan are not on the border; non-manifold edges are not borders") {
  // A hexagonal fan around vertex 0: 0 is interior, the rim is border.
  TriangleMesh fan;
  fan.positions.push_back({0, 0, 0});
  for (int k = 0; k < 6; ++k)
    fan.positions.push_back({std::cos(k * 1.0471975511965976), std::sin(k * 1.0471975511965976), 0});
  for (uint32_t k = 0; k < 6; ++k) fan.triangles.push_back({0, 1 + k, 1 + (k + 1) % 6});
  VertexAdjacency adjacency = build_adjacency(fan);
  CHECK_FALSE(adjacency.on_border[0]);
  for (uint32_t v = 1; v <= 6; ++v) CHECK(adjacency.on_border[v]);

  // Two closed tetrahedra glued along edge 0-1: that edge has four triangles (non-manifold),
  // every other edge two, so no vertex is on a border.
  TriangleMesh glued;
  glued.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -1, 0}, {0, 0, -1}};
  glued.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 4, 1}, {0, 1, 5}, {0, 5, 4}, {1, 4, 5}};
  adjacency = build_adjacency(glued);
  for (uint32_t v = 0; v < 6; ++v) CHECK_FALSE(adjacency.on_border[v]);
  CHECK(one_ring(adjacency, 0) == std::vector<uint32_t>{1, 2, 3, 4, 5});
}

TEST_CASE("topology: area-weighted normals of a sphere point outward along the radius") {
  const TriangleMesh sphere = make_icosphere(2.0, 3);
  const std::vector<Vec3> normals = area_weighted_normals(sphere);
  REQUIRE(normals.size() == sphere.positions.size());
  double worst_alignment = 1.0;
  for (size_t v = 0; v < normals.size(); ++v) {
    CHECK(glm::length(normals[v]) == doctest::Approx(1.0).epsilon(1e-12));
    worst_alignment = std::min(worst_alignment, glm::dot(normals[v], glm::normalize(sphere.positions[v])));
  }
  CHECK(worst_alignment > 0.999);
}

TEST_CASE("topology: area weighting favours the larger face; degenerate and isolated vertices get zero") {
  // Vertex 0 is shared by a large triangle in z = 0 (normal +z) and a small one in x = 0
  // (normal +x): the normal leans to +z by the area ratio.
  TriangleMesh mesh;
  mesh.positions = {{0, 0, 0}, {4, 0, 0}, {0, 4, 0}, {0, 1, 0}, {0, 0, 1}, {7, 7, 7}, {8, 8, 8}, {9, 9, 9}, {3, 3, 3}};
  mesh.triangles = {{0, 1, 2}, {0, 3, 4}, {5, 6, 7}};  // 5-6-7 is collinear: zero area
  const std::vector<Vec3> normals = area_weighted_normals(mesh);
  const Vec3 expected = glm::normalize(Vec3(0.5, 0.0, 8.0));  // areas 8 (+z) and 0.5 (+x)
  CHECK(glm::length(normals[0] - expected) < 1e-12);
  CHECK(normals[5] == Vec3(0.0));
  CHECK(normals[8] == Vec3(0.0));
}
