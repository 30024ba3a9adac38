// Evaluation for the instance half of the C API (skelform.h "Evaluation"): the options'
// checks, the frame's stages in order (instance.h) into scratch buffers, and the refusal of a
// result that is not finite before it replaces the last output.
#include "api_instance.h"

#include <cstdint>
#include <cstring>

using namespace skelform::runtime;

namespace {

// Buffers of one dense result (positions, normals, tangents if any primitive has them).
struct DenseBuffers {
  Array<glm::vec3>* positions;
  Array<glm::vec3>* normals;
  Array<glm::vec4>* tangents;
  DenseOutput output() const {
    return {positions->data(), normals->data(), tangents->empty() ? nullptr : tangents->data()};
  }
};

DenseBuffers skelform_buffers(sf_instance& instance) {
  return {&instance.skelform_positions, &instance.skelform_normals, &instance.skelform_tangents};
}
DenseBuffers lbs_buffers(sf_instance& instance) {
  return {&instance.lbs_positions, &instance.lbs_normals, &instance.lbs_tangents};
}

// The contact pass inside the guard (lbs_guard.h FirstRoundHook): it takes the guard's first
// search as its detection, so that one exact search serves both.
class ContactHook final : public FirstRoundHook {
 public:
  ContactHook(const ContactMesh& mesh, float scale, glm::vec3* k, uint32_t vertex_count, ContactWorkspace& ws,
              const ContactBlend& blend)
      : mesh_(mesh), scale_(scale), k_(k), vertex_count_(vertex_count), ws_(ws), blend_(blend) {}
  const Array<uint32_t>& after_first_search(const ContactPairs& pairs) override {
    resolve_contacts(mesh_, scale_, k_, vertex_count_, ws_, blend_, &pairs);
    return ws_.moved;
  }

