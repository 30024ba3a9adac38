// runtime/src/rest_clearance.h: the rest bound that lets the LBS guard pass over leaf pairs.
// clearance_between against the exact distance of two triangles (closest points, written here)
// on random, near-coplanar, far-scaled and crossing pairs; every leaf's D against the exact
// distances of its pairs on two tubes, one through the other at rest; and leaves_apart against
// a brute-force test of every pair of triangles, on a tube under a two-joint skin bent up to
// 170 degrees (where LBS folds it through itself) with and without noise, rigid, scaled by 100.
#include "rest_clearance.h"

#include "cpu.h"
#include "skelform/core/triangle_intersection.h"
#include "skin_blend.h"
#include "triangle_bvh.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <random>
#include <vector>

using namespace skelform::runtime;

namespace {

// The closest point to p on the triangle (a, b, c) (by its Voronoi regions).
glm::dvec3 closest_on_triangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const glm::dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const glm::dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denominator = va + vb + vc;
  if (!(std::abs(denominator) > 0)) return a;  // a degenerate triangle: the edges cover it
  return a + ab * (vb / denominator) + ac * (vc / denominator);
}

// The distance between the segments p0p1 and q0q1.
double segment_distance(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& q0, const glm::dvec3& q1) {
  const glm::dvec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = glm::dot(d1, d1), e = glm::dot(d2, d2), f = glm::dot(d2, r);
  double s = 0, t = 0;
  if (a <= 1e-300 && e <= 1e-300) return glm::length(r);
  if (a <= 1e-300) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = glm::dot(d1, r);
    if (e <= 1e-300) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = glm::dot(d1, d2), denominator = a * e - b * b;
      s = denominator > 0 ? std::clamp((b * f - c * e) / denominator, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return glm::length((p0 + d1 * s) - (q0 + d2 * t));
}

// The distance between two closed triangles: 0 where they meet, else the least of the corner to
// triangle and edge to edge distances.
double triangle_distance(const glm::dvec3* a, const glm::dvec3* b) {
  if (skelform::geometry::triangles_intersect(a[0], a[1], a[2], b[0], b[1], b[2])) return 0.0;
  double d = INFINITY;
  for (int i = 0; i < 3; ++i) {
    d = std::min(d, glm::length(a[i] - closest_on_triangle(a[i], b[0], b[1], b[2])));
    d = std::min(d, glm::length(b[i] - closest_on_triangle(b[i], a[0], a[1], a[2])));
    for (int j = 0; j < 3; ++j) d = std::min(d, segment_distance(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]));
  }
  return d;
}

double size_of(const glm::dvec3* a, const glm::dvec3* b) {
  double s = 0;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) s = std::max({s, std::abs(a[i][k] - a[0][k]), std::abs(b[i][k] - a[0][k])});
  return s;
}

// A tube along x: `rings` rings of `segments` vertices, radius `radius`, from x0 to x0 + length,
// turned by `turn` (radians about z) about its start and moved by `offset`.
struct Tube {
  std::vector<glm::vec3> positions;
  std::vector<uint32_t> triangles;
};

void add_tube(Tube& tube, int rings, int segments, float radius, float x0, float length, float turn,
              const glm::vec3& offset) {
  const uint32_t first = uint32_t(tube.positions.size());
  const glm::mat4 m = glm::translate(glm::mat4(1.0f), offset) * glm::rotate(glm::mat4(1.0f), turn, glm::vec3(0, 0, 1));
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const float a = 6.2831853f * float(s) / float(segments);
      const glm::vec3 p(x0 + length * float(r) / float(rings - 1), radius * std::cos(a), radius * std::sin(a));
      tube.positions.push_back(glm::vec3(m * glm::vec4(p, 1.0f)));
    }
  for (int r = 0; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const uint32_t i = first + uint32_t(r * segments + s), j = first + uint32_t(r * segments + (s + 1) % segments);
      const uint32_t k = i + uint32_t(segments), l = j + uint32_t(segments);
      tube.triangles.insert(tube.triangles.end(), {i, j, l, i, l, k});
    }
}

