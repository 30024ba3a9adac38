// The instance half of the C API (skelform.h "Instances", "Evaluation"): argument checks,
// driver selection, the frame's stages in order (instance.h), and the strided copy into the
// caller's vertex buffers. Nothing throws past this file: every entry point catches at the
// boundary and turns the exception into an sf_result plus the instance's message.
#include "handles.h"
#include "instance.h"

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <new>
#include <stdexcept>
#include <utility>

using namespace skelform::runtime;

sf_instance::sf_instance(const sf_asset& owner, const Deformable& d)
    : asset(&owner),
      deformable(&d),
      allocator(owner.allocator),
      joints(owner.allocator),
      handles(owner.allocator),
      skeletal(CallbackAllocator<glm::vec3>(owner.allocator)),
      normal_matrices(CallbackAllocator<glm::mat3>(owner.allocator)),
      control(CallbackAllocator<glm::vec3>(owner.allocator)),
      previous_skeletal(CallbackAllocator<glm::vec3>(owner.allocator)),
      previous_control(CallbackAllocator<glm::vec3>(owner.allocator)),
      step_normals_a(CallbackAllocator<glm::vec3>(owner.allocator)),
      step_normals_b(CallbackAllocator<glm::vec3>(owner.allocator)),
      rest_normal_offset(CallbackAllocator<glm::vec3>(owner.allocator)),
      arc_poses(CallbackAllocator<ArcPose>(owner.allocator)),
      arc_radius(CallbackAllocator<float>(owner.allocator)),
      scaled_radius(CallbackAllocator<float>(owner.allocator)),
      fairing(owner.allocator),
      contact(owner.allocator),
      fairing_frames(CallbackAllocator<glm::mat3>(owner.allocator)),
      fairing_offset(CallbackAllocator<glm::vec3>(owner.allocator)),
      fairing_start(CallbackAllocator<glm::vec3>(owner.allocator)),
      fairing_shape(CallbackAllocator<glm::vec3>(owner.allocator)),
      fairing_reference_umbrella(CallbackAllocator<glm::vec3>(owner.allocator)),
      fairing_mean_edge(CallbackAllocator<float>(owner.allocator)),
      fairing_fixed(CallbackAllocator<uint8_t>(owner.allocator)),
      control_normal_sums(CallbackAllocator<glm::vec3>(owner.allocator)),
      refined_positions(CallbackAllocator<glm::vec3>(owner.allocator)),
      refined_normals(CallbackAllocator<glm::vec3>(owner.allocator)),
      dense_positions(CallbackAllocator<glm::vec3>(owner.allocator)),
      dense_normals(CallbackAllocator<glm::vec3>(owner.allocator)),
      dense_tangents(CallbackAllocator<glm::vec4>(owner.allocator)),
      skelform_positions(CallbackAllocator<glm::vec3>(owner.allocator)),
      skelform_normals(CallbackAllocator<glm::vec3>(owner.allocator)),
      skelform_tangents(CallbackAllocator<glm::vec4>(owner.allocator)),
      lbs_positions(CallbackAllocator<glm::vec3>(owner.allocator)),
      lbs_normals(CallbackAllocator<glm::vec3>(owner.allocator)),
      lbs_tangents(CallbackAllocator<glm::vec4>(owner.allocator)),
      guard(owner.allocator) {
  // Every buffer of every stage, sized once: evaluation and output never allocate.
  JointAffine identity_affine;
  JointDualQuaternion identity_dq;
  prepare_joint(glm::mat4(1.0f), identity_affine, identity_dq);
  joints.affine.assign(d.joint_count, identity_affine);
  joints.dual_quaternion.assign(d.joint_count, identity_dq);
  joints.skin_affine.assign(d.joint_count, identity_affine);
  joints.skin_dual_quaternion.assign(d.joint_count, identity_dq);
  joints.scale_ratio.assign(d.joint_count, 1.0f);
  joints.matrices.assign(d.joint_count, glm::mat4(1.0f));
  const size_t control_count = d.control_vertex_count;
  skeletal.resize(control_count);
  normal_matrices.resize(control_count);
  // The buffers displace reads with 16-byte loads end in padding (memory.h kVec3ReadPadding);
  // `control` and `previous_control` trade places after every evaluation, so both have it.
  control.resize(control_count + kVec3ReadPadding);
  previous_skeletal.resize(control_count);
  previous_control.resize(control_count + kVec3ReadPadding);
  step_normals_a.resize(control_count);
  step_normals_b.resize(control_count);
  rest_normal_offset.resize(control_count);
  rest_normal_offsets(d, rest_normal_offset.data());
  arc_poses.resize(d.arc_joints.size());
  arc_radius.resize(control_count);
  scaled_radius.resize(control_count);
  radius = d.medial_radius.data();
  fairing = make_fairing_workspace(d.fairing_topology, kMaxIntersectionGrid, owner.allocator);
  fairing_frames.resize(control_count);
  fairing_offset.assign(control_count, glm::vec3(0.0f));
  fairing_start.resize(control_count);
  fairing_shape.assign(control_count, glm::vec3(0.0f));
  fairing_reference_umbrella.assign(control_count, glm::vec3(0.0f));
  fairing_mean_edge.assign(control_count, 0.0f);
  fairing_fixed.assign(control_count, 0);
  control_normal_sums.resize(control_count + kVec3ReadPadding);
  refined_positions.resize(d.refined_vertex_count + kVec3ReadPadding);
  refined_normals.resize(d.refined_vertex_count + kVec3ReadPadding);
  dense_positions.resize(d.vertex_count);
  dense_normals.resize(d.vertex_count);
  bool any_tangents = false;
  for (const PrimitiveRecord& p : d.primitives) any_tangents = any_tangents || p.has_tangents;
  if (any_tangents) dense_tangents.resize(d.vertex_count);
  skelform_positions.resize(d.vertex_count);
  skelform_normals.resize(d.vertex_count);
  if (any_tangents) skelform_tangents.resize(d.vertex_count);
  if (d.influences > 0 && d.joint_count > 0) {
    lbs_positions.resize(d.vertex_count);
    lbs_normals.resize(d.vertex_count);
    if (any_tangents) lbs_tangents.resize(d.vertex_count);
    guard = make_guard_workspace(d.welded, owner.allocator);
  }
}

