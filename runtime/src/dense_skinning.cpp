// The baselines SF_METHOD_LBS and SF_METHOD_DQS: the glTF skin applied straight to the
// original vertices (DESIGN.md "per-frame cost": timed beside skelform on the same mesh and
// pose, through the same call path). Written like ozz-animation's SkinningJob: one pass
// over the vertices, a fixed number of influences per vertex (zero-weight slots name joint 0
// and add nothing, so the blend loop has no branch), the blend a tight loop over 12 (LBS) or
// 17 (DQS) contiguous floats the compiler vectorises, all in float.
//
// Normals and tangents go through the blended matrix's linear part and are renormalised (the
// usual engine shortcut, exact for rigid and uniformly scaled blends); tangent w is kept.
#include "instance.h"

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif
#if defined(__SSE2__) && (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#  define SKELFORM_SKINNING_AVX2 1
#  include <immintrin.h>
#endif

namespace skelform::runtime {

namespace {

// The loop every kernel shares: kernel(v, tangents) for every dense vertex, primitive by
// primitive (`tangents`: the vertex's primitive has tangents to write).
template <class Kernel>
void for_each_dense_vertex(const Deformable& d, bool with_normals, const DenseOutput& out, Kernel&& kernel) {
  for (const PrimitiveRecord& primitive : d.primitives) {
    const uint32_t end = primitive.first_vertex + primitive.vertex_count;
    const bool tangents = with_normals && primitive.has_tangents && out.tangents;
    for (uint32_t v = primitive.first_vertex; v < end; ++v) kernel(v, tangents);
  }
}

// A rest tangent through the blended matrix m's linear part, renormalised, w kept.
inline glm::vec4 skinned_tangent(const float* m, const glm::vec4& rest) {
  return glm::vec4(normalize_or(transform_vector(m, glm::vec3(rest)), glm::vec3(rest)), rest.w);
}

#if defined(__SSE2__)
// LBS four lanes at a time, bit for bit the portable kernel's result: the blend adds w·row in
// influence order (the same multiply and add per element), the rows are transposed to columns
// so that x' = ((c0·x + c1·y) + c2·z) + c3 per lane is transform_point's sum in its order, and
// the normal's length is (x² + y²) + z² as glm::dot sums it. Tangents take the portable path.
inline void store3(glm::vec3& out, __m128 v) {
  _mm_storel_pi(reinterpret_cast<__m64*>(&out.x), v);
  _mm_store_ss(&out.z, _mm_movehl_ps(v, v));
}

void skin_linear_sse2(const Deformable& d, const JointAffine* joints, bool with_normals, const DenseOutput& out) {
  const uint32_t influences = d.influences;
  const uint16_t* joint_index = d.dense_joints.data();
  const float* weight = d.dense_weights.data();
  const glm::vec3* rest_positions = d.rest_positions.data();
  const glm::vec3* rest_normals = d.rest_normals.data();
  for_each_dense_vertex(d, with_normals, out, [&](uint32_t v, bool tangents) {
    const size_t first = size_t(v) * influences;
    __m128 r0 = _mm_setzero_ps(), r1 = r0, r2 = r0;
    for (uint32_t k = 0; k < influences; ++k) {
      const __m128 w = _mm_set1_ps(weight[first + k]);
      const float* m = joints[joint_index[first + k]].m;
      r0 = _mm_add_ps(r0, _mm_mul_ps(w, _mm_loadu_ps(m)));
      r1 = _mm_add_ps(r1, _mm_mul_ps(w, _mm_loadu_ps(m + 4)));
      r2 = _mm_add_ps(r2, _mm_mul_ps(w, _mm_loadu_ps(m + 8)));
    }
    __m128 c0 = r0, c1 = r1, c2 = r2, c3 = _mm_setzero_ps();
    _MM_TRANSPOSE4_PS(c0, c1, c2, c3);
    const glm::vec3 p = rest_positions[v];
    const __m128 xy = _mm_add_ps(_mm_mul_ps(c0, _mm_set1_ps(p.x)), _mm_mul_ps(c1, _mm_set1_ps(p.y)));
    store3(out.positions[v], _mm_add_ps(_mm_add_ps(xy, _mm_mul_ps(c2, _mm_set1_ps(p.z))), c3));
    if (with_normals) {
      const glm::vec3 n = rest_normals[v];
      const __m128 t = _mm_add_ps(_mm_add_ps(_mm_mul_ps(c0, _mm_set1_ps(n.x)), _mm_mul_ps(c1, _mm_set1_ps(n.y))),
                                  _mm_mul_ps(c2, _mm_set1_ps(n.z)));
      const __m128 sq = _mm_mul_ps(t, t);
      const __m128 sum = _mm_add_ss(_mm_add_ss(sq, _mm_shuffle_ps(sq, sq, 1)), _mm_movehl_ps(sq, sq));
      const float length = _mm_cvtss_f32(_mm_sqrt_ss(sum));
      if (length > 1e-30f && std::isfinite(length))
        store3(out.normals[v], _mm_div_ps(t, _mm_set1_ps(length)));
      else
        out.normals[v] = n;
    }
    if (tangents) {
      alignas(16) float m[12];
      _mm_store_ps(m, r0);
      _mm_store_ps(m + 4, r1);
      _mm_store_ps(m + 8, r2);
      out.tangents[v] = skinned_tangent(m, d.rest_tangents[v]);
    }
  });
}
#endif

#if defined(SKELFORM_SKINNING_AVX2)
// LBS with AVX2 (chosen at run time), bit for bit the portable kernel's result like the SSE2
// kernel: the blend reads the caller's column-major matrices as they were given
// (JointTransforms::matrices; affine's rows are the same floats), columns 0|1 and 2|3 in one
// 8-lane register each, so an influence costs two multiplies and two adds instead of three of
// each and the transpose; each element is still w·m added in influence order, and the
// position and normal sums are the SSE2 kernel's. No FMA: one rounding instead of two would
// change the bits (and the build turns contraction off for the same reason).
template <uint32_t kInfluences>
__attribute__((target("avx2"))) void skin_linear_avx2_range(const Deformable& d, const glm::mat4* matrices,
                                                            bool with_normals, bool tangents, uint32_t begin,
                                                            uint32_t end, const DenseOutput& out) {
  const uint32_t influences = kInfluences != 0 ? kInfluences : d.influences;
  const uint16_t* joint_index = d.dense_joints.data();
  const float* weight = d.dense_weights.data();
  const glm::vec3* rest_positions = d.rest_positions.data();
  const glm::vec3* rest_normals = d.rest_normals.data();
  for (uint32_t v = begin; v < end; ++v) {
    const size_t first = size_t(v) * influences;
    __m256 a = _mm256_setzero_ps(), b = a;  // columns 0|1, 2|3 (lane 3 of each: the bottom row, unused)
    for (uint32_t k = 0; k < influences; ++k) {
      const __m256 w = _mm256_broadcast_ss(weight + first + k);
      const float* m = &matrices[joint_index[first + k]][0][0];
      a = _mm256_add_ps(a, _mm256_mul_ps(w, _mm256_loadu_ps(m)));
      b = _mm256_add_ps(b, _mm256_mul_ps(w, _mm256_loadu_ps(m + 8)));
    }
    const __m128 c0 = _mm256_castps256_ps128(a), c1 = _mm256_extractf128_ps(a, 1);
    const __m128 c2 = _mm256_castps256_ps128(b), c3 = _mm256_extractf128_ps(b, 1);
    const float* p = &rest_positions[v].x;
    const __m128 xy = _mm_add_ps(_mm_mul_ps(c0, _mm_broadcast_ss(p)), _mm_mul_ps(c1, _mm_broadcast_ss(p + 1)));
    store3(out.positions[v], _mm_add_ps(_mm_add_ps(xy, _mm_mul_ps(c2, _mm_broadcast_ss(p + 2))), c3));
    if (with_normals) {
      const float* n = &rest_normals[v].x;
      const __m128 t =
          _mm_add_ps(_mm_add_ps(_mm_mul_ps(c0, _mm_broadcast_ss(n)), _mm_mul_ps(c1, _mm_broadcast_ss(n + 1))),
                     _mm_mul_ps(c2, _mm_broadcast_ss(n + 2)));
      const __m128 sq = _mm_mul_ps(t, t);
      const __m128 sum = _mm_add_ss(_mm_add_ss(sq, _mm_shuffle_ps(sq, sq, 1)), _mm_movehl_ps(sq, sq));
      const float length = _mm_cvtss_f32(_mm_sqrt_ss(sum));
      if (length > 1e-30f && std::isfinite(length))
        store3(out.normals[v], _mm_div_ps(t, _mm_set1_ps(length)));
      else
        out.normals[v] = rest_normals[v];
    }
    if (tangents) {
      alignas(32) float columns[16];
      _mm256_store_ps(columns, a);
      _mm256_store_ps(columns + 8, b);
      float m[12];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) m[4 * r + c] = columns[4 * c + r];
      out.tangents[v] = skinned_tangent(m, d.rest_tangents[v]);
    }
  }
}

void skin_linear_avx2(const Deformable& d, const glm::mat4* matrices, bool with_normals, const DenseOutput& out) {
  for (const PrimitiveRecord& primitive : d.primitives) {
    const uint32_t begin = primitive.first_vertex, end = begin + primitive.vertex_count;
    const bool tangents = with_normals && primitive.has_tangents && out.tangents;
    if (d.influences == 4)
      skin_linear_avx2_range<4>(d, matrices, with_normals, tangents, begin, end, out);
    else if (d.influences == 8)
      skin_linear_avx2_range<8>(d, matrices, with_normals, tangents, begin, end, out);
    else
      skin_linear_avx2_range<0>(d, matrices, with_normals, tangents, begin, end, out);
  }
}

bool cpu_has_avx2() {
  static const bool has = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return has;
}
#endif

// One instantiation per blend so the per-vertex kernel is a direct call the compiler can inline.
template <class Joint, void (*BlendFn)(const Joint*, const uint16_t*, const float*, uint32_t, float*)>
void skin_vertices(const Deformable& d, const Joint* joints, bool with_normals, const DenseOutput& out) {
  const uint32_t influences = d.influences;
  const uint16_t* joint_index = d.dense_joints.data();
  const float* weight = d.dense_weights.data();
  const glm::vec3* rest_positions = d.rest_positions.data();
  const glm::vec3* rest_normals = d.rest_normals.data();
  for_each_dense_vertex(d, with_normals, out, [&](uint32_t v, bool tangents) {
    const size_t first = size_t(v) * influences;
    float m[12];
    BlendFn(joints, joint_index + first, weight + first, influences, m);
    out.positions[v] = transform_point(m, rest_positions[v]);
    if (with_normals) out.normals[v] = normalize_or(transform_vector(m, rest_normals[v]), rest_normals[v]);
    if (tangents) out.tangents[v] = skinned_tangent(m, d.rest_tangents[v]);
  });
}

}  // namespace

