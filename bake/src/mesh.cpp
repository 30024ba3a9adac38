#include "skelform/bake/mesh.h"

#include <glm/geometric.hpp>

namespace skelform::bake {

void Bounds::grow(const Vec3& p) {
  min = glm::min(min, p);
  max = glm::max(max, p);
}

double Bounds::diagonal() const {
  if (min.x > max.x || min.y > max.y || min.z > max.z) return 0.0;
  return glm::length(max - min);
}

Bounds bounds_of(const std::vector<Vec3>& points) {
  Bounds b;
  for (const Vec3& p : points) b.grow(p);
  return b;
}

}  // namespace skelform::bake
