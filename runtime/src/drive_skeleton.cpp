// Stage 1 of a frame: deform the skeletal mesh S → S' (DESIGN.md runtime step 1; the paper's
// section 3 "free-form deformation of the skeletal mesh", here by the glTF skin or by the
// handles of its reference [25]).
#include "handles.h"
#include "instance.h"

namespace skelform::runtime {

void drive_skeleton_skin(const Deformable& d, const JointTransforms& joints, Blend blend, glm::vec3* skeletal_out,
                         glm::mat3* normal_matrices) {
  const uint32_t count = d.control_vertex_count;
  const uint32_t influences = d.influences;
  if (d.joint_count == 0 || influences == 0) {
    // Unskinned deformable driven by the skin driver: the rest pose, whatever the matrices.
    for (uint32_t v = 0; v < count; ++v) {
      skeletal_out[v] = d.skeletal_positions[v];
      normal_matrices[v] = glm::mat3(1.0f);
    }
    return;
  }
  const uint16_t* joint_index = d.control_joints.data();
  const float* weight = d.control_weights.data();
  float blended[12];
  for (uint32_t v = 0; v < count; ++v) {
    const size_t first = size_t(v) * influences;
    if (blend == Blend::linear)
      blend_affine(joints.affine.data(), joint_index + first, weight + first, influences, blended);
    else
      blend_dual_quaternion(joints.dual_quaternion.data(), joint_index + first, weight + first, influences, blended);
    skeletal_out[v] = transform_point(blended, d.skeletal_positions[v]);
    // Kept for the carried reconstruction: the rest normal N_i turns with the same blended
    // transform that moved S_i, so M = S' + d·N stays consistent with the skin.
    normal_matrices[v] = normal_matrix(blended);
  }
}

void drive_skeleton_handles(const Deformable& d, HandleState& handles, glm::vec3* skeletal_out) {
  // The displacement a handle asks for is that of the ORIGINAL vertex the caller picked; the
  // skeletal vertex under it moves by the same amount (the binding carries the surface along).
  for (size_t h = 0; h < handles.original.size(); ++h)
    handles.displacements[h] = handles.targets[h] - d.rest_positions[handles.original[h]];
  handle_system_solve(*handles.system, d, handles.displacements.data(), skeletal_out);
}

}  // namespace skelform::runtime
