// Runtime step 5 (DESIGN.md "LBS where LBS is exact, skelform where it is not"): the output is
// linear blend skinning plus a share of skelform's correction, and never intersects itself
// where LBS does not.
//
// Every dense vertex v gets x_v = L_v + w_v·λ_v·(K_v − L_v), where L is LBS of the pose, K
// skelform's result, w_v the baked skelform weight (0 on rigidly weighted vertices, 1 in the
// blend zones) and λ_v ∈ [0, 1] the guard's factor, per welded vertex. The guard starts from
// λ = 1 and looks for intersecting pairs of non-adjacent triangles of x that involve a
// triangle moved off LBS (a pair of unmoved triangles is LBS's own pair). A pair that LBS
// does not have (the same two triangles tested at L), and that does not intersect at rest
// either (ContactMesh::rest_pairs: parts modelled through each other), halves λ at the moved
// corners of its triangle further off LBS (the summed distance of its corners from L; the
// other keeps its share, and is lowered in a later round only if the pair is still there),
// and the search repeats; after kGuardHalvings rounds such corners fall to λ = 0
// (exactly LBS). It ends when no such pair is left, which it must: a pair whose corners are
// all at λ = 0 is LBS's. So every frame's intersecting pairs are a subset of LBS's and the
// model's: skelform never adds a self-intersection to what LBS gives over the bind pose, on
// any character, in any pose. Where skelform does not
// add one (nearly everywhere), λ stays 1 and its result is kept whole. The fallback is made
// smooth: around a corrected vertex λ rises back to 1 over kGuardRampRings rings (each at most
// half-way from its neighbours' smallest to 1), and the lowered factors are checked again.
//
// The triangle test is geometry::triangles_intersect (double precision, the metric's own; with
// AVX, exact_triangles.h's form of it, which gives the same verdict), after a float test of the
// face planes that answers only where that verdict is surely "apart" (triangles_surely_apart);
// the broad phase is the welded mesh's triangle hierarchy (triangle_bvh.h): the first round
// meets it with itself, refitted to the boxes at x (in the re-check after the ramp, the node
// boxes of the search before, grown around the triangles it re-boxes), and passes over the leaf
// pairs a bound from the rest pose shows apart (rest_clearance.h, with the caller's joints);
// later rounds query it with the triangles whose corners moved, its node boxes grown around
// their new boxes.
// The guard's work per evaluation is bounded (pair_visit_budget, triangle_bvh.h: candidate
// pairs its searches visit, linear in the welded triangles): a pose that would need more, a
// surface tangled over itself as only degenerate or corrupt data gives (the corpus's worst
// frame uses under half of it), is output as LBS, so no input makes an evaluation quadratic.
// Volume, on a closed mesh: after the intersection guard, if the result's volume is further
// from the rest volume (times the pose's reference scale cubed: the bind volume) than LBS's,
// the corrected surface first moves along its normals, each vertex by δ times its share w·λ
// of skelform's correction (junction anchors stay), with the smallest δ that brings the
// volume within 0.99 of LBS's error, at most the contact pass's largest move (ContactMesh::cap)
// per try, or the δ that comes nearest when none does; the intersection guard then takes back
// the pairs this makes. If the volume is still outside, every λ is scaled by the largest
// μ ∈ [0, 1] that brings it back within LBS's error (the volume of L + μ·correction is a cubic
// in μ), and the intersection guard runs again from there; a try is a move and a scaling, and
// after kVolumeAttempts tries the correction falls back to 0 (LBS) altogether. So
// a closed character's volume is never further from its bind volume than LBS's, frame by
// frame, and skelform's shape is kept where a move along the normals restores its volume
// (scaling λ instead gave most of the correction back to LBS, and LBS's pairs with it). Open
// meshes bound no volume and are not moved.
//
// The guard is per evaluation (a held pose gives the same λ, bit for bit: no jitter); where a
// contact starts or ends between frames, the corrected vertices change their share there.
#pragma once

#include "contact.h"
#include "memory.h"
#include "triangle_bvh.h"

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstdint>