sf_instance::~sf_instance() { handle_system_destroy(handles.system, allocator); }

namespace {

sf_result fail(const sf_instance* instance, sf_result result, const char* format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

sf_result fail(const sf_instance* instance, sf_result result, const char* format, ...) {
  va_list args;
  va_start(args, format);
  std::vsnprintf(instance->message, sizeof instance->message, format, args);
  va_end(args);
  return result;
}

// Runs `body` with every exception turned into a result and a message on the instance.
template <class Body>
sf_result guarded(const sf_instance* instance, const char* call, Body&& body) {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return fail(instance, SF_ERROR_OUT_OF_MEMORY, "%s: out of memory", call);
  } catch (const std::invalid_argument& e) {
    return fail(instance, SF_ERROR_INVALID_ARGUMENT, "%s: %s", call, e.what());
  } catch (const std::exception& e) {
    return fail(instance, SF_ERROR_INVALID_DATA, "%s: %s", call, e.what());
  } catch (...) {
    return fail(instance, SF_ERROR_INVALID_DATA, "%s: unknown error", call);
  }
}

bool all_finite(const float* values, size_t count) {
  for (size_t i = 0; i < count; ++i)
    if (!std::isfinite(values[i])) return false;
  return true;
}

// Reads `floats` floats of element `i` of a strided array (memcpy: the caller's stride need
// not keep floats aligned).
void read_element(const float* base, size_t stride, size_t i, float* out, size_t floats) {
  std::memcpy(out, reinterpret_cast<const unsigned char*>(base) + i * stride, floats * sizeof(float));
}

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
                         instance.has_fairing_offset ? instance.fairing_start.data() : instance.previous_control.data(),
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
  fairing.from_rest = (options.flags & SF_EVAL_FROM_REST) != 0 || !instance.has_previous;
  fair_stage(instance, fairing);
  // 4. Refine and displace: skelform's own result.
  displace(d, instance.control.data(), instance.skeletal.data(), instance.control_normal_sums.data(),
           instance.refined_positions.data(), instance.refined_normals.data(), with_normals, result);
  // Back from the normalised space to the caller's.
  const bool skin = instance.driver == Driver::skin;
  scale = skin ? instance.joints.scale : 1.0f;
  if (scale != 1.0f)
    for (uint32_t v = 0; v < d.vertex_count; ++v) result.positions[v] *= scale;
  // 5. The contact pass (contact.h), when the caller turned it on: on skelform's own result,
  // moving only what skelform may move, before the guard checks it against LBS.
  const bool blended = skin && !instance.lbs_positions.empty();
  if (instance.contacts_enabled)
    resolve_contacts(d.welded, scale, result.positions, d.vertex_count, instance.contact,
                     blended ? d.skelform_weight.data() : nullptr);
  // 6. LBS where LBS is exact, and never an intersection LBS does not have (lbs_guard.h),
  // blended in place.
  if (blended) {
    const DenseOutput lbs = lbs_buffers(instance).output();
    dense_skinning(d, instance.joints, Blend::linear, with_normals, lbs);
    guard_and_blend(d, d.welded, scale, result, lbs, with_normals, result, instance.guard);
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
  const uint32_t fairing_iterations = instance.last_fairing_iterations;
  const float fairing_residual = instance.last_fairing_residual;
  float scale = 1.0f;
  if (skelform)
    evaluate_skelform(instance, options, with_normals, result, scale);
  else
    dense_skinning(d, instance.joints, options.method == SF_METHOD_LBS ? Blend::linear : Blend::dual_quaternion,
                   with_normals, result);

  // Output that would not be finite is refused before it replaces the last output. The
  // refused pose's fairing correction is no warm start for the next evaluation.
  if (!output_finite(d, result, with_normals)) {
    instance.has_fairing_offset = false;
    instance.last_fairing_iterations = fairing_iterations;
    instance.last_fairing_residual = fairing_residual;
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

// Copies one element per vertex from `source` to the caller's strided stream. Only the
// element bytes are written; the gaps of a larger stride are never touched. A tightly packed
// stream (the default stride) is one block copy: the same bytes, without a call per vertex.
template <class Element>
void write_stream(float* destination, size_t stride, const Element* source, size_t count) {
  unsigned char* out = reinterpret_cast<unsigned char*>(destination);
  if (stride == sizeof(Element)) {
    std::memcpy(out, source, count * sizeof(Element));
    return;
  }
  for (size_t i = 0; i < count; ++i) std::memcpy(out + i * stride, &source[i], sizeof(Element));
}

}  // namespace

extern "C" {

sf_result sf_instance_create(const sf_asset* asset, uint32_t deformable, sf_instance** out_instance) {
  if (!out_instance) return SF_ERROR_INVALID_ARGUMENT;
  *out_instance = nullptr;
  if (!asset || deformable >= asset->deformables.size()) return SF_ERROR_INVALID_ARGUMENT;
  try {
    *out_instance = create_object<sf_instance>(asset->allocator, *asset, asset->deformables[deformable]);
    return SF_OK;
  } catch (const std::bad_alloc&) {
    return SF_ERROR_OUT_OF_MEMORY;
  } catch (...) {
    return SF_ERROR_INVALID_DATA;
  }
}

void sf_instance_destroy(sf_instance* instance) {
  if (!instance) return;
  const AllocatorRef allocator = instance->allocator;  // outlives the object it lives in
  destroy_object(allocator, instance);
}

const char* sf_instance_last_error(const sf_instance* instance) { return instance ? instance->message : ""; }

sf_result sf_instance_set_joint_matrices(sf_instance* instance, const float* matrices, size_t count,
                                         size_t stride_bytes) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  return guarded(instance, "sf_instance_set_joint_matrices", [&]() -> sf_result {
    const Deformable& d = *instance->deformable;
    if (count != d.joint_count)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                  "sf_instance_set_joint_matrices: the skin has %u joints, %zu matrices given", d.joint_count, count);
    if (count > 0 && !matrices)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_set_joint_matrices: matrices is NULL");
    const size_t stride = stride_bytes == 0 ? 16 * sizeof(float) : stride_bytes;
    if (stride < 16 * sizeof(float))
      return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                  "sf_instance_set_joint_matrices: stride %zu is smaller than a 4x4 float matrix (64)", stride_bytes);
    // Check all before changing any: a refused call leaves the previous pose in place.
    for (size_t j = 0; j < count; ++j) {
      float m[16];
      read_element(matrices, stride, j, m, 16);
      if (!all_finite(m, 16))
        return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                    "sf_instance_set_joint_matrices: matrix %zu has a NaN or infinite element", j);
    }
    glm::mat4* pose = instance->joints.matrices.data();
    for (size_t j = 0; j < count; ++j) read_element(matrices, stride, j, &pose[j][0][0], 16);
    prepare_joints(d, pose, instance->joints);
    instance->driver = Driver::skin;
    return SF_OK;
  });
}

