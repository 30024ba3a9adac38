// A test-side evaluator of stored bake data at the rest pose: stencils, then the DSS binding
// through the shared dss_frame.h formula. Independent of the baker's own structures: it reads
// only the flat arrays that the extension stores.
#pragma once

#include "skelform/core/dss_frame.h"
#include "skelform/bake/baked.h"

#include <vector>

namespace skelform::test {

// The stencils applied to one value per control vertex (positions, or normal sums).
inline std::vector<glm::vec3> refine_control(const bake::BakedDeformable& baked,
                                             const std::vector<glm::vec3>& control) {
  const size_t refined_count = baked.stencil_offsets.size() - 1;
  std::vector<glm::vec3> refined(refined_count, glm::vec3(0.0f));
  for (size_t v = 0; v < refined_count; ++v)
    for (uint32_t s = baked.stencil_offsets[v]; s < baked.stencil_offsets[v + 1]; ++s)
      refined[v] += baked.stencil_weights[s] * control[baked.stencil_indices[s]];
  return refined;
}
inline std::vector<glm::vec3> refine_control(const bake::BakedDeformable& baked) {
  return refine_control(baked, baked.control_positions);
}

// Every dense (original) vertex evaluated from the stored arrays at rest.
inline std::vector<glm::vec3> evaluate_rest(const bake::BakedDeformable& baked) {
  const std::vector<glm::vec3> refined = refine_control(baked);
  // The refined normals (extension version 2): the control mesh's area-weighted normal sums,
  // refined by the stencils, normalised.
  std::vector<glm::vec3> sums(baked.control_positions.size(), glm::vec3(0.0f));
  dss::add_face_normals(baked.control_positions.data(), baked.control_indices.data(), baked.control_indices.size() / 3,
                        sums.data());
  std::vector<glm::vec3> normals = refine_control(baked, sums);
  for (glm::vec3& n : normals) n = dss::normalise_or_zero(n);
  std::vector<glm::vec3> dense(baked.binding_triangle.size());
  for (size_t i = 0; i < dense.size(); ++i) {
    const uint32_t* corner = &baked.refined_indices[3 * size_t(baked.binding_triangle[i])];
    const dss::SurfaceFrame frame = dss::surface_frame(refined[corner[0]], refined[corner[1]], refined[corner[2]],
                                                       normals[corner[0]], normals[corner[1]], normals[corner[2]],
                                                       baked.binding_barycentric[i].x, baked.binding_barycentric[i].y);
    dense[i] = dss::displaced_point(frame, baked.binding_displacement[i], baked.binding_residual[i]);
  }
  return dense;
}

}  // namespace skelform::test
