// Refinement of the control mesh with the grouped stencils (refine.h). Compiled without
// loop vectorisation where the compiler has the switch (runtime/CMakeLists.txt): GCC would
// otherwise vectorise the walk along a stencil with in-order ("fold-left") reductions,
// shuffling every product into place and adding lane after lane (~30% slower than the scalar
// code on CesiumMan_loop2); the scalar code keeps 12 independent sums in flight instead.
// With SSE2 (every x86-64) the same 12 sums run as one vector per row, x, y and z side by
// side (vec3_sse.h): one load, one multiply and one add per row and stencil entry where the
// scalar code has three of each. Each lane does the scalar code's operations in its order.
// The stencils (2 MB on CesiumMan_loop2, read once per frame) are prefetched 512 bytes ahead:
// their loads were the loop's stalls, and asking for them ahead took ~2.5 % off a whole
// evaluation there (256 bytes ahead: ~1.5 %).
#include "prefetch.h"
#include "refine.h"
#include "vec3_sse.h"

namespace skelform::runtime {

namespace {
constexpr size_t kStencilPrefetch = 512;  // bytes ahead in the index and weight streams
}  // namespace

void refine_positions(const Deformable& deformable, const glm::vec3* control, glm::vec3* refined) {
  const uint32_t* rows = deformable.stencil_group_rows.data();
  const uint32_t* indices = deformable.stencil_group_indices.data();
  const float* weights = deformable.stencil_group_weights.data();
  const size_t groups = deformable.stencil_group_lengths.size();
#if defined(__SSE2__)
  static_assert(kStencilLanes == 4, "one SSE vector of weights per stencil step");
  const sse::Vec3Reader read(control, deformable.control_vertex_count);
  for (size_t g = 0; g < groups; ++g, rows += kStencilLanes) {
    // Row r's sum (x, y, z) in sum[r], from zero, in stencil order: the scalar code's bits.
    __m128 sum[kStencilLanes] = {_mm_setzero_ps(), _mm_setzero_ps(), _mm_setzero_ps(), _mm_setzero_ps()};
    const uint32_t length = deformable.stencil_group_lengths[g];
    for (uint32_t s = 0; s < length; ++s, indices += kStencilLanes, weights += kStencilLanes) {
      prefetch_ahead(weights, kStencilPrefetch);
      prefetch_ahead(indices, kStencilPrefetch);
      const __m128 w = _mm_loadu_ps(weights);
      sum[0] = _mm_add_ps(sum[0], _mm_mul_ps(_mm_shuffle_ps(w, w, _MM_SHUFFLE(0, 0, 0, 0)), read(indices[0])));
      sum[1] = _mm_add_ps(sum[1], _mm_mul_ps(_mm_shuffle_ps(w, w, _MM_SHUFFLE(1, 1, 1, 1)), read(indices[1])));
      sum[2] = _mm_add_ps(sum[2], _mm_mul_ps(_mm_shuffle_ps(w, w, _MM_SHUFFLE(2, 2, 2, 2)), read(indices[2])));
      sum[3] = _mm_add_ps(sum[3], _mm_mul_ps(_mm_shuffle_ps(w, w, _MM_SHUFFLE(3, 3, 3, 3)), read(indices[3])));
    }
    sse::store3(refined[rows[0]], sum[0]);
    sse::store3(refined[rows[1]], sum[1]);
    sse::store3(refined[rows[2]], sum[2]);
    sse::store3(refined[rows[3]], sum[3]);
  }
#else
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
#endif
}

}  // namespace skelform::runtime