sf_result sf_instance_set_handle_set(sf_instance* instance, const uint32_t* handles, size_t handle_count,
                                     const uint32_t* pinned, size_t pinned_count) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  return guarded(instance, "sf_instance_set_handle_set", [&]() -> sf_result {
    const Deformable& d = *instance->deformable;
    if (handle_count == 0 || !handles)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_set_handle_set: no handle given");
    if (pinned_count > 0 && !pinned)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_set_handle_set: pinned is NULL");
    // Original vertex ids → the control vertices they move (Deformable::handle_control_vertex).
    Array<uint32_t> handle_control{CallbackAllocator<uint32_t>(instance->allocator)};
    Array<uint32_t> pinned_control{CallbackAllocator<uint32_t>(instance->allocator)};
    handle_control.resize(handle_count);
    pinned_control.resize(pinned_count);
    for (size_t i = 0; i < handle_count; ++i) {
      if (handles[i] >= d.vertex_count)
        return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                    "sf_instance_set_handle_set: handle %zu is vertex %u, the deformable has %u", i, handles[i],
                    d.vertex_count);
      handle_control[i] = d.handle_control_vertex[handles[i]];
    }
    for (size_t i = 0; i < pinned_count; ++i) {
      if (pinned[i] >= d.vertex_count)
        return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                    "sf_instance_set_handle_set: pinned %zu is vertex %u, the deformable has %u", i, pinned[i],
                    d.vertex_count);
      pinned_control[i] = d.handle_control_vertex[pinned[i]];
    }
    // A handle and a pin on one control vertex would ask it both to move and to stay.
    for (size_t i = 0; i < handle_count; ++i)
      for (size_t k = 0; k < pinned_count; ++k)
        if (handle_control[i] == pinned_control[k])
          return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                      "sf_instance_set_handle_set: handle vertex %u and pinned vertex %u move the same skeletal "
                      "vertex %u",
                      handles[i], pinned[k], handle_control[i]);
    // Build the new set completely before replacing the old one: a failure keeps the old.
    HandleState next(instance->allocator);
    next.original.assign(handles, handles + handle_count);
    next.targets.resize(handle_count);
    for (size_t i = 0; i < handle_count; ++i) next.targets[i] = d.rest_positions[handles[i]];  // at rest
    next.displacements.resize(handle_count);
    next.system = handle_system_create(d, handle_control.data(), handle_count, pinned_control.data(), pinned_count,
                                       instance->allocator);
    handle_system_destroy(instance->handles.system, instance->allocator);
    instance->handles.system = next.system;
    instance->handles.original.swap(next.original);
    instance->handles.targets.swap(next.targets);
    instance->handles.displacements.swap(next.displacements);
    return SF_OK;
  });
}

