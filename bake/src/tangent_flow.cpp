// Bilaplacian tangent flow (paper section 2, "Mesh smoothing", its reference [24]).
//
// The bi-umbrella operator of Kobbelt et al. (the paper's [17]) is a discrete Δ²; the flow
// ∂p/∂t = −Δ²p fairs the surface. Keeping only the component of −U² in the vertex's tangent
// plane leaves the geometry (to first order) where it is and moves vertices within the
// surface, evening out their spacing: that is what improves the triangles' aspect ratios and,
// through them, the Voronoi skeleton (the paper's Fig. 5).
#include "skelform/bake/tangent_flow.h"

#include "skelform/bake/metrics.h"
#include "skelform/bake/topology.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

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

// Largest move of one step, as a fraction of the vertex's shortest edge.
constexpr double kMaxStepPerEdge = 0.1;

// Triangles around each vertex, in compressed rows, for the fold guard.
struct IncidentTriangles {
  std::vector<uint32_t> offsets;
  std::vector<uint32_t> triangles;
};

IncidentTriangles incident_triangles(const TriangleMesh& mesh) {
  IncidentTriangles out;
  out.offsets.assign(mesh.positions.size() + 1, 0);
  for (const Triangle& t : mesh.triangles)
    for (uint32_t v : t) ++out.offsets[v + 1];
  for (size_t v = 0; v < mesh.positions.size(); ++v) out.offsets[v + 1] += out.offsets[v];
  out.triangles.resize(out.offsets.back());
  std::vector<uint32_t> fill(out.offsets.begin(), out.offsets.end() - 1);
  for (uint32_t t = 0; t < mesh.triangles.size(); ++t)
    for (uint32_t v : mesh.triangles[t]) out.triangles[fill[v]++] = t;
  return out;
}

// Moves vertex v to `target` unless that would turn one of its triangles over (or collapse
// it). Tangential steps and projections are small, but near high-valence vertices (a UV
// pole, a decimated cap) neighbours can slide past each other; a folded triangle flips the
// area-weighted normal, and a vertex with an inward normal gets its skeletal point outside.
// With a reference surface (a decimated control mesh, whose triangles start out faithful to
// the dense surface) gradual rotation over many steps is caught too, by comparing with the
// triangle's normal before the flow (`initial_normals`, empty otherwise): no triangle may end
// up facing away from where it faced. Without one the input's own triangles may be slivers
// whose initial normals mean nothing, and only the step-to-step check applies.
bool move_without_folding(TriangleMesh& mesh, const IncidentTriangles& incident,
                          const std::vector<Vec3>& initial_normals, uint32_t v, const Vec3& target) {
  for (uint32_t k = incident.offsets[v]; k < incident.offsets[v + 1]; ++k) {
    const uint32_t triangle = incident.triangles[k];
    const Triangle& t = mesh.triangles[triangle];
    const Vec3& a = mesh.positions[t[0]];
    const Vec3& b = mesh.positions[t[1]];
    const Vec3& c = mesh.positions[t[2]];
    const Vec3 before = glm::cross(b - a, c - a);
    const Vec3 a2 = t[0] == v ? target : a, b2 = t[1] == v ? target : b, c2 = t[2] == v ? target : c;
    const Vec3 after = glm::cross(b2 - a2, c2 - a2);
    if (glm::dot(before, after) <= 0.0) return false;
    if (!initial_normals.empty() && glm::dot(initial_normals[triangle], after) <= 0.0) return false;
  }
  mesh.positions[v] = target;
  return true;
}

// Face normals (unnormalised) of every triangle.
std::vector<Vec3> face_normals(const TriangleMesh& mesh) {
  std::vector<Vec3> normals(mesh.triangles.size());
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const Triangle& t = mesh.triangles[i];
    normals[i] = glm::cross(mesh.positions[t[1]] - mesh.positions[t[0]], mesh.positions[t[2]] - mesh.positions[t[0]]);
  }
  return normals;
}

// Shortest edge at each vertex: the per-step move is capped by a fraction of it. The
// bi-umbrella is a sum of edge vectors, so next to a long edge (decimated meshes mix edges
// of very different lengths) even a stable step moves a vertex across its short neighbours.
std::vector<double> shortest_edges(const TriangleMesh& mesh, const VertexAdjacency& adjacency) {
  std::vector<double> shortest(mesh.positions.size(), 0.0);
  for (uint32_t v = 0; v < mesh.positions.size(); ++v) {
    double best = std::numeric_limits<double>::infinity();
    for (uint32_t k = adjacency.offsets[v]; k < adjacency.offsets[v + 1]; ++k)
      best = std::min(best, glm::length(mesh.positions[adjacency.neighbours[k]] - mesh.positions[v]));
    shortest[v] = std::isfinite(best) ? best : 0.0;
  }
  return shortest;
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

  std::unique_ptr<TriangleTree> reference;
  if (options.reference_surface && !options.reference_surface->triangles.empty())
    reference = std::make_unique<TriangleTree>(*options.reference_surface);
  const int interval = std::max(1, options.projection_interval);
  const IncidentTriangles incident = incident_triangles(mesh);
  const std::vector<Vec3> initial_normals = reference ? face_normals(mesh) : std::vector<Vec3>();
  auto project = [&] {
    for (uint32_t v = 0; v < vertex_count; ++v)
      if (step_size[v] != 0.0)
        move_without_folding(mesh, incident, initial_normals, v, reference->closest(mesh.positions[v]).point);
  };

  std::vector<Vec3> umbrella_vectors(vertex_count), bi_umbrella_vectors(vertex_count), targets(vertex_count);
  for (int step = 0; step < options.steps; ++step) {
    if (reference && step > 0 && step % interval == 0) project();
    // Normals follow the moving vertices; the tangent plane is the current one.
    const std::vector<Vec3> normals = area_weighted_normals(mesh);
    const std::vector<double> shortest = shortest_edges(mesh, adjacency);
    umbrella(adjacency, mesh.positions, umbrella_vectors);
    umbrella(adjacency, umbrella_vectors, bi_umbrella_vectors);  // U²(p) = mean U(q_j) − U(p)
    // Every displacement is computed from the same state before any moves; the moves are
    // then applied in vertex order, each refused if it would fold a triangle.
    for (uint32_t v = 0; v < vertex_count; ++v) {
      const Vec3& n = normals[v];
      // Without a tangent plane (zero normal) the tangential part is undefined: stay put.
      if (step_size[v] == 0.0 || n == Vec3(0.0)) {
        targets[v] = mesh.positions[v];
        continue;
      }
      const Vec3& bi = bi_umbrella_vectors[v];
      const Vec3 tangential = bi - glm::dot(bi, n) * n;
      Vec3 displacement = -step_size[v] * tangential;
      const double length = glm::length(displacement), limit = kMaxStepPerEdge * shortest[v];
      if (length > limit) displacement *= limit / length;
      const Vec3 moved = mesh.positions[v] + displacement;
      const bool finite = std::isfinite(moved.x) && std::isfinite(moved.y) && std::isfinite(moved.z);
      targets[v] = finite ? moved : mesh.positions[v];
    }
    for (uint32_t v = 0; v < vertex_count; ++v)
      if (targets[v] != mesh.positions[v]) move_without_folding(mesh, incident, initial_normals, v, targets[v]);
  }
  if (reference) project();
}

}  // namespace skelform::bake