bool share_corner(const uint32_t* a, const uint32_t* b) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a[i] == b[j]) return true;
  return false;
}

std::vector<uint32_t> leaves_of(const TriangleHierarchy& h) {
  std::vector<uint32_t> leaves;
  for (uint32_t n = 0; n < h.nodes.size(); ++n)
    if (h.nodes[n].count > 0) leaves.push_back(n);
  return leaves;
}

bool boxes_meet(const float* a, const float* b) {
  return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

}  // namespace

TEST_CASE("rest clearance: clearance_between is at most the triangles' distance, 0 only where they meet") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  size_t separated = 0, meeting = 0;
  for (int kind = 0; kind < 4; ++kind)
    for (int trial = 0; trial < 20000; ++trial) {
      glm::dvec3 a[3], b[3];
      const double scale = kind == 3 ? std::ldexp(1.0, int(unit(rng) * 30)) : 1.0;
      for (int i = 0; i < 3; ++i) {
        a[i] = glm::dvec3(unit(rng), unit(rng), unit(rng));
        b[i] = glm::dvec3(unit(rng), unit(rng), unit(rng)) + glm::dvec3(kind == 0 ? 0.0 : 1.2 * unit(rng), 0, 0);
        if (kind == 1) a[i].z *= 1e-3, b[i].z = 1e-3 * unit(rng);  // nearly coplanar, as on a smooth surface
        if (kind == 2) b[i] = 0.5 * (a[i] + b[i]);                 // near, often crossing
        a[i] *= scale;
        b[i] *= scale;
      }
      const glm::dvec3 af[3] = {glm::dvec3(glm::vec3(a[0])), glm::dvec3(glm::vec3(a[1])), glm::dvec3(glm::vec3(a[2]))};
      const glm::dvec3 bf[3] = {glm::dvec3(glm::vec3(b[0])), glm::dvec3(glm::vec3(b[1])), glm::dvec3(glm::vec3(b[2]))};
      const double exact = triangle_distance(af, bf), size = size_of(af, bf);
      const double bound = clearance_between(af, bf);
      CAPTURE(kind);
      CAPTURE(trial);
      REQUIRE(bound >= 0.0);
      REQUIRE(bound <= exact * (1 + 1e-12) + 1e-13 * size);
      if (exact == 0.0) {
        ++meeting;
        REQUIRE(bound == 0.0);
      } else if (exact > 1e-9 * size) {
        ++separated;
        REQUIRE(bound > 0.0);  // the axes are the separating-axis test's: one parts them
      }
      // Stopping at `enough`: the same value below it, at least it otherwise.
      const double enough = exact * std::abs(unit(rng)) * 2;
      const double stopped = clearance_between(af, bf, enough);
      if (bound < enough)
        REQUIRE(stopped == bound);
      else
        REQUIRE(stopped >= enough);
    }
  CHECK(separated > 40000);
  CHECK(meeting > 1000);
}

