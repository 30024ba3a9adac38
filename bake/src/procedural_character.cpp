// The project's own test character: a smooth union of tapered capsules (one per bone of a
// small humanoid rig), polygonised with marching tetrahedra.
//
// Why this construction: the paper's method needs a closed, genus-0 mesh with elongated
// parts, and the repository may not embed a third-party model. An implicit surface gives
// smooth joints for free; marching tetrahedra over a Kuhn (6 tetrahedra per cube)
// subdivision of a regular grid is watertight and manifold by construction, because every
// tetrahedron face is shared by exactly two tetrahedra that cut it the same way.
#include "skelform/bake/procedural.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <queue>
#include <tuple>
#include <unordered_map>

namespace skelform::bake {
namespace {

// Proportions are authored for a 1.8 m character and scaled to the requested height.
constexpr double kReferenceHeight = 1.8;
// Blend radius of the smooth union at the reference height: large enough to round every
// joint, smaller than every gap between parts that must stay apart (hands–hips, legs).
constexpr double kReferenceBlend = 0.04;
// Thinnest parts (wrist radius 0.035, hand tips 0.04 at the reference height) must span a
// few grid steps or the arms break apart and the tips get cut short; height / 45 (0.04 at
// 1.8) is the coarsest grid where the tests find the mesh whole and its extents right.
constexpr double kCoarsestResolutionPerHeight = 1.0 / 45.0;
// Edges shorter than this many grid steps are collapsed after polygonisation: it brings the
// triangle count to about a quarter of the raw marching-tetrahedra output.
constexpr double kCollapseBelowSteps = 0.8;
// A triangle is well oriented when its normal is within acos(this) (45 degrees) of the
// field's gradient: collapses and smoothing never make a triangle worse than this, or worse
// than it already was.
constexpr double kGoodOrientationCos = 0.7;
// Tangential smoothing steps after the collapses (triangle shape, not surface shape).
constexpr int kRelaxIterations = 4;
constexpr double kMaxGridSamples = double(1u << 26);

// The A-pose arm direction: 40 degrees below the horizontal, in the xy plane, so the hands
// stay far from the hips.
const Vec3 kArmDirection{0.76604444311897801, -0.64278760968653925, 0.0};

// The rig at the reference height: torso chain on x = 0, then each side's limbs (authored
// for the left, mirrored in x for the right).
std::vector<CharacterJoint> reference_joints() {
  const Vec3 shoulder{0.17, 1.40, -0.01};
  const Vec3 elbow = shoulder + 0.28 * kArmDirection;
  const Vec3 wrist = elbow + Vec3{0.0, 0.0, 0.01} + 0.25 * kArmDirection;
  const Vec3 fingertip = wrist + Vec3{0.0, 0.0, 0.01} + 0.17 * kArmDirection;
  const Vec3 hip{0.09, 0.93, 0.0}, knee{0.11, 0.50, 0.01}, ankle{0.12, 0.09, -0.02};
  // The foot's tail sphere touches y = 0 exactly (0.045 - 0.045): the lowest point.
  const Vec3 toe{0.13, 0.045, 0.15};

  // Torso and head on the symmetry plane. The head's tail sphere reaches y = 1.80 exactly.
  std::vector<CharacterJoint> joints = {
      {"pelvis", -1, {0.0, 0.90, 0.0}, {0.0, 1.04, 0.0}, 0.13, 0.12},
      {"spine", 0, {0.0, 1.04, 0.0}, {0.0, 1.24, -0.01}, 0.12, 0.13},
      {"chest", 1, {0.0, 1.24, -0.01}, {0.0, 1.38, -0.01}, 0.135, 0.11},
      {"neck", 2, {0.0, 1.40, -0.01}, {0.0, 1.55, 0.0}, 0.05, 0.045},
      {"head", 3, {0.0, 1.55, 0.0}, {0.0, 1.71, 0.02}, 0.06, 0.09},
  };
  const std::array<CharacterJoint, 7> left = {{
      {"shoulder", 2, {0.03, 1.38, -0.01}, shoulder, 0.07, 0.055},
      {"upper_arm", 0, shoulder, elbow, 0.05, 0.042},
      {"lower_arm", 1, elbow + Vec3{0.0, 0.0, 0.01}, wrist, 0.042, 0.035},
      {"hand", 2, wrist + Vec3{0.0, 0.0, 0.01}, fingertip, 0.038, 0.04},
      {"upper_leg", -2, hip, knee, 0.08, 0.06},
      {"lower_leg", 4, knee, ankle, 0.058, 0.045},
      {"foot", 5, ankle, toe, 0.05, 0.045},
  }};
  // In `left`, parents >= 0 are indices within the side's own block; -2 means the pelvis and
  // the shoulder's parent 2 means the chest (a torso index).
  for (int side = 0; side < 2; ++side) {
    const double mirror = side == 0 ? 1.0 : -1.0;
    const int base = static_cast<int>(joints.size());
    for (size_t i = 0; i < left.size(); ++i) {
      CharacterJoint j = left[i];
      j.name += side == 0 ? ".L" : ".R";
      if (i == 0)
        j.parent = 2;
      else if (j.parent == -2)
        j.parent = 0;
      else
        j.parent += base;
      j.head.x *= mirror;
      j.tail.x *= mirror;
      joints.push_back(j);
    }
  }
  return joints;
}

void check_height(const CharacterOptions& options) {
  if (!(options.height > 0.0) || !std::isfinite(options.height))
    throw Error(ErrorKind::usage, "test character: height must be positive and finite");
}

// The convex hull of two balls (a "round cone"), with exact signed distance outside.
// Work in the plane of the axis: x along the axis from `a`, y the distance to the axis. The
// lateral line is tangent to both circles; its unit normal is (s, c) with s = (ra - rb) / L.
struct RoundCone {
  Vec3 a, axis;  // axis: unit vector from a to b
  double length = 0, ra = 0, rb = 0, s = 0, c = 1;
  Vec3 centre;                 // of a sphere enclosing the hull
  double bounding_radius = 0;  // of that sphere