namespace skelform::runtime {

struct Deformable;
struct DenseOutput;
struct JointAffine;

constexpr uint32_t kGuardHalvings = 4;   // rounds that halve λ before it drops to 0
constexpr uint32_t kGuardRampRings = 2;  // rings over which λ rises back from a corrected vertex
constexpr uint32_t kVolumeAttempts = 3;  // volume moves and shares tried before LBS

// Scratch of one instance (make_guard_workspace), sized for its deformable's welded mesh.
struct GuardWorkspace {
  explicit GuardWorkspace(const AllocatorRef& a)
      : factor(a),
        positions(a),
        moved(a),
        flagged(a),
        changed(a),
        flagged_list(a),
        ramp(a),
        lowered(a),
        corrected_list(a),
        lowered_list(a),
        tested(a),
        wanted(a),
        test_list(a),
        boxes(a),
        node_boxes(a),
        node_flags(a),
        leaf_flags(a),
        pair_keys(a),
        pair_added(a),
        gradient(a),
        volume_base(a),
        volume_delta(a),
        volume_norm(a),
        clearance_maps(a) {}
  Array<float> factor;             // λ per welded vertex
  Array<glm::vec3> positions;      // x per welded vertex
  Array<uint8_t> moved;            // per welded vertex: x differs from L (+ 3 bytes: guard_seed.h)
  Array<uint8_t> flagged;          // per welded vertex: a corner of an added pair this round
  Array<uint8_t> changed;          // per welded vertex: its λ changed this round
  Array<uint32_t> flagged_list;    // the vertices flagged this round
  Array<float> ramp;               // per welded vertex: its λ after a ramp ring (then applied)
  Array<uint8_t> lowered;          // per welded vertex: a mark of the ramp's (then cleared)
  Array<uint32_t> corrected_list;  // the vertices whose λ the intersection guard lowered from 1
  Array<uint32_t> lowered_list;    // the vertices whose λ the ramp lowered
  Array<uint8_t> tested;           // per triangle: in this round's list
  Array<uint8_t> wanted;           // per hierarchy slot (slot_stride()): tested, for the first round
  Array<uint32_t> test_list;       // the triangles this round tests
  // Per triangle (by hierarchy slot): its box at x. The contact pass (FirstRoundHook) grows
  // those around the vertices it moves; the guard sets them again there (search_after_moves).
  SlotBoxes boxes;
  Array<float> node_boxes;      // ContactMesh::hierarchy refitted to boxes, then grown around them
  Array<uint8_t> node_flags;    // per node: it holds a triangle of the first round
  Array<LeafLanes> leaf_flags;  // per leaf node: its lanes holding one
  // The first round's intersecting pairs (s << 32 | t, s < t), but those the model has at rest,
  // and whether LBS lacks each, when a FirstRoundHook wants them; pairs_complete is false when
  // they outnumbered the capacity (kGuardPairsPerTriangle per triangle), and the hook is then
  // not called (the contact pass skips that evaluation).
  Array<uint64_t> pair_keys;
  Array<uint8_t> pair_added;
  bool pairs_complete = false;
  Array<glm::vec3> gradient;  // per welded vertex: the volume offset's direction (offset_for_volume)
  // Per welded vertex of a closed mesh (else empty): the volume cubic's base point and
  // direction (volume_cubic), in double.
  Array<glm::dvec3> volume_base;
  Array<glm::dvec3> volume_delta;
  Array<double> volume_norm;     // |base|₁ + |delta|₁: the scale of volume_within's rounding bound
  ClearanceMaps clearance_maps;  // the first round's leaf maps (rest_clearance.h)
  bool use_clearance = true;     // false: the first round tests every leaf pair (for tests)
  PairBudget budget;             // this evaluation's candidate pairs
  bool over_budget = false;      // the last evaluation ran out of it (and is LBS)
  uint32_t rounds = 0;           // of the last evaluation
  uint32_t leaves_apart = 0;     // leaf pairs the last evaluation's first rounds passed over
  uint32_t corrected = 0;        // welded vertices with λ < 1 after the last evaluation
  float volume_share = 1.0f;     // μ of the last evaluation
};

// Capacity of GuardWorkspace::pair_keys, per welded triangle (the corpus's frames intersect far
// fewer: a pair per triangle would be a mesh through itself everywhere).
constexpr uint32_t kGuardPairsPerTriangle = 1;

// Work run between the guard's first search and its first lowering: the contact pass, which
// then needs no search of its own. It gets every intersecting pair of non-adjacent triangles
// that search found (at λ = 1, every pair with a corner off LBS, but those the model has at
// rest), may move skelform's result K at welded vertices, and returns those vertices. The
// guard then keeps the verdicts of the pairs none of whose corners moved, and searches again
// only around the moved ones, with an allowance of the work budget of its own: the guard's
// outcome is that of a whole first round over the moved result (except at the edge of the
// work budget, which the two ways spend differently). It may grow the boxes of the triangles
// around the vertices it returns (ContactPairs), and leaves every other box as it found it.
class FirstRoundHook {
 public:
  virtual const Array<uint32_t>& after_first_search(const ContactPairs& pairs) = 0;

 protected:
  ~FirstRoundHook() = default;
};

// Throws std::bad_alloc.
GuardWorkspace make_guard_workspace(const ContactMesh& mesh, const AllocatorRef& allocator);

// `skelform` (K) and `lbs` (L) are this pose's dense results (positions, normals, tangents as
// the evaluation computed them); `out` receives the blend, and may be `skelform` itself (each
// vertex is written after the last read of its own K). `with_normals`: also blend normals
// (renormalised) and tangents.
// Junction anchors (Deformable::anchor_vertices): sets skelform's result K at each anchored
// dense vertex so that its output before the guard, L + w·(K − L), is its rest position under
// its host's skin (the host vertex's LBS matrix, from the caller's joints as
// prepare_joints made them: JointTransforms::affine). `lbs` is L.
void anchor_junctions(const Deformable& d, const JointAffine* joints, const glm::vec3* lbs, glm::vec3* skelform);

// `hook` (or null) runs once, after the first search (FirstRoundHook). On a closed mesh the
// volume step may move skelform's result K in place (along the normals), with or without a hook.
// `joints` (JointTransforms::affine, or null): with them, the first round passes over the
// leaf pairs that rest_clearance.h shows apart (the same verdicts, fewer tests).
void guard_and_blend(const Deformable& d, const ContactMesh& mesh, float scale, const DenseOutput& skelform,
                     const DenseOutput& lbs, bool with_normals, const DenseOutput& out, GuardWorkspace& ws,
                     FirstRoundHook* hook = nullptr, const JointAffine* joints = nullptr);

}  // namespace skelform::runtime
