// Leaf pairs of the triangle hierarchy whose triangles cannot meet in the pose, from a bound
// taken at rest: the LBS guard's first round (lbs_guard.h) passes over them without testing.
//
// At load, each leaf a gets D_a: a lower bound on the rest distance between any triangle of a
// and any triangle sharing no corner with it in a leaf whose rest box meets a's (a itself
// too); each pair's bound is the largest gap along the separating-axis test's axes
// (clearance_between). Two leaves whose rest boxes meet are then at least max(D_a, D_b) apart
// pair by pair; two whose rest boxes do not, at least the gap between the boxes.
//
// In the pose, each leaf gets an affine map from the rest pose, A_a(p) = x_α + L_a (p − p_α):
// L_a is the LBS matrix of one of its vertices α (its anchor, near the leaf's centre, at x_α),
// and the leaf's stray r_a is the largest |x − A_a(p)| over its vertices (rest p, pose x). A
// point of a triangle strays by at most its corners' largest stray (it is their barycentric
// blend on both sides), so two triangles of a and b sharing no corner are at least
// σ_min(L_a)·D − r_a − r_b' apart, where r_b' = r_b + |A_b(c_b) − A_a(c_b)| + ‖L_b − L_a‖_F ρ_b
// bounds b's vertices' stray under A_a (c_b, ρ_b: a sphere around b's rest vertices). Where
// that is positive, with a margin for rounding, the leaves' pairs are apart. The exact test says
// so where neither triangle has collapsed to a segment or a point (its axes are then complete),
// which 2r < σ_min·h rules out for both leaves (h: the leaf's least rest altitude). So the
// guard's verdicts are those of testing the pairs, bit for bit; only its work budget
// (pair_visit_budget), spent on the pairs it tests, lasts longer, so that a pose at its edge may
// finish where testing every pair would have fallen back to LBS (both keep the guard's promise;
// the corpus's worst evaluation uses under half of it).
//
// Where a leaf moves nearly as its anchor's skin, as most of a limb does, its neighbours are
// skipped; in a joint's blend zone, where LBS bends the surface over a leaf's span and
// skelform's correction varies, they are tested as before. The bound skips about two thirds of
// the leaf pairs on the dense CesiumMan, a sixth on the Horse (docs/results.md).
#pragma once

#include "memory.h"
#include "triangle_bvh.h"

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <limits>