  RoundCone(const Vec3& head, const Vec3& tail, double head_radius, double tail_radius)
      : a(head), ra(head_radius), rb(tail_radius) {
    const Vec3 d = tail - head;
    length = glm::length(d);
    axis = length > 0 ? d / length : Vec3{0, 1, 0};
    centre = 0.5 * (head + tail);
    bounding_radius = 0.5 * length + std::max(ra, rb);
    // When one ball contains the other (|ra - rb| >= length) the hull is the bigger ball;
    // c = 0 marks that case.
    if (length > std::abs(ra - rb)) {
      s = (ra - rb) / length;
      c = std::sqrt(1.0 - s * s);
    } else {
      s = 0.0;
      c = 0.0;
    }
  }

  // Signed distance to the hull and its gradient (unit length outside).
  double distance(const Vec3& p, Vec3& gradient) const {
    const Vec3 ap = p - a;
    if (c <= 0.0) {
      const Vec3 from_centre = ra >= rb ? ap : ap - length * axis;
      const double r = glm::length(from_centre);
      gradient = r > 0.0 ? from_centre / r : axis;
      return r - std::max(ra, rb);
    }
    const double x = glm::dot(ap, axis);
    const Vec3 radial = ap - x * axis;
    const double y = glm::length(radial);
    // On the axis (deep inside) any direction across it will do.
    const Vec3 across =
        y > 0.0 ? radial / y : glm::normalize(glm::cross(axis, std::abs(axis.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0}));
    // Position along the lateral line's direction (c, -s): 0 at the tangent point on the
    // head circle, length * c at the tangent point on the tail circle.
    const double u = x * c - y * s;
    if (u <= 0.0 || u >= length * c) {
      const double x0 = u <= 0.0 ? x : x - length;
      const double r = std::sqrt(x0 * x0 + y * y);
      gradient = r > 0.0 ? (x0 * axis + y * across) / r : axis;
      return r - (u <= 0.0 ? ra : rb);
    }
    gradient = s * axis + c * across;
    return x * s + y * c - ra;
  }
};

// Polynomial smooth minimum: equals min(a, b) when they differ by more than k, and rounds the
// crease where two capsules meet within k. Always <= min(a, b), so blending only adds volume.
// Its gradient mixes the two: (1 - h/2) of the smaller one's plus h/2 of the other's.
double smooth_min(double a, const Vec3& grad_a, double b, const Vec3& grad_b, double k, Vec3& gradient) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  gradient = a < b ? (1.0 - 0.5 * h) * grad_a + 0.5 * h * grad_b : 0.5 * h * grad_a + (1.0 - 0.5 * h) * grad_b;
  return std::min(a, b) - 0.25 * k * h * h;
}

struct CharacterField {
  std::vector<RoundCone> cones;
  double blend = 0;

