// Generalized winding numbers (Jacobson et al. 2013): the exact sum of signed solid angles,
// and its hierarchical far-field approximation (Barill et al. 2018, "Fast winding numbers for
// soups and clouds"), which the skeleton's inside check uses (metrics.h).
#include "skelform/bake/metrics.h"

#include "triangle_hierarchy.h"

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <thread>

namespace skelform::bake {
namespace {

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

// A node's triangles seen from afar (Barill et al. 2018, section 3.2). The solid angle at q
// of the node's triangles is Σ_t ∫_t n_t·F(x) dA with F(x) = (x − q)/|x − q|³. Expanding F to
// second order about the node's area-weighted centre p, with d = x − p, r = p − q, R = |r|:
//   F(x) ≈ r/R³ + J d + ½ H[d, d],  J = I/R³ − 3 r rᵀ/R⁵,
//   H_kij = −3 (δ_ki r_j + δ_kj r_i + δ_ij r_k)/R⁵ + 15 r_k r_i r_j/R⁷,
// and integrating over the triangles gives Ω ≈ T1·r/R³ + J:T2 + ½ H⋮T3 with the moments
//   T1 = Σ_t a_t n_t,  T2 = Σ_t a_t (c_t − p) n_tᵀ,  T3_kij = Σ_t n_tk ∫_t d_i d_j dA,
// exact per triangle (a_t its area, c_t its centroid; the second moment of a triangle with
// corners v relative to p is a_t/12 (Σ v vᵀ + (Σ v)(Σ v)ᵀ)).
struct FarField {
  Vec3 centre{0.0};               // p
  double radius = 0.0;            // largest distance from p to a corner of the node
  Vec3 area_vector{0.0};          // T1
  glm::dmat3 dipole_moment{0.0};  // T2: column j holds Σ_t a_t n_tj (c_t − p)
  std::array<glm::dmat3, 3> quadrupole{glm::dmat3(0.0), glm::dmat3(0.0),
                                       glm::dmat3(0.0)};  // T3: [k] holds Σ_t n_tk ∫_t d dᵀ dA

  // Ω of the node's triangles at a query at r = p − query, |r|² = squared > 0.
  double solid_angle(const Vec3& r, double squared) const {
    const double distance = std::sqrt(squared);
    const double inverse3 = 1.0 / (squared * distance);
    const double inverse5 = inverse3 / squared;
    const double inverse7 = inverse5 / squared;
    const double first = glm::dot(area_vector, r) * inverse3;
    const double trace = dipole_moment[0][0] + dipole_moment[1][1] + dipole_moment[2][2];
    const double second = trace * inverse3 - 3.0 * glm::dot(r, dipole_moment * r) * inverse5;
    // H⋮T3 = −3/R⁵ (2 Σ_ki r_i T3_kki + Σ_k r_k tr T3_k) + 15/R⁷ Σ_k r_k rᵀT3_k r.
    double contracted_diagonal = 0.0, radial = 0.0;
    for (int k = 0; k < 3; ++k) {
      const glm::dmat3& t = quadrupole[static_cast<size_t>(k)];
      contracted_diagonal += 2.0 * glm::dot(r, t[k]) + r[k] * (t[0][0] + t[1][1] + t[2][2]);
      radial += r[k] * glm::dot(r, t * r);
    }
    const double third = 0.5 * (-3.0 * contracted_diagonal * inverse5 + 15.0 * radial * inverse7);
    return first + second + third;
  }
};

// Far-field terms replace a node when the query is farther than kAccuracy × the node's radius
// from its centre (Barill et al.'s β). The truncation error falls like (radius / distance)³
// times the node's solid angle; 3 rather than their 2 costs about twice the node visits and
// keeps the winding number within 2e-3 of the exact sum (tests/bake/metrics_test.cpp).
constexpr double kAccuracy = 3.0;

struct WindingTree {
  const TriangleMesh& mesh;
  detail::TriangleHierarchy hierarchy;
  std::vector<FarField> far;  // per node

  explicit WindingTree(const TriangleMesh& m) : mesh(m), hierarchy(detail::build_triangle_hierarchy(m)) {
    build_far_fields();
  }

  Vec3 corner(uint32_t triangle, int k) const {
    return mesh.positions[mesh.triangles[triangle][static_cast<size_t>(k)]];
  }

  // Every node covers a contiguous run of triangle_order; children come after their parent,
  // so a reverse sweep sees both children of a node before the node.
  void build_far_fields() {
    const size_t node_count = hierarchy.nodes.size();
    std::vector<uint32_t> range_begin(node_count), range_end(node_count);
    for (size_t n = node_count; n-- > 0;) {
      const detail::TriangleHierarchy::Node& node = hierarchy.nodes[n];
      if (node.count > 0) {
        range_begin[n] = node.first;
        range_end[n] = node.first + node.count;
      } else {
        range_begin[n] = range_begin[node.first];
        range_end[n] = range_end[node.first + 1];
      }
    }
    far.resize(node_count);
    for (size_t n = 0; n < node_count; ++n) far[n] = far_field(range_begin[n], range_end[n]);
  }

