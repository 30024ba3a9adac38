#include "lbs_guard.h"

#include "asset.h"
#include "exact_triangles.h"
#include "guard_blend.h"
#include "guard_seed.h"
#include "instance.h"
#include "skin_blend.h"
#include "triangle_bvh.h"
#include "volume_sums.h"

#include <glm/common.hpp>

#include <algorithm>
#include <cmath>

namespace skelform::runtime {

namespace {

glm::dvec3 widen(const glm::vec3& p) { return glm::dvec3(p); }

}  // namespace

GuardWorkspace make_guard_workspace(const ContactMesh& mesh, const AllocatorRef& allocator) {
  GuardWorkspace ws(allocator);
  const size_t triangles = mesh.triangle_count;
  ws.factor.resize(mesh.vertex_count);
  ws.positions.resize(mesh.vertex_count);
  ws.moved.resize(mesh.vertex_count + 3);  // + 3: guard_seed.h
  ws.flagged.resize(mesh.vertex_count);
  ws.changed.resize(mesh.vertex_count);
  ws.flagged_list.reserve(mesh.vertex_count);
  ws.ramp.resize(mesh.vertex_count);
  ws.lowered.resize(mesh.vertex_count);
  ws.corrected_list.reserve(mesh.vertex_count);
  ws.lowered_list.reserve(mesh.vertex_count);
  ws.tested.resize(triangles);
  ws.wanted.resize(mesh.hierarchy.slot_stride());
  ws.test_list.reserve(triangles);
  ws.boxes.resize(mesh.hierarchy);
  ws.node_boxes.resize(6 * mesh.hierarchy.nodes.size());
  ws.node_flags.resize(mesh.hierarchy.nodes.size());
  ws.leaf_flags.resize(mesh.hierarchy.nodes.size());
  ws.pair_keys.reserve(size_t(kGuardPairsPerTriangle) * triangles);
  ws.pair_added.reserve(size_t(kGuardPairsPerTriangle) * triangles);
  ws.gradient.resize(mesh.vertex_count);
  ws.clearance_maps.resize(mesh.clearance.empty() ? 0 : mesh.hierarchy.nodes.size());
  if (mesh.closed) {
    ws.volume_base.resize(mesh.vertex_count);
    ws.volume_delta.resize(mesh.vertex_count);
    ws.volume_norm.resize(mesh.vertex_count);
  }
  return ws;
}

namespace {

// x at welded vertex v from its factor.
glm::vec3 blended_position(const Deformable& d, const ContactMesh& mesh, const DenseOutput& skelform,
                           const DenseOutput& lbs, const GuardWorkspace& ws, uint32_t v) {
  const uint32_t r = mesh.representative[v];
  return blend_with_lbs(lbs.positions[r], skelform.positions[r], d.skelform_weight[r] * ws.factor[v]);
}

// One run of the intersection guard over the current factors (ws.factor), in named steps:
// the first round's triangles (seed_*), each round's search for pairs LBS lacks (search),
// and the halving of λ at their moved corners (lower).
class GuardPass {
 public:
  GuardPass(const Deformable& d, const ContactMesh& mesh, const DenseOutput& skelform, const DenseOutput& lbs,
            GuardWorkspace& ws, const JointAffine* joints)
      : d_(d),
        mesh_(mesh),
        skelform_(skelform),
        lbs_(lbs),
        ws_(ws),
        tri_(mesh.triangles.data()),
        rep_(mesh.representative.data()),
        h_(mesh.hierarchy),
        intersect_(exact_triangle_test()),
        pose_{ws.positions.data(), rep_, d.dense_joints.data(), d.dense_weights.data(), d.influences, joints},
        clearance_(joints && ws.use_clearance && !mesh.clearance.empty() &&
                   ws.clearance_maps.maps.size() == h_.nodes.size()) {}

  // The positions of the vertices in `only` and the boxes of their triangles; lists the
  // triangles with a moved corner among those.
  void seed_incremental(const Array<uint32_t>& only) {
    for (uint32_t v : only) {
      ws_.positions[v] = blended_position(d_, mesh_, skelform_, lbs_, ws_, v);
      ws_.moved[v] = ws_.positions[v] != lbs_.positions[rep_[v]];
    }
    for (uint32_t v : only)
      for (uint32_t k = mesh_.incident_offsets[v]; k < mesh_.incident_offsets[v + 1]; ++k) {
        const uint32_t t = mesh_.incident[k];
        if (ws_.tested[t]) continue;
        const uint32_t* c = tri_ + 3 * size_t(t);
        float box[6];
        triangle_box(ws_.positions[c[0]], ws_.positions[c[1]], ws_.positions[c[2]], box);
        ws_.boxes.set(h_.slot[t], box);
        grow_triangle_hierarchy(h_, h_.slot[t], box, ws_.node_boxes.data());
        if (ws_.moved[c[0]] || ws_.moved[c[1]] || ws_.moved[c[2]]) {
          ws_.tested[t] = 1;
          ws_.wanted[h_.slot[t]] = 1;
          ws_.test_list.push_back(t);
        }
      }
  }

