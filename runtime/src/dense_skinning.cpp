// The baselines SF_METHOD_LBS and SF_METHOD_DQS: the glTF skin applied straight to the
// original vertices (DESIGN.md "per-frame cost": timed beside skelform on the same mesh and
// pose, through the same call path). Written like ozz-animation's SkinningJob: one pass
// over the vertices, a fixed number of influences per vertex (zero-weight slots name joint 0
// and add nothing, so the blend loop has no branch), the blend a tight loop over 12 (LBS) or
// 17 (DQS) contiguous floats the compiler vectorises, all in float.
//
// Normals and tangents go through the blended matrix's linear part and are renormalised (the
// usual engine shortcut, exact for rigid and uniformly scaled blends); tangent w is kept.
//
// Every kernel works on a range of one primitive's vertices and writes through a sink: the
// instance's arrays (sf_instance_evaluate) or the caller's strided streams
// (sf_instance_skin_range), the same floats either way.
#include "cpu.h"
#include "instance.h"

#include <cmath>
#include <cstring>

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif
#if defined(SKELFORM_HAS_AVX2_KERNELS)
#  include <immintrin.h>
#endif

namespace skelform::runtime {

namespace {

// Where a kernel puts vertex v's position, normal and tangent: the instance's arrays, indexed
// by dense vertex.
// Sinks and ranges are held by value in the kernels: a store through a sink could otherwise
// alias them, and the compiler would reload them after every store.
struct ArraySink {
  DenseOutput out;
  void* position(uint32_t v) const { return &out.positions[v]; }
  void* normal(uint32_t v) const { return &out.normals[v]; }
  void* tangent(uint32_t v) const { return &out.tangents[v]; }
};

// The caller's strided streams (StridedOutput), element 0 being vertex `first`.
struct StridedSink {
  StridedOutput out;
  uint32_t first;
  void* position(uint32_t v) const { return out.positions + size_t(v - first) * out.position_stride; }
  void* normal(uint32_t v) const { return out.normals + size_t(v - first) * out.normal_stride; }
  void* tangent(uint32_t v) const { return out.tangents + size_t(v - first) * out.tangent_stride; }
};

inline void put3(void* out, const glm::vec3& value) { std::memcpy(out, &value, sizeof value); }
inline void put4(void* out, const glm::vec4& value) { std::memcpy(out, &value, sizeof value); }

// A rest tangent through the blended matrix m's linear part, renormalised, w kept.
inline glm::vec4 skinned_tangent(const float* m, const glm::vec4& rest) {
  return glm::vec4(normalize_or(transform_vector(m, glm::vec3(rest)), glm::vec3(rest)), rest.w);
}

// What a kernel skins: vertices [begin, end) of one primitive, normals (and, where the
// primitive has them, tangents) or positions only.
struct Range {
  uint32_t begin, end;
  bool normals, tangents;
};

#if defined(__SSE2__)
// Stores lanes 0-2 (nothing past them: the caller's element may end there), at any byte
// address: the caller's strides need not be multiples of 4.
inline void store3(void* out, __m128 v) {
  _mm_storeu_si64(out, _mm_castps_si128(v));
  _mm_storeu_si32(static_cast<unsigned char*>(out) + 8, _mm_castps_si128(_mm_movehl_ps(v, v)));
}

// Lanes 0-2 of the OR of every position: any lane not finite leaves a NaN in `sticky`
// (x·0 is NaN exactly for an infinite or NaN x, and NaN stays NaN under addition).
inline __m128 accumulate_non_finite(__m128 sticky, __m128 position) {
  return _mm_add_ps(sticky, _mm_mul_ps(position, _mm_setzero_ps()));
}

inline bool lanes_finite(__m128 sticky) {
  alignas(16) float lanes[4];
  _mm_store_ps(lanes, sticky);
  return lanes[0] == 0.0f && lanes[1] == 0.0f && lanes[2] == 0.0f;  // lane 3: the bottom row, not output
}

// The rest direction u (a normal, a tangent's xyz) through the blend's linear part (columns
// c0, c1, c2; lane 3 unused), renormalised, into out (xyz), as the portable loop computes it:
// (c0·x + c1·y) + c2·z per lane (transform_vector's order), the length of (x² + y²) + z²
// (glm::dot's), and u itself where that is not above 1e-30 or not finite (normalize_or).
inline void unit_direction(__m128 c0, __m128 c1, __m128 c2, const float* u, void* out) {
  const __m128 t = _mm_add_ps(_mm_add_ps(_mm_mul_ps(c0, _mm_set1_ps(u[0])), _mm_mul_ps(c1, _mm_set1_ps(u[1]))),
                              _mm_mul_ps(c2, _mm_set1_ps(u[2])));
  const __m128 sq = _mm_mul_ps(t, t);
  const __m128 sum = _mm_add_ss(_mm_add_ss(sq, _mm_shuffle_ps(sq, sq, 1)), _mm_movehl_ps(sq, sq));
  const float length = _mm_cvtss_f32(_mm_sqrt_ss(sum));
  if (length > 1e-30f && std::isfinite(length))
    store3(out, _mm_div_ps(t, _mm_set1_ps(length)));
  else
    std::memcpy(out, u, 3 * sizeof(float));
}

// Vertex v's position, normal and tangent from its blend's columns c0..c3 (lane 3 unused):
// x' = ((c0·x + c1·y) + c2·z) + c3 per lane, transform_point's sum in its order. Returns
// `sticky` with the position accumulated (accumulate_non_finite).
template <class Sink>
inline __m128 finish_vertex(const Deformable& d, uint32_t v, const Range& range, const Sink& sink, __m128 c0, __m128 c1,
                            __m128 c2, __m128 c3, __m128 sticky) {
  const float* p = &d.rest_positions[v].x;
  const __m128 xy = _mm_add_ps(_mm_mul_ps(c0, _mm_set1_ps(p[0])), _mm_mul_ps(c1, _mm_set1_ps(p[1])));
  const __m128 position = _mm_add_ps(_mm_add_ps(xy, _mm_mul_ps(c2, _mm_set1_ps(p[2]))), c3);
  store3(sink.position(v), position);
  if (range.normals) unit_direction(c0, c1, c2, &d.rest_normals[v].x, sink.normal(v));
  if (range.tangents) {
    const glm::vec4& rest = d.rest_tangents[v];
    unsigned char* out = static_cast<unsigned char*>(sink.tangent(v));
    unit_direction(c0, c1, c2, &rest.x, out);
    std::memcpy(out + 3 * sizeof(float), &rest.w, sizeof(float));  // the handedness as authored
  }
  return accumulate_non_finite(sticky, position);
}

// LBS four lanes at a time, bit for bit the portable kernel's result: the blend adds w·row in
// influence order (the same multiply and add per element), the rows are transposed to columns
// so that x' = ((c0·x + c1·y) + c2·z) + c3 per lane is transform_point's sum in its order, and
// the normal's length is (x² + y²) + z² as glm::dot sums it (finish_vertex).
template <class Sink>
bool skin_linear_sse2(const Deformable& d, const JointAffine* joints, Range range, Sink sink) {
  const uint32_t influences = d.influences;
  const uint16_t* joint_index = d.dense_joints.data();
  const float* weight = d.dense_weights.data();
  __m128 sticky = _mm_setzero_ps();
  for (uint32_t v = range.begin; v < range.end; ++v) {
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
    sticky = finish_vertex(d, v, range, sink, c0, c1, c2, c3, sticky);
  }
  return lanes_finite(sticky);
}
#endif

#if defined(SKELFORM_HAS_AVX2_KERNELS)
// LBS with AVX2 (chosen at run time), bit for bit the portable kernel's result like the SSE2
// kernel: the blend reads the caller's column-major matrices as they were given
// (JointTransforms::matrices; affine's rows are the same floats), columns 0|1 and 2|3 in one
// 8-lane register each, so an influence costs two multiplies and two adds instead of three of
// each and the transpose; each element is still w·m added in influence order, and the
// position and normal sums are the SSE2 kernel's. No FMA: one rounding instead of two would
// change the bits (and the build turns contraction off for the same reason).
// Vertex v's blend: columns 0|1 in a, 2|3 in b (lane 3 of each: the bottom row, unused).
template <uint32_t kInfluences>
__attribute__((target("avx2"))) inline void blend_columns_avx2(const uint16_t* joint_index, const float* weight,
                                                               uint32_t influences, const glm::mat4* matrices,
                                                               size_t first, __m256& a, __m256& b) {
  a = _mm256_setzero_ps();
  b = a;
  for (uint32_t k = 0; k < influences; ++k) {
    const __m256 w = _mm256_broadcast_ss(weight + first + k);
    const float* m = &matrices[joint_index[first + k]][0][0];
    a = _mm256_add_ps(a, _mm256_mul_ps(w, _mm256_loadu_ps(m)));
    b = _mm256_add_ps(b, _mm256_mul_ps(w, _mm256_loadu_ps(m + 8)));
  }
}

// [x of u ×4 | x of w ×4]: one coordinate of two vertices, one per half.
__attribute__((target("avx2"))) inline __m256 pair_broadcast(const float* u, const float* w) {
  return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_broadcast_ss(u)), _mm_broadcast_ss(w), 1);
}

