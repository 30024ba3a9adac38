// The contact mesh (contact.h): the deformable's dense mesh welded by rest position, its
// triangles around each vertex, its rest lengths, closedness and volume, its triangle
// hierarchy and the pairs that intersect as modelled. Built once per deformable at load.
#include "contact.h"

#include "skelform/core/triangle_intersection.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace skelform::runtime {
namespace {

// Welds by exact rest position: sort the vertices by (x, y, z), ties by index. Fills
// mesh.weld, mesh.representative and mesh.vertex_count.
void weld_vertices(const glm::vec3* rest_positions, uint32_t vertex_count, const AllocatorRef& allocator,
                   ContactMesh& mesh) {
  Array<uint32_t> order{CallbackAllocator<uint32_t>(allocator)};
  order.resize(vertex_count);
  std::iota(order.begin(), order.end(), 0u);
  auto less = [&](uint32_t a, uint32_t b) {
    const glm::vec3 &p = rest_positions[a], &q = rest_positions[b];
    if (p.x != q.x) return p.x < q.x;
    if (p.y != q.y) return p.y < q.y;
    if (p.z != q.z) return p.z < q.z;
    return a < b;
  };
  std::sort(order.begin(), order.end(), less);
  mesh.weld.assign(vertex_count, 0u);
  // The first vertex (lowest index) of each run of equal positions represents it; welded
  // vertices are numbered in the order of their representatives.
  Array<uint32_t> first{CallbackAllocator<uint32_t>(allocator)};
  first.assign(vertex_count, 0u);
  for (size_t i = 0; i < order.size();) {
    size_t j = i + 1;
    while (j < order.size() && rest_positions[order[j]] == rest_positions[order[i]]) ++j;
    for (size_t k = i; k < j; ++k) first[order[k]] = order[i];
    i = j;
  }
  Array<uint32_t> id{CallbackAllocator<uint32_t>(allocator)};
  id.assign(vertex_count, std::numeric_limits<uint32_t>::max());
  for (uint32_t v = 0; v < vertex_count; ++v) {
    const uint32_t r = first[v];
    if (id[r] == std::numeric_limits<uint32_t>::max()) {
      id[r] = mesh.vertex_count++;
      mesh.representative.push_back(r);
    }
    mesh.weld[v] = id[r];
  }
}

// The welded triangles without a repeated corner, and the triangles around each vertex (CSR).
void weld_triangles(const uint32_t* triangles, size_t triangle_count, const AllocatorRef& allocator,
                    ContactMesh& mesh) {
  for (size_t t = 0; t < triangle_count; ++t) {
    const uint32_t a = mesh.weld[triangles[3 * t]], b = mesh.weld[triangles[3 * t + 1]],
                   c = mesh.weld[triangles[3 * t + 2]];
    if (a == b || b == c || c == a) continue;
    mesh.triangles.push_back(a);
    mesh.triangles.push_back(b);
    mesh.triangles.push_back(c);
  }
  mesh.triangle_count = uint32_t(mesh.triangles.size() / 3);
  mesh.incident_offsets.assign(size_t(mesh.vertex_count) + 1, 0u);
  for (uint32_t i : mesh.triangles) ++mesh.incident_offsets[i + 1];
  for (uint32_t v = 0; v < mesh.vertex_count; ++v) mesh.incident_offsets[v + 1] += mesh.incident_offsets[v];
  mesh.incident.resize(mesh.triangles.size());
  Array<uint32_t> fill{CallbackAllocator<uint32_t>(allocator)};
  fill.assign(mesh.incident_offsets.begin(), mesh.incident_offsets.end() - 1);
  for (uint32_t t = 0; t < mesh.triangle_count; ++t)
    for (int k = 0; k < 3; ++k) mesh.incident[fill[mesh.triangles[3 * size_t(t) + k]]++] = t;
}

// The pass's lengths, relative to the mean rest edge (the pass is scale-invariant), whether
// the mesh is closed, and its rest volume.
void measure_rest(const glm::vec3* rest_positions, const AllocatorRef& allocator, ContactMesh& mesh) {
  double edge_sum = 0.0;
  for (uint32_t t = 0; t < mesh.triangle_count; ++t)
    for (int k = 0; k < 3; ++k)
      edge_sum += double(glm::length(rest_positions[mesh.representative[mesh.triangles[3 * size_t(t) + k]]] -
                                     rest_positions[mesh.representative[mesh.triangles[3 * size_t(t) + (k + 1) % 3]]]));
  const float mean_edge = mesh.triangle_count ? float(edge_sum / (3.0 * mesh.triangle_count)) : 0.0f;
  mesh.gap = kContactGap * mean_edge;
  mesh.cap = kContactCap * mean_edge;
  // Closed: every directed edge once and its reverse once (sorted directed edges, each with
  // its reverse found by binary search).
  Array<uint64_t> edges{CallbackAllocator<uint64_t>(allocator)};
  edges.reserve(mesh.triangles.size());
  for (uint32_t t = 0; t < mesh.triangle_count; ++t)
    for (int k = 0; k < 3; ++k)
      edges.push_back(uint64_t(mesh.triangles[3 * size_t(t) + k]) << 32 | mesh.triangles[3 * size_t(t) + (k + 1) % 3]);
  std::sort(edges.begin(), edges.end());
  bool closed = mesh.triangle_count > 0;
  for (size_t i = 0; i < edges.size() && closed; ++i) {
    if (i + 1 < edges.size() && edges[i + 1] == edges[i]) closed = false;
    const uint64_t reverse = (edges[i] << 32) | (edges[i] >> 32);
    if (!std::binary_search(edges.begin(), edges.end(), reverse)) closed = false;
  }
  mesh.closed = closed;
  double six_volume = 0.0;
  for (uint32_t t = 0; t < mesh.triangle_count; ++t) {
    const uint32_t* q = mesh.triangles.data() + 3 * size_t(t);
    const glm::dvec3 a(rest_positions[mesh.representative[q[0]]]), b(rest_positions[mesh.representative[q[1]]]),
        c(rest_positions[mesh.representative[q[2]]]);
    six_volume += glm::dot(a, glm::cross(b, c));
  }
  mesh.rest_volume = six_volume / 6.0;
}

// The hierarchy over the rest pose and the pairs that intersect as modelled (by the exact
// test, through the hierarchy, within pair_visit_budget).
void find_rest_pairs(const glm::vec3* rest_positions, const AllocatorRef& allocator, ContactMesh& mesh) {
  Array<glm::vec3> welded_rest{CallbackAllocator<glm::vec3>(allocator)};
  welded_rest.resize(mesh.vertex_count);
  for (uint32_t v = 0; v < mesh.vertex_count; ++v) welded_rest[v] = rest_positions[mesh.representative[v]];
  mesh.hierarchy = build_triangle_hierarchy(welded_rest.data(), mesh.triangles.data(), mesh.triangle_count, allocator);
  // The pairs that intersect at rest, by the exact test, through the hierarchy.
  Array<float> node_boxes{CallbackAllocator<float>(allocator)};
  Array<uint8_t> wanted{CallbackAllocator<uint8_t>(allocator)}, node_wanted{CallbackAllocator<uint8_t>(allocator)};
  Array<LeafLanes> leaf_wanted{CallbackAllocator<LeafLanes>(allocator)};
  SlotBoxes boxes(allocator);
  node_boxes.resize(6 * mesh.hierarchy.nodes.size());
  wanted.assign(mesh.hierarchy.slot_stride(), 1);  // by slot
  node_wanted.resize(mesh.hierarchy.nodes.size());
  leaf_wanted.resize(mesh.hierarchy.nodes.size());
  boxes.resize(mesh.hierarchy);
  const uint32_t* tri = mesh.triangles.data();
  for (uint32_t t = 0; t < mesh.triangle_count; ++t) {
    const glm::vec3 &a = welded_rest[tri[3 * size_t(t)]], &b = welded_rest[tri[3 * size_t(t) + 1]],
                    &c = welded_rest[tri[3 * size_t(t) + 2]];
    float box[6];
    for (int k = 0; k < 3; ++k) {
      box[k] = std::min({a[k], b[k], c[k]});
      box[3 + k] = std::max({a[k], b[k], c[k]});
    }
    boxes.set(mesh.hierarchy.slot[t], box);
  }
  refit_triangle_hierarchy(mesh.hierarchy, boxes, node_boxes.data());
  PairBudget budget(mesh.triangle_count);
  const bool complete = self_pairs_triangle_hierarchy(
      mesh.hierarchy, node_boxes.data(), boxes, wanted.data(), node_wanted.data(), leaf_wanted.data(),
      [&](uint32_t s, uint32_t t) {
        if (!budget.spend()) return false;
        const uint32_t* p = tri + 3 * size_t(s);
        const uint32_t* q = tri + 3 * size_t(t);
        auto at = [&](uint32_t v) { return glm::dvec3(welded_rest[v]); };
        if (geometry::triangles_intersect(at(p[0]), at(p[1]), at(p[2]), at(q[0]), at(q[1]), at(q[2])))
          mesh.rest_pairs.push_back(pair_key(s, t));
        return true;
      });
  if (!complete) {
    mesh.tangled_at_rest = true;
    Array<uint64_t>(CallbackAllocator<uint64_t>(allocator)).swap(mesh.rest_pairs);  // its memory too
  }
  std::sort(mesh.rest_pairs.begin(), mesh.rest_pairs.end());
  // The rest bound of the guard's leaf pairs (none for a mesh tangled over itself at rest).
  if (!mesh.tangled_at_rest)
    mesh.clearance = build_rest_clearance(mesh.hierarchy, welded_rest.data(), mesh.triangles.data(), allocator);
}

}  // namespace

ContactMesh build_contact_mesh(const glm::vec3* rest_positions, uint32_t vertex_count, const uint32_t* triangles,
                               size_t triangle_count, const AllocatorRef& allocator) {
  ContactMesh mesh(allocator);
  weld_vertices(rest_positions, vertex_count, allocator, mesh);
  weld_triangles(triangles, triangle_count, allocator, mesh);
  measure_rest(rest_positions, allocator, mesh);
  find_rest_pairs(rest_positions, allocator, mesh);
  return mesh;
}

}  // namespace skelform::runtime
