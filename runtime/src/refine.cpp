#include "refine.h"

namespace skelform::runtime {

void refine_positions(const Deformable& deformable, const glm::vec3* control, glm::vec3* refined) {
  const uint32_t* offsets = deformable.stencil_offsets.data();
  const uint32_t* indices = deformable.stencil_indices.data();
  const float* weights = deformable.stencil_weights.data();
  for (uint32_t v = 0; v < deformable.refined_vertex_count; ++v) {
    // Written exactly as the baker's apply_stencils (float, from zero, stencil order, no
    // fused multiply-add): the binding was computed against these bits.
    glm::vec3 sum(0.0f);
    for (uint32_t s = offsets[v]; s < offsets[v + 1]; ++s) sum += weights[s] * control[indices[s]];
    refined[v] = sum;
  }
}

void refined_normals(const Deformable& deformable, const glm::vec3* refined, glm::vec3* normals) {
  dss::refined_vertex_normals(refined, deformable.refined_vertex_count, deformable.refined_indices.data(),
                              deformable.refined_indices.size() / 3, normals);
}

}  // namespace skelform::runtime
