// Bilaplacian tangent flow (paper section 2, "Mesh smoothing", its reference [24]).
//
// The bi-umbrella operator of Kobbelt et al. (the paper's [17]) is a discrete Δ²; the flow
// ∂p/∂t = −Δ²p fairs the surface. Keeping only the component of −U² in the vertex's tangent
// plane leaves the geometry (to first order) where it is and moves vertices within the
// surface, evening out their spacing: that is what improves the triangles' aspect ratios and,
// through them, the Voronoi skeleton (the paper's Fig. 5).
#include "skelform/bake/tangent_flow.h"

#include "skelform/bake/topology.h"

#include <glm/geometric.hpp>

#include <cmath>

namespace skelform::bake {
namespace {

// Uniform umbrella U(p) = mean of the one-ring − p, for every vertex; zero without neighbours.
void umbrella(const VertexAdjacency& adjacency, const std::vector<Vec3>& values, std::vector<Vec3>& out) {
  const size_t vertex_count = adjacency.vertex_count();
  for (uint32_t v = 0; v < vertex_count; ++v) {
    const size_t degree = adjacency.degree(v);
    if (degree == 0) {
      out[v] = Vec3(0.0);
      continue;
    }
    Vec3 sum(0.0);
    for (uint32_t k = adjacency.offsets[v]; k < adjacency.offsets[v + 1]; ++k) sum += values[adjacency.neighbours[k]];
    out[v] = sum / static_cast<double>(degree) - values[v];
  }
}

}  // namespace

void apply_tangent_flow(TriangleMesh& mesh, const TangentFlowOptions& options) {
  const size_t vertex_count = mesh.positions.size();
  if (vertex_count == 0 || mesh.triangles.empty() || options.steps <= 0) return;
  const VertexAdjacency adjacency = build_adjacency(mesh);

  // Per-vertex step λ = step_fraction / ν with ν = 1 + (1/n_p) Σ_j 1/n_j, the diagonal of the
  // bi-umbrella (Kobbelt et al. 1998): 1/ν is the largest stable explicit step, so a
  // fraction of it is a "sufficiently small" step in the paper's sense. Fixed vertices
  // (open border, isolated) get λ = 0.
  std::vector<double> step_size(vertex_count, 0.0);
  for (uint32_t v = 0; v < vertex_count; ++v) {
    const size_t degree = adjacency.degree(v);
    if (degree == 0 || adjacency.on_border[v]) continue;
    double inverse_degree_sum = 0.0;
    for (uint32_t k = adjacency.offsets[v]; k < adjacency.offsets[v + 1]; ++k) {
      const size_t neighbour_degree = adjacency.degree(adjacency.neighbours[k]);
      inverse_degree_sum += 1.0 / static_cast<double>(neighbour_degree);  // >= 1: v is its neighbour
    }
    const double nu = 1.0 + inverse_degree_sum / static_cast<double>(degree);
    step_size[v] = options.step_fraction / nu;
  }

  std::vector<Vec3> umbrella_vectors(vertex_count), bi_umbrella_vectors(vertex_count);
  for (int step = 0; step < options.steps; ++step) {
    // Normals follow the moving vertices; the tangent plane is the current one.
    const std::vector<Vec3> normals = area_weighted_normals(mesh);
    umbrella(adjacency, mesh.positions, umbrella_vectors);
    umbrella(adjacency, umbrella_vectors, bi_umbrella_vectors);  // U²(p) = mean U(q_j) − U(p)
    // Jacobi update: every displacement is computed from the same state before any moves.
    for (uint32_t v = 0; v < vertex_count; ++v) {
      const Vec3& n = normals[v];
      // Without a tangent plane (zero normal) the tangential part is undefined: stay put.
      if (step_size[v] == 0.0 || n == Vec3(0.0)) continue;
      const Vec3& bi = bi_umbrella_vectors[v];
      const Vec3 tangential = bi - glm::dot(bi, n) * n;
      const Vec3 moved = mesh.positions[v] - step_size[v] * tangential;
      if (std::isfinite(moved.x) && std::isfinite(moved.y) && std::isfinite(moved.z)) mesh.positions[v] = moved;
    }
  }
}

}  // namespace skelform::bake