sf_result sf_instance_set_contacts(sf_instance* instance, uint32_t enabled) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  return guarded(instance, "sf_instance_set_contacts", [&]() -> sf_result {
    if (enabled > 1)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_set_contacts: enabled is %u, not 0 or 1", enabled);
    if (enabled && !instance->contacts_enabled) {
      // The pass's scratch is made here, for the instances that use it; a failure leaves it off.
      instance->contact = make_contact_workspace(instance->deformable->welded, instance->allocator);
    } else if (!enabled && instance->contacts_enabled) {
      instance->contact = ContactWorkspace(instance->allocator);  // frees the buffers
    }
    instance->contacts_enabled = enabled != 0;
    return SF_OK;
  });
}

sf_result sf_instance_set_handle_targets(sf_instance* instance, const float* targets, size_t count,
                                         size_t stride_bytes) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  return guarded(instance, "sf_instance_set_handle_targets", [&]() -> sf_result {
    HandleState& handles = instance->handles;
    if (!handles.system)
      return fail(instance, SF_ERROR_NOT_READY,
                  "sf_instance_set_handle_targets: no handle set (sf_instance_set_handle_set)");
    if (count != handles.original.size())
      return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                  "sf_instance_set_handle_targets: the set has %zu handles, %zu targets given", handles.original.size(),
                  count);
    if (!targets) return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_set_handle_targets: targets is NULL");
    const size_t stride = stride_bytes == 0 ? 3 * sizeof(float) : stride_bytes;
    if (stride < 3 * sizeof(float))
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_set_handle_targets: stride %zu is smaller than 12",
                  stride_bytes);
    for (size_t i = 0; i < count; ++i) {
      float t[3];
      read_element(targets, stride, i, t, 3);
      if (!all_finite(t, 3))
        return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_set_handle_targets: target %zu is not finite", i);
    }
    for (size_t i = 0; i < count; ++i) read_element(targets, stride, i, &handles.targets[i].x, 3);
    instance->driver = Driver::handles;
    return SF_OK;
  });
}

