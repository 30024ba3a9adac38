// Runtime step 5 (DESIGN.md departure, "Contact pass"): the output's remaining self-
// intersections, resolved on the dense mesh itself.
//
// Flows (4) and (5) act on the control mesh, through medial balls; the dense mesh follows it by
// displacement along the refined normals. Where two parts meet (a leg against the chest of a
// running fox), the dense skins can still cross after the flows, and a correction of the
// control mesh alone does not reach them (dense vertices lie up to an edge length off the
// control mesh; docs/tuning.md). This pass therefore works on the welded dense output: it finds the intersecting
// pairs of non-adjacent triangles and moves their vertices out of each other, one vertex at a
// time, keeping a move only where the number of intersecting pairs around that vertex does not
// grow (pairs that intersect at rest, ContactMesh::rest_pairs, are not resolved, pushed out
// of or counted; a move may trade one pair for another, which the LBS guard then judges). It
// runs after the displacement, is not part of the fairing's warm start (the next evaluation
// starts from the flows' result, not from this pass's), and leaves the normals and tangents as
// the displacement computed them.
#pragma once

#include "memory.h"
#include "rest_clearance.h"
#include "triangle_bvh.h"

#include <glm/vec3.hpp>

#include <algorithm>
#include <cstdint>

namespace skelform::runtime {

// The welded dense mesh of a deformable, built when an instance turns the pass on
// (sf_instance_set_contacts).
struct ContactMesh {
  explicit ContactMesh(const AllocatorRef& a)
      : weld(a),
        representative(a),
        triangles(a),
        incident_offsets(a),
        incident(a),
        hierarchy(a),
        clearance(a),
        rest_pairs(a) {}
  uint32_t vertex_count = 0;         // welded vertices
  uint32_t triangle_count = 0;       // welded triangles without a repeated corner
  Array<uint32_t> weld;              // per dense vertex: its welded vertex (same rest position, bit for bit)
  Array<uint32_t> representative;    // per welded vertex: the first dense vertex with its position
  Array<uint32_t> triangles;         // 3 per triangle, welded indices
  Array<uint32_t> incident_offsets;  // vertex_count + 1 (CSR)
  Array<uint32_t> incident;          // triangles around each welded vertex, ascending
  float gap = 0.0f;                  // clearance a push aims for: kContactGap mean rest edges
  float cap = 0.0f;                  // largest total move of a vertex: kContactCap mean rest edges
  // Every edge has exactly two triangles using it in opposite directions: the welded mesh
  // bounds a volume, `rest_volume` (signed, divergence theorem, in the stored mesh's units).
  bool closed = false;
  double rest_volume = 0.0;
  // The triangles' hierarchy over the rest pose (triangle_bvh.h), for the LBS guard.
  TriangleHierarchy hierarchy;
  // Its leaves' rest clearances (rest_clearance.h), for the LBS guard's first round.
  RestClearance clearance;
  // The pairs that intersect as modelled (pair_key, ascending): parts a modeller embedded in
  // each other. The contact pass and the LBS guard leave them be.
  Array<uint64_t> rest_pairs;
  bool intersects_at_rest(uint64_t pair) const {
    return std::binary_search(rest_pairs.begin(), rest_pairs.end(), pair);
  }
  // The rest-pair search ran out of its budget (pair_visit_budget: a mesh tangled over itself
  // at rest, as corrupt data gives): rest_pairs is empty, and the contact pass leaves the mesh.
  bool tangled_at_rest = false;
};

// Two triangles as one key, the smaller index first: s << 32 | t with s < t.
inline uint64_t pair_key(uint32_t s, uint32_t t) { return uint64_t(std::min(s, t)) << 32 | std::max(s, t); }

constexpr uint32_t kContactSweeps = 4;  // passes over the active vertices, at most
// Active vertices a pass keeps its looks for, to pass over those near which nothing moved
// (resolve_contacts); the corpus's passes have at most 187 (`./run.sh quality`).
constexpr uint32_t kContactSkipCapacity = 1024;
// The pass's work budget, in guard budgets (pair_visit_budget): its detection is one search,
// then each sweep gathers and tests candidates around every active vertex, several times
// (docs/tuning.md has the corpus's worst use against it).
constexpr uint64_t kContactBudgetPasses = 128;
constexpr float kContactGap = 0.05f;  // in mean rest edge lengths
constexpr float kContactCap = 0.5f;   // in mean rest edge lengths

// Builds the welded mesh from the dense rest positions and triangles. Throws std::bad_alloc.
ContactMesh build_contact_mesh(const glm::vec3* rest_positions, uint32_t vertex_count, const uint32_t* triangles,
                               size_t triangle_count, const AllocatorRef& allocator);

// Scratch of one instance, sized once for its mesh (make_contact_workspace).
struct ContactWorkspace {
  explicit ContactWorkspace(const AllocatorRef& a)
      : positions(a),
        start(a),
        state(a),
        active(a),
        cell_offsets(a),
        entries(a),
        ranges(a),
        boxes(a),
        normals(a),
        stamps(a),
        candidates(a),
        candidate_boxes(a),
        candidate_shared(a),
        corner_stars(a),
        corner_stamps(a),
        regions(a),
        seen(a),
        move_boxes(a),
        moved(a) {}
  Array<glm::vec3> positions;    // welded positions
  Array<glm::vec3> start;        // position of each active vertex when the pass began
  Array<uint8_t> state;          // per welded vertex: movable, active (in a detected pair), moved
  Array<uint32_t> active;        // the active vertices, ascending
  Array<uint32_t> cell_offsets;  // broad-phase grid (CSR), at most 4 cells per triangle
  Array<uint32_t> entries;       // triangles per cell, 8 entries per triangle reserved
  Array<int16_t> ranges;         // per triangle: its cells (lo xyz, hi xyz)
  Array<float> boxes;            // per triangle: its box when the pass began (lo xyz, hi xyz)
  Array<glm::vec3> normals;      // per triangle: its unit normal when the pass began (0 if degenerate)
  Array<uint32_t> stamps;        // per triangle: the last gather that listed it
  Array<uint32_t> candidates;    // the last gather's triangles
  // Their boxes when gathered, as six planes (lo x, y, z, hi x, y, z) of candidate_stride
  // floats each (one per triangle): pairs_around compares four candidates at a time.
  Array<float> candidate_boxes;
  size_t candidate_stride = 0;
  // Per candidate: bit k set when it shares a corner with triangle k of the gathered vertex's
  // star (its incident triangles, k < 32), a pair that never counts. Built from corner_stars:
  // per welded vertex, the star triangles it is a corner of, valid where corner_stamps holds
  // the gather's stamp.
  Array<uint32_t> candidate_shared;
  Array<uint32_t> corner_stars;
  Array<uint32_t> corner_stamps;
  // Per active vertex (by its place in `active`, up to kContactSkipCapacity): where its last
  // look found its candidates (its star's box grown by the reach of its last gather; lo xyz, hi
  // xyz) and the pass's count of moves then (or kLookAgain). A ring of the last moves' boxes, as
  // many as active vertices.
  Array<float> regions;
  Array<uint32_t> seen;
  Array<float> move_boxes;
  Array<uint32_t> moved;  // the welded vertices the last pass moved, ascending
  uint32_t stamp = 0;
  bool grid = false;  // cell_offsets, entries, ranges, boxes and normals are sized (add_contact_grid)
  // This pass's work: every triangle pair a search or a push visits spends one. A surface
  // tangled over itself would make the pass quadratic (all boxes meeting all boxes); past
  // kContactBudgetPasses × pair_visit_budget the pass stops and moves nothing.
  PairBudget budget;
};

// The scratch of the pass inside the LBS guard (a ContactPairs search). Throws std::bad_alloc.
ContactWorkspace make_contact_workspace(const ContactMesh& mesh, const AllocatorRef& allocator);
// Adds the pass's own grid, which it needs without a shared search (the handle driver: no LBS,
// no guard). Throws std::bad_alloc.
void add_contact_grid(const ContactMesh& mesh, ContactWorkspace& workspace);

struct ContactStats {
  uint32_t pairs_before = 0;  // intersecting pairs found by the first detection
  uint32_t moved = 0;         // welded vertices moved
  bool over_budget = false;   // the pass ran out of its work budget and moved nothing
};

// The output's blend of skelform's result k with LBS's l by the share s (lbs_guard.h: the
// skelform weight times the guard's factor): l + s·(k − l), exactly l at s = 0. The guard and
// the contact pass use this one expression, so that they see the same mesh.
inline glm::vec3 blend_with_lbs(const glm::vec3& l, const glm::vec3& k, float s) {
  return s == 0.0f ? l : l + s * (k - l);
}

// How the output blends skelform's result K with LBS (blend_with_lbs before the guard's
// share), when it does.
struct ContactBlend {
  const glm::vec3* lbs = nullptr;  // L per dense vertex
  const float* weight = nullptr;   // w per dense vertex
};

// The caller's search of the mesh the pass sees (the LBS guard's first round, lbs_guard.h), which
// then stands in for the pass's own grid: its intersecting pairs of non-adjacent triangles, as
// s << 32 | t with s < t (every such pair with a movable corner, but those in
// ContactMesh::rest_pairs), are the pass's detection, and
// its hierarchy, with the node and triangle boxes at the positions the pass starts from, serves
// the pass's gathers.
// The pass writes those boxes: as it moves vertices it keeps them holding every triangle (a
// moved vertex's triangles' boxes and their node boxes grow around where they are now), so its
// gathers query the hierarchy with no allowance for motion. Only the triangles around the
// vertices it lists as moved keep grown boxes (a pass that runs out of budget takes its moves
// and their boxes back); the node boxes still hold every triangle's box.
struct ContactPairs {
  const uint64_t* keys = nullptr;
  size_t count = 0;
  const TriangleHierarchy* hierarchy = nullptr;
  float* node_boxes = nullptr;
  SlotBoxes* boxes = nullptr;
};

// With a blend, a welded vertex moves only if every copy of it takes at least this share of
// skelform's result: a copy below it (a rigid one, at 0) would stay behind and open the seam,
// and K = L + (x − L)/w must stay finite.
constexpr float kContactMinWeight = 1e-6f;

// The pass on `dense_positions` (skelform's result K per dense vertex, in place).
// Deterministic. With a blend, it resolves the contacts of the blended mesh L + w·(K − L),
// what the output shows, moves only welded vertices whose every copy has w ≥
// kContactMinWeight (rigid parts stay rigid), and writes each moved copy's K back so that its
// blend lands where the pass put it (K = L + (x − L) / w): a vertex that takes a tenth of
// skelform's result still gets the whole of its push. Without one, it resolves the contacts of
// K and any vertex may move. With `detected`, its search stands in for the pass's grid;
// without, the pass needs its grid (add_contact_grid) and does nothing if it has none, and the
// pass writes its boxes (ContactPairs). Lists the moved welded vertices in workspace.moved.
ContactStats resolve_contacts(const ContactMesh& mesh, float scale, glm::vec3* dense_positions,
                              uint32_t dense_vertex_count, ContactWorkspace& workspace,
                              const ContactBlend& blend = ContactBlend(), const ContactPairs* detected = nullptr);

}  // namespace skelform::runtime
