// Metrics of DESIGN.md "Metrics": closest-point distances (medial quality) and enclosed volume
// (volume change). The winding number (skeleton inside) is in winding_number.cpp.
#include "skelform/bake/metrics.h"

#include "triangle_hierarchy.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace skelform::bake {
namespace {

// Closest point to p on triangle (a, b, c), exact, by the Voronoi regions of the triangle's
// features (vertices, edges, face). Degenerate triangles fall into a vertex or edge region.
Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Vec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + ab * (d1 / (d1 - d3));
  const Vec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denominator = va + vb + vc;
  if (!(denominator > 0.0)) {
    // Collinear corners that passed every region test by rounding: take the best edge point.
    auto on_segment = [&p](const Vec3& s, const Vec3& e) {
      const Vec3 direction = e - s;
      const double length2 = glm::dot(direction, direction);
      const double t = length2 > 0.0 ? std::clamp(glm::dot(p - s, direction) / length2, 0.0, 1.0) : 0.0;
      return s + t * direction;
    };
    const Vec3 candidates[3] = {on_segment(a, b), on_segment(b, c), on_segment(c, a)};
    Vec3 best = candidates[0];
    for (const Vec3& q : candidates)
      if (glm::dot(q - p, q - p) < glm::dot(best - p, best - p)) best = q;
    return best;
  }
  const double v = vb / denominator, w = vc / denominator;
  return a + ab * v + ac * w;
}

}  // namespace

// The closest-point tree: the hierarchy and its own copy of the mesh.
struct TriangleTree::Impl {
  std::vector<Vec3> positions;
  std::vector<Triangle> triangles;
  detail::TriangleHierarchy hierarchy;
};

TriangleTree::TriangleTree(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()) {
  impl_->positions = mesh.positions;
  impl_->triangles = mesh.triangles;
  impl_->hierarchy = detail::build_triangle_hierarchy(mesh);
}

TriangleTree::~TriangleTree() = default;
TriangleTree::TriangleTree(TriangleTree&&) noexcept = default;
TriangleTree& TriangleTree::operator=(TriangleTree&&) noexcept = default;

TriangleTree::Hit TriangleTree::closest(const Vec3& query) const {
  Hit best;
  best.distance = std::numeric_limits<double>::infinity();
  const detail::TriangleHierarchy& tree = impl_->hierarchy;
  if (tree.nodes.empty()) return best;
  double best_squared = std::numeric_limits<double>::infinity();
  // Depth-first, nearer child first, pruning boxes farther than the best hit so far.
  uint32_t stack[128];
  int stack_size = 0;
  stack[stack_size++] = 0;
  while (stack_size > 0) {
    const detail::TriangleHierarchy::Node& node = tree.nodes[stack[--stack_size]];
    if (node.box.squared_distance(query) >= best_squared) continue;
    if (node.count > 0) {
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        const uint32_t t = tree.triangle_order[i];
        const Triangle& tri = impl_->triangles[t];
        const Vec3 point = closest_point_on_triangle(query, impl_->positions[tri[0]], impl_->positions[tri[1]],
                                                     impl_->positions[tri[2]]);
        const double squared = glm::dot(point - query, point - query);
        if (squared < best_squared) {
          best_squared = squared;
          best.triangle = t;
          best.point = point;
        }
      }
      continue;
    }
    const uint32_t left = node.first, right = node.first + 1;
    const double left_distance = tree.nodes[left].box.squared_distance(query);
    const double right_distance = tree.nodes[right].box.squared_distance(query);
    // Push the farther child first so the nearer one is visited next. A median split keeps
    // the depth at about log2(F), far below the stack's capacity.
    if (left_distance < right_distance) {
      stack[stack_size++] = right;
      stack[stack_size++] = left;
    } else {
      stack[stack_size++] = left;
      stack[stack_size++] = right;
    }
  }
  best.distance = std::sqrt(best_squared);
  return best;
}

std::vector<double> surface_distances(const TriangleMesh& mesh, const std::vector<Vec3>& queries) {
  const TriangleTree tree(mesh);
  std::vector<double> distances(queries.size());
  for (size_t q = 0; q < queries.size(); ++q) distances[q] = tree.closest(queries[q]).distance;
  return distances;
}

double enclosed_volume(const TriangleMesh& mesh) {
  // Divergence theorem: V = (1/3)∮ x·n dA = Σ a·(b×c)/6 over the triangles. Summing with
  // coordinates relative to the centroid of the vertices reduces cancellation far from origin.
  if (mesh.positions.empty()) return 0.0;
  Vec3 origin(0.0);
  for (const Vec3& p : mesh.positions) origin += p;
  origin /= static_cast<double>(mesh.positions.size());
  double six_volume = 0.0;
  for (const Triangle& t : mesh.triangles) {
    six_volume += glm::dot(mesh.positions[t[0]] - origin,
                           glm::cross(mesh.positions[t[1]] - origin, mesh.positions[t[2]] - origin));
  }
  return six_volume / 6.0;
}

}  // namespace skelform::bake
