// Metrics of DESIGN.md "Metrics": generalized winding number (skeleton inside), closest-point
// distances (medial quality) and enclosed volume (volume change).
#include "skelform/bake/metrics.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace skelform::bake {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Signed solid angle of triangle (a, b, c) seen from the origin (the vectors are corner −
// query), by the formula of Van Oosterom and Strackee (1983):
// tan(Ω/2) = a·(b×c) / (|a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|). atan2 keeps the right
// branch for |Ω| > π and yields 0 for a query on the triangle's plane.
double signed_solid_angle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
  const double numerator = glm::dot(a, glm::cross(b, c));
  const double denominator = la * lb * lc + glm::dot(a, b) * lc + glm::dot(b, c) * la + glm::dot(c, a) * lb;
  return 2.0 * std::atan2(numerator, denominator);
}

struct Box {
  Vec3 min{std::numeric_limits<double>::max()};
  Vec3 max{std::numeric_limits<double>::lowest()};
  void grow(const Vec3& p) {
    min = glm::min(min, p);
    max = glm::max(max, p);
  }
  void grow(const Box& other) {
    min = glm::min(min, other.min);
    max = glm::max(max, other.max);
  }
  double squared_distance(const Vec3& p) const {
    const Vec3 outside = glm::max(glm::max(min - p, p - max), Vec3(0.0));
    return glm::dot(outside, outside);
  }
};

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

std::vector<double> winding_numbers(const TriangleMesh& mesh, const std::vector<Vec3>& queries) {
  std::vector<double> winding(queries.size(), 0.0);
  for (size_t q = 0; q < queries.size(); ++q) {
    const Vec3& query = queries[q];
    double total_solid_angle = 0.0;
    for (const Triangle& t : mesh.triangles) {
      total_solid_angle += signed_solid_angle(mesh.positions[t[0]] - query, mesh.positions[t[1]] - query,
                                              mesh.positions[t[2]] - query);
    }
    winding[q] = total_solid_angle / (4.0 * kPi);
  }
  return winding;
}

double inside_fraction(const TriangleMesh& mesh, const std::vector<Vec3>& queries) {
  if (queries.empty()) return 0.0;
  const std::vector<double> winding = winding_numbers(mesh, queries);
  const auto inside = std::count_if(winding.begin(), winding.end(), [](double w) { return w > 0.5; });
  return static_cast<double>(inside) / static_cast<double>(queries.size());
}

// A binary AABB tree over triangle indices; leaves hold up to kLeafSize triangles.
struct TriangleTree::Impl {
  static constexpr uint32_t kLeafSize = 4;
  struct Node {
    Box box;
    uint32_t first = 0;  // leaf: first entry in triangle_order; inner: index of the left child
    uint32_t count = 0;  // leaf: number of triangles; inner: 0 (right child = left + 1)
  };
  std::vector<Vec3> positions;
  std::vector<Triangle> triangles;
  std::vector<uint32_t> triangle_order;
  std::vector<Node> nodes;

  void build(const std::vector<Vec3>& centroids, const std::vector<Box>& boxes, uint32_t node_index,
             uint32_t first, uint32_t count);
};

void TriangleTree::Impl::build(const std::vector<Vec3>& centroids, const std::vector<Box>& boxes,
                               uint32_t node_index, uint32_t first, uint32_t count) {
  Impl& tree = *this;
  Box node_box, centroid_box;
  for (uint32_t i = first; i < first + count; ++i) {
    node_box.grow(boxes[tree.triangle_order[i]]);
    centroid_box.grow(centroids[tree.triangle_order[i]]);
  }
  tree.nodes[node_index].box = node_box;
  const Vec3 extent = centroid_box.max - centroid_box.min;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  if (count <= kLeafSize || !(extent[axis] > 0.0)) {
    tree.nodes[node_index].first = first;
    tree.nodes[node_index].count = count;
    return;
  }
  // Median split along the widest centroid axis: balanced depth, O(n log n) build.
  const uint32_t half = count / 2;
  auto begin = tree.triangle_order.begin() + first;
  std::nth_element(begin, begin + half, begin + count,
                   [&](uint32_t l, uint32_t r) { return centroids[l][axis] < centroids[r][axis]; });
  const uint32_t left = static_cast<uint32_t>(tree.nodes.size());
  tree.nodes.emplace_back();
  tree.nodes.emplace_back();
  tree.nodes[node_index].first = left;
  tree.nodes[node_index].count = 0;
  build(centroids, boxes, left, first, half);
  build(centroids, boxes, left + 1, first + half, count - half);
}

TriangleTree::TriangleTree(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()) {
  impl_->positions = mesh.positions;
  impl_->triangles = mesh.triangles;
  const size_t triangle_count = mesh.triangles.size();
  if (triangle_count == 0) return;
  std::vector<Vec3> centroids(triangle_count);
  std::vector<Box> boxes(triangle_count);
  for (size_t t = 0; t < triangle_count; ++t) {
    for (uint32_t corner : mesh.triangles[t]) boxes[t].grow(mesh.positions[corner]);
    centroids[t] = (mesh.positions[mesh.triangles[t][0]] + mesh.positions[mesh.triangles[t][1]] +
                    mesh.positions[mesh.triangles[t][2]]) / 3.0;
  }
  impl_->triangle_order.resize(triangle_count);
  std::iota(impl_->triangle_order.begin(), impl_->triangle_order.end(), 0u);
  impl_->nodes.reserve(2 * triangle_count);
  impl_->nodes.emplace_back();
  impl_->build(centroids, boxes, 0, 0, static_cast<uint32_t>(triangle_count));
}

TriangleTree::~TriangleTree() = default;
TriangleTree::TriangleTree(TriangleTree&&) noexcept = default;
TriangleTree& TriangleTree::operator=(TriangleTree&&) noexcept = default;

TriangleTree::Hit TriangleTree::closest(const Vec3& query) const {
  Hit best;
  best.distance = std::numeric_limits<double>::infinity();
  if (impl_->nodes.empty()) return best;
  double best_squared = std::numeric_limits<double>::infinity();
  // Depth-first, nearer child first, pruning boxes farther than the best hit so far.
  uint32_t stack[128];
  int stack_size = 0;
  stack[stack_size++] = 0;
  while (stack_size > 0) {
    const Impl::Node& node = impl_->nodes[stack[--stack_size]];
    if (node.box.squared_distance(query) >= best_squared) continue;
    if (node.count > 0) {
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        const uint32_t t = impl_->triangle_order[i];
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
    const double left_distance = impl_->nodes[left].box.squared_distance(query);
    const double right_distance = impl_->nodes[right].box.squared_distance(query);
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