// The rest directions u0, u1 (a normal, a tangent's xyz) of the halves' two vertices through
// their blends' linear parts (c0, c1, c2), renormalised, into out0 / out1 (xyz): per lane the
// one-vertex sums, (c0·x + c1·y) + c2·z, the length of (x² + y²) + z², and the rest direction
// itself where that length is not above 1e-30 or not finite (normalize_or).
__attribute__((target("avx2"))) inline void pair_unit(__m256 c0, __m256 c1, __m256 c2, const float* u0, const float* u1,
                                                      void* out0, void* out1) {
  const __m256 t = _mm256_add_ps(
      _mm256_add_ps(_mm256_mul_ps(c0, pair_broadcast(u0, u1)), _mm256_mul_ps(c1, pair_broadcast(u0 + 1, u1 + 1))),
      _mm256_mul_ps(c2, pair_broadcast(u0 + 2, u1 + 2)));
  const __m256 sq = _mm256_mul_ps(t, t);
  // Lane 0 of each half: (x² + y²) + z², then in every lane of its half.
  const __m256 sum = _mm256_add_ps(_mm256_add_ps(sq, _mm256_permute_ps(sq, 1)), _mm256_permute_ps(sq, 2));
  const __m256 length = _mm256_sqrt_ps(_mm256_permute_ps(sum, 0));
  const __m256 usable = _mm256_and_ps(_mm256_cmp_ps(length, _mm256_set1_ps(1e-30f), _CMP_GT_OQ),
                                      _mm256_cmp_ps(length, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
  const int lanes = _mm256_movemask_ps(usable);
  const __m256 unit = _mm256_div_ps(t, length);
  if (lanes & 0x01)
    store3(out0, _mm256_castps256_ps128(unit));
  else
    std::memcpy(out0, u0, 3 * sizeof(float));
  if (lanes & 0x10)
    store3(out1, _mm256_extractf128_ps(unit, 1));
  else
    std::memcpy(out1, u1, 3 * sizeof(float));
}

template <uint32_t kInfluences, class Sink>
__attribute__((target("avx2"))) bool skin_linear_avx2(const Deformable& d, const glm::mat4* matrices, Range range,
                                                      Sink sink) {
  const uint32_t influences = kInfluences != 0 ? kInfluences : d.influences;
  const uint16_t* joint_index = d.dense_joints.data();
  const float* weight = d.dense_weights.data();
  const glm::vec3* rest_positions = d.rest_positions.data();
  const glm::vec3* rest_normals = d.rest_normals.data();
  __m128 sticky = _mm_setzero_ps();
  // Two vertices at a time, one per 128-bit half: every lane runs the one-vertex sums below.
  uint32_t v = range.begin;
  for (; v + 1 < range.end; v += 2) {
    __m256 a0, b0, a1, b1;
    blend_columns_avx2<kInfluences>(joint_index, weight, influences, matrices, size_t(v) * influences, a0, b0);
    blend_columns_avx2<kInfluences>(joint_index, weight, influences, matrices, size_t(v + 1) * influences, a1, b1);
    const __m256 c0 = _mm256_permute2f128_ps(a0, a1, 0x20), c1 = _mm256_permute2f128_ps(a0, a1, 0x31);
    const __m256 c2 = _mm256_permute2f128_ps(b0, b1, 0x20), c3 = _mm256_permute2f128_ps(b0, b1, 0x31);
    const float *p0 = &rest_positions[v].x, *p1 = &rest_positions[v + 1].x;
    const __m256 xy =
        _mm256_add_ps(_mm256_mul_ps(c0, pair_broadcast(p0, p1)), _mm256_mul_ps(c1, pair_broadcast(p0 + 1, p1 + 1)));
    const __m256 position = _mm256_add_ps(_mm256_add_ps(xy, _mm256_mul_ps(c2, pair_broadcast(p0 + 2, p1 + 2))), c3);
    const __m128 position0 = _mm256_castps256_ps128(position), position1 = _mm256_extractf128_ps(position, 1);
    sticky = accumulate_non_finite(accumulate_non_finite(sticky, position0), position1);
    store3(sink.position(v), position0);
    store3(sink.position(v + 1), position1);
    if (range.normals)
      pair_unit(c0, c1, c2, &rest_normals[v].x, &rest_normals[v + 1].x, sink.normal(v), sink.normal(v + 1));
    if (range.tangents) {
      const glm::vec4 *t0 = &d.rest_tangents[v], *t1 = &d.rest_tangents[v + 1];
      unsigned char *out0 = static_cast<unsigned char*>(sink.tangent(v)),
                    *out1 = static_cast<unsigned char*>(sink.tangent(v + 1));
      pair_unit(c0, c1, c2, &t0->x, &t1->x, out0, out1);
      std::memcpy(out0 + 3 * sizeof(float), &t0->w, sizeof(float));  // the handedness as authored
      std::memcpy(out1 + 3 * sizeof(float), &t1->w, sizeof(float));
    }
  }
  for (; v < range.end; ++v) {
    __m256 a, b;
    blend_columns_avx2<kInfluences>(joint_index, weight, influences, matrices, size_t(v) * influences, a, b);
    sticky = finish_vertex(d, v, range, sink, _mm256_castps256_ps128(a), _mm256_extractf128_ps(a, 1),
                           _mm256_castps256_ps128(b), _mm256_extractf128_ps(b, 1), sticky);
  }
  return lanes_finite(sticky);
}

template <class Sink>
bool skin_linear_avx2_any(const Deformable& d, const glm::mat4* matrices, Range range, Sink sink) {
  if (d.influences == 4) return skin_linear_avx2<4>(d, matrices, range, sink);
  if (d.influences == 8) return skin_linear_avx2<8>(d, matrices, range, sink);
  return skin_linear_avx2<0>(d, matrices, range, sink);
}
#endif

// The portable loop, one instantiation per blend so the per-vertex kernel is a direct call
// the compiler can inline.
template <class Joint, void (*BlendFn)(const Joint*, const uint16_t*, const float*, uint32_t, float*), class Sink>
bool skin_vertices(const Deformable& d, const Joint* joints, Range range, Sink sink) {
  const uint32_t influences = d.influences;
  const uint16_t* joint_index = d.dense_joints.data();
  const float* weight = d.dense_weights.data();
  const glm::vec3* rest_positions = d.rest_positions.data();
  const glm::vec3* rest_normals = d.rest_normals.data();
  glm::vec3 sticky(0.0f);  // as the SIMD kernels' (accumulate_non_finite): NaN once a position is not finite
  for (uint32_t v = range.begin; v < range.end; ++v) {
    const size_t first = size_t(v) * influences;
    float m[12];
    BlendFn(joints, joint_index + first, weight + first, influences, m);
    const glm::vec3 position = transform_point(m, rest_positions[v]);
    sticky += position * 0.0f;
    put3(sink.position(v), position);
    if (range.normals) put3(sink.normal(v), normalize_or(transform_vector(m, rest_normals[v]), rest_normals[v]));
    if (range.tangents) put4(sink.tangent(v), skinned_tangent(m, d.rest_tangents[v]));
  }
  return sticky.x == 0.0f && sticky.y == 0.0f && sticky.z == 0.0f;
}

// One range through the chosen kernel (an unavailable one runs the portable loop).
template <class Sink>
bool skin_range(const Deformable& d, const JointTransforms& joints, Blend blend, LinearKernel kernel, Range range,
                Sink sink) {
  if (blend == Blend::dual_quaternion)
    return skin_vertices<JointDualQuaternion, blend_dual_quaternion>(d, joints.dual_quaternion.data(), range, sink);
  switch (kernel) {
#if defined(SKELFORM_HAS_AVX2_KERNELS)
    case LinearKernel::avx2:
      if (cpu_has_avx2()) return skin_linear_avx2_any(d, joints.matrices.data(), range, sink);
      break;
#endif
#if defined(__SSE2__)
    case LinearKernel::sse2:
      return skin_linear_sse2(d, joints.affine.data(), range, sink);
#endif
    default:
      break;
  }
  return skin_vertices<JointAffine, blend_affine>(d, joints.affine.data(), range, sink);
}

// The fastest kernel this build and CPU run.
LinearKernel best_linear_kernel() {
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (cpu_has_avx2()) return LinearKernel::avx2;
#endif
#if defined(__SSE2__)
  return LinearKernel::sse2;
#else
  return LinearKernel::portable;
#endif
}

bool skin_all(const Deformable& d, const JointTransforms& joints, Blend blend, LinearKernel kernel, bool with_normals,
              const DenseOutput& out) {
  bool finite = true;
  const ArraySink sink{out};
  for (const PrimitiveRecord& primitive : d.primitives) {
    const Range range{primitive.first_vertex, primitive.first_vertex + primitive.vertex_count, with_normals,
                      with_normals && primitive.has_tangents && out.tangents};
    finite &= skin_range(d, joints, blend, kernel, range, sink);
  }
  return finite;
}

// Vertices [first, first + count) of one primitive into the caller's streams.
bool skin_strided(const Deformable& d, const JointTransforms& joints, Blend blend, LinearKernel kernel,
                  uint32_t primitive, uint32_t first, uint32_t count, const StridedOutput& out) {
  const uint32_t begin = d.primitives[primitive].first_vertex + first;
  const Range range{begin, begin + count, out.normals != nullptr, out.tangents != nullptr};
  return skin_range(d, joints, blend, kernel, range, StridedSink{out, begin});
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
#if defined(SKELFORM_HAS_AVX2_KERNELS)
      return cpu_has_avx2();
#else
      return false;
#endif
  }
  return false;
}

bool dense_skinning_linear(const Deformable& d, const JointTransforms& joints, LinearKernel kernel, bool with_normals,
                           const DenseOutput& out) {
  return skin_all(d, joints, Blend::linear, kernel, with_normals, out);
}

bool dense_skinning(const Deformable& d, const JointTransforms& joints, Blend blend, bool with_normals,
                    const DenseOutput& out) {
  return skin_all(d, joints, blend, best_linear_kernel(), with_normals, out);
}

bool dense_skinning_linear_range(const Deformable& d, const JointTransforms& joints, LinearKernel kernel,
                                 uint32_t primitive, uint32_t first, uint32_t count, const StridedOutput& out) {
  return skin_strided(d, joints, Blend::linear, kernel, primitive, first, count, out);
}

bool dense_skinning_range(const Deformable& d, const JointTransforms& joints, Blend blend, uint32_t primitive,
                          uint32_t first, uint32_t count, const StridedOutput& out) {
  return skin_strided(d, joints, blend, best_linear_kernel(), primitive, first, count, out);
}

}  // namespace skelform::runtime