 private:
  const ContactMesh& mesh_;
  float scale_;
  glm::vec3* k_;
  uint32_t vertex_count_;
  ContactWorkspace& ws_;
  ContactBlend blend_;
};

// True when `count` floats are all finite. A test of the exponent bits, with no branch per
// value, that the compiler vectorises: a small fraction of the pass that wrote them.
bool floats_finite(const float* values, size_t count) {
  constexpr uint32_t kExponent = 0x7f800000u;  // all ones: inf or NaN
  uint32_t non_finite = 0;
  for (size_t i = 0; i < count; ++i) {
    uint32_t bits;
    std::memcpy(&bits, values + i, sizeof bits);
    non_finite |= static_cast<uint32_t>((bits & kExponent) == kExponent);
  }
  return non_finite == 0;
}

// Whether the dense result is finite where the evaluation wrote it: every position; with
// normals, every normal and the tangents of the primitives that have them.
bool output_finite(const Deformable& d, const DenseOutput& result, bool with_normals) {
  if (!floats_finite(&result.positions[0].x, 3 * size_t{d.vertex_count})) return false;
  if (!with_normals) return true;
  if (!floats_finite(&result.normals[0].x, 3 * size_t{d.vertex_count})) return false;
  if (!result.tangents) return true;
  for (const PrimitiveRecord& p : d.primitives)
    if (p.has_tangents && !floats_finite(&result.tangents[p.first_vertex].x, 4 * size_t{p.vertex_count})) return false;
  return true;
}

// The first vertex whose position or normal is not finite (for the message; the refusal path).
uint32_t first_non_finite_vertex(const Deformable& d, const DenseOutput& result, bool with_normals) {
  for (uint32_t v = 0; v < d.vertex_count; ++v)
    if (!floats_finite(&result.positions[v].x, 3) || (with_normals && !floats_finite(&result.normals[v].x, 3)))
      return v;
  return 0;  // a tangent
}

// Makes `result` the output sf_instance_write reads: the buffers trade places (pointers only,
// no allocation); `result` receives the previous output's, the next evaluation's scratch.
void commit_output(sf_instance& instance, const DenseBuffers& result) {
  instance.dense_positions.swap(*result.positions);
  instance.dense_normals.swap(*result.normals);
  instance.dense_tangents.swap(*result.tangents);
}

// The options' checks: SF_OK, or the refusal with its message.
sf_result check_options(sf_instance& instance, const sf_eval_options& options) {
  if (options.method > SF_METHOD_DQS)
    return fail(&instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_evaluate: unknown method %u", options.method);
  if (options.skeleton_skinning > SF_SKELETON_LBS)
    return fail(&instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_evaluate: unknown skeleton_skinning %u",
                options.skeleton_skinning);
  if (options.reconstruction > SF_RECONSTRUCTION_PAPER)
    return fail(&instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_evaluate: unknown reconstruction %u",
                options.reconstruction);
  if (options.homotopy_steps > kMaxHomotopySteps)
    return fail(&instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_evaluate: homotopy_steps %u exceeds %u",
                options.homotopy_steps, kMaxHomotopySteps);
  const uint32_t known_flags = SF_EVAL_FROM_REST | SF_EVAL_SKIP_NORMALS;
  if (options.flags & ~known_flags)
    return fail(&instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_evaluate: unknown flags 0x%x",
                options.flags & ~known_flags);
  const uint32_t known_fairing_flags = SF_FAIR_OFF | SF_FAIR_SEMI_IMPLICIT;
  if (options.fairing_flags & ~known_fairing_flags)
    return fail(&instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_evaluate: unknown fairing_flags 0x%x",
                options.fairing_flags & ~known_fairing_flags);
  if (!(options.fairing_step >= 0.0f && options.fairing_step <= 10.0f) ||
      !(options.intersection_step >= 0.0f && options.intersection_step <= 10.0f))
    return fail(&instance, SF_ERROR_INVALID_ARGUMENT,
                "sf_instance_evaluate: fairing_step and intersection_step must be in [0, 10] (0 = default)");
  if (options.intersection_grid > kMaxIntersectionGrid)
    return fail(&instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_evaluate: intersection_grid %u exceeds %u",
                options.intersection_grid, kMaxIntersectionGrid);
  if (options.fairing_iterations > kMaxFairingIterations)
    return fail(&instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_evaluate: fairing_iterations %u exceeds %u",
                options.fairing_iterations, kMaxFairingIterations);
  if (instance.driver == Driver::handles && !instance.handles.system)
    return fail(&instance, SF_ERROR_NOT_READY, "sf_instance_evaluate: the handle driver has no handle set");
  if (options.method != SF_METHOD_SKELFORM && instance.driver != Driver::skin)
    return fail(&instance, SF_ERROR_UNSUPPORTED,
                "sf_instance_evaluate: the LBS/DQS baselines deform by the skin, but the handle driver is selected");
  const Deformable& d = *instance.deformable;
  if (options.method != SF_METHOD_SKELFORM && (d.joint_count == 0 || d.influences == 0))
    return fail(&instance, SF_ERROR_UNSUPPORTED,
                "sf_instance_evaluate: the LBS/DQS baselines need a skinned deformable");
  return SF_OK;
}

// Stages 1 and 2: S → S' by the current driver, then S' → M, into instance.skeletal and
// instance.control (instance.radius: the radii the pose gives the skeletal vertices).
void drive_and_reconstruct(sf_instance& instance, const sf_eval_options& options) {
  const Deformable& d = *instance.deformable;
  const bool skin = instance.driver == Driver::skin;
  instance.radius = d.medial_radius.data();
  if (skin && options.skeleton_skinning == SF_SKELETON_ARCS) {
    pose_joint_arcs(d, instance.joints.skin_affine.data(), instance.arc_poses.data());
    drive_skeleton_arcs(d, instance.joints, instance.arc_poses.data(), instance.skeletal.data(),
                        instance.normal_matrices.data(), instance.arc_radius.data());
    instance.radius = instance.arc_radius.data();
  } else if (skin) {
    drive_skeleton_skin(d, instance.joints,
                        options.skeleton_skinning == SF_SKELETON_DQS ? Blend::dual_quaternion : Blend::linear,
                        instance.skeletal.data(), instance.normal_matrices.data());
  } else {
    drive_skeleton_handles(d, instance.handles, instance.skeletal.data());
  }
  // The skin is evaluated in its normalised space (instance.h JointTransforms): joints
  // scaled unlike the pose's reference scale thicken or thin what they drive.
  if (skin && !instance.joints.uniform) {
    scale_medial_radii(d, instance.joints, instance.radius, instance.scaled_radius.data());
    instance.radius = instance.scaled_radius.data();
  }
  // Carried normals: the skin's per-vertex transform turns the rest normals; the handle driver
  // has none and takes them from the surface its skeletal motion predicts.
  if (options.reconstruction == SF_RECONSTRUCTION_CARRIED && skin) {
    reconstruct_carried(d, instance.skeletal.data(), instance.normal_matrices.data(), instance.radius,
                        instance.control.data());
    return;
  }
  if (options.reconstruction == SF_RECONSTRUCTION_CARRIED) {
    reconstruct_predicted(d, instance.rest_normal_offset.data(), instance.skeletal.data(),
                          instance.step_normals_a.data(), instance.step_normals_b.data(), instance.control.data());
    return;
  }
  const uint32_t steps = options.homotopy_steps == 0 ? kDefaultHomotopySteps : options.homotopy_steps;
  const bool incremental = (options.flags & SF_EVAL_FROM_REST) == 0 && instance.has_previous;
  const glm::vec3* offset = instance.rest_normal_offset.data();
  if (incremental)
    // The homotopy continues from the previous reconstruction, before its fairing (the flows
    // post-process a reconstruction; they are not its state).
    reconstruct_homotopy(d, offset, instance.previous_skeletal.data(),
                         instance.fairing.has_offset ? instance.fairing.start.data() : instance.previous_control.data(),
                         nullptr, instance.skeletal.data(), instance.radius, steps, instance.step_normals_a.data(),
                         instance.step_normals_b.data(), instance.control.data());
  else
    reconstruct_homotopy(d, offset, d.skeletal_positions.data(), d.control_positions.data(), d.control_normals.data(),
                         instance.skeletal.data(), instance.radius, steps, instance.step_normals_a.data(),
                         instance.step_normals_b.data(), instance.control.data());
}

// SF_METHOD_SKELFORM, stages 1 to 6, into `result` (skelform_*); the coarse state S', M stays
// in instance.skeletal / instance.control until the evaluation is committed. `scale` receives
// the pose's reference scale the output was scaled back by.
void evaluate_skelform(sf_instance& instance, const sf_eval_options& options, bool with_normals,
                       const DenseOutput& result, float& scale) {
  const Deformable& d = *instance.deformable;
  if (!instance.joints.skin_prepared) prepare_skin_joints(d, instance.joints);
  drive_and_reconstruct(instance, options);
  // 3. Fairing (flows (4), (5)), warm-started from the previous evaluation.
  FairStageOptions fairing;
  fairing.params.fold_flow = (options.fairing_flags & SF_FAIR_NO_FOLD_FLOW) == 0;
  fairing.params.intersection_flow = (options.fairing_flags & SF_FAIR_NO_INTERSECTION_FLOW) == 0;
  fairing.params.semi_implicit = (options.fairing_flags & SF_FAIR_SEMI_IMPLICIT) != 0;
  fairing.params.iterations = options.fairing_iterations;
  fairing.params.fold_step = options.fairing_step;
  fairing.params.intersection_step = options.intersection_step;
  fairing.params.grid_size = options.intersection_grid;
  fairing.requested = (options.flags & SF_EVAL_FROM_REST) != 0;
  fairing.from_rest = fairing.requested || !instance.has_previous;
  fair_stage(instance, fairing);
  // 4. Refine and displace: skelform's own result.
  displace(d, instance.control.data(), instance.skeletal.data(), instance.control_normal_sums.data(),
           instance.refine_lanes.empty() ? nullptr : instance.refine_lanes.data(), instance.refined_positions.data(),
           instance.refined_normals.data(), with_normals, result);
  // Back from the normalised space to the caller's.
  const bool skin = instance.driver == Driver::skin;
  scale = skin ? instance.joints.scale : 1.0f;
  if (scale != 1.0f)
    for (uint32_t v = 0; v < d.vertex_count; ++v) result.positions[v] *= scale;
  // 5. The contact pass (contact.h), when the caller turned it on: on the output as the
  // skelform weight blends it with LBS, moving only what skelform may move, before the guard
  // checks it against LBS.
  const bool blended = skin && !instance.lbs_positions.empty();
  const DenseOutput lbs = lbs_buffers(instance).output();
  if (blended) dense_skinning(d, instance.joints, Blend::linear, with_normals, lbs);
  if (blended) anchor_junctions(d, instance.joints.affine.data(), lbs.positions, result.positions);
  // Blended, the pass runs inside the guard's first round and takes its search (ContactHook).
  if (instance.contacts_enabled && !blended)
    resolve_contacts(d.welded, scale, result.positions, d.vertex_count, instance.contact);
  // 6. LBS where LBS is exact, and never an intersection LBS does not have (lbs_guard.h),
  // blended in place.
  if (blended) {
    ContactHook contacts(d.welded, scale, result.positions, d.vertex_count, instance.contact,
                         {lbs.positions, d.skelform_weight.data()});
    guard_and_blend(d, d.welded, scale, result, lbs, with_normals, result, instance.guard,
                    instance.contacts_enabled ? &contacts : nullptr, instance.joints.affine.data());
  }
}

sf_result evaluate(sf_instance& instance, const sf_eval_options& options) {
  const sf_result checked = check_options(instance, options);
  if (checked != SF_OK) return checked;
  const Deformable& d = *instance.deformable;
  const bool with_normals = (options.flags & SF_EVAL_SKIP_NORMALS) == 0;
  const bool skelform = options.method == SF_METHOD_SKELFORM;
  const DenseBuffers buffers = skelform ? skelform_buffers(instance) : lbs_buffers(instance);
  const DenseOutput result = buffers.output();
  const uint32_t fairing_iterations = instance.fairing.last_iterations;
  const float fairing_residual = instance.fairing.last_residual;
  float scale = 1.0f;
  bool finite;
  if (skelform) {
    evaluate_skelform(instance, options, with_normals, result, scale);
    finite = output_finite(d, result, with_normals);
  } else {
    // The kernels check their positions as they go; their normals and tangents are finite.
    finite =
        dense_skinning(d, instance.joints, options.method == SF_METHOD_LBS ? Blend::linear : Blend::dual_quaternion,
                       with_normals, result);
  }

  // Output that would not be finite is refused before it replaces the last output. The
  // refused pose's fairing correction is no warm start for the next evaluation.
  if (!finite) {
    instance.fairing.has_offset = false;
    instance.fairing.last_iterations = fairing_iterations;
    instance.fairing.last_residual = fairing_residual;
    return fail(&instance, SF_ERROR_INVALID_ARGUMENT,
                "sf_instance_evaluate: the output would not be finite (vertex %u): the joint matrices or handle "
                "targets are out of range for this asset; the last output is kept",
                first_non_finite_vertex(d, result, with_normals));
  }
  commit_output(instance, buffers);
  if (skelform) {
    // This evaluation's S' and M are the next incremental evaluation's start. Swapping
    // vectors of one allocator moves pointers only: no allocation.
    instance.previous_skeletal.swap(instance.skeletal);
    instance.previous_control.swap(instance.control);
    instance.output_scale = scale;
    instance.has_previous = true;
  }
  instance.evaluated = true;
  instance.normals_valid = with_normals;
  return SF_OK;
}

}  // namespace

extern "C" {

sf_result sf_instance_evaluate(sf_instance* instance, const sf_eval_options* options) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  return guarded(instance, "sf_instance_evaluate", [&]() -> sf_result {
    const sf_eval_options defaults{};
    return evaluate(*instance, options ? *options : defaults);
  });
}

sf_result sf_instance_fairing_stats(const sf_instance* instance, uint32_t* iterations, float* residual) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  if (iterations) *iterations = instance->fairing.last_iterations;
  if (residual) *residual = instance->fairing.last_residual;
  return SF_OK;
}

}  // extern "C"