  // Every position and box, slot by slot, and the triangles with a moved corner (guard_seed.h).
  // False when a position is not finite.
  bool seed_all() {
    const SeedOutput out{ws_.positions.data(), ws_.moved.data(),  &ws_.boxes,
                         ws_.tested.data(),    ws_.wanted.data(), &ws_.test_list};
    if (!seed_positions(mesh_.vertex_count, d_.vertex_count,
                        {rep_, lbs_.positions, skelform_.positions, d_.skelform_weight.data(), ws_.factor.data()}, out))
      return false;
    seed_boxes(mesh_.vertex_count, ws_.moved.size(), h_, out);
    return true;
  }

  // Round `round`'s search over ws.test_list: flags the corners of every pair LBS lacks (of its
  // triangle further off LBS: flag_pair)
  // (ws.flagged_list) and sets `added`. Round one (0) meets the hierarchy against itself on
  // the boxes at x; later rounds query it with the boxes lower() changed, in node boxes it
  // grew around them. False when the budget ran out.
  bool search(uint32_t round, bool& added) {
    added = false;
    if (round == 0) {
      ws_.clearance_maps.next();
      return self_pairs_triangle_hierarchy(
          h_, ws_.node_boxes.data(), ws_.boxes, ws_.wanted.data(), ws_.node_flags.data(), ws_.leaf_flags.data(),
          [&](uint32_t t, uint32_t s) {
            if (!spend()) return false;
            check_exact(t, s, added);
            return true;
          },
          [&](uint32_t a, uint32_t b) {
            const bool apart = clearance_ && leaves_apart(mesh_.clearance, pose_, ws_.clearance_maps, a, b);
            ws_.leaves_apart += apart;
            return apart;
          });
    }
    for (uint32_t t : ws_.test_list) {
      float bt[6];
      ws_.boxes.get(h_.slot[t], bt);
      const bool complete = query_triangle_hierarchy(h_, ws_.node_boxes.data(), ws_.boxes, bt, [&](uint32_t s) {
        // Each pair once: two triangles of this round's list meet when the larger queries.
        if (s == t || (ws_.tested[s] && s > t)) return true;
        if (triangles_share_corner(tri_ + 3 * size_t(t), tri_ + 3 * size_t(s)))
          return true;  // as the first round's kernel
        if (!spend()) return false;
        check_exact(t, s, added);
        return true;
      });
      if (!complete) return false;
    }
    return true;
  }

  void stop_recording() { record_ = false; }

  // Keep the first round's intersecting pairs (check_exact) in ws.pair_keys.
  void record_pairs() {
    record_ = true;
    ws_.pair_keys.clear();
    ws_.pair_added.clear();
    ws_.pairs_complete = true;
  }

  // The first round again after K moved at the welded vertices `moved` (a FirstRoundHook):
  // the recorded pairs none of whose corners moved keep their verdicts, and the triangles
  // around the moved vertices query the hierarchy, its node boxes grown around their new
  // boxes. Replaces the first search's flags. False when the budget ran out.
  // It has its own allowance of the work budget (the first search's spent), so that the pass
  // does not push an evaluation over the budget that a guard afresh would stay within.
  bool search_after_moves(const Array<uint32_t>& moved, bool& added) {
    record_ = false;
    ws_.budget = PairBudget(mesh_.triangle_count);
    for (uint32_t v : ws_.flagged_list) ws_.flagged[v] = 0;
    ws_.flagged_list.clear();
    added = false;
    for (uint32_t v : moved) ws_.changed[v] = 1;
    for (size_t i = 0; i < ws_.pair_keys.size(); ++i) {
      if (!ws_.pair_added[i]) continue;
      const uint32_t* ct = tri_ + 3 * size_t(ws_.pair_keys[i] >> 32);
      const uint32_t* cs = tri_ + 3 * size_t(uint32_t(ws_.pair_keys[i]));
      if (ws_.changed[ct[0]] || ws_.changed[ct[1]] || ws_.changed[ct[2]] || ws_.changed[cs[0]] || ws_.changed[cs[1]] ||
          ws_.changed[cs[2]])
        continue;
      flag_pair(ct, cs);
      added = true;
    }
    for (uint32_t v : moved) {
      ws_.changed[v] = 0;
      ws_.positions[v] = blended_position(d_, mesh_, skelform_, lbs_, ws_, v);
      ws_.moved[v] = ws_.positions[v] != lbs_.positions[rep_[v]];
    }
    for (uint32_t v : moved) list_around(v);
    bool around = false;
    const bool complete = search(1, around);
    added |= around;
    return complete;
  }