TEST_CASE("rest clearance: a leaf's D is at most the distance of each of its pairs, 0 where tubes cross at rest") {
  Tube tube;
  add_tube(tube, 30, 16, 0.5f, 0.0f, 6.0f, 0.0f, glm::vec3(0.0f));
  add_tube(tube, 12, 10, 0.2f, -1.0f, 2.0f, 1.3f, glm::vec3(4.5f, 0.0f, 0.0f));  // through the first
  const size_t triangles = tube.triangles.size() / 3;
  const TriangleHierarchy h = build_triangle_hierarchy(tube.positions.data(), tube.triangles.data(), triangles, {});
  const RestClearance c = build_rest_clearance(h, tube.positions.data(), tube.triangles.data(), {});
  REQUIRE(c.clearance.size() == h.nodes.size());
  const std::vector<uint32_t> leaves = leaves_of(h);
  auto at = [&](uint32_t slot, glm::dvec3* p) {
    for (int k = 0; k < 3; ++k)
      p[k] = glm::dvec3(tube.positions[tube.triangles[3 * size_t(h.order[slot]) + size_t(k)]]);
  };
  size_t positive = 0, zero = 0, checked = 0;
  double mean_edge = 0;
  for (size_t t = 0; t < triangles; ++t)
    for (int k = 0; k < 3; ++k)
      mean_edge += glm::length(tube.positions[tube.triangles[3 * t + size_t(k)]] -
                               tube.positions[tube.triangles[3 * t + size_t(k + 1) % 3]]);
  mean_edge /= 3.0 * double(triangles);
  for (uint32_t a : leaves) {
    const float d = c.clearance[a];
    REQUIRE(d >= 0.0f);
    REQUIRE(double(d) <= kClearanceCap * mean_edge * (1 + 1e-6));
    (d > 0.0f ? positive : zero) += 1;
    for (uint32_t b : leaves) {
      if (!boxes_meet(&c.rest_boxes[6 * size_t(a)], &c.rest_boxes[6 * size_t(b)])) continue;
      for (uint32_t i = h.nodes[a].first; i < h.nodes[a].first + h.nodes[a].count; ++i)
        for (uint32_t j = h.nodes[b].first; j < h.nodes[b].first + h.nodes[b].count; ++j) {
          if (i == j || share_corner(&tube.triangles[3 * size_t(h.order[i])], &tube.triangles[3 * size_t(h.order[j])]))
            continue;
          glm::dvec3 p[3], q[3];
          at(i, p);
          at(j, q);
          ++checked;
          REQUIRE(double(d) <= triangle_distance(p, q));
        }
    }
  }
  MESSAGE(leaves.size() << " leaves: D > 0 at " << positive << ", 0 at " << zero << "; " << checked << " pairs");
  CHECK(zero > 0);             // the leaves where the tubes cross
  CHECK(positive > 3 * zero);  // and nowhere else
}

