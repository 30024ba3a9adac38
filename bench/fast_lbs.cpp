#include "fast_lbs.h"

#include <cmath>
#include <stdexcept>

#if defined(__x86_64__) || defined(_M_X64)
#  include <immintrin.h>
#  define SKELFORM_BENCH_X86 1
#endif

namespace skelform::bench {

namespace {

// A glTF joint matrix is column-major: its first three columns and the translation, each with
// the bottom row's entry in lane 3, are the 3x4 blend's four columns as they are stored. The
// blend reads them in place.
constexpr size_t kMatrixFloats = 16;

void skin_portable(const float* m, const float* positions, const float* normals, const uint32_t* joints,
                   const float* weights, size_t influences, size_t vertices, float* out, size_t stride) {
  for (size_t v = 0; v < vertices; ++v, out += stride) {
    float c[12] = {};
    for (size_t k = 0; k < influences; ++k) {
      const float w = weights[v * influences + k];
      const float* j = m + joints[v * influences + k];
      for (int col = 0; col < 4; ++col)
        for (int r = 0; r < 3; ++r) c[3 * col + r] += w * j[4 * col + r];
    }
    const float* p = positions + 4 * v;
    const float* n = normals + 4 * v;
    float q[3], d[3];
    for (int r = 0; r < 3; ++r) {
      q[r] = c[r] * p[0] + c[3 + r] * p[1] + c[6 + r] * p[2] + c[9 + r];
      d[r] = c[r] * n[0] + c[3 + r] * n[1] + c[6 + r] * n[2];
    }
    const float length = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    const float inverse = length > 0.0f ? 1.0f / length : 0.0f;
    for (int r = 0; r < 3; ++r) {
      out[r] = q[r];
      out[3 + r] = d[r] * inverse;
    }
  }
}

#if defined(SKELFORM_BENCH_X86)

// Stores lanes 0-2 (no write past them: the buffer may end there).
inline void store3(float* out, __m128 value) {
  _mm_storel_pi(reinterpret_cast<__m64*>(out), value);
  _mm_store_ss(out + 2, _mm_movehl_ps(value, value));
}

void skin_sse2(const float* m, const float* positions, const float* normals, const uint32_t* joints,
               const float* weights, size_t influences, size_t vertices, float* out, size_t stride) {
  for (size_t v = 0; v < vertices; ++v, out += stride) {
    __m128 c0 = _mm_setzero_ps(), c1 = c0, c2 = c0, c3 = c0;
    for (size_t k = 0; k < influences; ++k) {
      const __m128 w = _mm_set1_ps(weights[v * influences + k]);
      const float* j = m + joints[v * influences + k];
      c0 = _mm_add_ps(c0, _mm_mul_ps(w, _mm_loadu_ps(j)));
      c1 = _mm_add_ps(c1, _mm_mul_ps(w, _mm_loadu_ps(j + 4)));
      c2 = _mm_add_ps(c2, _mm_mul_ps(w, _mm_loadu_ps(j + 8)));
      c3 = _mm_add_ps(c3, _mm_mul_ps(w, _mm_loadu_ps(j + 12)));
    }
    const float* p = positions + 4 * v;
    const float* n = normals + 4 * v;
    const __m128 q = _mm_add_ps(_mm_add_ps(_mm_mul_ps(c0, _mm_set1_ps(p[0])), _mm_mul_ps(c1, _mm_set1_ps(p[1]))),
                                _mm_add_ps(_mm_mul_ps(c2, _mm_set1_ps(p[2])), c3));
    const __m128 d = _mm_add_ps(_mm_add_ps(_mm_mul_ps(c0, _mm_set1_ps(n[0])), _mm_mul_ps(c1, _mm_set1_ps(n[1]))),
                                _mm_mul_ps(c2, _mm_set1_ps(n[2])));
    // |d|² in every lane (lane 3 of d is 0: the columns' bottom row is 0 for a normal).
    __m128 s = _mm_mul_ps(d, d);
    s = _mm_add_ps(s, _mm_shuffle_ps(s, s, _MM_SHUFFLE(2, 3, 0, 1)));
    s = _mm_add_ps(s, _mm_shuffle_ps(s, s, _MM_SHUFFLE(1, 0, 3, 2)));
    store3(out, q);
    store3(out + 3, _mm_div_ps(d, _mm_sqrt_ps(_mm_max_ps(s, _mm_set1_ps(1e-30f)))));
  }
}

// Four influences, the common case, unrolled; other counts take the loop.
template <size_t kInfluences>
__attribute__((target("avx2,fma"))) void skin_avx2(const float* m, const float* positions, const float* normals,
                                                   const uint32_t* joints, const float* weights, size_t influences,
                                                   size_t vertices, float* out, size_t stride) {
  const size_t count = kInfluences ? kInfluences : influences;
  for (size_t v = 0; v < vertices; ++v, out += stride) {
    const uint32_t* jv = joints + v * count;
    const float* wv = weights + v * count;
    __m256 a = _mm256_setzero_ps(), b = a;  // columns 0|1 and 2|3
    for (size_t k = 0; k < count; ++k) {
      const __m256 w = _mm256_broadcast_ss(wv + k);
      const float* j = m + jv[k];
      a = _mm256_fmadd_ps(w, _mm256_loadu_ps(j), a);
      b = _mm256_fmadd_ps(w, _mm256_loadu_ps(j + 8), b);
    }
    const __m128 c0 = _mm256_castps256_ps128(a), c1 = _mm256_extractf128_ps(a, 1);
    const __m128 c2 = _mm256_castps256_ps128(b), c3 = _mm256_extractf128_ps(b, 1);
    const float* p = positions + 4 * v;
    const float* n = normals + 4 * v;
    const __m128 q =
        _mm_fmadd_ps(c0, _mm_broadcast_ss(p),
                     _mm_fmadd_ps(c1, _mm_broadcast_ss(p + 1), _mm_fmadd_ps(c2, _mm_broadcast_ss(p + 2), c3)));
    const __m128 d = _mm_fmadd_ps(c0, _mm_broadcast_ss(n),
                                  _mm_fmadd_ps(c1, _mm_broadcast_ss(n + 1), _mm_mul_ps(c2, _mm_broadcast_ss(n + 2))));
    const __m128 s = _mm_dp_ps(d, d, 0x7F);
    store3(out, q);
    store3(out + 3, _mm_div_ps(d, _mm_sqrt_ps(_mm_max_ps(s, _mm_set1_ps(1e-30f)))));
  }
}

#endif

}  // namespace

FastLbs::FastLbs(const std::vector<float>& rest_positions, const std::vector<float>& rest_normals,
                 const std::vector<uint16_t>& joints, const std::vector<float>& weights, size_t influences)
    : influences_(influences), kernel_(0) {
  const size_t n = rest_positions.size() / 3;
  if (rest_positions.size() != 3 * n || rest_normals.size() != 3 * n || influences == 0 ||
      joints.size() != n * influences || weights.size() != joints.size())
    throw std::invalid_argument("FastLbs: inconsistent sizes");
  positions_.resize(4 * n);
  normals_.resize(4 * n);
  for (size_t v = 0; v < n; ++v)
    for (size_t c = 0; c < 3; ++c) {
      positions_[4 * v + c] = rest_positions[3 * v + c];
      normals_[4 * v + c] = rest_normals[3 * v + c];
    }
  for (size_t v = 0; v < n; ++v) positions_[4 * v + 3] = 1.0f;
  joints_.resize(joints.size());
  for (size_t i = 0; i < joints.size(); ++i) joints_[i] = uint32_t(joints[i]) * uint32_t(kMatrixFloats);
  weights_ = weights;
#if defined(SKELFORM_BENCH_X86)
  __builtin_cpu_init();
  kernel_ = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") ? 2 : 1;
#endif
}

const char* FastLbs::kernel() const { return kernel_ == 2 ? "avx2+fma" : kernel_ == 1 ? "sse2" : "portable"; }

void FastLbs::skin(const float* joint_matrices, float* out, size_t stride_floats) {
  const size_t n = vertex_count();
  const float *p = positions_.data(), *nr = normals_.data(), *w = weights_.data();
  const uint32_t* j = joints_.data();
#if defined(SKELFORM_BENCH_X86)
  if (kernel_ == 2) {
    if (influences_ == 4)
      skin_avx2<4>(joint_matrices, p, nr, j, w, influences_, n, out, stride_floats);
    else
      skin_avx2<0>(joint_matrices, p, nr, j, w, influences_, n, out, stride_floats);
    return;
  }
  if (kernel_ == 1) {
    skin_sse2(joint_matrices, p, nr, j, w, influences_, n, out, stride_floats);
    return;
  }
#endif
  skin_portable(joint_matrices, p, nr, j, w, influences_, n, out, stride_floats);
}

}  // namespace skelform::bench
