// Refinement of the control mesh and of its normals with the grouped stencils (refine.h).
// Compiled without loop vectorisation where the compiler has the switch
// (runtime/CMakeLists.txt): GCC would otherwise vectorise the walk along a stencil with
// in-order ("fold-left") reductions, shuffling every product into place and adding lane after
// lane (slower than the scalar code, which keeps its independent sums in flight). With SSE2
// (every x86-64) the sums run as one vector per row, x, y and z side by side (vec3_sse.h): one
// load, one multiply and one add per row and stencil entry where the scalar code has three of
// each. Each lane does the scalar code's
// operations in its order. The stencils (megabytes, read once per frame) are prefetched 512
// bytes ahead: their loads were the loop's stalls.
// Positions and normals share the walk: the normals cost one more gather, multiply and add
// per entry (none with AVX2, which reads a control vertex's position and normal sum as one
// 32-byte vector from a copy of the two side by side), where normals of the refined triangles
// would cost a scatter over every refined triangle. Each group's four normals are normalised
// before they are stored (no second pass over the refined normals). The figures behind these
// choices: docs/tuning.md.
#include "cpu.h"
#include "prefetch.h"
#include "refine.h"
#include "vec3_sse.h"

#include <algorithm>
#include <vector>

#if defined(SKELFORM_HAS_AVX2_KERNELS)
#  include <immintrin.h>
#endif

