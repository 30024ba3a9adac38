// Reusable checks of a triangle mesh's topology and geometry for the tests: closed,
// consistently oriented, edge- and vertex-manifold, components, Euler characteristic,
// enclosed volume, degenerate triangles. Computed from scratch here, independently of the
// baker's own mesh code, so a bug there cannot hide itself.
#pragma once

#include "skelform/bake/mesh.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cstdint>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace skelform::test {

struct MeshReport {
  size_t vertices = 0;  // referenced vertices
  size_t edges = 0;     // undirected edges
  size_t faces = 0;
  long euler = 0;         // V - E + F (2 for a closed genus-0 surface)
  size_t components = 0;  // connected components of the triangles (through shared vertices)
  size_t degenerate = 0;  // triangles of area <= 1e-12 * diagonal^2 (or with repeated indices)
  double volume = 0;      // enclosed volume by the divergence theorem (> 0: outward)
  double min_area = 0;    // smallest triangle area
  // First problems found with closedness, orientation or manifoldness; empty when the mesh
  // is a closed, consistently oriented 2-manifold without unreferenced vertices.
  std::string manifold_problem;
};

// Analyses `mesh`. Never throws on bad topology: the problems are described in the report.
inline MeshReport analyze_mesh(const bake::TriangleMesh& mesh) {
  MeshReport r;
  std::ostringstream problems;
  int problem_count = 0;
  auto problem = [&](const std::string& text) {
    if (problem_count++ < 5) problems << text << "; ";
  };

  const size_t n = mesh.positions.size();
  r.faces = mesh.triangles.size();
  std::vector<int> uses(n, 0);
  std::map<std::pair<uint32_t, uint32_t>, int> directed;  // (from, to) -> count
  const double diagonal = bake::bounds_of(mesh.positions).diagonal();
  r.min_area = 1e300;
  for (const bake::Triangle& t : mesh.triangles) {
    if (t[0] >= n || t[1] >= n || t[2] >= n) {
      problem("index out of range");
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      ++uses[t[k]];
      ++directed[{t[k], t[(k + 1) % 3]}];
    }
    const bake::Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
    r.min_area = std::min(r.min_area, area);
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || !(area > 1e-12 * diagonal * diagonal)) ++r.degenerate;
    r.volume += glm::dot(a, glm::cross(b, c)) / 6.0;
  }
  if (problem_count > 0) {
    r.manifold_problem = problems.str();
    return r;
  }

  // Closed and consistently oriented: each directed edge once, and its reverse once.
  for (const auto& [e, count] : directed) {
    if (count != 1)
      problem("directed edge " + std::to_string(e.first) + "->" + std::to_string(e.second) + " used " +
              std::to_string(count) + " times");
    const auto reverse = directed.find({e.second, e.first});
    if (reverse == directed.end())
      problem("edge " + std::to_string(e.first) + "-" + std::to_string(e.second) +
              " has no opposite half (open or inconsistently oriented)");
    if (e.first < e.second || reverse == directed.end()) ++r.edges;
  }
  for (size_t v = 0; v < n; ++v) {
    if (uses[v] == 0)
      problem("vertex " + std::to_string(v) + " unreferenced");
    else
      ++r.vertices;
  }

  // Vertex-manifold: around each vertex, the triangles (v, a, b) chain a -> b into a single
  // cycle (one fan), not several fans touching at v.
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> fan(n);
  for (const bake::Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) fan[t[k]].push_back({t[(k + 1) % 3], t[(k + 2) % 3]});
  for (size_t v = 0; v < n; ++v) {
    if (fan[v].empty()) continue;
    std::map<uint32_t, uint32_t> next;
    for (const auto& [a, b] : fan[v]) next[a] = b;
    uint32_t at = fan[v].front().first;
    size_t steps = 0;
    do {
      const auto it = next.find(at);
      if (it == next.end()) break;
      at = it->second;
      ++steps;
    } while (at != fan[v].front().first && steps <= fan[v].size());
    if (steps != fan[v].size() || next.size() != fan[v].size())
      problem("vertex " + std::to_string(v) + " is not one fan");
  }

  // Connected components with a union-find over vertices.
  std::vector<uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const bake::Triangle& t : mesh.triangles) {
    parent[find(t[1])] = find(t[0]);
    parent[find(t[2])] = find(t[0]);
  }
  for (size_t v = 0; v < n; ++v)
    if (uses[v] > 0 && find(uint32_t(v)) == v) ++r.components;

  r.euler = long(r.vertices) - long(r.edges) + long(r.faces);
  r.manifold_problem = problems.str();
  return r;
}

}  // namespace skelform::test