TEST_CASE(
    "rest clearance: leaves_apart only parts leaves whose triangles do not meet, and parts most of a rigid pose") {
  // A tube from x = 0 to 6, two joints: the first carries x < 2.5, the second x > 3.5, blended
  // in between; the second turns about (3, 0, 0).
  Tube tube;
  add_tube(tube, 40, 16, 0.5f, 0.0f, 6.0f, 0.0f, glm::vec3(0.0f));
  const uint32_t n = uint32_t(tube.positions.size());
  const size_t triangles = tube.triangles.size() / 3;
  const TriangleHierarchy h = build_triangle_hierarchy(tube.positions.data(), tube.triangles.data(), triangles, {});
  const RestClearance c = build_rest_clearance(h, tube.positions.data(), tube.triangles.data(), {});
  std::vector<uint16_t> joints(2 * size_t(n));
  std::vector<float> weights(2 * size_t(n));
  for (uint32_t v = 0; v < n; ++v) {
    const float w = std::clamp((tube.positions[v].x - 2.5f) / 1.0f, 0.0f, 1.0f);
    joints[2 * v] = 0, joints[2 * v + 1] = 1;
    weights[2 * v] = 1.0f - w, weights[2 * v + 1] = w;
  }
  std::vector<uint32_t> identity(n);
  for (uint32_t v = 0; v < n; ++v) identity[v] = v;
  const std::vector<uint32_t> leaves = leaves_of(h);
  ClearanceMaps maps{AllocatorRef{}};
  maps.resize(h.nodes.size());
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  size_t parted = 0, meeting_pairs = 0, rigid_parted = 0, rigid_pairs = 0;
  // `pokes` vertices, chosen at random, pushed through the axis out of the far wall: their
  // leaves stray, their neighbours' do not, and the far wall's triangles meet theirs.
  // `squash` scales the tube along its axis (a skin that shrinks it, σ_min of the map), and then
  // the noise moves vertices along the axis only, by more than the squashed rings' spacing.
  struct Pose {
    float bend, noise, scale;
    int pokes;
    float squash = 1.0f;
  };
  for (const Pose pose : {Pose{0, 0, 100, 0}, Pose{30, 0, 1, 0}, Pose{90, 0, 1, 0}, Pose{170, 0, 1, 0},
                          Pose{60, 0.02f, 1, 0}, Pose{120, 0.05f, 2, 0}, Pose{170, 0.2f, 1, 0}, Pose{0, 0, 1, 6},
                          Pose{45, 0, 3, 6}, Pose{0, 0.03f, 1, 0, 0.1f}, Pose{20, 0.02f, 1, 0, 0.1f}}) {
    CAPTURE(pose.bend);
    CAPTURE(pose.noise);
    const glm::mat4 world = glm::translate(glm::mat4(1.0f), glm::vec3(10, -3, 2)) *
                            glm::rotate(glm::mat4(1.0f), 0.7f, glm::normalize(glm::vec3(1, 2, 3))) *
                            glm::scale(glm::mat4(1.0f), glm::vec3(pose.scale)) *
                            glm::scale(glm::mat4(1.0f), glm::vec3(pose.squash, 1.0f, 1.0f));
    const glm::mat4 bend = glm::translate(glm::mat4(1.0f), glm::vec3(3, 0, 0)) *
                           glm::rotate(glm::mat4(1.0f), glm::radians(pose.bend), glm::vec3(0, 0, 1)) *
                           glm::translate(glm::mat4(1.0f), glm::vec3(-3, 0, 0));
    JointAffine affine[2];
    for (int j = 0; j < 2; ++j) {
      const glm::mat4 m = j == 0 ? world : world * bend;
      for (int row = 0; row < 3; ++row)
        for (int col = 0; col < 4; ++col) affine[j].m[4 * row + col] = m[col][row];
    }
    std::vector<glm::vec3> x(n);
    for (uint32_t v = 0; v < n; ++v) {
      float m[12];
      blend_affine(affine, &joints[2 * v], &weights[2 * v], 2, m);
      const glm::vec3 noise = pose.squash == 1.0f ? glm::vec3(unit(rng), unit(rng), unit(rng))
                                                  : glm::vec3(world * glm::vec4(unit(rng) / pose.squash, 0, 0, 0));
      x[v] = transform_point(m, tube.positions[v]) + pose.noise * pose.scale * noise;
    }
    std::uniform_int_distribution<uint32_t> vertex(0, n - 1);
    for (int k = 0; k < pose.pokes; ++k) {
      const uint32_t v = vertex(rng);
      float m[12];
      blend_affine(affine, &joints[2 * v], &weights[2 * v], 2, m);
      const glm::vec3 p = tube.positions[v];
      x[v] = transform_point(m, glm::vec3(p.x, -1.5f * p.y, -1.5f * p.z));
    }
    const ClearancePose input{x.data(), identity.data(), joints.data(), weights.data(), 2, affine};
    maps.next();
    for (uint32_t a : leaves)
      for (uint32_t b : leaves) {
        if (b < a) continue;
        // Each way: a's map, and b's.
        const bool apart = leaves_apart(c, input, maps, a, b), apart_back = leaves_apart(c, input, maps, b, a);
        bool meet = false;
        for (uint32_t i = h.nodes[a].first; i < h.nodes[a].first + h.nodes[a].count && !meet; ++i)
          for (uint32_t j = a == b ? i + 1 : h.nodes[b].first; j < h.nodes[b].first + h.nodes[b].count && !meet; ++j) {
            const uint32_t* p = &tube.triangles[3 * size_t(h.order[i])];
            const uint32_t* q = &tube.triangles[3 * size_t(h.order[j])];
            if (share_corner(p, q)) continue;
            meet =
                skelform::geometry::triangles_intersect(glm::dvec3(x[p[0]]), glm::dvec3(x[p[1]]), glm::dvec3(x[p[2]]),
                                                        glm::dvec3(x[q[0]]), glm::dvec3(x[q[1]]), glm::dvec3(x[q[2]]));
          }
        CAPTURE(a);
        CAPTURE(b);
        REQUIRE(!(apart && meet));
        REQUIRE(!(apart_back && meet));
        parted += apart;
        meeting_pairs += meet;
        if (pose.bend == 0 && pose.noise == 0 && pose.pokes == 0 && pose.squash == 1.0f) {
          const bool near = boxes_meet(&c.rest_boxes[6 * size_t(a)], &c.rest_boxes[6 * size_t(b)]);
          rigid_pairs += near;
          rigid_parted += near && apart;
        }
      }
  }
  MESSAGE("parted " << parted << " leaf pairs; " << meeting_pairs << " leaf pairs meet; rigid: " << rigid_parted
                    << " of " << rigid_pairs << " neighbours");
  CHECK(meeting_pairs > 0);  // LBS folds the tube through itself at 170 degrees: the test can fail
  CHECK(rigid_parted == rigid_pairs);
}