  // The field's value at `p` (negative inside) and its analytic gradient.
  double evaluate(const Vec3& p, Vec3& gradient) const {
    double d = cones.front().distance(p, gradient);
    for (size_t i = 1; i < cones.size(); ++i) {
      // A capsule at least `blend` farther than the current value cannot change it
      // (smooth_min(d, x) = d for x >= d + blend): skip its exact distance. The bounding
      // sphere gives a cheap lower bound.
      const RoundCone& cone = cones[i];
      const Vec3 to_centre = p - cone.centre;
      const double reach = d + blend + cone.bounding_radius;
      if (reach > 0.0 && glm::dot(to_centre, to_centre) >= reach * reach) continue;
      Vec3 cone_gradient;
      const double di = cone.distance(p, cone_gradient);
      d = smooth_min(d, gradient, di, cone_gradient, blend, gradient);
    }
    return d;
  }

  double operator()(const Vec3& p) const {
    Vec3 unused;
    return evaluate(p, unused);
  }

  Vec3 normal(const Vec3& p) const {
    Vec3 g;
    evaluate(p, g);
    const double l = glm::length(g);
    return l > 0.0 ? g / l : Vec3{0, 1, 0};
  }

  // Moves `p` onto the zero set along the gradient (Newton), by at most `max_move`: the
  // interpolated grid-edge crossing is only accurate to O(step^2) and, after clamping away
  // from the grid points, up to a tenth of a step off.
  Vec3 project(const Vec3& start, double max_move) const {
    Vec3 p = start;
    for (int it = 0; it < 6; ++it) {
      Vec3 g;
      const double f = evaluate(p, g);
      if (std::abs(f) < 1e-7 * max_move) break;
      const double g2 = glm::dot(g, g);
      if (!(g2 > 1e-12)) break;
      const Vec3 next = p - (f / g2) * g;
      const Vec3 offset = next - start;
      const double moved = glm::length(offset);
      p = moved > max_move ? start + offset * (max_move / moved) : next;
    }
    return p;
  }
};

// Parity of a permutation of 4 distinct small integers: true if even.
bool is_even(const std::array<int, 4>& p) {
  int inversions = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) inversions += p[i] > p[j];
  return inversions % 2 == 0;
}

// The 6 Kuhn tetrahedra of a cube around the diagonal from corner 0 to corner 7 (corner bits:
// 1 = +x, 2 = +y, 4 = +z), each listed with positive orientation. The same split in every
// cube makes the shared faces of neighbouring cubes match.
std::array<std::array<int, 4>, 6> kuhn_tetrahedra() {
  std::array<std::array<int, 4>, 6> tets{};
  const int axes[6][3] = {{1, 2, 4}, {1, 4, 2}, {2, 1, 4}, {2, 4, 1}, {4, 1, 2}, {4, 2, 1}};
  for (int t = 0; t < 6; ++t) {
    std::array<int, 4> tet = {0, axes[t][0], axes[t][0] | axes[t][1], 7};
    auto corner = [](int bits) { return Vec3{double(bits & 1), double((bits >> 1) & 1), double((bits >> 2) & 1)}; };
    const Vec3 p0 = corner(tet[0]);
    const double det = glm::dot(corner(tet[1]) - p0, glm::cross(corner(tet[2]) - p0, corner(tet[3]) - p0));
    if (det < 0) std::swap(tet[2], tet[3]);
    tets[t] = tet;
  }
  return tets;
}

// Shape quality of a triangle: 1 for equilateral, 0 for degenerate (4*sqrt(3)*area over the
// sum of squared edge lengths).
double triangle_quality(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double squares = glm::dot(b - a, b - a) + glm::dot(c - b, c - b) + glm::dot(a - c, a - c);
  if (!(squares > 0.0)) return 0.0;
  return 2.0 * std::sqrt(3.0) * glm::length(glm::cross(b - a, c - a)) / squares;
}

