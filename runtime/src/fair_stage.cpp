// Runtime step 3 (DESIGN.md "Fair"): the fairing flows on the reconstructed control mesh,
// incremental across evaluations.
//
// Warm start. The fairing's result differs from the reconstruction M by a correction c_v per
// control vertex. It is stored in the vertex's local frame of M (fair.h fairing_frames: the
// reconstruction direction and a one-ring edge), so that the next evaluation starts from
// M_next + frame_next · c: a character that translates or turns keeps its correction, and a
// pose that changes a little needs only a few iterations to follow. From rest (the first
// evaluation, a pose jump, SF_EVAL_FROM_REST) the correction is 0 and the flows converge: in
// that evaluation when the caller asked for it, else over it and the next ones (instance.h
// kFreshStartChunks).
#include "fair_shapes.h"
#include "instance.h"

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <cstring>
#include <limits>

namespace skelform::runtime {

FairingState::FairingState(const AllocatorRef& allocator)
    : workspace(allocator),
      frames(allocator),
      offset(allocator),
      start(allocator),
      shape(allocator),
      reference_umbrella(allocator),
      mean_edge(allocator),
      rest_change(allocator),
      fixed(allocator) {}

void FairingState::allocate(const Deformable& d, const AllocatorRef& allocator) {
  const uint32_t n = d.control_vertex_count;
  workspace = make_fairing_workspace(d.fairing_topology, kMaxIntersectionGrid, allocator);
  frames.resize(n);
  offset.assign(n, glm::vec3(0.0f));
  start.resize(n);
  shape.assign(n, glm::vec3(0.0f));
  reference_umbrella.assign(n, glm::vec3(0.0f));
  mean_edge.assign(n, 0.0f);
  rest_change.assign(n, 0.0f);
  fixed.assign(n, 0);
}

namespace {

// Pose jump: the local shape of M (each umbrella vector in its vertex's frame, in units of the
// vertex's mean edge length) changed by more than kPoseJumpShape at more than
// kPoseJumpFraction of the vertices since the last evaluation. Rigid motion leaves it
// unchanged; 30 fps animation changes it at a few thin spots (fast legs); a teleport into
// another pose, a new animation or a switch of driver changes it over whole limbs. Stores
// this evaluation's shapes, and how far each is from rest's (FairingState::rest_change; the
// rest umbrella is stored in the rest frame, as the shape is in this one); returns how many
// vertices changed by more than kPoseJumpShape.
uint32_t record_local_shapes(sf_instance& instance, const glm::mat3* frames) {
  const Deformable& d = *instance.deformable;
  FairingState& f = instance.fairing;
  const ShapeRecord record{d.fairing_topology.neighbour_offsets.data(),
                           frames,
                           f.reference_umbrella.data(),
                           f.mean_edge.data(),
                           d.fairing_rest.umbrella.data(),
                           f.shape.data(),
                           f.rest_change.data()};
  return record_shapes(record, d.control_vertex_count, kPoseJumpShape);
}

// The skin driver's vertices kept out of this evaluation's flows (FairingState::fixed): the
// rigid ones (Deformable::control_rigid), and the quiet ones, where M's local shape is within
// kQuietShape of rest's at the vertex and its one-ring and the correction it holds (`offset`:
// this evaluation warm-starts from it) is under kQuietCorrection, both in mean edges. Every
// term of the flows is relative to rest (fair.h FairingRest): the shape terms of flow (4) are
// then about zero. Flow (5), and flow (4)'s E_T term, also see the balls around the vertex,
// which another part of the body can bring near while the local shape stays as at rest; this
// test does not, and leaves such contact to the vertices the pose bends and to the contact
// pass and the guard after the fairing (over the corpus the pairs moved within their spread:
// docs/tuning.md).
// The fairing's work goes to the blend zones the pose bends. A quiet vertex keeps its small
// correction, in its frame, until it is bent again.
void mark_kept_vertices(sf_instance& instance, bool warm) {
  const Deformable& d = *instance.deformable;
  const FairingTopology& topo = d.fairing_topology;
  const FairingState& f = instance.fairing;
  for (uint32_t v = 0; v < d.control_vertex_count; ++v) {
    uint8_t kept = d.control_rigid[v];
    if (!kept) {
      // (Each value compared on its own: a NaN anywhere keeps the vertex in the flows.)
      bool quiet = f.rest_change[v] < kQuietShape;
      for (uint32_t k = topo.neighbour_offsets[v]; quiet && k < topo.neighbour_offsets[v + 1]; ++k)
        quiet = f.rest_change[topo.neighbours[k]] < kQuietShape;
      const float correction = warm ? glm::length(f.offset[v]) : 0.0f;
      kept = quiet && correction < kQuietCorrection * f.mean_edge[v] ? 1 : 0;
    }
    instance.fairing.fixed[v] = kept;
  }
}

// This evaluation's fairing parameters: the options' with their defaults filled in, the α and
// W smoothing acting on the correction (fair.h FairingParams::smoothing_reference), and the
// vertices the flows leave where the driver put them.
FairingParams stage_params(sf_instance& instance, const FairStageOptions& options, bool warm) {
  const Deformable& d = *instance.deformable;
  const size_t n = d.control_vertex_count;
  const glm::vec3* skeletal = instance.skeletal.data();
  FairingParams params = options.params;
  params.smoothing_reference = instance.fairing.start.data();
  params.smoothing_reference_umbrella = instance.fairing.reference_umbrella.data();
  // The handle driver's pinned region stays at rest (paper Fig. 1): a skeletal vertex that the
  // displacement field left exactly in place keeps its control vertex out of the fairing.
  if (instance.driver == Driver::handles) {
    for (size_t v = 0; v < n; ++v) instance.fairing.fixed[v] = skeletal[v] == d.skeletal_positions[v] ? 1 : 0;
    params.fixed = instance.fairing.fixed.data();
  } else if (!d.control_rigid.empty()) {
    // The skin driver: what one joint carries alone moves rigidly with it (lbs_guard.h), so
    // the flows leave it where the skin put it and bend the blend zones between; so they do
    // where the pose leaves the shape as at rest (mark_kept_vertices).
    mark_kept_vertices(instance, warm);
    params.fixed = instance.fairing.fixed.data();
  }
  if (params.iterations == 0) params.iterations = kDefaultFairingIterations;
  if (!(params.fold_step > 0.0f))
    params.fold_step = params.semi_implicit ? kDefaultFoldStepSemiImplicit : kDefaultFoldStepExplicit;
  if (!(params.intersection_step > 0.0f)) params.intersection_step = kDefaultIntersectionStep;
  return params;
}

}  // namespace

void fair_stage(sf_instance& instance, const FairStageOptions& options) {
  const Deformable& d = *instance.deformable;
  instance.fairing.last_iterations = 0;
  instance.fairing.last_residual = 0.0f;
  const bool enabled = d.fairing_supported && (options.params.fold_flow || options.params.intersection_flow);
  if (!enabled) {
    instance.fairing.has_offset = false;
    return;
  }
  const size_t n = d.control_vertex_count;
  glm::vec3* x = instance.control.data();
  const glm::vec3* skeletal = instance.skeletal.data();
  glm::mat3* frames = instance.fairing.frames.data();
  // The frames, and from the same pass U(M) (the smoothing reference's umbrellas, for fair_run)
  // and the mean edge lengths of M (the pose-jump test's unit).
  fairing_frames(d.fairing_topology, skeletal, x, frames, &d.fairing_rest, instance.fairing.reference_umbrella.data(),
                 instance.fairing.mean_edge.data());

  const FairingTopology& topo = d.fairing_topology;
  const uint32_t changed = record_local_shapes(instance, frames);
  // A switch of driver (handles ↔ skin) is a jump too.
  const bool jump = static_cast<float>(changed) > kPoseJumpFraction * static_cast<float>(n);
  const bool warm =
      !options.from_rest && instance.fairing.has_offset && !jump && instance.fairing.driver == instance.driver;
  instance.fairing.driver = instance.driver;
  // Annealing. f is a minimum over balls and α a threshold rule, so the flows' right-hand
  // sides jump where the minimiser or the rule switches, and fixed steps chatter there with an
  // amplitude proportional to the step (docs/tuning.md). A held pose (the same
  // reconstruction, bit for bit, as last time) therefore halves the steps at every evaluation,
  // so it comes to rest; any change of the input restores them, except during a spread
  // convergence, which anneals on its own schedule.
  const bool held = warm && std::memcmp(instance.fairing.start.data(), x, n * sizeof(glm::vec3)) == 0;
  // A convergence that an earlier evaluation began goes on from its annealed steps.
  const bool continuing = warm && instance.fairing.converging > 0;
  if (!continuing) instance.fairing.gain = held ? instance.fairing.gain * 0.5f : 1.0f;
  std::memcpy(instance.fairing.start.data(), x, n * sizeof(glm::vec3));
  if (warm)
    for (size_t v = 0; v < n; ++v) x[v] += frames[v] * instance.fairing.offset[v];

  const FairingParams params = stage_params(instance, options, warm);
  // A fresh start forgets the tracking schedule too: its result depends on this input only.
  if (!warm) {
    instance.fairing.workspace.search_phase = 0;
    std::fill(instance.fairing.workspace.hull_case.begin(), instance.fairing.workspace.hull_case.end(),
              kHullCaseUnknown);
    // (A free vertex that is not finite skips the search and would keep its old minimiser.)
    std::fill(instance.fairing.workspace.minimiser.begin(), instance.fairing.workspace.minimiser.end(),
              std::numeric_limits<uint32_t>::max());
  }
  // A fresh start's convergence is spread over evaluations, so that no frame pays for all of
  // it: kFreshStartChunks chunks now, then one chunk per evaluation (warm-started as usual)
  // until it is done; never fewer chunks than hold the evaluation's own budget of iterations. A
  // fresh start the caller asked for (SF_EVAL_FROM_REST) runs it whole.
  const bool converge = !warm || continuing;
  const uint32_t budget_chunks = (params.iterations + kConvergenceChunk - 1) / kConvergenceChunk;
  const uint32_t calls = options.requested ? UINT32_MAX : std::max(continuing ? 1u : kFreshStartChunks, budget_chunks);
  const FairingSchedule run = run_fairing_schedule(topo, skeletal, instance.radius, x, n, params, !converge,
                                                   instance.fairing.gain, instance.fairing.workspace, &d.fairing_rest,
                                                   frames, continuing ? instance.fairing.converging : 0, calls);
  instance.fairing.converging = converge && !run.finished ? run.converged_iterations : 0;
  instance.fairing.gain = run.gain;  // a held pose continues from the annealed steps
  instance.fairing.last_iterations = run.iterations;
  instance.fairing.last_residual = run.residual;

  // The correction, in the local frames, for the next evaluation's warm start.
  for (size_t v = 0; v < n; ++v)
    instance.fairing.offset[v] = glm::transpose(frames[v]) * (x[v] - instance.fairing.start[v]);
  instance.fairing.has_offset = true;
}

FairingSchedule run_fairing_schedule(const FairingTopology& topology, const glm::vec3* skeletal, const float* radius,
                                     glm::vec3* positions, size_t vertex_count, FairingParams params, bool warm,
                                     float gain, FairingWorkspace& workspace, const FairingRest* rest,
                                     const glm::mat3* frames, uint32_t done, uint32_t calls) {
  const uint32_t budget = params.iterations;
  const uint32_t limit = warm ? budget : std::max(budget, kConvergenceIterations);
  const float fold_step = params.fold_step, intersection_step = params.intersection_step;
  FairingSchedule run;
  uint32_t total = warm ? 0 : done;  // iterations of this convergence, with those done before
  run.finished = warm;
  for (uint32_t call = 0; call < calls; ++call) {
    if (total >= limit || !(gain > 1e-7f)) break;
    params.iterations = warm ? budget : std::min(kConvergenceChunk, limit - total);
    params.search_stride = warm ? kSearchStride : 1;  // a fresh start searches everywhere
    params.fold_step = fold_step * gain;
    params.intersection_step = intersection_step * gain;
    run.residual = fair_run(topology, skeletal, radius, positions, vertex_count, params, workspace, rest, frames);
    run.iterations += params.iterations;
    total += params.iterations;
    // (< 0: sizes that do not match the topology)
    if (run.residual < 0.0f || warm || run.residual < kConvergedResidual) {
      run.finished = true;
      break;
    }
    if (total >= kAnnealAfter) gain *= kAnnealRate;
  }
  run.finished = run.finished || total >= limit || !(gain > 1e-7f);
  run.converged_iterations = total;
  run.gain = gain;
  return run;
}

}  // namespace skelform::runtime