TEST_CASE("rest clearance: a stack tangled at rest gets no clearances, within a bounded work") {
  // 3,000 parallel triangles 0.001 apart, each tilted through the whole stack: none meet, and
  // every box meets every other, so every pair of them would be compared (4.5 million). The
  // build stops at its budget and leaves the bound out: the guard then tests every leaf pair,
  // as without it.
  Tube stack;
  for (uint32_t t = 0; t < 3000; ++t) {
    const float z = 0.001f * float(t);
    stack.positions.insert(stack.positions.end(),
                           {glm::vec3(-1, -1, z), glm::vec3(1, -1, z + 3.0f), glm::vec3(0, 1, z + 1.5f)});
    stack.triangles.insert(stack.triangles.end(), {3 * t, 3 * t + 1, 3 * t + 2});
  }
  const TriangleHierarchy h = build_triangle_hierarchy(stack.positions.data(), stack.triangles.data(), 3000, {});
  CHECK(build_rest_clearance(h, stack.positions.data(), stack.triangles.data(), {}).empty());
  // A clean tube of as many triangles is well within it.
  Tube tube;
  add_tube(tube, 95, 16, 0.5f, 0.0f, 6.0f, 0.0f, glm::vec3(0.0f));
  const TriangleHierarchy t =
      build_triangle_hierarchy(tube.positions.data(), tube.triangles.data(), tube.triangles.size() / 3, {});
  CHECK(!build_rest_clearance(t, tube.positions.data(), tube.triangles.data(), {}).empty());
}

namespace {

// Every pair of leaves of `rest`, posed at `x`: the pairs leaves_apart passes over (counted in
// `parted`) whose triangles the exact test says meet. `joints` (or empty: all 0) names each
// vertex's one joint among `affine` (or empty: one joint, scaled by `scale`).
size_t unsound_pairs(const std::vector<glm::vec3>& rest, const std::vector<uint32_t>& tri,
                     const std::vector<glm::vec3>& x, float scale, std::vector<uint16_t> joints = {},
                     std::vector<JointAffine> affine = {}, size_t* parted = nullptr) {
  const uint32_t n = uint32_t(rest.size());
  const TriangleHierarchy h = build_triangle_hierarchy(rest.data(), tri.data(), tri.size() / 3, {});
  const RestClearance c = build_rest_clearance(h, rest.data(), tri.data(), {});
  if (joints.empty()) joints.assign(n, 0);
  std::vector<float> weights(n, 1.0f);
  std::vector<uint32_t> identity(n);
  for (uint32_t v = 0; v < n; ++v) identity[v] = v;
  if (affine.empty()) {
    affine.emplace_back();
    affine[0].m[0] = affine[0].m[5] = affine[0].m[10] = scale;
  }
  ClearanceMaps maps{AllocatorRef{}};
  maps.resize(h.nodes.size());
  maps.next();
  const ClearancePose pose{x.data(), identity.data(), joints.data(), weights.data(), 1, affine.data()};
  size_t unsound = 0;
  for (uint32_t a : leaves_of(h))
    for (uint32_t b : leaves_of(h)) {
      if (!leaves_apart(c, pose, maps, a, b)) continue;
      if (parted) ++*parted;
      for (uint32_t i = h.nodes[a].first; i < h.nodes[a].first + h.nodes[a].count; ++i)
        for (uint32_t j = h.nodes[b].first; j < h.nodes[b].first + h.nodes[b].count; ++j) {
          const uint32_t* p = &tri[3 * size_t(h.order[i])];
          const uint32_t* q = &tri[3 * size_t(h.order[j])];
          if (i == j || share_corner(p, q)) continue;
          unsound +=
              skelform::geometry::triangles_intersect(glm::dvec3(x[p[0]]), glm::dvec3(x[p[1]]), glm::dvec3(x[p[2]]),
                                                      glm::dvec3(x[q[0]]), glm::dvec3(x[q[1]]), glm::dvec3(x[q[2]]));
        }
    }
  return unsound;
}

}  // namespace