namespace skelform::runtime {

struct JointAffine;

// The largest D kept, in mean rest edges: a pose whose strays reach further tests anyway.
constexpr double kClearanceCap = 4.0;

// The load's work bound, in pair_visit_budget()s (triangle_bvh.h: 64 per triangle and 65,536):
// leaf pairs and triangle pairs compared. The corpus's meshes use at most 45 per triangle.
constexpr uint64_t kClearanceBudgetSearches = 4;

// Built once per welded mesh (build_rest_clearance); per node, filled at leaves only.
struct RestClearance {
  explicit RestClearance(const AllocatorRef& a)
      : vertex_offsets(a),
        vertices(a),
        offsets(a),
        anchor(a),
        anchor_rest(a),
        reach(a),
        altitude(a),
        sphere(a),
        rest_boxes(a),
        clearance(a) {}
  Array<uint32_t> vertex_offsets;  // nodes + 1 (CSR): the welded vertices of a leaf's triangles
  Array<uint32_t> vertices;
  // Each vertex's rest position less its leaf's anchor's, as three planes of vertices.size()
  // floats (x, then y, then z): the stray loop reads them four at a time.
  Array<float> offsets;
  Array<uint32_t> anchor;        // per node: the leaf's vertex nearest its rest box's centre
  Array<glm::vec3> anchor_rest;  // per node: the anchor's rest position
  Array<float> reach;            // per node: the largest |offset| coordinate (rounded up)
  Array<float> altitude;         // per node: the least altitude of its triangles (rounded down)
  Array<glm::vec4> sphere;       // per node: c (near the rest box's centre) and ρ
  Array<float> rest_boxes;       // per node: its rest box (lo xyz, hi xyz)
  // Per node: D_a, at most the rest distance between a triangle of the leaf and any triangle
  // sharing no corner with it in a leaf whose rest box meets the leaf's (itself too), rounded
  // down to float, and at most kClearanceCap mean rest edges.
  Array<float> clearance;
  bool gathers_fit = false;  // entries and welded vertices take int32 gather offsets (cpu.h)
  bool empty() const { return vertex_offsets.empty(); }
};

// `welded_rest`: rest position per welded vertex; `triangles`: welded corners, 3 per triangle.
// Empty (no leaf pair is then passed over) for a mesh tangled over itself at rest, past
// kClearanceBudgetSearches. Throws std::bad_alloc.
RestClearance build_rest_clearance(const TriangleHierarchy& h, const glm::vec3* welded_rest, const uint32_t* triangles,
                                   const AllocatorRef& allocator);

// A lower bound on the distance between two closed triangles (double), 0 when they meet: the
// largest gap along the separating-axis test's seventeen axes and the line between the
// centroids, less their rounding. It may stop at the first gap of at least `enough`.
double clearance_between(const glm::dvec3* a, const glm::dvec3* b,
                         double enough = std::numeric_limits<double>::infinity());

// A leaf's map in the pose: A(p) = x_anchor + L (p − rest_anchor). L and x_anchor are floats
// (a blend of the joints' and a position), taken to double where the bound uses them.
struct LeafMap {
  glm::mat3 linear;      // L, the anchor's LBS matrix
  glm::vec3 anchor;      // x at the anchor
  double stray = 0.0;    // r: at least the largest |x − A(rest)| over the leaf's vertices
  double stretch = 0.0;  // at most σ_min(L)
};

// Per-instance scratch: each leaf's map, computed when first asked for in a search.
struct ClearanceMaps {
  explicit ClearanceMaps(const AllocatorRef& a) : maps(a), stamps(a) {}
  Array<LeafMap> maps;
  Array<uint32_t> stamps;  // per node: the search that computed its map
  uint32_t stamp = 0;
  void resize(size_t nodes) {
    maps.resize(nodes);
    stamps.assign(nodes, 0u);
  }
  // A new search (positions changed): every map is computed again.
  void next() {
    if (++stamp == 0) {
      std::fill(stamps.begin(), stamps.end(), 0u);
      stamp = 1;
    }
  }
};

// Inputs of the bound for one evaluation: positions x per welded vertex, the dense skin (with
// each welded vertex's representative) and the joints.
struct ClearancePose {
  const glm::vec3* positions;
  const uint32_t* representative;  // per welded vertex
  const uint16_t* joints;          // dense, `influences` per vertex
  const float* weights;
  uint32_t influences;
  const JointAffine* affine;
};

namespace detail {

// A leaf's strays in the pose: over its entries [begin, end) of RestClearance::vertices, the
// largest |(x_v − x_anchor) − L·offset_v|² in float (`l`: L by rows) and the largest
// |x_v − x_anchor|₁ (for the rounding bound); `squared` NaN when a term is NaN (`spread` is then
// unspecified). `avx2`: eight entries at a time where built and gathers fit, else four (SSE2) or
// one; the same sums either way (rest_clearance_test).
struct StraySums {
  float squared = 0.0f;
  float spread = 0.0f;
};
StraySums stray_sums(const RestClearance& c, const glm::vec3* x, uint32_t begin, uint32_t end, const float* l,
                     const glm::vec3& xa, bool avx2);

}  // namespace detail

// True when no triangle of leaf `a` meets a triangle of leaf `b` sharing no corner with it, by
// the bound above. Computes the leaves' maps into `maps` when they are not yet this search's.
bool leaves_apart(const RestClearance& c, const ClearancePose& pose, ClearanceMaps& maps, uint32_t a, uint32_t b);

}  // namespace skelform::runtime