namespace skelform::runtime {

namespace {
constexpr size_t kStencilPrefetch = 512;  // bytes ahead in the index and weight streams

#if defined(__SSE2__)
// A group's four rows (x, y, z in lanes 0-2 of point[r] and normal[r]) stored: the normals
// normalised, lanes = rows: (x x + y y) + z z, its square root and three divisions, zero where
// the length is ≤ 1e-30 (dss::normalise_or_zero's bits).
inline void store_group(const __m128 (&point)[kStencilLanes], const __m128 (&normal)[kStencilLanes],
                        const uint32_t* rows, glm::vec3* refined, glm::vec3* refined_normals) {
  __m128 nx = normal[0], ny = normal[1], nz = normal[2], nw = normal[3];
  _MM_TRANSPOSE4_PS(nx, ny, nz, nw);
  const __m128 norm = _mm_sqrt_ps(lane4::dot(nx, ny, nz, nx, ny, nz));
  const __m128 keep = _mm_cmpgt_ps(norm, _mm_set1_ps(1e-30f));
  nx = _mm_and_ps(keep, _mm_div_ps(nx, norm));
  ny = _mm_and_ps(keep, _mm_div_ps(ny, norm));
  nz = _mm_and_ps(keep, _mm_div_ps(nz, norm));
  nw = _mm_setzero_ps();
  _MM_TRANSPOSE4_PS(nx, ny, nz, nw);
  const __m128 unit[kStencilLanes] = {nx, ny, nz, nw};
  for (uint32_t r = 0; r < kStencilLanes; ++r) {
    sse::store3(refined[rows[r]], point[r]);
    sse::store3(refined_normals[rows[r]], unit[r]);
  }
}
#endif

#if defined(SKELFORM_HAS_AVX2_KERNELS)
// The SSE2 walk (refine_surface) with each control vertex's position and normal sum read as one
// 32-byte vector of `lanes` (position in lanes 0-3, normal sum in 4-7): per row and stencil entry
// one load, one multiply and one add for both, each lane the SSE2 loop's operations in its order.
__attribute__((target("avx2"))) void walk_groups_avx2(const Deformable& deformable, const float* lanes,
                                                      glm::vec3* refined, glm::vec3* refined_normals) {
  const uint32_t* rows = deformable.stencil_group_rows.data();
  const uint32_t* indices = deformable.stencil_group_indices.data();
  const float* weights = deformable.stencil_group_weights.data();
  const size_t groups = deformable.stencil_group_lengths.size();
  for (size_t g = 0; g < groups; ++g, rows += kStencilLanes) {
    __m256 sum[kStencilLanes];
    for (uint32_t r = 0; r < kStencilLanes; ++r) sum[r] = _mm256_setzero_ps();
    const uint32_t length = deformable.stencil_group_lengths[g];
    for (uint32_t s = 0; s < length; ++s, indices += kStencilLanes, weights += kStencilLanes) {
      prefetch_ahead(weights, kStencilPrefetch);
      prefetch_ahead(indices, kStencilPrefetch);
      for (uint32_t r = 0; r < kStencilLanes; ++r)
        sum[r] = _mm256_add_ps(
            sum[r], _mm256_mul_ps(_mm256_broadcast_ss(weights + r), _mm256_loadu_ps(lanes + 8 * size_t{indices[r]})));
    }
    __m128 point[kStencilLanes], normal[kStencilLanes];
    for (uint32_t r = 0; r < kStencilLanes; ++r) {
      point[r] = _mm256_castps256_ps128(sum[r]);
      normal[r] = _mm256_extractf128_ps(sum[r], 1);
    }
    store_group(point, normal, rows, refined, refined_normals);
  }
}
#endif
}  // namespace

void refine_surface(const Deformable& deformable, const glm::vec3* control, const glm::vec3* skeletal,
                    glm::vec3* control_normal_sums, glm::vec3* refined, glm::vec3* refined_normals, float* lanes) {
  const size_t control_count = deformable.control_vertex_count;
  for (size_t v = 0; v < control_count; ++v) control_normal_sums[v] = glm::vec3(0.0f);
  add_face_normals(control, control_count, deformable.control_indices.data(), deformable.control_indices.size() / 3,
                   control_normal_sums);
  if (skeletal) medial_normal_sums(control, skeletal, control_count, control_normal_sums);
  const glm::vec3* sums = control_normal_sums;
#if !defined(SKELFORM_HAS_AVX2_KERNELS)
  (void)lanes;
#endif

  const uint32_t* rows = deformable.stencil_group_rows.data();
  const uint32_t* indices = deformable.stencil_group_indices.data();
  const float* weights = deformable.stencil_group_weights.data();
  const size_t groups = deformable.stencil_group_lengths.size();
#if defined(__SSE2__)
#  if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (lanes && cpu_has_avx2()) {
    // Each control vertex's position and normal sum side by side, one 32-byte vector each.
    for (size_t v = 0; v < control_count; ++v) {
      float* lane = lanes + 8 * v;
      lane[0] = control[v].x, lane[1] = control[v].y, lane[2] = control[v].z, lane[3] = 0.0f;
      lane[4] = sums[v].x, lane[5] = sums[v].y, lane[6] = sums[v].z, lane[7] = 0.0f;
    }
    walk_groups_avx2(deformable, lanes, refined, refined_normals);
    return;
  }
#  endif
  static_assert(kStencilLanes == 4, "one SSE vector of weights per stencil step");
  // Both buffers are padded (refine.h): plain 16-byte loads, no special last vertex.
  const sse::PaddedVec3Reader read(control), read_normal(sums);
  for (size_t g = 0; g < groups; ++g, rows += kStencilLanes) {
    // Row r's sums (x, y, z) in point[r] and normal[r], from zero, in stencil order: the
    // scalar code's bits. One walk of the stencils feeds both.
    __m128 point[kStencilLanes], normal[kStencilLanes];
    for (uint32_t r = 0; r < kStencilLanes; ++r) point[r] = normal[r] = _mm_setzero_ps();
    const uint32_t length = deformable.stencil_group_lengths[g];
    for (uint32_t s = 0; s < length; ++s, indices += kStencilLanes, weights += kStencilLanes) {
      prefetch_ahead(weights, kStencilPrefetch);
      prefetch_ahead(indices, kStencilPrefetch);
      const __m128 w = _mm_loadu_ps(weights);
      const __m128 w_row[kStencilLanes] = {
          _mm_shuffle_ps(w, w, _MM_SHUFFLE(0, 0, 0, 0)), _mm_shuffle_ps(w, w, _MM_SHUFFLE(1, 1, 1, 1)),
          _mm_shuffle_ps(w, w, _MM_SHUFFLE(2, 2, 2, 2)), _mm_shuffle_ps(w, w, _MM_SHUFFLE(3, 3, 3, 3))};
      for (uint32_t r = 0; r < kStencilLanes; ++r) {
        point[r] = _mm_add_ps(point[r], _mm_mul_ps(w_row[r], read(indices[r])));
        normal[r] = _mm_add_ps(normal[r], _mm_mul_ps(w_row[r], read_normal(indices[r])));
      }
    }
    store_group(point, normal, rows, refined, refined_normals);
  }
#else
  for (size_t g = 0; g < groups; ++g, rows += kStencilLanes) {
    // Each row's sums are written exactly as the baker's apply_stencils (float, from zero,
    // stencil order, no fused multiply-add): the binding was computed against these bits.
    // The group's rows only run side by side, each in its own accumulators.
    glm::vec3 point[kStencilLanes], normal[kStencilLanes];
    for (uint32_t lane = 0; lane < kStencilLanes; ++lane) point[lane] = normal[lane] = glm::vec3(0.0f);
    const uint32_t length = deformable.stencil_group_lengths[g];
    for (uint32_t s = 0; s < length; ++s, indices += kStencilLanes, weights += kStencilLanes)
      for (uint32_t lane = 0; lane < kStencilLanes; ++lane) {
        point[lane] += weights[lane] * control[indices[lane]];
        normal[lane] += weights[lane] * sums[indices[lane]];
      }
    for (uint32_t lane = 0; lane < kStencilLanes; ++lane) {
      refined[rows[lane]] = point[lane];
      refined_normals[rows[lane]] = dss::normalise_or_zero(normal[lane]);
    }
  }
#endif
}

void refine_rest_surface(const Deformable& deformable, glm::vec3* refined, glm::vec3* refined_normals) {
  std::vector<glm::vec3> control(deformable.control_vertex_count + kVec3ReadPadding, glm::vec3(0.0f));
  std::copy(deformable.control_positions.begin(), deformable.control_positions.end(), control.begin());
  std::vector<glm::vec3> sums(deformable.control_vertex_count + kVec3ReadPadding);
  refine_surface(deformable, control.data(), deformable.skeletal_positions.data(), sums.data(), refined,
                 refined_normals);
}

}  // namespace skelform::runtime