// Cosine between a triangle's normal and its reference normal, the sum of the field's
// (unit) gradients at its corners; -1 for a degenerate triangle.
double orientation_cos(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& reference) {
  const Vec3 n = glm::cross(b - a, c - a);
  const double ln = glm::length(n), lr = glm::length(reference);
  if (!(ln > 0.0) || !(lr > 0.0)) return -1.0;
  return glm::dot(n, reference) / (ln * lr);
}

// Marching tetrahedra leave about four times the triangles a grid of this step needs, and
// many slivers. This collapses edges shortest first until none is shorter than
// `min_edge`, each survivor moved onto the zero set at its edge's midpoint. A general
// purpose simplifier (meshoptimizer) was tried and rejected: it does not check the link
// condition and made non-manifold edges on this mesh. Here every collapse keeps the surface
// a closed 2-manifold of the same genus (the link condition: the edge's endpoints share
// exactly the two opposite vertices) and is refused if a triangle around it would flip or
// become a worse sliver than the worst one it replaces.
void collapse_short_edges(TriangleMesh& mesh, const CharacterField& field, double min_edge, double max_move) {
  std::vector<Vec3>& P = mesh.positions;
  std::vector<Triangle>& T = mesh.triangles;
  const size_t n = P.size();
  std::vector<std::vector<uint32_t>> around(n);  // live triangles of each vertex
  for (uint32_t t = 0; t < T.size(); ++t)
    for (uint32_t v : T[t]) around[v].push_back(t);
  std::vector<char> triangle_alive(T.size(), 1), vertex_alive(n, 1);
  std::vector<uint32_t> version(n, 0);
  std::vector<Vec3> normal(n);  // unit field gradient at each vertex
  for (size_t v = 0; v < n; ++v) normal[v] = field.normal(P[v]);

  // Min-heap of (length, u, v, version u, version v); stale entries are skipped when popped.
  using Entry = std::tuple<double, uint32_t, uint32_t, uint32_t, uint32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
  auto push = [&](uint32_t u, uint32_t v) {
    const double length = glm::length(P[u] - P[v]);
    if (length < min_edge)
      heap.emplace(length, std::min(u, v), std::max(u, v), version[std::min(u, v)], version[std::max(u, v)]);
  };
  for (const Triangle& t : T)
    for (int k = 0; k < 3; ++k)
      if (t[k] < t[(k + 1) % 3]) push(t[k], t[(k + 1) % 3]);

  auto neighbours = [&](uint32_t v) {
    std::vector<uint32_t> out;
    for (uint32_t t : around[v])
      for (uint32_t w : T[t])
        if (w != v) out.push_back(w);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  };

  while (!heap.empty()) {
    const auto [length, u, v, version_u, version_v] = heap.top();
    heap.pop();
    if (!vertex_alive[u] || !vertex_alive[v] || version[u] != version_u || version[v] != version_v) continue;

    // The two triangles of the edge, and the link condition.
    std::vector<uint32_t> shared;
    for (uint32_t t : around[u])
      if (T[t][0] == v || T[t][1] == v || T[t][2] == v) shared.push_back(t);
    if (shared.size() != 2) continue;
    const std::vector<uint32_t> nu = neighbours(u), nv = neighbours(v);
    std::vector<uint32_t> common;
    std::set_intersection(nu.begin(), nu.end(), nv.begin(), nv.end(), std::back_inserter(common));
    if (common.size() != 2) continue;

    const Vec3 target = field.project(0.5 * (P[u] + P[v]), max_move);
    const Vec3 target_normal = field.normal(target);
    // Geometric check on every triangle around the edge: none may end up worse shaped or
    // worse oriented (against the field's gradient) than the worst one before, or than
    // the thresholds. Comparing with the field rather than with the old normals lets a
    // collapse remove a triangle that projection onto the surface had flipped.
    double shape_before = 1.0, shape_after = 1.0, facing_before = 1.0, facing_after = 1.0;
    for (uint32_t w : {u, v}) {
      for (uint32_t t : around[w]) {
        const Triangle& tri = T[t];
        facing_before = std::min(facing_before, orientation_cos(P[tri[0]], P[tri[1]], P[tri[2]],
                                                                normal[tri[0]] + normal[tri[1]] + normal[tri[2]]));
        shape_before = std::min(shape_before, triangle_quality(P[tri[0]], P[tri[1]], P[tri[2]]));
        if (t == shared[0] || t == shared[1]) continue;
        std::array<Vec3, 3> after;
        Vec3 reference{0.0};
        for (int k = 0; k < 3; ++k) {
          const bool moved = tri[k] == u || tri[k] == v;
          after[k] = moved ? target : P[tri[k]];
          reference += moved ? target_normal : normal[tri[k]];
        }
        facing_after = std::min(facing_after, orientation_cos(after[0], after[1], after[2], reference));
        shape_after = std::min(shape_after, triangle_quality(after[0], after[1], after[2]));
      }
    }
    if (facing_after < std::min(kGoodOrientationCos, facing_before) || shape_after < std::min(0.2, shape_before))
      continue;

    // Apply: v merges into u at `target`.
    for (uint32_t t : shared) {
      triangle_alive[t] = 0;
      for (uint32_t w : T[t]) {
        auto& list = around[w];
        list.erase(std::remove(list.begin(), list.end(), t), list.end());
      }
    }
    for (uint32_t t : around[v]) {
      for (uint32_t& w : T[t])
        if (w == v) w = u;
      around[u].push_back(t);
    }
    around[v].clear();
    vertex_alive[v] = 0;
    P[u] = target;
    normal[u] = target_normal;
    ++version[u];
    for (uint32_t w : neighbours(u)) push(u, w);
  }

  // Compact, keeping the surviving vertices and triangles in their original order so the
  // result is deterministic and independent of the heap's internals.
  std::vector<uint32_t> remap(n, UINT32_MAX);
  std::vector<Vec3> positions;
  for (uint32_t v = 0; v < n; ++v) {
    if (!vertex_alive[v]) continue;
    remap[v] = uint32_t(positions.size());
    positions.push_back(P[v]);
  }
  std::vector<Triangle> triangles;
  for (uint32_t t = 0; t < T.size(); ++t)
    if (triangle_alive[t]) triangles.push_back({remap[T[t][0]], remap[T[t][1]], remap[T[t][2]]});
  mesh.positions = std::move(positions);
  mesh.triangles = std::move(triangles);
}