  FarField far_field(uint32_t begin, uint32_t end) const {
    FarField f;
    double area = 0.0;
    Vec3 weighted_centroids(0.0);
    for (uint32_t i = begin; i < end; ++i) {
      const uint32_t t = hierarchy.triangle_order[i];
      const Vec3 a = corner(t, 0), b = corner(t, 1), c = corner(t, 2);
      const Vec3 area_vector = 0.5 * glm::cross(b - a, c - a);
      const double triangle_area = glm::length(area_vector);
      f.area_vector += area_vector;
      area += triangle_area;
      weighted_centroids += triangle_area * (a + b + c) / 3.0;
    }
    // A node without area (degenerate triangles) has no far field; any point of it will do.
    f.centre = area > 0.0 ? weighted_centroids / area : corner(hierarchy.triangle_order[begin], 0);
    for (uint32_t i = begin; i < end; ++i) {
      const uint32_t t = hierarchy.triangle_order[i];
      const Vec3 a = corner(t, 0), b = corner(t, 1), c = corner(t, 2);
      const Vec3 area_vector = 0.5 * glm::cross(b - a, c - a);
      const Vec3 offset = (a + b + c) / 3.0 - f.centre;
      for (int j = 0; j < 3; ++j) f.dipole_moment[j] += area_vector[j] * offset;
      const double triangle_area = glm::length(area_vector);
      if (triangle_area > 0.0) {
        const Vec3 unit_normal = area_vector / triangle_area;
        const Vec3 da = a - f.centre, db = b - f.centre, dc = c - f.centre, sum = da + db + dc;
        const glm::dmat3 second_moment =
            (triangle_area / 12.0) * (glm::outerProduct(da, da) + glm::outerProduct(db, db) +
                                      glm::outerProduct(dc, dc) + glm::outerProduct(sum, sum));
        for (int k = 0; k < 3; ++k) f.quadrupole[static_cast<size_t>(k)] += unit_normal[k] * second_moment;
      }
      for (const Vec3& p : {a, b, c}) f.radius = std::max(f.radius, glm::length(p - f.centre));
    }
    return f;
  }

  double solid_angle(const Vec3& query) const {
    if (hierarchy.nodes.empty()) return 0.0;
    double total = 0.0;
    // The median split bounds the depth by about log2(triangles), and the stack holds at
    // most one pending sibling per level.
    uint32_t stack[128];
    int stack_size = 0;
    stack[stack_size++] = 0;
    while (stack_size > 0) {
      const uint32_t n = stack[--stack_size];
      const FarField& f = far[n];
      const Vec3 r = f.centre - query;
      const double squared = glm::dot(r, r);
      const double reach = kAccuracy * f.radius;
      if (squared > reach * reach) {
        total += f.solid_angle(r, squared);
        continue;
      }
      const detail::TriangleHierarchy::Node& node = hierarchy.nodes[n];
      if (node.count == 0) {
        stack[stack_size++] = node.first;
        stack[stack_size++] = node.first + 1;
        continue;
      }
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        const uint32_t t = hierarchy.triangle_order[i];
        total += signed_solid_angle(corner(t, 0) - query, corner(t, 1) - query, corner(t, 2) - query);
      }
    }
    return total;
  }
};

// Runs work(begin, end) over [0, count) split between the hardware threads: queries are
// independent, so the result does not depend on the split.
template <class Work>
void parallel_ranges(size_t count, const Work& work) {
  const size_t threads = std::clamp<size_t>(std::thread::hardware_concurrency(), 1, 16);
  constexpr size_t kMinPerThread = 1024;
  const size_t used = std::max<size_t>(1, std::min(threads, count / kMinPerThread));
  if (used == 1) {
    work(size_t{0}, count);
    return;
  }
  std::vector<std::thread> workers;
  const size_t chunk = (count + used - 1) / used;
  for (size_t k = 1; k < used; ++k)
    workers.emplace_back([&work, k, chunk, count] { work(k * chunk, std::min(count, (k + 1) * chunk)); });
  work(size_t{0}, std::min(count, chunk));
  for (std::thread& worker : workers) worker.join();
}

}  // namespace

std::vector<double> winding_numbers(const TriangleMesh& mesh, const std::vector<Vec3>& queries) {
  std::vector<double> winding(queries.size(), 0.0);
  for (size_t q = 0; q < queries.size(); ++q) {
    const Vec3& query = queries[q];
    double total_solid_angle = 0.0;
    for (const Triangle& t : mesh.triangles) {
      total_solid_angle +=
          signed_solid_angle(mesh.positions[t[0]] - query, mesh.positions[t[1]] - query, mesh.positions[t[2]] - query);
    }
    winding[q] = total_solid_angle / (4.0 * glm::pi<double>());
  }
  return winding;
}

std::vector<double> fast_winding_numbers(const TriangleMesh& mesh, const std::vector<Vec3>& queries) {
  std::vector<double> winding(queries.size(), 0.0);
  if (queries.empty()) return winding;
  const WindingTree tree(mesh);
  parallel_ranges(queries.size(), [&](size_t begin, size_t end) {
    for (size_t q = begin; q < end; ++q) winding[q] = tree.solid_angle(queries[q]) / (4.0 * glm::pi<double>());
  });
  return winding;
}

double inside_fraction(const TriangleMesh& mesh, const std::vector<Vec3>& queries) {
  if (queries.empty()) return 0.0;
  const std::vector<double> winding = fast_winding_numbers(mesh, queries);
  const auto inside = std::count_if(winding.begin(), winding.end(), [](double w) { return w > 0.5; });
  return static_cast<double>(inside) / static_cast<double>(queries.size());
}

}  // namespace skelform::bake