  // Halves λ at the flagged moved corners (0 after kGuardHalvings rounds), moves them, and
  // lists the triangles around them for the next round.
  void lower(uint32_t round) {
    for (uint32_t v : ws_.flagged_list) {
      ws_.flagged[v] = 0;
      ws_.changed[v] = ws_.moved[v];
      if (!ws_.moved[v]) continue;
      if (ws_.factor[v] == 1.0f) ws_.corrected_list.push_back(v);  // capacity for every vertex
      ws_.factor[v] = round + 1 >= kGuardHalvings ? 0.0f : 0.5f * ws_.factor[v];
      ws_.positions[v] = blended_position(d_, mesh_, skelform_, lbs_, ws_, v);
      ws_.moved[v] = ws_.positions[v] != lbs_.positions[rep_[v]];
    }
    for (uint32_t v : ws_.flagged_list) {
      if (!ws_.changed[v]) continue;
      ws_.changed[v] = 0;
      list_around(v);
    }
  }

 private:
  bool spend() { return ws_.budget.spend(); }

  // Lists the triangles around welded vertex v (not listed yet) for the next search, with their
  // boxes at x and the node boxes grown around them.
  void list_around(uint32_t v) {
    for (uint32_t k = mesh_.incident_offsets[v]; k < mesh_.incident_offsets[v + 1]; ++k) {
      const uint32_t t = mesh_.incident[k];
      if (ws_.tested[t]) continue;
      ws_.tested[t] = 1;
      ws_.test_list.push_back(t);
      const uint32_t* c = tri_ + 3 * size_t(t);
      float box[6];
      triangle_box(ws_.positions[c[0]], ws_.positions[c[1]], ws_.positions[c[2]], box);
      ws_.boxes.set(h_.slot[t], box);
      grow_triangle_hierarchy(h_, h_.slot[t], box, ws_.node_boxes.data());
    }
  }

  // A pair of triangles whose boxes meet now and that share no corner: intersecting at x and
  // not at L? Then it is flagged.
  void check_exact(uint32_t t, uint32_t s, bool& added) {
    const uint32_t* ct = tri_ + 3 * size_t(t);
    const uint32_t* cs = tri_ + 3 * size_t(s);
    const glm::vec3* x = ws_.positions.data();
    // (Most pairs a plane separates by far more than rounding: the exact test's verdict too.)
    if (triangles_surely_apart(x[ct[0]], x[ct[1]], x[ct[2]], x[cs[0]], x[cs[1]], x[cs[2]]) ||
        !intersect_(widen(x[ct[0]]), widen(x[ct[1]]), widen(x[ct[2]]), widen(x[cs[0]]), widen(x[cs[1]]),
                    widen(x[cs[2]])))
      return;
    // The model has this pair as made: neither the guard nor the contact pass acts on it.
    const uint64_t key = pair_key(t, s);
    if (mesh_.intersects_at_rest(key)) return;
    const glm::vec3* l = lbs_.positions;
    const bool lbs_has = intersect_(widen(l[rep_[ct[0]]]), widen(l[rep_[ct[1]]]), widen(l[rep_[ct[2]]]),
                                    widen(l[rep_[cs[0]]]), widen(l[rep_[cs[1]]]), widen(l[rep_[cs[2]]]));
    if (record_) {
      if (ws_.pair_keys.size() < ws_.pair_keys.capacity() && ws_.pair_added.size() < ws_.pair_added.capacity()) {
        ws_.pair_keys.push_back(key);  // no allocation
        ws_.pair_added.push_back(lbs_has ? 0 : 1);
      } else {
        ws_.pairs_complete = false;
      }
    }
    if (lbs_has) return;  // LBS has this pair too
    flag_pair(ct, cs);
    added = true;
  }