// Collapses leave vertices unevenly spaced. A few Jacobi steps move each vertex halfway to
// its neighbours' centroid within the tangent plane (the component along the field's
// gradient is dropped so the shape does not shrink), then back onto the zero set. A move
// that would leave one of the vertex's triangles facing away from the field's gradient by
// more than 45 degrees (or more than it already did) is skipped, so no triangle folds over.
void relax_tangentially(TriangleMesh& mesh, const CharacterField& field, double max_move) {
  const size_t n = mesh.positions.size();
  std::vector<std::vector<uint32_t>> around(n);
  for (uint32_t t = 0; t < mesh.triangles.size(); ++t)
    for (uint32_t v : mesh.triangles[t]) around[v].push_back(t);
  for (int iteration = 0; iteration < kRelaxIterations; ++iteration) {
    const std::vector<Vec3> old = mesh.positions;
    std::vector<Vec3> normals(n);  // unit field gradients at the old positions
    for (size_t v = 0; v < n; ++v) normals[v] = field.normal(old[v]);
    for (uint32_t v = 0; v < n; ++v) {
      Vec3 sum{0.0};
      double weight = 0.0;
      for (uint32_t t : around[v])
        for (uint32_t w : mesh.triangles[t])
          if (w != v) {  // each neighbour is seen twice (two triangles per edge): same weight
            sum += old[w];
            weight += 1.0;
          }
      if (weight == 0.0) continue;
      Vec3 move = sum / weight - old[v];
      move -= glm::dot(move, normals[v]) * normals[v];
      const Vec3 target = field.project(old[v] + 0.5 * move, max_move);
      double facing_before = 1.0, facing_after = 1.0;
      for (uint32_t t : around[v]) {
        const Triangle& tri = mesh.triangles[t];
        std::array<Vec3, 3> after;
        for (int k = 0; k < 3; ++k) after[k] = tri[k] == v ? target : old[tri[k]];
        const Vec3 reference = normals[tri[0]] + normals[tri[1]] + normals[tri[2]];
        facing_before = std::min(facing_before, orientation_cos(old[tri[0]], old[tri[1]], old[tri[2]], reference));
        facing_after = std::min(facing_after, orientation_cos(after[0], after[1], after[2], reference));
      }
      const bool folds = facing_after < std::min(kGoodOrientationCos, facing_before);
      if (!folds) mesh.positions[v] = target;
    }
  }
}

}  // namespace

