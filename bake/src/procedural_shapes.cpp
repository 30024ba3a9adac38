// Analytic test shapes: capsule, UV sphere, icosphere.
#include "skelform/bake/procedural.h"

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

#include <cmath>
#include <algorithm>
#include <map>
#include <utility>

namespace skelform::bake {
namespace {

// Rings of `segments` vertices stacked along z, closed by one vertex at each end. Each ring
// is given by (z, ring radius); the caps' pole vertices are at z_bottom and z_top.
TriangleMesh revolve_rings(const std::vector<std::pair<double, double>>& rings, double z_bottom, double z_top,
                           int segments) {
  TriangleMesh mesh;
  const uint32_t n = static_cast<uint32_t>(segments);
  mesh.positions.push_back({0.0, 0.0, z_bottom});
  for (const auto& [z, r] : rings) {
    for (uint32_t s = 0; s < n; ++s) {
      const double a = 2.0 * glm::pi<double>() * s / n;
      mesh.positions.push_back({r * std::cos(a), r * std::sin(a), z});
    }
  }
  const uint32_t top = static_cast<uint32_t>(mesh.positions.size());
  mesh.positions.push_back({0.0, 0.0, z_top});

  auto ring_vertex = [n](size_t ring, uint32_t s) { return 1 + static_cast<uint32_t>(ring) * n + s % n; };
  // Bottom fan: looking from -z the ring runs clockwise, so (pole, s+1, s) faces outward.
  for (uint32_t s = 0; s < n; ++s) mesh.triangles.push_back({0, ring_vertex(0, s + 1), ring_vertex(0, s)});
  for (size_t r = 0; r + 1 < rings.size(); ++r) {
    for (uint32_t s = 0; s < n; ++s) {
      const uint32_t a = ring_vertex(r, s), b = ring_vertex(r, s + 1);
      const uint32_t c = ring_vertex(r + 1, s), d = ring_vertex(r + 1, s + 1);
      mesh.triangles.push_back({a, b, d});
      mesh.triangles.push_back({a, d, c});
    }
  }
  const size_t last = rings.size() - 1;
  for (uint32_t s = 0; s < n; ++s) mesh.triangles.push_back({top, ring_vertex(last, s), ring_vertex(last, s + 1)});
  return mesh;
}

}  // namespace

TriangleMesh make_capsule(double radius, double cylinder_length, int segments, int cylinder_rings, int cap_rings) {
  if (radius <= 0 || cylinder_length < 0 || segments < 3 || cylinder_rings < 1 || cap_rings < 1)
    throw Error(ErrorKind::usage, "make_capsule: invalid parameters");
  const double half = 0.5 * cylinder_length;
  std::vector<std::pair<double, double>> rings;
  for (int i = 1; i <= cap_rings; ++i) {  // bottom cap, pole excluded, equator included
    const double phi = 0.5 * glm::pi<double>() * (1.0 - double(i) / cap_rings);
    rings.push_back({-half - radius * std::sin(phi), radius * std::cos(phi)});
  }
  for (int i = 1; i <= cylinder_rings; ++i)
    rings.push_back({-half + cylinder_length * double(i) / cylinder_rings, radius});
  for (int i = 1; i < cap_rings; ++i) {  // top cap, equator already placed, pole excluded
    const double phi = 0.5 * glm::pi<double>() * double(i) / cap_rings;
    rings.push_back({half + radius * std::sin(phi), radius * std::cos(phi)});
  }
  return revolve_rings(rings, -half - radius, half + radius, segments);
}

TriangleMesh make_uv_sphere(double radius, int slices, int stacks) {
  if (radius <= 0 || slices < 3 || stacks < 2) throw Error(ErrorKind::usage, "make_uv_sphere: invalid parameters");
  std::vector<std::pair<double, double>> rings;
  for (int i = 1; i < stacks; ++i) {
    const double theta = glm::pi<double>() * double(i) / stacks;  // from the south pole
    rings.push_back({-radius * std::cos(theta), radius * std::sin(theta)});
  }
  return revolve_rings(rings, -radius, radius, slices);
}

TriangleMesh make_icosphere(double radius, int subdivisions) {
  if (radius <= 0 || subdivisions < 0) throw Error(ErrorKind::usage, "make_icosphere: invalid parameters");
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  TriangleMesh mesh;
  mesh.positions = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  mesh.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                    {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                    {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoint;
    auto mid = [&](uint32_t a, uint32_t b) {
      const std::pair<uint32_t, uint32_t> key{std::min(a, b), std::max(a, b)};
      auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      const uint32_t index = static_cast<uint32_t>(mesh.positions.size());
      mesh.positions.push_back(0.5 * (mesh.positions[a] + mesh.positions[b]));
      midpoint.emplace(key, index);
      return index;
    };
    std::vector<Triangle> refined;
    refined.reserve(mesh.triangles.size() * 4);
    for (const Triangle& tri : mesh.triangles) {
      const uint32_t ab = mid(tri[0], tri[1]), bc = mid(tri[1], tri[2]), ca = mid(tri[2], tri[0]);
      refined.push_back({tri[0], ab, ca});
      refined.push_back({tri[1], bc, ab});
      refined.push_back({tri[2], ca, bc});
      refined.push_back({ab, bc, ca});
    }
    mesh.triangles = std::move(refined);
  }
  for (Vec3& p : mesh.positions) p = radius * glm::normalize(p);
  return mesh;
}

}  // namespace skelform::bake
