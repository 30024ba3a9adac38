// DSS binding (DESIGN.md bake step 6, Math notes "DSS binding"; paper section 4 after Lee
// et al. 2000). For a dense vertex p we look for a refined triangle and barycentrics b with
//     p = q(b) + h·n(b),   q(b) = Σ b_i p_i,   n(b) = normalize(Σ b_i n_i),
// the displaced subdivision surface's scalar displacement along its smooth normal field.
// The closest point gives the start; Newton on (b1, b2, h) refines it and walks across
// edges; what the normal field cannot reach goes into a tangential residual. The last step
// is done in float through core/include/skelform/core/dss_frame.h, the very code the runtime runs.
#include "skelform/bake/dss.h"

#include "skelform/bake/metrics.h"

#include "skelform/core/dss_frame.h"

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

namespace skelform::bake {
namespace {

constexpr uint32_t kNoNeighbour = std::numeric_limits<uint32_t>::max();
constexpr int kMaxNewtonIterations = 32;
// Edge crossings per vertex: a solution is normally within a triangle or two of the closest
// point; more walks mean the normal field sweeps past p (beyond its focal distance) and the
// residual is the honest answer.
constexpr int kMaxWalks = 8;
// Barycentric slack for "inside": Newton converging onto an edge lands at b_i ≈ −1e-12, not
// exactly 0; it is clamped afterwards and the float correction absorbs the difference.
constexpr double kInsideSlack = 1e-9;

// The refined mesh in double (copied from the float positions and normals the runtime will
// have at rest), with edge adjacency for walking.
struct RefinedSurface {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;
  const std::vector<glm::vec3>* float_positions = nullptr;
  const std::vector<glm::vec3>* float_normals = nullptr;
  const std::vector<Triangle>* triangles = nullptr;
  // neighbour[3 t + i]: the triangle across the edge opposite corner i of triangle t, when
  // exactly one other triangle shares that edge (a border or non-manifold edge has none:
  // the walk stops there rather than guess a sheet).
  std::vector<uint32_t> neighbour;
};

void build_neighbours(RefinedSurface& surface) {
  const std::vector<Triangle>& triangles = *surface.triangles;
  struct EdgeSlot {
    uint64_t key;
    uint32_t slot;  // 3 t + i, the edge opposite corner i
  };
  std::vector<EdgeSlot> edges(triangles.size() * 3);
  for (size_t t = 0; t < triangles.size(); ++t)
    for (uint32_t i = 0; i < 3; ++i) {
      const uint32_t a = triangles[t][(i + 1) % 3], b = triangles[t][(i + 2) % 3];
      const uint64_t key = (static_cast<uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
      edges[3 * t + i] = {key, static_cast<uint32_t>(3 * t + i)};
    }
  std::sort(edges.begin(), edges.end(),
            [](const EdgeSlot& l, const EdgeSlot& r) { return l.key != r.key ? l.key < r.key : l.slot < r.slot; });
  surface.neighbour.assign(triangles.size() * 3, kNoNeighbour);
  for (size_t begin = 0; begin < edges.size();) {
    size_t end = begin + 1;
    while (end < edges.size() && edges[end].key == edges[begin].key) ++end;
    if (end - begin == 2) {
      surface.neighbour[edges[begin].slot] = edges[begin + 1].slot / 3;
      surface.neighbour[edges[begin + 1].slot] = edges[begin].slot / 3;
    }
    begin = end;
  }
}

// Barycentrics (b0, b1, b2) of a point of the plane of triangle (a, b, c); a degenerate
// triangle gives its first corner (the frame's fallbacks and the residual take over).
std::array<double, 3> barycentrics_of(const Vec3& point, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, d = point - a;
  const double d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2);
  const double d1 = glm::dot(d, e1), d2 = glm::dot(d, e2);
  const double determinant = d11 * d22 - d12 * d12;
  if (!(determinant > 1e-24 * d11 * d22) || !(determinant > 0.0)) return {1.0, 0.0, 0.0};
  const double b1 = (d22 * d1 - d12 * d2) / determinant;
  const double b2 = (d11 * d2 - d12 * d1) / determinant;
  return {1.0 - b1 - b2, b1, b2};
}

std::array<double, 3> clamp_to_triangle(std::array<double, 3> b) {
  for (double& x : b) x = std::max(x, 0.0);
  const double sum = b[0] + b[1] + b[2];
  if (!(sum > 0.0)) return {1.0, 0.0, 0.0};
  return {b[0] / sum, b[1] / sum, b[2] / sum};
}

struct Candidate {
  uint32_t triangle = 0;
  std::array<double, 3> b{1.0, 0.0, 0.0};
  double tangential = std::numeric_limits<double>::infinity();  // |p − q − h n| with the best h
};

// Evaluation of q(b), n(b) and the residual's tangential size at a candidate.
struct Evaluation {
  Vec3 q, normal_sum, normal;
  double normal_length = 0.0;
};

Evaluation evaluate(const RefinedSurface& surface, uint32_t t, const std::array<double, 3>& b) {
  const Triangle& tri = (*surface.triangles)[t];
  Evaluation e;
  e.q = b[0] * surface.positions[tri[0]] + b[1] * surface.positions[tri[1]] + b[2] * surface.positions[tri[2]];
  e.normal_sum = b[0] * surface.normals[tri[0]] + b[1] * surface.normals[tri[1]] + b[2] * surface.normals[tri[2]];
  e.normal_length = glm::length(e.normal_sum);
  e.normal = e.normal_length > 1e-12 ? e.normal_sum / e.normal_length : Vec3(0.0);
  return e;
}

void consider(const RefinedSurface& surface, const Vec3& p, uint32_t t, const std::array<double, 3>& b,
              Candidate& best) {
  const std::array<double, 3> inside = clamp_to_triangle(b);
  const Evaluation e = evaluate(surface, t, inside);
  const Vec3 offset = p - e.q;
  const double tangential = glm::length(offset - glm::dot(offset, e.normal) * e.normal);
  if (tangential < best.tangential) best = {t, inside, tangential};
}

// Newton on F(b1, b2, h) = q(b) + h n(b) − p from the closest point, walking across edges.
// Returns the best candidate met (the converged one when Newton converges).
Candidate solve_binding(const RefinedSurface& surface, const Vec3& p, uint32_t start_triangle,
                        const std::array<double, 3>& start_b, double tolerance) {
  Candidate best;
  consider(surface, p, start_triangle, start_b, best);

  uint32_t t = start_triangle;
  std::array<double, 3> b = start_b;
  Evaluation e = evaluate(surface, t, b);
  double h = glm::dot(p - e.q, e.normal);
  int walks = 0;
  for (int iteration = 0; iteration < kMaxNewtonIterations; ++iteration) {
    if (!(e.normal_length > 1e-12)) break;  // zero normal field: nothing to displace along
    consider(surface, p, t, b, best);
    const Vec3 residual = e.q + h * e.normal - p;
    if (glm::length(residual) <= tolerance) break;
    const Triangle& tri = (*surface.triangles)[t];
    const Vec3& p0 = surface.positions[tri[0]];
    const Vec3& n0 = surface.normals[tri[0]];
    // ∂n/∂b_j = (I − n nᵀ)(n_j − n0)/|m| for the normalised interpolation n = m/|m|.
    auto normal_derivative = [&](const Vec3& nj) {
      const Vec3 dm = nj - n0;
      return (dm - glm::dot(dm, e.normal) * e.normal) / e.normal_length;
    };
    const Vec3 column1 = surface.positions[tri[1]] - p0 + h * normal_derivative(surface.normals[tri[1]]);
    const Vec3 column2 = surface.positions[tri[2]] - p0 + h * normal_derivative(surface.normals[tri[2]]);
    const glm::dmat3 jacobian(column1, column2, e.normal);
    const double determinant = glm::determinant(jacobian);
    const double scale = glm::length(column1) * glm::length(column2);
    if (!(std::fabs(determinant) > 1e-12 * scale)) break;  // singular: at a focal point of the field
    const Vec3 step = -(glm::inverse(jacobian) * residual);
    std::array<double, 3> delta{-step.x - step.y, step.x, step.y};
    // The nearest point where the step leaves the triangle, if it does.
    double exit_fraction = 1.0;
    int exit_corner = -1;
    for (int i = 0; i < 3; ++i)
      if (b[static_cast<size_t>(i)] + delta[static_cast<size_t>(i)] < -kInsideSlack &&
          delta[static_cast<size_t>(i)] < 0.0) {
        const double fraction = std::max(0.0, b[static_cast<size_t>(i)]) / -delta[static_cast<size_t>(i)];
        if (fraction < exit_fraction) {
          exit_fraction = fraction;
          exit_corner = i;
        }
      }
    for (size_t i = 0; i < 3; ++i) b[i] += exit_fraction * delta[i];
    h += exit_fraction * step.z;
    if (exit_corner >= 0) {
      const size_t corner = static_cast<size_t>(exit_corner);
      b[corner] = 0.0;
      b = clamp_to_triangle(b);
      consider(surface, p, t, b, best);
      const uint32_t next = surface.neighbour[3 * t + corner];
      if (next == kNoNeighbour || walks >= kMaxWalks) break;  // border, non-manifold edge or wandering
      ++walks;
      // Same point of the shared edge, expressed in the neighbour's corners.
      const Triangle& next_tri = (*surface.triangles)[next];
      std::array<double, 3> next_b{0.0, 0.0, 0.0};
      for (size_t i = 0; i < 3; ++i)
        for (size_t j = 0; j < 3; ++j)
          if (next_tri[j] == tri[i]) next_b[j] += b[i];
      t = next;
      b = clamp_to_triangle(next_b);
    }
    e = evaluate(surface, t, b);
  }
  return best;
}

// Final binding of one vertex in float: the frame as dss_frame.h computes it from the
// float barycentrics, h and the residual from projecting p − q onto it, then one correction
// round with the float evaluation's own error (rounding of h·n and r·t adds up otherwise).
struct FloatBinding {
  glm::vec2 barycentric;
  float displacement;
  glm::vec2 residual;
  double error;  // |evaluated − p|, model units
};

FloatBinding finish_in_float(const RefinedSurface& surface, const Vec3& p, const Candidate& candidate) {
  const Triangle& tri = (*surface.triangles)[candidate.triangle];
  float b1 = static_cast<float>(candidate.b[1]), b2 = static_cast<float>(candidate.b[2]);
  b1 = std::clamp(b1, 0.0f, 1.0f);
  b2 = std::clamp(b2, 0.0f, 1.0f - b1);
  const std::vector<glm::vec3>& positions = *surface.float_positions;
  const std::vector<glm::vec3>& normals = *surface.float_normals;
  const dss::SurfaceFrame frame = dss::surface_frame(positions[tri[0]], positions[tri[1]], positions[tri[2]],
                                                     normals[tri[0]], normals[tri[1]], normals[tri[2]], b1, b2);
  const Vec3 normal(frame.normal), tangent(frame.tangent), bitangent(frame.bitangent);
  const Vec3 offset = p - Vec3(frame.point);
  double h = glm::dot(offset, normal);
  glm::dvec2 r(glm::dot(offset, tangent), glm::dot(offset, bitangent));
  FloatBinding result{{b1, b2}, static_cast<float>(h), glm::vec2(r), 0.0};
  result.error = glm::length(Vec3(dss::displaced_point(frame, result.displacement, result.residual)) - p);
  for (int round = 0; round < 2 && result.error > 0.0; ++round) {
    const Vec3 error = p - Vec3(dss::displaced_point(frame, result.displacement, result.residual));
    h += glm::dot(error, normal);
    r += glm::dvec2(glm::dot(error, tangent), glm::dot(error, bitangent));
    const FloatBinding corrected{
        {b1, b2},
        static_cast<float>(h),
        glm::vec2(r),
        glm::length(Vec3(dss::displaced_point(frame, static_cast<float>(h), glm::vec2(r))) - p)};
    if (corrected.error < result.error) result = corrected;
  }
  return result;
}

}  // namespace

DssBinding bind_dense_vertices(const std::vector<glm::vec3>& refined_positions,
                               const std::vector<glm::vec3>& refined_normals,
                               const std::vector<Triangle>& refined_triangles, const std::vector<Vec3>& dense_positions,
                               double diagonal) {
  if (refined_positions.empty() || refined_triangles.empty())
    throw Error(ErrorKind::invalid_input, "DSS binding needs a non-empty refined mesh");
  if (refined_normals.size() != refined_positions.size())
    throw Error(ErrorKind::invalid_input, "DSS binding: " + std::to_string(refined_normals.size()) + " normals for " +
                                              std::to_string(refined_positions.size()) + " refined vertices");
  for (size_t t = 0; t < refined_triangles.size(); ++t)
    for (uint32_t corner : refined_triangles[t])
      if (corner >= refined_positions.size())
        throw Error(ErrorKind::invalid_input, "refined triangle " + std::to_string(t) + " has vertex index " +
                                                  std::to_string(corner) + " out of range");
  for (size_t v = 0; v < dense_positions.size(); ++v)
    if (!std::isfinite(dense_positions[v].x) || !std::isfinite(dense_positions[v].y) ||
        !std::isfinite(dense_positions[v].z))
      throw Error(ErrorKind::invalid_input, "dense vertex " + std::to_string(v) + " is not finite");
  if (!(diagonal > 0.0) || !std::isfinite(diagonal)) diagonal = 1.0;

  RefinedSurface surface;
  surface.float_positions = &refined_positions;
  surface.triangles = &refined_triangles;
  // The normals the runtime computes at rest, bit for bit (refined_normals).
  surface.float_normals = &refined_normals;
  surface.positions.assign(refined_positions.begin(), refined_positions.end());
  surface.normals.assign(refined_normals.begin(), refined_normals.end());
  build_neighbours(surface);

  TriangleMesh tree_mesh;
  tree_mesh.positions = surface.positions;
  tree_mesh.triangles = refined_triangles;
  const TriangleTree tree(tree_mesh);

  // glTF splits vertices at seams; equal positions are bound once, so copies are identical
  // by construction and the work scales with the welded count.
  std::vector<uint32_t> order(dense_positions.size());
  std::iota(order.begin(), order.end(), 0u);
  auto less = [&](uint32_t l, uint32_t r) {
    const Vec3 &a = dense_positions[l], &b = dense_positions[r];
    if (a.x != b.x) return a.x < b.x;
    if (a.y != b.y) return a.y < b.y;
    if (a.z != b.z) return a.z < b.z;
    return l < r;
  };
  std::sort(order.begin(), order.end(), less);

  DssBinding binding;
  const size_t count = dense_positions.size();
  binding.triangle.resize(count);
  binding.barycentric.resize(count);
  binding.displacement.resize(count);
  binding.residual.resize(count);
  // Newton stops at a relative 1e-10 of the model size: far below float's 6e-8, so the
  // final float rounding, not the solve, sets the rest error.
  const double tolerance = 1e-10 * diagonal;
  const double residual_threshold = 1e-3 * diagonal;
  double max_error = 0.0;
  for (size_t k = 0; k < count;) {
    const uint32_t first = order[k];
    const Vec3& p = dense_positions[first];
    const TriangleTree::Hit hit = tree.closest(p);
    const Triangle& tri = refined_triangles[hit.triangle];
    const std::array<double, 3> start = clamp_to_triangle(
        barycentrics_of(hit.point, surface.positions[tri[0]], surface.positions[tri[1]], surface.positions[tri[2]]));
    const Candidate candidate = solve_binding(surface, p, hit.triangle, start, tolerance);
    const FloatBinding result = finish_in_float(surface, p, candidate);
    max_error = std::max(max_error, result.error);
    size_t end = k;
    for (; end < count && dense_positions[order[end]] == p; ++end) {
      const uint32_t v = order[end];
      binding.triangle[v] = candidate.triangle;
      binding.barycentric[v] = result.barycentric;
      binding.displacement[v] = result.displacement;
      binding.residual[v] = result.residual;
      if (glm::length(glm::dvec2(result.residual)) > residual_threshold) ++binding.residual_vertices;
    }
    k = end;
  }
  binding.max_rest_error = max_error / diagonal;
  return binding;
}

}  // namespace skelform::bake
