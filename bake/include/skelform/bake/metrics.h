// Metrics shared by tests, benchmarks and tool summaries (DESIGN.md "Metrics").
#pragma once

#include "skelform/bake/mesh.h"

#include <memory>
#include <vector>

namespace skelform::bake {

// Generalized winding number of a closed (or nearly closed) triangle mesh at each query point
// (Jacobson et al. 2013: sum of signed solid angles / 4π). > 0.5 means inside. Exact, and
// O(queries × triangles): the reference fast_winding_numbers is measured against.
std::vector<double> winding_numbers(const TriangleMesh& mesh, const std::vector<Vec3>& queries);

// The same winding numbers in O((triangles + queries) log triangles), by the hierarchical
// approximation of Barill et al. 2018: a bounding-volume hierarchy over the triangles, each
// node far from the query (beyond three times its radius) replaced by its second-order
// multipole expansion, the near ones summed exactly. The error, within 2e-3 of
// winding_numbers on the test meshes, is far below the distance from 1/2 an inside test
// needs: a closed mesh's winding number is 0 or ±1. Runs on every hardware thread; the
// result does not depend on their number.
std::vector<double> fast_winding_numbers(const TriangleMesh& mesh, const std::vector<Vec3>& queries);

// Fraction of queries with winding number > 0.5, by fast_winding_numbers.
double inside_fraction(const TriangleMesh& mesh, const std::vector<Vec3>& queries);

// Bounding-volume hierarchy over a mesh's triangles for closest-point queries.
class TriangleTree {
 public:
  explicit TriangleTree(const TriangleMesh& mesh);
  ~TriangleTree();
  TriangleTree(TriangleTree&&) noexcept;
  TriangleTree& operator=(TriangleTree&&) noexcept;

  struct Hit {
    double distance = 0;    // Euclidean distance to the closest point
    uint32_t triangle = 0;  // index of the closest triangle
    Vec3 point{};           // the closest point
  };
  // Requires a mesh with at least one triangle.
  Hit closest(const Vec3& query) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Distance from each query point to the surface of the mesh.
std::vector<double> surface_distances(const TriangleMesh& mesh, const std::vector<Vec3>& queries);

// Signed volume enclosed by a closed, outward-oriented mesh (divergence theorem).
double enclosed_volume(const TriangleMesh& mesh);

}  // namespace skelform::bake
