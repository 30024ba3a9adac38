// Voronoi-based skeletal mesh (paper section 2, "Extraction of skeletal mesh"; DESIGN.md bake
// step 5). The Voronoi vertices of the mesh vertices are the circumcentres of their Delaunay
// tetrahedra; those on the inner side of a vertex's tangent plane approximate the inner
// medial axis near it (the paper's Fig. 4). Averaging them without the unstable pole gives a
// point whose distance d along the inner normal defines S = M − d·N, the paper's eq. (1).
#include "skelform/bake/skeleton.h"

#include "skelform/bake/topology.h"

#include <glm/geometric.hpp>
#include <libqhullcpp/Qhull.h>
#include <libqhullcpp/QhullError.h>
#include <libqhullcpp/QhullFacet.h>
#include <libqhullcpp/QhullFacetList.h>
#include <libqhullcpp/QhullPoint.h>
#include <libqhullcpp/QhullVertex.h>
#include <libqhullcpp/QhullVertexSet.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <tuple>

namespace skelform::bake {
namespace {

bool is_finite(const Vec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// Running statistics of the inner candidates of one mesh vertex: the pole (farthest
// candidate) is only known at the end, so keep the sum of all and subtract the pole.
struct CandidateAccumulator {
  Vec3 sum{0.0};
  uint32_t count = 0;
  double pole_distance = -1.0;
  Vec3 pole{0.0};
  size_t pole_cell = 0;  // Delaunay cell whose circumcentre is the pole
};

// One Delaunay cell (finite tetrahedron, or a merged cospherical cell) of the mesh vertices.
struct DelaunayCell {
  Vec3 circumcentre;
  uint32_t first_corner;  // into the flat corner list
  uint32_t corner_count;
};

struct Delaunay {
  std::vector<DelaunayCell> cells;
  std::vector<uint32_t> corners;  // unique-point indices
};

// Circumcentre of the tetrahedron (a, b, c, d): a + (|u|²(v×w) + |v|²(w×u) + |w|²(u×v)) /
// (2 u·(v×w)) with u, v, w the edges from a. A flat tetrahedron gives a huge or non-finite
// point, which the bounding-box and finiteness filters drop.
Vec3 circumcentre(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3 u = b - a, v = c - a, w = d - a;
  const Vec3 v_cross_w = glm::cross(v, w);
  const double twice_signed_volume6 = 2.0 * glm::dot(u, v_cross_w);
  return a + (glm::dot(u, u) * v_cross_w + glm::dot(v, v) * glm::cross(w, u) + glm::dot(w, w) * glm::cross(u, v)) /
                 twice_signed_volume6;
}

// Circumcentre of a cell whose corners are cospherical (a Qhull-merged, non-simplicial
// Delaunay cell): any non-flat four of them define the sphere, so take the best-spread four
// (farthest from the first, then largest triangle, then largest tetrahedron).
Vec3 cospherical_centre(const std::vector<Vec3>& points, const uint32_t* corners, uint32_t count) {
  const Vec3& a = points[corners[0]];
  uint32_t best_b = 1, best_c = 2, best_d = 3;
  double best = -1.0;
  for (uint32_t k = 1; k < count; ++k) {
    const double measure = glm::length(points[corners[k]] - a);
    if (measure > best) best = measure, best_b = k;
  }
  const Vec3& b = points[corners[best_b]];
  best = -1.0;
  for (uint32_t k = 1; k < count; ++k) {
    const double measure = glm::length(glm::cross(b - a, points[corners[k]] - a));
    if (measure > best) best = measure, best_c = k;
  }
  const Vec3& c = points[corners[best_c]];
  const Vec3 triangle_normal = glm::cross(b - a, c - a);
  best = -1.0;
  for (uint32_t k = 1; k < count; ++k) {
    const double measure = std::abs(glm::dot(triangle_normal, points[corners[k]] - a));
    if (measure > best) best = measure, best_d = k;
  }
  return circumcentre(a, b, c, points[corners[best_d]]);
}

// Delaunay cells of `points` (distinct) through Qhull's lifting to the 4D paraboloid:
// "d" Delaunay; "Qbb" scales the lifted coordinate to the others' range (precision); "Qz"
// adds a point at infinity so that cospherical input (a sphere mesh) is not degenerate
// (DEPENDENCIES.md pitfall 7). Cells are the lower-hull facets. Their Voronoi vertices are
// computed here rather than with Qhull's "v": that option made Qhull about 1.5x slower on an
// 8K-vertex mesh, and the formula is the same for simplicial cells.
Delaunay delaunay_cells(const std::vector<Vec3>& points) {
  std::vector<double> coordinates;
  coordinates.reserve(points.size() * 3);
  for (const Vec3& p : points) coordinates.insert(coordinates.end(), {p.x, p.y, p.z});

  Delaunay result;
  std::ostringstream qhull_messages;
  try {
    orgQhull::Qhull qhull;
    // Qhull writes warnings and errors to its streams; a library must not print, and the
    // message reaches the caller through QhullError instead.
    qhull.setOutputStream(&qhull_messages);
    qhull.setErrorStream(&qhull_messages);
    qhull.runQhull("", 3, static_cast<int>(points.size()), coordinates.data(), "d Qbb Qz");
    result.cells.reserve(static_cast<size_t>(qhull.facetCount()));
    result.corners.reserve(static_cast<size_t>(qhull.facetCount()) * 4);
    for (orgQhull::QhullFacet facet = qhull.beginFacet(); facet != qhull.endFacet(); facet = facet.next()) {
      if (facet.isUpperDelaunay()) continue;
      DelaunayCell cell{Vec3(0.0), static_cast<uint32_t>(result.corners.size()), 0};
      for (const orgQhull::QhullVertex& vertex : facet.vertices()) {
        const int id = vertex.point().id();
        // The point at infinity of "Qz" has an id past the input; it only joins upper
        // facets, but guard anyway.
        if (id < 0 || static_cast<size_t>(id) >= points.size()) continue;
        result.corners.push_back(static_cast<uint32_t>(id));
        ++cell.corner_count;
      }
      if (cell.corner_count < 4) {
        result.corners.resize(cell.first_corner);
        continue;
      }
      const uint32_t* corners = result.corners.data() + cell.first_corner;
      cell.circumcentre = cell.corner_count == 4 ? circumcentre(points[corners[0]], points[corners[1]],
                                                                points[corners[2]], points[corners[3]])
                                                 : cospherical_centre(points, corners, cell.corner_count);
      result.cells.push_back(cell);
    }
  } catch (const orgQhull::QhullError& error) {
    // what() holds only the code ("QH6154"); the sentence is the line of Qhull's log that
    // starts with that code (warnings may come before it).
    const std::string code = error.what();
    const std::string log = qhull_messages.str();
    std::string message = code;
    const size_t line_start = code.empty() ? std::string::npos : log.find(code);
    if (line_start != std::string::npos) message = log.substr(line_start, log.find('\n', line_start) - line_start);
    throw Error(ErrorKind::invalid_input, "skeleton: Delaunay tetrahedralization failed (Qhull): " + message);
  }
  return result;
}

// Gives every vertex without Voronoi candidates the mean d of its one-ring neighbours that have
// one, front by front (each front only reads values from earlier fronts, so the result does not
// depend on vertex order). A connected component where no vertex has a candidate keeps d = 0:
// the skeleton there coincides with the surface, which still satisfies M = S + d·N. Each front
// is found from the previous one, so the whole fill is linear in the mesh size.
void fill_medial_radius_from_neighbours(const VertexAdjacency& adjacency, std::vector<double>& medial_radius,
                                        std::vector<bool>& known) {
  const size_t vertex_count = medial_radius.size();
  std::vector<bool> in_front(vertex_count, false);
  std::vector<uint32_t> front;
  auto enqueue_unknown_neighbours = [&](uint32_t v, std::vector<uint32_t>& next) {
    for (uint32_t k = adjacency.offsets[v]; k < adjacency.offsets[v + 1]; ++k) {
      const uint32_t neighbour = adjacency.neighbours[k];
      if (known[neighbour] || in_front[neighbour]) continue;
      in_front[neighbour] = true;
      next.push_back(neighbour);
    }
  };
  for (uint32_t v = 0; v < vertex_count; ++v)
    if (known[v]) enqueue_unknown_neighbours(v, front);
  std::vector<double> front_radius;
  std::vector<uint32_t> next;
  while (!front.empty()) {
    front_radius.assign(front.size(), 0.0);
    for (size_t i = 0; i < front.size(); ++i) {
      const uint32_t v = front[i];
      double sum = 0.0;
      uint32_t count = 0;
      for (uint32_t k = adjacency.offsets[v]; k < adjacency.offsets[v + 1]; ++k) {
        const uint32_t neighbour = adjacency.neighbours[k];
        if (!known[neighbour]) continue;
        sum += medial_radius[neighbour];
        ++count;
      }
      front_radius[i] = sum / count;  // count >= 1: v joined the front through a known neighbour
    }
    for (size_t i = 0; i < front.size(); ++i) {
      medial_radius[front[i]] = front_radius[i];
      known[front[i]] = true;
    }
    next.clear();
    for (uint32_t v : front) enqueue_unknown_neighbours(v, next);
    front.swap(next);
  }
  for (uint32_t v = 0; v < vertex_count; ++v)
    if (!known[v]) medial_radius[v] = 0.0;
}

}  // namespace

SkeletalMesh extract_skeleton(const TriangleMesh& mesh, const SkeletonOptions& options) {
  const size_t vertex_count = mesh.positions.size();
  if (vertex_count > kMaxSkeletonVertices)
    throw Error(ErrorKind::unsupported, "skeleton: " + std::to_string(vertex_count) + " vertices, more than the " +
                                            std::to_string(kMaxSkeletonVertices) +
                                            " the Voronoi skeleton takes (decimate the mesh first)");
  for (const Vec3& p : mesh.positions)
    if (!is_finite(p)) throw Error(ErrorKind::invalid_input, "skeleton: mesh has a non-finite vertex position");
  for (const Triangle& t : mesh.triangles)
    for (uint32_t corner : t)
      if (corner >= vertex_count) throw Error(ErrorKind::invalid_input, "skeleton: triangle index out of range");

  // The Voronoi diagram is of the surface's vertices: a vertex no triangle uses (welding
  // keeps them) would carve the cells of its neighbours, so it stays out of Qhull and ends up
  // without candidates (and without a normal: S = M).
  std::vector<bool> referenced(vertex_count, false);
  for (const Triangle& t : mesh.triangles)
    for (uint32_t corner : t) referenced[corner] = true;

  // Qhull does not keep exactly coincident points as Delaunay vertices; feed it each position
  // once and let the copies share the result, so every mesh vertex maps to a Qhull point id.
  constexpr uint32_t kNotInDiagram = ~0u;
  std::vector<uint32_t> unique_of_vertex(vertex_count, kNotInDiagram);
  std::vector<Vec3> unique_points;
  {
    std::map<std::tuple<double, double, double>, uint32_t> index_of_position;
    for (uint32_t v = 0; v < vertex_count; ++v) {
      if (!referenced[v]) continue;
      const Vec3& p = mesh.positions[v];
      // +0.0 and -0.0 compare equal as doubles, so they are one key.
      const auto [it, inserted] =
          index_of_position.emplace(std::make_tuple(p.x, p.y, p.z), static_cast<uint32_t>(unique_points.size()));
      if (inserted) unique_points.push_back(p);
      unique_of_vertex[v] = it->second;
    }
  }
  if (unique_points.size() < 4)
    throw Error(ErrorKind::invalid_input, "skeleton: the mesh needs at least 4 distinct triangle vertices, it has " +
                                              std::to_string(unique_points.size()));
  {
    // Coplanar input has no tetrahedra; say so plainly instead of relaying Qhull's message.
    const Bounds box = bounds_of(unique_points);
    const double scale = box.diagonal();
    const Vec3& origin = unique_points[0];
    Vec3 span_u(0.0), span_normal(0.0);
    double best = 0.0;
    for (const Vec3& p : unique_points) {
      const double length = glm::length(p - origin);
      if (length > best) best = length, span_u = p - origin;
    }
    best = 0.0;
    for (const Vec3& p : unique_points) {
      const Vec3 normal = glm::cross(span_u, p - origin);
      const double length = glm::length(normal);
      if (length > best) best = length, span_normal = normal;
    }
    double max_offset = 0.0;
    if (best > 0.0) {
      const Vec3 unit_normal = span_normal / best;
      for (const Vec3& p : unique_points)
        max_offset = std::max(max_offset, std::abs(glm::dot(p - origin, unit_normal)));
    }
    if (!(max_offset > 1e-12 * scale))
      throw Error(ErrorKind::invalid_input, "skeleton: all triangle vertices are coplanar (no enclosed volume)");
  }

  const Delaunay delaunay = delaunay_cells(unique_points);

  SkeletalMesh skeleton;
  skeleton.normals = area_weighted_normals(mesh);
  const VertexAdjacency adjacency = build_adjacency(mesh);

  // Inner Voronoi vertices must lie in the mesh's box grown by the margin (the paper drops
  // those "located outside some bounding box of the mesh"; far ones come from flat Delaunay
  // cells and would otherwise dominate the mean).
  Bounds keep_box = bounds_of(mesh.positions);
  const Vec3 margin(options.bounding_box_margin * keep_box.diagonal());
  keep_box.min -= margin;
  keep_box.max += margin;
  auto inside_keep_box = [&keep_box](const Vec3& p) {
    return p.x >= keep_box.min.x && p.y >= keep_box.min.y && p.z >= keep_box.min.z && p.x <= keep_box.max.x &&
           p.y <= keep_box.max.y && p.z <= keep_box.max.z;
  };

  // Mesh vertices per unique point (usually one).
  std::vector<uint32_t> vertex_offsets(unique_points.size() + 1, 0);
  for (uint32_t v = 0; v < vertex_count; ++v)
    if (unique_of_vertex[v] != kNotInDiagram) ++vertex_offsets[unique_of_vertex[v] + 1];
  for (size_t u = 0; u < unique_points.size(); ++u) vertex_offsets[u + 1] += vertex_offsets[u];
  std::vector<uint32_t> vertices_of_unique(vertex_offsets.back());
  {
    std::vector<uint32_t> fill(vertex_offsets.begin(), vertex_offsets.end() - 1);
    for (uint32_t v = 0; v < vertex_count; ++v)
      if (unique_of_vertex[v] != kNotInDiagram) vertices_of_unique[fill[unique_of_vertex[v]]++] = v;
  }

  // Each cell's circumcentre is a Voronoi vertex of the cell of each of its corners.
  std::vector<CandidateAccumulator> candidates(vertex_count);
  std::vector<uint32_t> cell_uses(delaunay.cells.size(), 0);  // (vertex, cell) pairs kept
  for (size_t cell_index = 0; cell_index < delaunay.cells.size(); ++cell_index) {
    const DelaunayCell& cell = delaunay.cells[cell_index];
    const Vec3& centre = cell.circumcentre;
    if (!is_finite(centre) || !inside_keep_box(centre)) continue;
    for (uint32_t k = 0; k < cell.corner_count; ++k) {
      const uint32_t unique = delaunay.corners[cell.first_corner + k];
      for (uint32_t i = vertex_offsets[unique]; i < vertex_offsets[unique + 1]; ++i) {
        const uint32_t v = vertices_of_unique[i];
        const Vec3 offset = centre - mesh.positions[v];
        // Inner side of the tangent plane: the paper's "mesh orientation" test.
        if (!(glm::dot(offset, skeleton.normals[v]) < 0.0)) continue;
        CandidateAccumulator& accumulator = candidates[v];
        accumulator.sum += centre;
        ++accumulator.count;
        ++cell_uses[cell_index];
        const double distance = glm::length(offset);
        if (distance > accumulator.pole_distance) {
          accumulator.pole_distance = distance;
          accumulator.pole = centre;
          accumulator.pole_cell = cell_index;
        }
      }
    }
  }

  skeleton.medial_radius.assign(vertex_count, 0.0);
  skeleton.voronoi_vertex_count.assign(vertex_count, 0);
  std::vector<bool> has_medial_radius(vertex_count, false);
  for (uint32_t v = 0; v < vertex_count; ++v) {
    const CandidateAccumulator& accumulator = candidates[v];
    if (accumulator.count == 0) continue;
    Vec3 mean_centre = accumulator.pole;
    uint32_t kept = 1;
    if (accumulator.count >= 2) {
      // The pole is neglected (paper: poles are unstable under small mesh defects).
      --cell_uses[accumulator.pole_cell];
      kept = accumulator.count - 1;
      mean_centre = (accumulator.sum - accumulator.pole) / static_cast<double>(kept);
    }
    // A single inner Voronoi vertex is kept although it is the pole: it is all the medial
    // information the vertex has. Exactly cospherical input (a sphere, the rings of a
    // cylinder) gives this case: Qhull merges the cospherical Delaunay cells into one, whose
    // one Voronoi vertex is the true centre.
    const double d = glm::length(mean_centre - mesh.positions[v]);
    if (!std::isfinite(d)) continue;
    skeleton.medial_radius[v] = d;
    skeleton.voronoi_vertex_count[v] = kept;
    has_medial_radius[v] = true;
  }
  for (size_t cell_index = 0; cell_index < delaunay.cells.size(); ++cell_index)
    if (cell_uses[cell_index] > 0) skeleton.kept_voronoi_vertices.push_back(delaunay.cells[cell_index].circumcentre);

  for (uint32_t v = 0; v < vertex_count; ++v)
    if (!has_medial_radius[v]) ++skeleton.vertices_without_candidates;
  fill_medial_radius_from_neighbours(adjacency, skeleton.medial_radius, has_medial_radius);

  // S = M − d·N (paper eq. (1)); a vertex without a normal has S = M whatever d is.
  skeleton.skeletal_positions.resize(vertex_count);
  for (uint32_t v = 0; v < vertex_count; ++v)
    skeleton.skeletal_positions[v] = mesh.positions[v] - skeleton.medial_radius[v] * skeleton.normals[v];
  return skeleton;
}

}  // namespace skelform::bake