sf_result sf_instance_evaluate(sf_instance* instance, const sf_eval_options* options) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  return guarded(instance, "sf_instance_evaluate", [&]() -> sf_result {
    const sf_eval_options defaults{};
    return evaluate(*instance, options ? *options : defaults);
  });
}

sf_result sf_instance_write(const sf_instance* instance, uint32_t primitive, const sf_vertex_output* output) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  return guarded(instance, "sf_instance_write", [&]() -> sf_result {
    const Deformable& d = *instance->deformable;
    if (!output) return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write: output is NULL");
    if (primitive >= d.primitives.size())
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write: primitive %u, the deformable has %zu",
                  primitive, d.primitives.size());
    if (!instance->evaluated)
      return fail(instance, SF_ERROR_NOT_READY, "sf_instance_write: nothing evaluated yet (sf_instance_evaluate)");
    const PrimitiveRecord& p = d.primitives[primitive];
    if (output->vertex_capacity < p.vertex_count)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write: capacity %zu, the primitive has %u vertices",
                  output->vertex_capacity, p.vertex_count);
    const size_t position_stride = output->position_stride ? output->position_stride : 12;
    const size_t normal_stride = output->normal_stride ? output->normal_stride : 12;
    const size_t tangent_stride = output->tangent_stride ? output->tangent_stride : 16;
    if ((output->positions && position_stride < 12) || (output->normals && normal_stride < 12) ||
        (output->tangents && tangent_stride < 16))
      return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                  "sf_instance_write: a stride is smaller than its element (12 bytes, 16 for tangents)");
    if (output->tangents && !p.has_tangents)
      return fail(instance, SF_ERROR_UNSUPPORTED, "sf_instance_write: primitive %u has no authored tangents",
                  primitive);
    const size_t first = p.first_vertex, count = p.vertex_count;
    if (output->positions)
      write_stream(output->positions, position_stride, instance->dense_positions.data() + first, count);
    // After an evaluation with SF_EVAL_SKIP_NORMALS the normal streams are left as they are.
    if (instance->normals_valid) {
      if (output->normals) write_stream(output->normals, normal_stride, instance->dense_normals.data() + first, count);
      if (output->tangents)
        write_stream(output->tangents, tangent_stride, instance->dense_tangents.data() + first, count);
    }
    return SF_OK;
  });
}

sf_result sf_instance_write_coarse(const sf_instance* instance, uint32_t mesh, float* positions, size_t stride_bytes,
                                   size_t vertex_capacity) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  return guarded(instance, "sf_instance_write_coarse", [&]() -> sf_result {
    const Deformable& d = *instance->deformable;
    if (mesh > SF_COARSE_SKELETAL)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write_coarse: unknown mesh %u", mesh);
    if (!positions) return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write_coarse: positions is NULL");
    const size_t stride = stride_bytes ? stride_bytes : 12;
    if (stride < 12)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT, "sf_instance_write_coarse: stride %zu is smaller than 12",
                  stride_bytes);
    if (vertex_capacity < d.control_vertex_count)
      return fail(instance, SF_ERROR_INVALID_ARGUMENT,
                  "sf_instance_write_coarse: capacity %zu, the mesh has %u vertices", vertex_capacity,
                  d.control_vertex_count);
    if (!instance->has_previous)
      return fail(instance, SF_ERROR_NOT_READY,
                  "sf_instance_write_coarse: no SF_METHOD_SKELFORM evaluation yet (sf_instance_evaluate)");
    // After an evaluation its S' and M live in previous_* (the incremental start).
    const glm::vec3* source =
        mesh == SF_COARSE_SKELETAL ? instance->previous_skeletal.data() : instance->previous_control.data();
    // Held in the evaluation's normalised space (instance.h JointTransforms).
    const float scale = instance->output_scale;
    unsigned char* out = reinterpret_cast<unsigned char*>(positions);
    for (uint32_t v = 0; v < d.control_vertex_count; ++v) {
      const glm::vec3 p = source[v] * scale;
      std::memcpy(out + v * stride, &p, sizeof p);
    }
    return SF_OK;
  });
}

sf_result sf_instance_fairing_stats(const sf_instance* instance, uint32_t* iterations, float* residual) {
  if (!instance) return SF_ERROR_INVALID_ARGUMENT;
  if (iterations) *iterations = instance->last_fairing_iterations;
  if (residual) *residual = instance->last_fairing_residual;
  return SF_OK;
}

}  // extern "C"