std::vector<CharacterJoint> test_character_joints(const CharacterOptions& options) {
  check_height(options);
  const double scale = options.height / kReferenceHeight;
  std::vector<CharacterJoint> joints = reference_joints();
  for (CharacterJoint& j : joints) {
    j.head *= scale;
    j.tail *= scale;
    j.head_radius *= scale;
    j.tail_radius *= scale;
  }
  return joints;
}

double test_character_blend_radius(const CharacterOptions& options) {
  check_height(options);
  return kReferenceBlend * options.height / kReferenceHeight;
}

TriangleMesh make_test_character(const CharacterOptions& options) {
  check_height(options);
  const double step = options.resolution;
  if (!(step > 0.0) || step > kCoarsestResolutionPerHeight * options.height)
    throw Error(ErrorKind::usage, "test character: resolution must be in (0, height/45]");

  CharacterField field;
  field.blend = test_character_blend_radius(options);
  Bounds box;
  for (const CharacterJoint& j : test_character_joints(options)) {
    field.cones.emplace_back(j.head, j.tail, j.head_radius, j.tail_radius);
    for (const auto& [c, r] : {std::pair{j.head, j.head_radius}, std::pair{j.tail, j.tail_radius}}) {
      box.grow(c - Vec3{r, r, r});
      box.grow(c + Vec3{r, r, r});
    }
  }

  // Grid: a margin of two steps beyond the capsules and the blend (which only adds volume
  // within `blend` of a crease). x is centred on the symmetry plane so the samples are
  // mirror-symmetric (the tetrahedral split is not, so the mesh is only nearly so).
  const double margin = field.blend + 2.0 * step;
  const double half_x = std::max(std::abs(box.min.x), std::abs(box.max.x)) + margin;
  // Counted in double first: a tiny resolution must be refused, not overflow an int.
  const double count_x = 2.0 * std::ceil(half_x / step) + 1.0;
  const double count_y = std::ceil((box.max.y - box.min.y + 2 * margin) / step) + 1.0;
  const double count_z = std::ceil((box.max.z - box.min.z + 2 * margin) / step) + 1.0;
  if (!(count_x * count_y * count_z <= kMaxGridSamples))
    throw Error(ErrorKind::usage, "test character: resolution too fine (grid above 2^26 samples)");
  const int nx = static_cast<int>(count_x), ny = static_cast<int>(count_y), nz = static_cast<int>(count_z);
  const Vec3 origin{-0.5 * (nx - 1) * step, box.min.y - margin, box.min.z - margin};
  auto grid_point = [&](int i, int j, int k) { return origin + step * Vec3{double(i), double(j), double(k)}; };
  auto grid_id = [&](int i, int j, int k) { return uint32_t(i + nx * (j + ny * k)); };

  std::vector<double> values(size_t(nx) * ny * nz);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) values[grid_id(i, j, k)] = field(grid_point(i, j, k));
  // Inside is strictly negative, so a sample exactly on the surface counts as outside and
  // every crossing edge has endpoints of strictly different classes.
  auto inside = [&](uint32_t id) { return values[id] < 0.0; };

  TriangleMesh mesh;
  std::unordered_map<uint64_t, uint32_t> edge_vertex;
  // One vertex per crossed grid edge, shared by every tetrahedron around the edge (welded).
  auto vertex_on_edge = [&](uint32_t in_id, const Vec3& in_p, uint32_t out_id, const Vec3& out_p) {
    const uint64_t key = (uint64_t(std::min(in_id, out_id)) << 32) | std::max(in_id, out_id);
    const auto found = edge_vertex.find(key);
    if (found != edge_vertex.end()) return found->second;
    const double f_in = values[in_id], f_out = values[out_id];
    // Kept a tenth of the edge away from the grid points: without this, a surface grazing
    // a sample makes several vertices (one per edge from it) nearly coincide, i.e.
    // degenerate slivers, which the projection below would not separate.
    const double t = std::clamp(f_in / (f_in - f_out), 0.1, 0.9);
    const Vec3 p = field.project(in_p + t * (out_p - in_p), 0.5 * step);
    const uint32_t index = uint32_t(mesh.positions.size());
    mesh.positions.push_back(p);
    edge_vertex.emplace(key, index);
    return index;
  };

  const auto tets = kuhn_tetrahedra();
  std::array<uint32_t, 8> corner_id{};
  std::array<Vec3, 8> corner_p{};
  for (int k = 0; k + 1 < nz; ++k) {
    for (int j = 0; j + 1 < ny; ++j) {
      for (int i = 0; i + 1 < nx; ++i) {
        int n_inside = 0;
        for (int c = 0; c < 8; ++c) {
          corner_id[c] = grid_id(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
          n_inside += inside(corner_id[c]);
        }
        if (n_inside == 0 || n_inside == 8) continue;
        for (int c = 0; c < 8; ++c) corner_p[c] = grid_point(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
        for (const auto& tet : tets) {
          std::array<int, 4> in{}, out{};
          int n_in = 0, n_out = 0;
          for (int v = 0; v < 4; ++v) {
            if (inside(corner_id[tet[v]]))
              in[n_in++] = v;
            else
              out[n_out++] = v;
          }
          if (n_in == 0 || n_out == 0) continue;
          auto edge = [&](int a, int b) {  // a: tet-local inside vertex, b: outside
            return vertex_on_edge(corner_id[tet[a]], corner_p[tet[a]], corner_id[tet[b]], corner_p[tet[b]]);
          };
          if (n_in == 1 || n_out == 1) {
            // One corner alone on its side. With (lone, a, b, c) an even permutation of a
            // positively oriented tetrahedron, (e_la, e_lb, e_lc) faces away from the lone
            // corner: outward when it is inside, inward otherwise.
            const bool lone_inside = n_in == 1;
            std::array<int, 4> order = lone_inside ? std::array<int, 4>{in[0], out[0], out[1], out[2]}
                                                   : std::array<int, 4>{out[0], in[0], in[1], in[2]};
            if (!is_even(order)) std::swap(order[2], order[3]);
            auto e = [&](int other) { return lone_inside ? edge(order[0], other) : edge(other, order[0]); };
            Triangle tri{e(order[1]), e(order[2]), e(order[3])};
            if (!lone_inside) std::swap(tri[1], tri[2]);
            mesh.triangles.push_back(tri);
          } else {
            // Two and two: with (i0, i1, o0, o1) even, the cycle e(i0,o0), e(i0,o1),
            // e(i1,o1), e(i1,o0) faces outward. Split it along its shorter diagonal: the
            // quad lies inside the tetrahedron, so either split keeps neighbours matching.
            std::array<int, 4> order{in[0], in[1], out[0], out[1]};
            if (!is_even(order)) std::swap(order[2], order[3]);
            const std::array<uint32_t, 4> q = {edge(order[0], order[2]), edge(order[0], order[3]),
                                               edge(order[1], order[3]), edge(order[1], order[2])};
            const auto& P = mesh.positions;
            if (glm::length(P[q[0]] - P[q[2]]) <= glm::length(P[q[1]] - P[q[3]])) {
              mesh.triangles.push_back({q[0], q[1], q[2]});
              mesh.triangles.push_back({q[0], q[2], q[3]});
            } else {
              mesh.triangles.push_back({q[0], q[1], q[3]});
              mesh.triangles.push_back({q[1], q[2], q[3]});
            }
          }
        }
      }
    }
  }
  collapse_short_edges(mesh, field, kCollapseBelowSteps * step, 0.5 * step);
  relax_tangentially(mesh, field, 0.5 * step);
  return mesh;
}

}  // namespace skelform::bake