TEST_CASE("rest clearance: triangles collapsed in the pose, and poses scaled far down, are tested") {
  // A sliver that flattens to a segment and a small triangle that collapses to a point beside
  // it: far apart, but the exact test's axes are all zero for that pair, and it says they meet.
  // The bound must leave such a pair to the test.
  {
    const float e = 1e-3f;
    const std::vector<glm::vec3> rest = {{0, 0, 0},       {2, 2, 0},           {1, 1, e},
                                         {1.5f, 0.5f, 0}, {1.5f + e, 0.5f, 0}, {1.5f, 0.5f + e, 0}};
    std::vector<glm::vec3> x = rest;
    x[2] = {1, 1, 0};
    x[4] = x[5] = x[3];
    CHECK(unsound_pairs(rest, {0, 1, 2, 3, 4, 5}, x, 1.0f) == 0);
  }
  // Two triangles a unit apart, the pose scaled by 1e-24 and a corner pushed through the other
  // triangle: the strays' squares underflow in float.
  {
    const float s = 1e-24f;
    const std::vector<glm::vec3> rest = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
    std::vector<glm::vec3> x(rest.size());
    for (size_t v = 0; v < rest.size(); ++v) x[v] = s * rest[v];
    x[3] = s * glm::vec3(0.2f, 0.2f, -1.0f);
    CHECK(unsound_pairs(rest, {0, 1, 2, 3, 4, 5}, x, s) == 0);
  }
}

TEST_CASE("rest clearance: two sheets turned against each other about one's centre are tested") {
  // Two 8×8 sheets of 4×4 quads, 3 apart (a leaf each, anchored at its centre), each carried by
  // its own joint; the upper one turns by 60 degrees about its own centre, so its map agrees
  // with the lower's there and both strays are 0, but
  // its edges dip through the lower sheet: only the maps' difference away from the centre
  // (‖L_b − L_a‖ρ_b) keeps the pair in the test.
  std::vector<glm::vec3> rest;
  std::vector<uint32_t> tri;
  std::vector<uint16_t> joints;
  for (int sheet = 0; sheet < 2; ++sheet) {
    const uint32_t first = uint32_t(rest.size());
    for (int i = 0; i <= 4; ++i)
      for (int j = 0; j <= 4; ++j) {
        rest.emplace_back(2.0f * float(i), 2.0f * float(j), 3.0f * float(sheet));
        joints.push_back(uint16_t(sheet));
      }
    for (uint32_t i = 0; i < 4; ++i)
      for (uint32_t j = 0; j < 4; ++j) {
        const uint32_t v = first + 5 * i + j;
        tri.insert(tri.end(), {v, v + 5, v + 6, v, v + 6, v + 1});
      }
  }
  const glm::mat4 turn = glm::translate(glm::mat4(1.0f), glm::vec3(4, 4, 3)) *
                         glm::rotate(glm::mat4(1.0f), glm::radians(60.0f), glm::vec3(1, 0, 0)) *
                         glm::translate(glm::mat4(1.0f), glm::vec3(-4, -4, -3));
  std::vector<JointAffine> affine(2);
  for (int j = 0; j < 2; ++j) {
    const glm::mat4 m = j == 0 ? glm::mat4(1.0f) : turn;
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 4; ++col) affine[size_t(j)].m[4 * row + col] = m[col][row];
  }
  std::vector<glm::vec3> x(rest.size());
  for (size_t v = 0; v < rest.size(); ++v) x[v] = transform_point(affine[joints[v]].m, rest[v]);
  size_t parted = 0;
  CHECK(unsound_pairs(rest, tri, x, 1.0f, joints, affine, &parted) == 0);
  // Unturned, the sheets are parted (rigid, 3 apart): the test above is not vacuous.
  size_t rigid = 0;
  affine[1] = affine[0];
  CHECK(unsound_pairs(rest, tri, rest, 1.0f, joints, affine, &rigid) == 0);
  MESSAGE("parted " << parted << " leaf pairs turned, " << rigid << " unturned");
  CHECK(rigid > parted);
}

