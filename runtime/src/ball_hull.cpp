// E_T(P), flow (4)'s signed distance from a point to the convex hull of three balls (fair.h
// ball_hull_distance): the interior (tangent-plane) candidate of ball_hull.h, else the
// boundary search over the three balls and the three edges' cone frusta, which a hint from the
// previous call may shortcut.
//
// In float, like the rest of the runtime's per-frame loops. The interior case's degeneracy
// test is relative, |e1 × e2|² > 1e-6 |e1|² |e2|² (the skeletal triangle's angles above
// ~0.06°): below that the Gram determinant is float cancellation noise and the boundary
// candidates decide.
#include "ball_hull.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace skelform::runtime {
namespace fair_detail {
namespace {

// with s the arc length along the axis, φ(s) = sqrt((a − s)² + h²) − r_i − k s,
// k = (r_j − r_i)/L; φ'(s) = 0 at s* = a + k h / sqrt(1 − k²) when |k| < 1 (else one ball
// contains the other: a vertex wins). False when the edge has no such minimum; `clamped` when
// s* was clamped to an end (a vertex is then the foot).
bool edge_foot(const glm::vec3& p, const glm::vec3* c, const float* r, int i, glm::vec3& foot, float& foot_radius,
               bool& clamped) {
  const int j = (i + 1) % 3;
  const glm::vec3 edge = c[j] - c[i];
  const float length = glm::length(edge);
  if (!(length > 0.0f)) return false;
  const float k = (r[j] - r[i]) / length;
  if (!(std::fabs(k) < 1.0f)) return false;
  const glm::vec3 axis = edge * (1.0f / length);
  const glm::vec3 u = p - c[i];
  const float a = glm::dot(u, axis);
  const float h = glm::length(u - a * axis);
  const float unclamped = a + k * h / std::sqrt(1.0f - k * k);
  const float s = std::clamp(unclamped, 0.0f, length);
  clamped = !(unclamped > 0.0f && unclamped < length);
  foot = c[i] + s * axis;
  foot_radius = r[i] + k * s;
  return true;
}

// Directional derivative of φ(b) = |P − c(b)| − r(b) at a foot (unit n = (P − foot)/|P − foot|)
// towards ball m: moving weight to m moves the foot by c_m − foot and its radius by r_m − r.
float toward(const glm::vec3& n, const glm::vec3& foot, float foot_radius, const glm::vec3& centre, float radius) {
  return -glm::dot(n, centre - foot) - (radius - foot_radius);
}

}  // namespace

// E_T where the minimum is not interior: the hint's candidate if the KKT conditions prove it
// the minimum, else the smallest of the three vertices and three edge minima.
HullDistance boundary_distance(const glm::vec3& p, const glm::vec3* c, const float* r, uint8_t* hint) {
  // The hint's candidate first. φ is convex in b and differentiable wherever P is off the
  // foot, so a boundary candidate whose derivatives towards the triangle's other corners are
  // all ≥ 0 (the KKT conditions) is the minimum over the whole triangle: the same foot, with
  // the same arithmetic, as the full search below would pick.
  if (hint && *hint >= kHullCaseVertex && *hint < kHullCaseVertex + 6) {
    const int which = *hint - kHullCaseVertex;  // 0..2 a vertex, 3..5 an edge
    const int i = which % 3;
    glm::vec3 foot;
    float foot_radius = 0.0f;
    bool clamped = false;
    bool valid = true;
    if (which < 3) {
      foot = c[i];
      foot_radius = r[i];
    } else {
      valid = edge_foot(p, c, r, i, foot, foot_radius, clamped) && !clamped;
    }
    if (valid) {
      const glm::vec3 offset = p - foot;
      const float distance = glm::length(offset);
      if (distance > 0.0f) {
        const glm::vec3 n = offset * (1.0f / distance);
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        const bool minimum = which < 3 ? toward(n, foot, foot_radius, c[j], r[j]) >= 0.0f &&
                                             toward(n, foot, foot_radius, c[k], r[k]) >= 0.0f
                                       : toward(n, foot, foot_radius, c[k], r[k]) >= 0.0f;
        if (minimum) {
          HullDistance result;
          result.value = distance - foot_radius;
          result.gradient = n;
          if (std::isfinite(result.value) && finite(result.gradient)) return result;
        }
      }
    }
  }

  float best = std::numeric_limits<float>::infinity();
  glm::vec3 best_gradient(0.0f);
  uint8_t best_case = kHullCaseUnknown;
  // A candidate b on the triangle's boundary with its foot c(b) and value |P − c(b)| − r(b);
  // the function is convex in b, so without an interior minimum the smallest candidate among
  // {each edge's minimum, each vertex} is the minimum.
  auto consider_foot = [&](const glm::vec3& foot, float foot_radius, uint8_t which) {
    const glm::vec3 offset = p - foot;
    const float distance = glm::length(offset);
    const float value = distance - foot_radius;
    if (value < best) {
      best = value;
      best_gradient = distance > 0.0f ? offset * (1.0f / distance) : glm::vec3(0.0f);
      best_case = which;
    }
  };
  for (int i = 0; i < 3; ++i) consider_foot(c[i], r[i], uint8_t(kHullCaseVertex + i));  // the sphere itself
  for (int i = 0; i < 3; ++i) {
    glm::vec3 foot;
    float foot_radius = 0.0f;
    bool clamped = false;
    if (edge_foot(p, c, r, i, foot, foot_radius, clamped))
      consider_foot(foot, foot_radius, uint8_t(kHullCaseVertex + 3 + i));
  }
  if (hint) *hint = best_case;

  HullDistance result;
  result.value = std::isfinite(best) ? best : 0.0f;
  result.gradient = std::isfinite(best) ? best_gradient : glm::vec3(0.0f);
  return result;
}

}  // namespace fair_detail

HullDistance ball_hull_distance(const glm::vec3& point, const glm::vec3* centres, const float* radii, uint8_t* hint) {
  using namespace fair_detail;
  const glm::vec3& p = point;
  const glm::vec3* c = centres;
  const float* r = radii;
  const glm::vec3 w0 = p - c[0], e1 = c[1] - c[0], e2 = c[2] - c[0];
  float value = 0.0f, nx = 0.0f, ny = 0.0f, nz = 0.0f;
  HullDistance result;
  if (interior_lane(w0.x, w0.y, w0.z, e1.x, e1.y, e1.z, e2.x, e2.y, e2.z, r[0], r[1] - r[0], r[2] - r[0], value, nx, ny,
                    nz) &&
      interior_result(value, nx, ny, nz, result)) {
    if (hint) *hint = kHullCaseInterior;
    return result;
  }
  return boundary_distance(p, c, r, hint);
}

}  // namespace skelform::runtime