bool linear_kernel_available(LinearKernel kernel) {
  switch (kernel) {
    case LinearKernel::portable:
      return true;
    case LinearKernel::sse2:
#if defined(__SSE2__)
      return true;
#else
      return false;
#endif
    case LinearKernel::avx2:
#if defined(SKELFORM_SKINNING_AVX2)
      return cpu_has_avx2();
#else
      return false;
#endif
  }
  return false;
}

void dense_skinning_linear(const Deformable& d, const JointTransforms& joints, LinearKernel kernel, bool with_normals,
                           const DenseOutput& out) {
  switch (kernel) {
#if defined(SKELFORM_SKINNING_AVX2)
    case LinearKernel::avx2:
      if (cpu_has_avx2()) return skin_linear_avx2(d, joints.matrices.data(), with_normals, out);
      break;
#endif
#if defined(__SSE2__)
    case LinearKernel::sse2:
      return skin_linear_sse2(d, joints.affine.data(), with_normals, out);
#endif
    default:
      break;
  }
  skin_vertices<JointAffine, blend_affine>(d, joints.affine.data(), with_normals, out);
}

void dense_skinning(const Deformable& d, const JointTransforms& joints, Blend blend, bool with_normals,
                    const DenseOutput& out) {
  if (blend == Blend::linear) {
#if defined(SKELFORM_SKINNING_AVX2)
    if (cpu_has_avx2()) return skin_linear_avx2(d, joints.matrices.data(), with_normals, out);
#endif
#if defined(__SSE2__)
    skin_linear_sse2(d, joints.affine.data(), with_normals, out);
#else
    skin_vertices<JointAffine, blend_affine>(d, joints.affine.data(), with_normals, out);
#endif
  } else {
    skin_vertices<JointDualQuaternion, blend_dual_quaternion>(d, joints.dual_quaternion.data(), with_normals, out);
  }
}

}  // namespace skelform::runtime
