#include "quality_metrics.h"

#include "skelform/bake/self_intersection.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <unordered_map>

namespace skelform::samples {
namespace {

struct PositionKey {
  float x, y, z;
  bool operator==(const PositionKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct PositionHash {
  size_t operator()(const PositionKey& k) const {
    uint32_t b[3];
    std::memcpy(&b[0], &k.x, 4);
    std::memcpy(&b[1], &k.y, 4);
    std::memcpy(&b[2], &k.z, 4);
    size_t h = 1469598103934665603ull;
    for (uint32_t v : b) h = (h ^ v) * 1099511628211ull;
    return h;
  }
};

// -0 and +0 are one position.
float canonical(float v) { return v == 0.0f ? 0.0f : v; }

}  // namespace

DenseTopology dense_topology(const std::vector<float>& positions, const std::vector<uint32_t>& triangles) {
  DenseTopology topology;
  const size_t vertex_count = positions.size() / 3;
  topology.welded_of_vertex.resize(vertex_count);
  std::unordered_map<PositionKey, uint32_t, PositionHash> index;
  index.reserve(vertex_count);
  for (size_t v = 0; v < vertex_count; ++v) {
    const PositionKey key{canonical(positions[3 * v]), canonical(positions[3 * v + 1]),
                          canonical(positions[3 * v + 2])};
    const auto inserted = index.emplace(key, uint32_t(topology.vertex_of_welded.size()));
    if (inserted.second) topology.vertex_of_welded.push_back(uint32_t(v));
    topology.welded_of_vertex[v] = inserted.first->second;
  }
  std::vector<std::array<uint32_t, 3>> seen;
  for (size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const std::array<uint32_t, 3> corners{topology.welded_of_vertex[triangles[t]],
                                          topology.welded_of_vertex[triangles[t + 1]],
                                          topology.welded_of_vertex[triangles[t + 2]]};
    if (corners[0] == corners[1] || corners[1] == corners[2] || corners[0] == corners[2]) continue;
    std::array<uint32_t, 3> sorted = corners;
    std::sort(sorted.begin(), sorted.end());
    seen.push_back(sorted);
    topology.triangles.push_back(corners);
  }
  // Repeated triangles (same corners, either orientation): keep the first.
  {
    std::map<std::array<uint32_t, 3>, bool> kept;
    std::vector<std::array<uint32_t, 3>> unique;
    for (size_t t = 0; t < topology.triangles.size(); ++t)
      if (kept.emplace(seen[t], true).second) unique.push_back(topology.triangles[t]);
    topology.triangles.swap(unique);
  }
  // Closed: every directed edge once, and its reverse once.
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (const auto& t : topology.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  bool closed = !topology.triangles.empty();
  for (const auto& [edge, count] : directed) {
    if (count != 1) {
      closed = false;
      break;
    }
    const auto reverse = directed.find({edge.second, edge.first});
    if (reverse == directed.end() || reverse->second != 1) {
      closed = false;
      break;
    }
  }
  topology.closed = closed;
  return topology;
}

std::vector<TrianglePair> intersecting_pairs(const DenseTopology& topology, const std::vector<float>& positions) {
  bake::TriangleMesh mesh;
  mesh.positions.resize(topology.vertex_of_welded.size());
  for (size_t w = 0; w < mesh.positions.size(); ++w) {
    const size_t v = topology.vertex_of_welded[w];
    mesh.positions[w] = bake::Vec3(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
  }
  mesh.triangles.assign(topology.triangles.begin(), topology.triangles.end());
  return bake::self_intersecting_pairs(mesh);
}

namespace {

// Calls visit(pair) for every pair of `posed` not in `reference` (both sorted).
template <class Visit>
void for_each_added(const std::vector<TrianglePair>& posed, const std::vector<TrianglePair>& reference, Visit&& visit) {
  auto r = reference.begin();
  for (const TrianglePair& pair : posed) {
    while (r != reference.end() && *r < pair) ++r;
    if (r == reference.end() || *r != pair) visit(pair);
  }
}

}  // namespace

size_t pairs_added(const std::vector<TrianglePair>& posed, const std::vector<TrianglePair>& reference) {
  size_t added = 0;
  for_each_added(posed, reference, [&](const TrianglePair&) { ++added; });
  return added;
}

Junctions find_junctions(const DenseTopology& topology, const std::vector<TrianglePair>& reference) {
  // Union-find over the welded vertices; a part is named by its smallest vertex.
  std::vector<uint32_t> root(topology.vertex_of_welded.size());
  for (size_t v = 0; v < root.size(); ++v) root[v] = uint32_t(v);
  auto find = [&](uint32_t v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  for (const auto& t : topology.triangles)
    for (int k = 1; k < 3; ++k) {
      const uint32_t a = find(t[0]), b = find(t[size_t(k)]);
      root[std::max(a, b)] = std::min(a, b);
    }
  Junctions junctions;
  junctions.part.reserve(topology.triangles.size());
  for (const auto& t : topology.triangles) junctions.part.push_back(find(t[0]));
  for (const TrianglePair& pair : reference) {
    const uint32_t a = junctions.part[pair.first], b = junctions.part[pair.second];
    if (a != b) junctions.joined.emplace_back(std::min(a, b), std::max(a, b));
  }
  std::sort(junctions.joined.begin(), junctions.joined.end());
  junctions.joined.erase(std::unique(junctions.joined.begin(), junctions.joined.end()), junctions.joined.end());
  return junctions;
}

size_t pairs_added_at_junctions(const std::vector<TrianglePair>& posed, const std::vector<TrianglePair>& reference,
                                const Junctions& junctions) {
  size_t added = 0;
  for_each_added(posed, reference, [&](const TrianglePair& pair) {
    const uint32_t a = junctions.part[pair.first], b = junctions.part[pair.second];
    added += a != b && std::binary_search(junctions.joined.begin(), junctions.joined.end(),
                                          std::make_pair(std::min(a, b), std::max(a, b)));
  });
  return added;
}

double enclosed_volume(const DenseTopology& topology, const std::vector<float>& positions) {
  auto at = [&](uint32_t w) {
    const size_t v = topology.vertex_of_welded[w];
    return std::array<double, 3>{positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]};
  };
  double six_volume = 0.0;
  for (const auto& t : topology.triangles) {
    const auto a = at(t[0]), b = at(t[1]), c = at(t[2]);
    six_volume +=
        a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
  }
  return six_volume / 6.0;
}

double bounding_diagonal(const std::vector<float>& positions) {
  if (positions.size() < 3) return 0.0;
  double lo[3] = {positions[0], positions[1], positions[2]}, hi[3] = {lo[0], lo[1], lo[2]};
  for (size_t i = 0; i + 2 < positions.size(); i += 3)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(positions[i + k]));
      hi[k] = std::max(hi[k], double(positions[i + k]));
    }
  return std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                   (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

}  // namespace skelform::samples
