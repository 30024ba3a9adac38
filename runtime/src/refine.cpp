// Refinement of the control mesh with the grouped stencils (refine.h). Compiled without
// loop vectorisation where the compiler has the switch (runtime/CMakeLists.txt): GCC would
// otherwise vectorise the walk along a stencil with in-order ("fold-left") reductions,
// shuffling every product into place and adding lane after lane (~30% slower than the scalar
// code on CesiumMan_loop2); the scalar code keeps 12 independent sums in flight instead.
#include "refine.h"

namespace skelform::runtime {

void refine_positions(const Deformable& deformable, const glm::vec3* control, glm::vec3* refined) {
  const uint32_t* rows = deformable.stencil_group_rows.data();
  const uint32_t* indices = deformable.stencil_group_indices.data();
  const float* weights = deformable.stencil_group_weights.data();
  const size_t groups = deformable.stencil_group_lengths.size();
  for (size_t g = 0; g < groups; ++g, rows += kStencilLanes) {
    // Each row's sum is written exactly as the baker's apply_stencils (float, from zero,
    // stencil order, no fused multiply-add): the binding was computed against these bits.
    // The group's rows only run side by side, each in its own accumulators.
    float x[kStencilLanes] = {}, y[kStencilLanes] = {}, z[kStencilLanes] = {};
    const uint32_t length = deformable.stencil_group_lengths[g];
    for (uint32_t s = 0; s < length; ++s, indices += kStencilLanes, weights += kStencilLanes)
      for (uint32_t lane = 0; lane < kStencilLanes; ++lane) {
        const glm::vec3& c = control[indices[lane]];
        x[lane] += weights[lane] * c.x;
        y[lane] += weights[lane] * c.y;
        z[lane] += weights[lane] * c.z;
      }
    for (uint32_t lane = 0; lane < kStencilLanes; ++lane) refined[rows[lane]] = glm::vec3(x[lane], y[lane], z[lane]);
  }
}

}  // namespace skelform::runtime