TEST_CASE("rest clearance: a leaf's strays are the same in the AVX2 form as in the baseline") {
  if (!cpu_has_avx2()) {
    MESSAGE("skipped: no AVX2 form on this target or CPU");
    return;
  }
  Tube tube;
  add_tube(tube, 30, 16, 0.5f, 0.0f, 6.0f, 0.0f, glm::vec3(0.0f));
  const size_t triangles = tube.triangles.size() / 3;
  const TriangleHierarchy h = build_triangle_hierarchy(tube.positions.data(), tube.triangles.data(), triangles, {});
  const RestClearance c = build_rest_clearance(h, tube.positions.data(), tube.triangles.data(), {});
  REQUIRE(c.gathers_fit);
  // A pose: every vertex moved by noise, a map that turns and stretches a little.
  std::mt19937 random(17);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  std::vector<glm::vec3> x;
  for (const glm::vec3& p : tube.positions)
    x.emplace_back(p.x + noise(random), p.y + noise(random), p.z + noise(random));
  const float l[9] = {0.99f, -0.12f, 0.01f, 0.12f, 0.98f, 0.03f, -0.01f, -0.02f, 1.02f};
  size_t leaves = 0, tails[8] = {};
  for (uint32_t n = 0; n < h.nodes.size(); ++n) {
    const uint32_t begin = c.vertex_offsets[n], end = c.vertex_offsets[n + 1];
    if (h.nodes[n].count == 0 || begin == end) continue;
    ++leaves;
    const glm::vec3 xa = x[c.anchor[n]];
    // The leaf's entries, and its first ones short of its last 1 to 7 (every tail length).
    for (uint32_t cut = 0; cut < 8 && cut < end - begin; ++cut) {
      const detail::StraySums lanes = detail::stray_sums(c, x.data(), begin, end - cut, l, xa, true);
      const detail::StraySums baseline = detail::stray_sums(c, x.data(), begin, end - cut, l, xa, false);
      CHECK(lanes.squared == baseline.squared);
      CHECK(lanes.spread == baseline.spread);
      CHECK(lanes.squared > 0.0f);
      ++tails[(end - cut - begin) % 8];
    }
  }
  CHECK(leaves > 10);
  CHECK(std::count(std::begin(tails), std::end(tails), size_t{0}) == 0);
  // A NaN position in a leaf makes its squared stray NaN in both forms.
  const uint32_t n = h.leaf[0], begin = c.vertex_offsets[n], end = c.vertex_offsets[n + 1];
  x[c.vertices[end - 1]].y = std::numeric_limits<float>::quiet_NaN();
  CHECK(std::isnan(detail::stray_sums(c, x.data(), begin, end, l, x[c.anchor[n]], true).squared));
  CHECK(std::isnan(detail::stray_sums(c, x.data(), begin, end, l, x[c.anchor[n]], false).squared));
}