  // Flags the corners of the triangle of a pair that is further off LBS (the summed distance of
  // its corners from L): the one that moved into the other, most likely, and whose share the
  // guard takes back first. The other keeps its share; if the pair is still there in the next
  // round, it is flagged again, and once the first is at LBS (0 off it), the other is the one.
  // Lowering both gave back more of the correction than the pair needed: over the corpus,
  // 17,171 pairs added against 16,858 (docs/tuning.md).
  void flag_pair(const uint32_t* ct, const uint32_t* cs) {
    auto off_lbs = [&](const uint32_t* c) {
      float m = 0.0f;
      for (int k = 0; k < 3; ++k) m += glm::length(ws_.positions[c[k]] - lbs_.positions[rep_[c[k]]]);
      return m;
    };
    const uint32_t* c = off_lbs(ct) >= off_lbs(cs) ? ct : cs;
    for (uint32_t v : {c[0], c[1], c[2]})
      if (!ws_.flagged[v]) {
        ws_.flagged[v] = 1;
        ws_.flagged_list.push_back(v);  // capacity for every vertex: no allocation
      }
  }

  const Deformable& d_;
  const ContactMesh& mesh_;
  const DenseOutput& skelform_;
  const DenseOutput& lbs_;
  GuardWorkspace& ws_;
  const uint32_t* tri_;
  const uint32_t* rep_;
  const TriangleHierarchy& h_;
  const ExactTriangleTest intersect_;  // geometry::triangles_intersect, in its fastest form here
  const ClearancePose pose_;           // the leaves' rest bound (rest_clearance.h)
  const bool clearance_;               // the first round uses it
  bool record_ = false;
};

// LBS everywhere, this evaluation: every λ 0 and none corrected (so no ramp lifts one).
void fall_back_to_lbs(GuardWorkspace& ws) {
  std::fill(ws.factor.begin(), ws.factor.end(), 0.0f);
  ws.corrected_list.clear();
}

// The intersection guard from the current factors (ws.factor): halves λ at the moved corners of
// every pair LBS does not have, until none is left. Round one tests every triangle with a
// moved corner; each later round only the triangles around the vertices the previous round
// changed (a pair none of whose corners changed keeps its verdict). Over the work budget
// (pair_visit_budget), LBS everywhere: every λ 0 and ws.over_budget.
//
// `only` (welded vertices, or null): the positions and boxes of the previous call are known
// to add no pair, and only the vertices listed have moved since (towards L), so the first
// round recomputes and tests only the triangles around those, and grows the previous call's
// node boxes around them instead of refitting the hierarchy.
//
// `hook` (or null; only without `only`) runs after the first search (FirstRoundHook).
void guard_intersections(const Deformable& d, const ContactMesh& mesh, const DenseOutput& skelform,
                         const DenseOutput& lbs, GuardWorkspace& ws, const JointAffine* joints,
                         const Array<uint32_t>* only = nullptr, FirstRoundHook* hook = nullptr) {
  GuardPass pass(d, mesh, skelform, lbs, ws, joints);
  if (hook) pass.record_pairs();
  ws.test_list.clear();
  if (only) {
    pass.seed_incremental(*only);
  } else if (!pass.seed_all()) {
    fall_back_to_lbs(ws);  // a non-finite position
    return;
  }
  if (ws.test_list.empty()) return;
  // Node boxes that hold every triangle's box: refitted to the new pose, or, after `only`,
  // those of the previous call (which its rounds grew) grown around the triangles re-boxed
  // (seed_incremental). Looser boxes than a refit's visit more node pairs, but the leaf pairs
  // test the triangles' own boxes: the same pairs, and the same verdicts.
  if (!only) refit_triangle_hierarchy(mesh.hierarchy, ws.boxes, ws.node_boxes.data());
  for (uint32_t round = 0; !ws.test_list.empty(); ++round) {
    ws.flagged_list.clear();
    bool added = false;
    bool complete = pass.search(round, added);
    pass.stop_recording();
    // The flags back to 0: by the list, or as two fills where it holds a good part of the mesh
    // (the first round lists every triangle with a moved corner: most of a character).
    if (ws.test_list.size() > mesh.triangle_count / 8) {
      std::fill(ws.tested.begin(), ws.tested.end(), uint8_t{0});
      std::fill(ws.wanted.begin(), ws.wanted.end(), uint8_t{0});
    } else {
      for (uint32_t t : ws.test_list) ws.tested[t] = 0, ws.wanted[mesh.hierarchy.slot[t]] = 0;
    }
    ws.test_list.clear();
    if (complete && round == 0 && hook && ws.pairs_complete && !ws.pair_keys.empty()) {
      const Array<uint32_t>& moved = hook->after_first_search(
          {ws.pair_keys.data(), ws.pair_keys.size(), &mesh.hierarchy, ws.node_boxes.data(), &ws.boxes});
      if (!moved.empty()) {
        complete = pass.search_after_moves(moved, added);
        for (uint32_t t : ws.test_list) ws.tested[t] = 0;
        ws.test_list.clear();
      }
    }
    if (!complete) {
      for (uint32_t v : ws.flagged_list) ws.flagged[v] = 0;
      fall_back_to_lbs(ws);
      ws.over_budget = true;
      return;
    }
    if (!added) return;
    ++ws.rounds;
    pass.lower(round);
  }
}

// Lowers every λ to at most half-way between 1 and its neighbours' smallest, kGuardRampRings
// times: a ramp from each corrected vertex back to full skelform. Each ring reads the factors
// of the ring before. Only a vertex next to one below 1 can change: the rings visit the
// neighbourhoods of ws.corrected_list, which they extend. Lists the lowered vertices in
// ws.lowered_list; false when there are none.
bool ramp_factors(const ContactMesh& mesh, GuardWorkspace& ws) {
  ws.lowered_list.clear();
  Array<uint32_t>& candidates = ws.flagged_list;  // free between guard rounds
  for (uint32_t ring = 0; ring < kGuardRampRings; ++ring) {
    candidates.clear();
    for (uint32_t u : ws.corrected_list)
      for (uint32_t k = mesh.incident_offsets[u]; k < mesh.incident_offsets[u + 1]; ++k)
        for (int j = 0; j < 3; ++j) {
          const uint32_t v = mesh.triangles[3 * size_t(mesh.incident[k]) + size_t(j)];
          if (ws.flagged[v]) continue;
          ws.flagged[v] = 1;
          candidates.push_back(v);
        }
    for (uint32_t v : candidates) {
      float lowest = 1.0f;
      for (uint32_t k = mesh.incident_offsets[v]; k < mesh.incident_offsets[v + 1]; ++k) {
        const uint32_t* c = mesh.triangles.data() + 3 * size_t(mesh.incident[k]);
        lowest = std::min({lowest, ws.factor[c[0]], ws.factor[c[1]], ws.factor[c[2]]});
      }
      ws.ramp[v] = std::min(ws.factor[v], 0.5f * (1.0f + lowest));
    }
    bool changed = false;
    for (uint32_t v : candidates) {
      ws.flagged[v] = 0;
      if (!(ws.ramp[v] < ws.factor[v])) continue;
      if (ws.factor[v] == 1.0f) ws.corrected_list.push_back(v);
      ws.factor[v] = ws.ramp[v];
      if (!ws.lowered[v]) {
        ws.lowered[v] = 1;
        ws.lowered_list.push_back(v);
      }
      changed = true;
    }
    candidates.clear();
    if (!changed) break;
  }
  for (uint32_t v : ws.lowered_list) ws.lowered[v] = 0;
  return !ws.lowered_list.empty();
}

// The volume bounded by p(m) = base[w] + m·delta[w] over the welded mesh, as the cubic
// V(m) = v[0] + v[1]m + v[2]m² + v[3]m³ (each triangle's det(a + mα, b + mβ, c + mγ) expanded), in
// double. `base` should be about a point near the mesh: a closed mesh's volume does not depend
// on the origin, and a near one keeps the products small. The callers fill base and delta per
// welded vertex first (GuardWorkspace::volume_base, volume_delta): the triangles then read
// them in place, each vertex converted and scaled once rather than at each of its triangles.
void volume_cubic(const ContactMesh& mesh, const glm::dvec3* base, const glm::dvec3* delta, double v[4]) {
  volume_cubic_sums(mesh.triangles.data(), mesh.triangle_count, base, delta, v);
  v[0] /= 6.0, v[1] /= 6.0, v[2] /= 6.0, v[3] /= 6.0;
}

// Whether the volume at m = 1 (base + delta) is surely no further from `target` than at m = 0
// (base), in two determinants per triangle where the cubic takes eight (volume_sums.h). With
// S the sum over the triangles of the product of their corners' L1 norms: each sum here, V(1)
// and V(0), and the cubic's V(1) = v[0] + v[1] + v[2] + v[3] and v[0] adds T determinants, each
// within a few units of double rounding of its triangle's product, and any order of adding T
// terms is within (T − 1)·2^-53 of their absolute sum. So this V(1) differs from the cubic's by
// e₁ ≤ 4(T + 32)·2^-52·S and this V(0) from v[0] by e₀ below the same (both now sum in
// triangle order, so e₀ = 0; the bound does not count on it): if |V(1) − target| + e₀ + e₁ ≤
// |V(0) − target|, the cubic's |V(1) − target| ≤ |v[0] − target| too, and its test
// (volume_share) says yes. Elsewhere the caller expands the cubic and decides as before.
// `norm` per welded vertex: |base|₁ + |delta|₁.
bool volume_within(const ContactMesh& mesh, const glm::dvec3* base, const glm::dvec3* delta, const double* norm,
                   double target) {
  const VolumeSums sums = volume_sums(mesh.triangles.data(), mesh.triangle_count, base, delta, norm);
  const double rounding = 8.0 * (double(mesh.triangle_count) + 32.0) * std::ldexp(1.0, -52) * sums.scale;
  return std::fabs(sums.at_one / 6.0 - target) + rounding <= std::fabs(sums.at_zero / 6.0 - target);
}

// The volume bounded by x(μ) = L + μ·c at the representatives, c the guarded correction, as a
// cubic in μ (volume_cubic), about the centre of L's bounds. With `within_target`: false, and
// no cubic, when x = L + c is already no further from it than L (volume_within), which most
// evaluations are.
bool volume_polynomial(const Deformable& d, const ContactMesh& mesh, const DenseOutput& skelform,
                       const DenseOutput& lbs, GuardWorkspace& ws, double v[4], const double* within_target = nullptr) {
  // L's bounds in float: min and max of floats widen to those of the widened floats.
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (uint32_t w = 0; w < mesh.vertex_count; ++w) {
    const glm::vec3 p = lbs.positions[mesh.representative[w]];
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const glm::dvec3 centre = 0.5 * (glm::dvec3(lo) + glm::dvec3(hi));
  // (Only volume_within reads the norms.)
  volume_points(mesh.vertex_count, mesh.representative.data(), lbs.positions, skelform.positions,
                d.skelform_weight.data(), ws.factor.data(), centre, ws.volume_base.data(), ws.volume_delta.data(),
                within_target ? ws.volume_norm.data() : nullptr);
  if (within_target &&
      volume_within(mesh, ws.volume_base.data(), ws.volume_delta.data(), ws.volume_norm.data(), *within_target))
    return false;
  volume_cubic(mesh, ws.volume_base.data(), ws.volume_delta.data(), v);
  return true;
}

// Bisection between `inside`, where within(m) holds, and `outside`, where it does not: `steps`
// halvings of the interval; the last point found within.
template <class Within>
double bisect(double inside, double outside, int steps, const Within& within) {
  for (int i = 0; i < steps; ++i) {
    const double m = 0.5 * (inside + outside);
    (within(m) ? inside : outside) = m;
  }
  return inside;
}

// The volume offset aims just inside LBS's error, so that the float output it writes is not
// found a rounding outside it.
constexpr double kVolumeAim = 0.99;

// Volume first by moving the corrected surface along its normals, not by taking the correction
// back: where the guarded result x (whose volume_polynomial is `v`) is further from the target
// volume than LBS is, each welded vertex moves by δ·s·n (s its share w·λ of skelform's
// correction, n its unit volume gradient: the area-weighted normal; junction anchors stay) with
// the smallest δ ≤ `limit` that brings the error within kVolumeAim of LBS's (the best of the
// tried δ when none does). Written into skelform's result K, so that the output's blend moves
// by it and a later λ scales it with the rest of the correction. Returns whether it moved
// anything.
bool offset_for_volume(const Deformable& d, const ContactMesh& mesh, const DenseOutput& skelform,
                       const DenseOutput& lbs, GuardWorkspace& ws, double target, double limit, const double v[4]) {
  const double lbs_error = std::fabs(v[0] - target);
  const double error = std::fabs(v[0] + v[1] + v[2] + v[3] - target);
  if (!(error > lbs_error) || !(limit > 0.0)) return false;
  const double aim = lbs_error * kVolumeAim;
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (uint32_t w = 0; w < mesh.vertex_count; ++w) {
    ws.positions[w] = blended_position(d, mesh, skelform, lbs, ws, w);
    lo = glm::min(lo, glm::dvec3(ws.positions[w]));
    hi = glm::max(hi, glm::dvec3(ws.positions[w]));
    ws.gradient[w] = glm::vec3(0.0f);
  }
  const glm::dvec3 centre = 0.5 * (lo + hi);
  const glm::vec3 c(centre);
  for (uint32_t t = 0; t < mesh.triangle_count; ++t) {
    const uint32_t* q = mesh.triangles.data() + 3 * size_t(t);
    const glm::vec3 a = ws.positions[q[0]] - c, b = ws.positions[q[1]] - c, e = ws.positions[q[2]] - c;
    ws.gradient[q[0]] += glm::cross(b, e);
    ws.gradient[q[1]] += glm::cross(e, a);
    ws.gradient[q[2]] += glm::cross(a, b);
  }
  const double sign = v[0] + v[1] + v[2] + v[3] < target ? 1.0 : -1.0;
  for (uint32_t w = 0; w < mesh.vertex_count; ++w) {
    const float length = glm::length(ws.gradient[w]);
    // (A subnormal length would make 1/length infinite.)
    ws.gradient[w] = length >= std::numeric_limits<float>::min() && std::isfinite(length)
                         ? (float(sign) / length) * ws.gradient[w]
                         : glm::vec3(0.0f);
  }
  // Junction anchors stay on their hosts (anchor_junctions): moved, they would slide the
  // crossing the model has at rest over new triangles.
  for (uint32_t i : d.anchor_vertices) ws.gradient[mesh.weld[i]] = glm::vec3(0.0f);
  for (uint32_t w = 0; w < mesh.vertex_count; ++w) {
    const float share = d.skelform_weight[mesh.representative[w]] * ws.factor[w];
    ws.volume_base[w] = glm::dvec3(ws.positions[w]) - centre;
    ws.volume_delta[w] = double(share) * glm::dvec3(ws.gradient[w]);
  }
  double u[4];
  volume_cubic(mesh, ws.volume_base.data(), ws.volume_delta.data(), u);
  // The error on the side it starts from (negative past the target): the first δ where it is
  // at most the aim is never beyond the target's window.
  const double side = u[0] < target ? -1.0 : 1.0;
  auto error_at = [&](double m) { return side * (u[0] + m * (u[1] + m * (u[2] + m * u[3])) - target); };
  if (!(error_at(0.0) > aim)) return false;  // within already, as the float x rounds
  // The first δ in (0, limit] within LBS's error: the first of δ = limit·2^(k−40), k = 0…40, that
  // is, then bisection from the one before; else the best of them.
  constexpr int kSteps = 40;
  double chosen = 0.0, best = error_at(0.0), before = 0.0;
  for (int k = 0; k <= kSteps; ++k) {
    const double m = std::ldexp(limit, k - kSteps);
    const double e = error_at(m);
    if (e <= aim) {
      chosen = bisect(m, before, 40, [&](double x) { return error_at(x) <= aim; });
      break;
    }
    if (e < best) {
      best = e;
      chosen = m;
    }
    before = m;
  }
  if (!(chosen > 0.0)) return false;
  // K moves by δ·n at each copy, so that x = L + w·λ·(K − L) moves by δ·w·λ·n.
  for (uint32_t i = 0; i < d.vertex_count; ++i) skelform.positions[i] += float(chosen) * ws.gradient[mesh.weld[i]];
  return true;
}

// The largest μ in [0, 1] whose volume error |V(μ) − target| does not exceed LBS's |V(0) −
// target|: 1 when the whole correction qualifies, else the last crossing found by sampling and
// bisection.
double volume_share(const double v[4], double target) {
  auto error = [&](double m) { return std::fabs(v[0] + m * (v[1] + m * (v[2] + m * v[3])) - target); };
  const double limit = error(0.0);
  if (error(1.0) <= limit) return 1.0;
  constexpr int kSamples = 32;
  double inside = 0.0;  // the largest sample within the limit
  for (int i = 1; i < kSamples; ++i) {
    const double m = double(i) / kSamples;
    if (error(m) <= limit) inside = m;
  }
  return bisect(inside, inside + 1.0 / kSamples, 30, [&](double m) { return error(m) <= limit; });
}

}  // namespace

void anchor_junctions(const Deformable& d, const JointAffine* joints, const glm::vec3* lbs, glm::vec3* skelform) {
  for (size_t k = 0; k < d.anchor_vertices.size(); ++k) {
    const uint32_t i = d.anchor_vertices[k], h = d.anchor_hosts[k];
    float m[12];  // the host's LBS matrix (its weights sum to 1: asset_skin.cpp)
    blend_affine(joints, d.dense_joints.data() + size_t{h} * d.influences,
                 d.dense_weights.data() + size_t{h} * d.influences, d.influences, m);
    const glm::vec3 anchored = transform_point(m, d.rest_positions[i]);
    // The contact pass's write-back (contact.h): w ≥ kContactMinWeight here (derive_junction_anchors).
    skelform[i] = lbs[i] + (anchored - lbs[i]) / d.skelform_weight[i];
  }
}

void guard_and_blend(const Deformable& d, const ContactMesh& mesh, float scale, const DenseOutput& skelform,
                     const DenseOutput& lbs, bool with_normals, const DenseOutput& out, GuardWorkspace& ws,
                     FirstRoundHook* hook, const JointAffine* joints) {
  const float* weight = d.skelform_weight.data();
  std::fill(ws.factor.begin(), ws.factor.end(), 1.0f);
  ws.corrected_list.clear();
  ws.rounds = 0;
  ws.leaves_apart = 0;
  ws.volume_share = 1.0f;
  ws.budget = PairBudget(mesh.triangle_count);
  ws.over_budget = false;
  const bool welded = mesh.weld.size() == d.vertex_count && mesh.triangle_count >= 2;
  if (welded) {
    guard_intersections(d, mesh, skelform, lbs, ws, joints, nullptr, hook);
    // A smooth fallback: around every vertex the guard pulled towards LBS, the factor may rise
    // by at most half of what is left per ring, over kGuardRampRings rings; the lowered factors
    // are then checked again (a vertex between K and L is not safe by itself).
    // Only the triangles around a lowered vertex can have a new pair: the rest is as checked.
    // Over the budget, every λ is 0 already (LBS): nothing is left to ramp or to scale.
    if (!ws.over_budget && ramp_factors(mesh, ws))
      guard_intersections(d, mesh, skelform, lbs, ws, joints, &ws.lowered_list);
    // Volume: a closed mesh keeps its rest volume, scaled by the pose's reference scale cubed,
    // no worse than LBS does. First by moving the corrected surface along its normals
    // (offset_for_volume, at most the contact pass's largest move), whose new pairs the guard
    // then takes back; where that is not enough, μ scales the whole guarded correction.
    if (!ws.over_budget && mesh.closed && std::isfinite(mesh.rest_volume) && mesh.rest_volume != 0.0) {
      const double target = mesh.rest_volume * double(scale) * double(scale) * double(scale);
      for (uint32_t attempt = 0; attempt < kVolumeAttempts; ++attempt) {
        double v[4];
        // (The first try asks first whether the whole correction is within: most are.)
        if (!volume_polynomial(d, mesh, skelform, lbs, ws, v, attempt == 0 ? &target : nullptr)) break;
        double share = volume_share(v, target);
        if (share >= 1.0) break;
        if (offset_for_volume(d, mesh, skelform, lbs, ws, target, double(mesh.cap) * double(scale), v)) {
          guard_intersections(d, mesh, skelform, lbs, ws, joints);
          if (ws.over_budget) break;
          volume_polynomial(d, mesh, skelform, lbs, ws, v);
          share = volume_share(v, target);
          if (share >= 1.0) break;
        }
        if (attempt + 1 == kVolumeAttempts) share = 0.0;
        for (float& f : ws.factor) f *= float(share);
        ws.volume_share *= float(share);
        // The scaled correction is checked again: its pairs must still be LBS's.
        guard_intersections(d, mesh, skelform, lbs, ws, joints);
        if (share == 0.0 || ws.over_budget) break;
      }
    }
  }

  ws.corrected = 0;
  for (uint32_t v = 0; v < mesh.vertex_count; ++v) ws.corrected += ws.factor[v] < 1.0f ? 1u : 0u;
  // The output, every dense vertex with its welded vertex's λ (guard_blend.h).
  const BlendInput in{weight, welded ? ws.factor.data() : nullptr, mesh.weld.data(), skelform, lbs};
  for (const PrimitiveRecord& primitive : d.primitives)
    blend_output(primitive.first_vertex, primitive.first_vertex + primitive.vertex_count, in, with_normals,
                 with_normals && primitive.has_tangents && out.tangents, out);
}

}  // namespace skelform::runtime
