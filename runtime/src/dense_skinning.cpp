// The baselines SF_METHOD_LBS and SF_METHOD_DQS: the glTF skin applied straight to the
// original vertices (DESIGN.md "per-frame cost": measured beside skelform on the same mesh
// and pose, through the same call path). Written like ozz-animation's SkinningJob: one pass
// over the vertices, a fixed number of influences per vertex (zero-weight slots name joint 0
// and add nothing, so the blend loop has no branch), the blend a tight loop over 12 (LBS) or
// 17 (DQS) contiguous floats the compiler vectorises, all in float.
//
// Normals and tangents go through the blended matrix's linear part and are renormalised (the
// usual engine shortcut, exact for rigid and uniformly scaled blends); tangent w is kept.
#include "instance.h"

namespace skelform::runtime {

namespace {

// One loop per blend so the per-vertex kernel is a direct call the compiler can inline.
template <class Joint, void (*BlendFn)(const Joint*, const uint16_t*, const float*, uint32_t, float*)>
void skin_vertices(const Deformable& d, const Joint* joints, bool with_normals, const DenseOutput& out) {
  const uint32_t influences = d.influences;
  const uint16_t* joint_index = d.dense_joints.data();
  const float* weight = d.dense_weights.data();
  const glm::vec3* rest_positions = d.rest_positions.data();
  const glm::vec3* rest_normals = d.rest_normals.data();
  for (const PrimitiveRecord& primitive : d.primitives) {
    const uint32_t end = primitive.first_vertex + primitive.vertex_count;
    const bool tangents = with_normals && primitive.has_tangents && out.tangents;
    for (uint32_t v = primitive.first_vertex; v < end; ++v) {
      const size_t first = size_t(v) * influences;
      float m[12];
      BlendFn(joints, joint_index + first, weight + first, influences, m);
      out.positions[v] = transform_point(m, rest_positions[v]);
      if (with_normals) out.normals[v] = normalize_or(transform_vector(m, rest_normals[v]), rest_normals[v]);
      if (tangents) {
        const glm::vec4 rest = d.rest_tangents[v];
        out.tangents[v] = glm::vec4(normalize_or(transform_vector(m, glm::vec3(rest)), glm::vec3(rest)), rest.w);
      }
    }
  }
}

}  // namespace

void dense_skinning(const Deformable& d, const JointTransforms& joints, Blend blend, bool with_normals,
                    const DenseOutput& out) {
  if (blend == Blend::linear)
    skin_vertices<JointAffine, blend_affine>(d, joints.affine.data(), with_normals, out);
  else
    skin_vertices<JointDualQuaternion, blend_dual_quaternion>(d, joints.dual_quaternion.data(), with_normals, out);
}

}  // namespace skelform::runtime
