// The instance half of the C API (skelform.h "Instances"): an instance's creation (every
// buffer of every stage sized once, instance.h) and destruction, its error message, and the
// inputs of an evaluation: joint matrices, handle sets and targets, the contact pass. The
// evaluation is api_evaluate.cpp's, the copy into the caller's buffers api_output.cpp's.
// Nothing throws past these files: every entry point catches at the boundary and turns the
// exception into an sf_result plus the instance's message (api_instance.h).
#include "api_instance.h"

#include "cpu.h"
#include "handles.h"

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <new>
#include <stdexcept>
#include <utility>

using namespace skelform::runtime;

namespace {

// The joint buffers, every joint at identity.
void size_joint_buffers(sf_instance& instance, const Deformable& d) {
  JointAffine identity_affine;
  JointDualQuaternion identity_dq;
  prepare_joint(glm::mat4(1.0f), identity_affine, identity_dq);
  instance.joints.affine.assign(d.joint_count, identity_affine);
  instance.joints.dual_quaternion.assign(d.joint_count, identity_dq);
  instance.joints.skin_affine.assign(d.joint_count, identity_affine);
  instance.joints.skin_dual_quaternion.assign(d.joint_count, identity_dq);
  instance.joints.scale_ratio.assign(d.joint_count, 1.0f);
  instance.joints.matrices.assign(d.joint_count, glm::mat4(1.0f));
}

// The buffers of the coarse stages, one element per control vertex: driver, reconstruction
// and fairing.
void size_control_buffers(sf_instance& instance, const Deformable& d, const AllocatorRef& allocator) {
  const size_t control_count = d.control_vertex_count;
  instance.skeletal.resize(control_count);
  instance.normal_matrices.resize(control_count);
  // The buffers displace reads with 16-byte loads end in padding (memory.h kVec3ReadPadding);
  // `control` and `previous_control` trade places after every evaluation, so both have it.
  instance.control.resize(control_count + kVec3ReadPadding);
  instance.previous_skeletal.resize(control_count);
  instance.previous_control.resize(control_count + kVec3ReadPadding);
  instance.step_normals_a.resize(control_count);
  instance.step_normals_b.resize(control_count);
  instance.rest_normal_offset.resize(control_count);
  rest_normal_offsets(d, instance.rest_normal_offset.data());
  instance.arc_poses.resize(d.arc_joints.size());
  instance.arc_radius.resize(control_count);
  instance.scaled_radius.resize(control_count);
  instance.radius = d.medial_radius.data();
  instance.fairing.allocate(d, allocator);
  instance.control_normal_sums.resize(control_count + kVec3ReadPadding);
  // (At level 0 every stencil row is one control vertex: the copy would cost what it saves.)
  if (cpu_has_avx2() && d.subdivision_level > 0) instance.refine_lanes.resize(8 * size_t{control_count});
}

// The buffers of the refined and dense stages: refinement, the output and the scratch of
// skelform's result, and (skinned deformables) the LBS result and the guard's workspace.
void size_dense_buffers(sf_instance& instance, const Deformable& d, const AllocatorRef& allocator) {
  instance.refined_positions.resize(d.named_refined_count + kVec3ReadPadding);  // the only ones read
  instance.refined_normals.resize(d.named_refined_count + kVec3ReadPadding);
  instance.dense_positions.resize(d.vertex_count);
  instance.dense_normals.resize(d.vertex_count);
  bool any_tangents = false;
  for (const PrimitiveRecord& p : d.primitives) any_tangents = any_tangents || p.has_tangents;
  if (any_tangents) instance.dense_tangents.resize(d.vertex_count);
  instance.skelform_positions.resize(d.vertex_count);
  instance.skelform_normals.resize(d.vertex_count);
  if (any_tangents) instance.skelform_tangents.resize(d.vertex_count);
  if (d.influences > 0 && d.joint_count > 0) {
    instance.lbs_positions.resize(d.vertex_count);
    instance.lbs_normals.resize(d.vertex_count);
    if (any_tangents) instance.lbs_tangents.resize(d.vertex_count);
    instance.guard = make_guard_workspace(d.welded, allocator);
  }
}

// The contact pass's scratch (contact.h), with its own grid where it runs without the guard:
// with a handle set, or without a skin (no LBS). Throws std::bad_alloc.
ContactWorkspace contact_workspace(const sf_instance& instance) {
  ContactWorkspace workspace = make_contact_workspace(instance.deformable->welded, instance.allocator);
  if (instance.handles.system || instance.lbs_positions.empty())
    add_contact_grid(instance.deformable->welded, workspace);
  return workspace;
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

}  // namespace

sf_instance::sf_instance(const sf_asset& owner, const Deformable& d)
    : asset(&owner),
      deformable(&d),
      allocator(owner.allocator),
      joints(owner.allocator),
      handles(owner.allocator),
      skeletal(owner.allocator),
      normal_matrices(owner.allocator),
      control(owner.allocator),
      previous_skeletal(owner.allocator),
      previous_control(owner.allocator),
      step_normals_a(owner.allocator),
      step_normals_b(owner.allocator),
      rest_normal_offset(owner.allocator),
      arc_poses(owner.allocator),
      arc_radius(owner.allocator),
      scaled_radius(owner.allocator),
      fairing(owner.allocator),
      contact(owner.allocator),
      control_normal_sums(owner.allocator),
      refine_lanes(owner.allocator),
      refined_positions(owner.allocator),
      refined_normals(owner.allocator),
      dense_positions(owner.allocator),
      dense_normals(owner.allocator),
      dense_tangents(owner.allocator),
      skelform_positions(owner.allocator),
      skelform_normals(owner.allocator),
      skelform_tangents(owner.allocator),
      lbs_positions(owner.allocator),
      lbs_normals(owner.allocator),
      lbs_tangents(owner.allocator),
      guard(owner.allocator) {
  // Every buffer of every stage, sized once: evaluation and output never allocate.
  size_joint_buffers(*this, d);
  size_control_buffers(*this, d, owner.allocator);
  size_dense_buffers(*this, d, owner.allocator);
  // The contact pass, on by default (sf_instance_set_contacts).
  contact = contact_workspace(*this);
  contacts_enabled = true;
}

sf_instance::~sf_instance() { handle_system_destroy(handles.system, allocator); }

namespace skelform::runtime {

sf_result fail(const sf_instance* instance, sf_result result, const char* format, ...) {
  va_list args;
  va_start(args, format);
  std::vsnprintf(instance->message, sizeof instance->message, format, args);
  va_end(args);
  return result;
}

}  // namespace skelform::runtime

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
    prepare_joints(d, instance->joints);  // the normalised forms wait for a skelform evaluation
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
    // The handle driver runs the contact pass on its own, without the guard: it needs its grid.
    if (instance->contacts_enabled && !instance->contact.grid)
      add_contact_grid(instance->deformable->welded, instance->contact);
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
      instance->contact = contact_workspace(*instance);  // made again; a failure leaves it off
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

}  // extern "C"
