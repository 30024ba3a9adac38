// Stage 1 of a frame: deform the skeletal mesh S → S' (DESIGN.md runtime step 1; the paper's
// section 3 "free-form deformation of the skeletal mesh", here by the glTF skin or by the
// handles of its reference [25]).
#include "handles.h"
#include "instance.h"

#include <cmath>

namespace skelform::runtime {

void prepare_joints(const Deformable& d, JointTransforms& joints) {
  for (size_t j = 0; j < d.joint_count; ++j)
    prepare_joint(joints.matrices[j], joints.affine[j], joints.dual_quaternion[j]);
  joints.skin_prepared = false;
}

void prepare_skin_joints(const Deformable& d, JointTransforms& joints) {
  const glm::mat4* matrices = joints.matrices.data();
  const size_t count = d.joint_count;
  // σ: the joints' scales weighted by their use in the control skin (in double: a sum over
  // joints), falling back to the plain mean when no control vertex uses any joint.
  double weighted = 0.0, usage = 0.0, plain = 0.0;
  bool all_equal = true;
  float first_scale = 0.0f;
  for (size_t j = 0; j < count; ++j) {
    const float s = std::cbrt(std::fabs(glm::determinant(glm::mat3(matrices[j]))));
    joints.scale_ratio[j] = s;  // the scale itself until σ is known
    if (j == 0) first_scale = s;
    all_equal = all_equal && s == first_scale;
    const double u = j < d.joint_usage.size() ? double(d.joint_usage[j]) : 0.0;
    weighted += u * double(s);
    usage += u;
    plain += double(s);
  }
  double sigma = usage > 0.0 ? weighted / usage : (count > 0 ? plain / double(count) : 1.0);
  // One scale for every joint: σ is that scale exactly, and every ratio is exactly 1.
  if (all_equal && count > 0) sigma = double(first_scale);
  // A degenerate pose (every joint collapsed to a point) or an overflow: evaluate unscaled.
  if (!(sigma > 1e-30) || !std::isfinite(sigma)) sigma = 1.0;
  const float scale = float(sigma);
  joints.scale = scale;
  joints.uniform = true;
  const float inverse = 1.0f / scale;
  for (size_t j = 0; j < count; ++j) {
    const glm::mat4 normalised = scale == 1.0f ? matrices[j] : matrices[j] * inverse;
    glm::mat4 m = normalised;
    m[3][3] = 1.0f;
    prepare_joint(m, joints.skin_affine[j], joints.skin_dual_quaternion[j]);
    const float ratio = all_equal ? 1.0f : joints.scale_ratio[j] * inverse;
    joints.scale_ratio[j] = std::isfinite(ratio) ? ratio : 1.0f;
    joints.uniform = joints.uniform && joints.scale_ratio[j] == 1.0f;
  }
  joints.skin_prepared = true;
}

void scale_medial_radii(const Deformable& d, const JointTransforms& joints, const float* radius_in, float* radius_out) {
  const uint32_t influences = d.influences;
  for (uint32_t v = 0; v < d.control_vertex_count; ++v) {
    float ratio = 0.0f;
    const size_t first = size_t(v) * influences;
    for (uint32_t k = 0; k < influences; ++k)
      ratio += d.control_weights[first + k] * joints.scale_ratio[d.control_joints[first + k]];
    radius_out[v] = radius_in[v] * ratio;
  }
}

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
      blend_affine(joints.skin_affine.data(), joint_index + first, weight + first, influences, blended);
    else
      blend_dual_quaternion(joints.skin_dual_quaternion.data(), joint_index + first, weight + first, influences,
                            blended);
    skeletal_out[v] = transform_point(blended, d.skeletal_positions[v]);
    // Kept for the carried reconstruction: the rest normal N_i turns with the same blended
    // transform that moved S_i, so M = S' + d·N stays consistent with the skin.
    normal_matrices[v] = normal_matrix(blended);
  }
}

void drive_skeleton_arcs(const Deformable& d, const JointTransforms& joints, const ArcPose* poses,
                         glm::vec3* skeletal_out, glm::mat3* normal_matrices, float* radius_out) {
  drive_skeleton_skin(d, joints, Blend::linear, skeletal_out, normal_matrices);
  const uint32_t influences = d.influences;
  if (d.arc_vertices.empty() || influences == 0) {
    for (uint32_t v = 0; v < d.control_vertex_count; ++v) radius_out[v] = d.medial_radius[v];
    return;
  }
  const uint16_t* joint_index = d.control_joints.data();
  const float* weight = d.control_weights.data();
  for (uint32_t v = 0; v < d.control_vertex_count; ++v) {
    const ArcVertex& part = d.arc_vertices[v];
    radius_out[v] = d.medial_radius[v];
    if (part.joint == kNoArc) continue;  // the linear blend above
    const ArcJoint& joint = d.arc_joints[part.joint];
    const ArcPose& pose = poses[part.joint];
    if (!(pose.weight > 0.0f)) continue;  // a mild bend: the linear blend above, bit for bit
    const ArcMap map = arc_map(joint, pose, part.axial);
    // The pair's share: β·(w_P + w_C)·A_P ∘ (x ↦ k·R·x + t), as a row-major 3x4, plus
    // (1 − β) of its linear blend, plus the other influences.
    const float* a = pose.parent.m;
    const float arc = pose.weight * part.share;
    float blended[12];
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c)
        blended[4 * r + c] =
            arc * map.scale *
            (a[4 * r] * map.rotation[c][0] + a[4 * r + 1] * map.rotation[c][1] + a[4 * r + 2] * map.rotation[c][2]);
      blended[4 * r + 3] = arc * (a[4 * r] * map.translation.x + a[4 * r + 1] * map.translation.y +
                                  a[4 * r + 2] * map.translation.z + a[4 * r + 3]);
    }
    const size_t first = size_t(v) * influences;
    for (uint32_t k = 0; k < influences; ++k) {
      const uint16_t j = joint_index[first + k];
      const float w =
          (j == joint.parent || j == joint.child) ? (1.0f - pose.weight) * weight[first + k] : weight[first + k];
      const float* m = joints.skin_affine[j].m;
      for (int c = 0; c < 12; ++c) blended[c] += w * m[c];
    }
    skeletal_out[v] = transform_point(blended, d.skeletal_positions[v]);
    normal_matrices[v] = normal_matrix(blended);
    radius_out[v] = d.medial_radius[v] * (1.0f + arc * (map.scale - 1.0f));
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
