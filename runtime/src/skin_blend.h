// Per-vertex blending of joint transforms, shared by the skin driver of the skeletal mesh
// (drive_skeleton.cpp, DESIGN.md runtime step 1) and the dense LBS/DQS baselines
// (dense_skinning.cpp): both halves blend the same joint data the same way, so a comparison
// of skelform with its baselines compares methods, not kernels.
//
// The joint data is prepared once per pose (sf_instance_set_joint_matrices), in float:
//  - JointAffine: the glTF joint matrix as a row-major 3x4 (linear part | translation), so an
//    LBS blend is 12 multiply-adds per influence over contiguous floats (vectorisable, no
//    branch), as in ozz-animation's SkinningJob.
//  - JointDualQuaternion: its rigid part as a unit dual quaternion plus the non-rigid
//    remainder ("stretch", R^T·L) applied before it (Kavan et al. 2008, sec. 4, "scale and
//    shear"): identity joints stay exact, scaled joints still work.
// Header-only, no allocation, no exceptions.
#pragma once

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cmath>
#include <cstdint>

#if defined(__SSE2__)
#  include <emmintrin.h>
#endif

namespace skelform::runtime {

// Row-major 3x4 affine transform: row r is (m[4r], m[4r+1], m[4r+2] | m[4r+3]).
struct JointAffine {
  float m[12];
};

// Unit dual quaternion and the 3x3 stretch (row-major) applied before the rigid motion, in
// one array so a blend runs over 17 contiguous floats: [0, 4) real = rotation (x, y, z, w),
// [4, 8) dual = ½·(t, 0)⊗real, [8, 17) stretch; padded to 20 floats (80 bytes).
struct JointDualQuaternion {
  static constexpr int kReal = 0, kDual = 4, kStretch = 8, kBlended = 17;
  float data[20];
};

// The rotation of a 3x3 linear part, by Gram-Schmidt on its columns: exact for rigid and
// uniformly scaled joints; a mirrored one keeps a proper rotation (its reflection is left in
// the rest). Degenerate columns fall back to the identity axes, so no NaN.
inline glm::mat3 rotation_part(const glm::mat3& linear) {
  glm::vec3 x = linear[0], y = linear[1];
  const float lx = std::sqrt(glm::dot(x, x));
  x = lx > 1e-20f ? x / lx : glm::vec3(1, 0, 0);
  y -= glm::dot(y, x) * x;
  const float ly = std::sqrt(glm::dot(y, y));
  if (ly > 1e-20f) {
    y /= ly;
  } else {
    const glm::vec3 a = std::fabs(x.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    y = glm::normalize(a - glm::dot(a, x) * x);
  }
  return glm::mat3(x, y, glm::cross(x, y));
}

// Both representations of one column-major glTF joint matrix.
inline void prepare_joint(const glm::mat4& matrix, JointAffine& affine, JointDualQuaternion& dq) {
  for (int r = 0; r < 3; ++r) {
    affine.m[4 * r + 0] = matrix[0][r];
    affine.m[4 * r + 1] = matrix[1][r];
    affine.m[4 * r + 2] = matrix[2][r];
    affine.m[4 * r + 3] = matrix[3][r];
  }
  // The rigid part's rotation; a mirrored joint's reflection goes into the stretch.
  const glm::mat3 linear(matrix);
  const glm::mat3 rotation = rotation_part(linear);
  const glm::mat3 stretch = glm::transpose(rotation) * linear;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) dq.data[JointDualQuaternion::kStretch + 3 * r + c] = stretch[c][r];
  // Quaternion of the rotation (Shepperd's method: the largest diagonal term keeps it stable).
  const float trace = rotation[0][0] + rotation[1][1] + rotation[2][2];
  float q[4];  // x, y, z, w
  if (trace > 0.0f) {
    const float s = 2.0f * std::sqrt(trace + 1.0f);
    q[3] = 0.25f * s;
    q[0] = (rotation[1][2] - rotation[2][1]) / s;
    q[1] = (rotation[2][0] - rotation[0][2]) / s;
    q[2] = (rotation[0][1] - rotation[1][0]) / s;
  } else if (rotation[0][0] > rotation[1][1] && rotation[0][0] > rotation[2][2]) {
    const float s = 2.0f * std::sqrt(std::fmax(1.0f + rotation[0][0] - rotation[1][1] - rotation[2][2], 1e-20f));
    q[3] = (rotation[1][2] - rotation[2][1]) / s;
    q[0] = 0.25f * s;
    q[1] = (rotation[1][0] + rotation[0][1]) / s;
    q[2] = (rotation[2][0] + rotation[0][2]) / s;
  } else if (rotation[1][1] > rotation[2][2]) {
    const float s = 2.0f * std::sqrt(std::fmax(1.0f + rotation[1][1] - rotation[0][0] - rotation[2][2], 1e-20f));
    q[3] = (rotation[2][0] - rotation[0][2]) / s;
    q[0] = (rotation[1][0] + rotation[0][1]) / s;
    q[1] = 0.25f * s;
    q[2] = (rotation[2][1] + rotation[1][2]) / s;
  } else {
    const float s = 2.0f * std::sqrt(std::fmax(1.0f + rotation[2][2] - rotation[0][0] - rotation[1][1], 1e-20f));
    q[3] = (rotation[0][1] - rotation[1][0]) / s;
    q[0] = (rotation[2][0] + rotation[0][2]) / s;
    q[1] = (rotation[2][1] + rotation[1][2]) / s;
    q[2] = 0.25f * s;
  }
  const float qn = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (float& c : q) c /= qn;
  const glm::vec3 t(matrix[3]);
  // dual = ½ (t, 0) ⊗ real, quaternion product with the pure quaternion t.
  float* real = dq.data + JointDualQuaternion::kReal;
  float* dual = dq.data + JointDualQuaternion::kDual;
  for (int c = 0; c < 4; ++c) real[c] = q[c];
  dual[0] = 0.5f * (t.x * q[3] + t.y * q[2] - t.z * q[1]);
  dual[1] = 0.5f * (-t.x * q[2] + t.y * q[3] + t.z * q[0]);
  dual[2] = 0.5f * (t.x * q[1] - t.y * q[0] + t.z * q[3]);
  dual[3] = 0.5f * (-t.x * q[0] - t.y * q[1] - t.z * q[2]);
  for (int c = JointDualQuaternion::kBlended; c < 20; ++c) dq.data[c] = 0.0f;
}

// LBS: out = Σ w_k · joint[index_k] over `count` influences. Zero-weight slots (joint 0,
// weight 0) add nothing, so the loop needs no branch.
// With SSE2 the 12 entries are three lanes of four, each lane the scalar loop's additions in
// the same order (no fused multiply-add): the same bits.
inline void blend_affine(const JointAffine* joints, const uint16_t* index, const float* weight, uint32_t count,
                         float out[12]) {
#if defined(__SSE2__)
  __m128 row0 = _mm_setzero_ps(), row1 = _mm_setzero_ps(), row2 = _mm_setzero_ps();
  for (uint32_t k = 0; k < count; ++k) {
    const __m128 w = _mm_set1_ps(weight[k]);
    const float* m = joints[index[k]].m;
    row0 = _mm_add_ps(row0, _mm_mul_ps(w, _mm_loadu_ps(m)));
    row1 = _mm_add_ps(row1, _mm_mul_ps(w, _mm_loadu_ps(m + 4)));
    row2 = _mm_add_ps(row2, _mm_mul_ps(w, _mm_loadu_ps(m + 8)));
  }
  _mm_storeu_ps(out, row0);
  _mm_storeu_ps(out + 4, row1);
  _mm_storeu_ps(out + 8, row2);
#else
  for (int c = 0; c < 12; ++c) out[c] = 0.0f;
  for (uint32_t k = 0; k < count; ++k) {
    const float w = weight[k];
    const float* m = joints[index[k]].m;
    for (int c = 0; c < 12; ++c) out[c] += w * m[c];
  }
#endif
}

// DQS: blends the dual quaternions (each flipped to the hemisphere of the first influence's,
// so q and -q, the same rotation, do not cancel) and the stretches, normalises, and returns
// the equivalent row-major 3x4 affine (R(q)·stretch | t). A blend that cancels out (only with
// all weights zero) gives the identity rather than NaN.
inline void blend_dual_quaternion(const JointDualQuaternion* joints, const uint16_t* index, const float* weight,
                                  uint32_t count, float out[12]) {
  float b[17];
  for (int c = 0; c < 17; ++c) b[c] = 0.0f;
  const float* pivot = joints[index[0]].data;
  for (uint32_t k = 0; k < count; ++k) {
    const float* j = joints[index[k]].data;
    const float hemisphere = j[0] * pivot[0] + j[1] * pivot[1] + j[2] * pivot[2] + j[3] * pivot[3];
    const float wq = std::copysign(weight[k], hemisphere);
    const float ws = weight[k];
    for (int c = 0; c < 8; ++c) b[c] += wq * j[c];
    for (int c = 8; c < 17; ++c) b[c] += ws * j[c];
  }
  float norm = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2] + b[3] * b[3]);
  if (!(norm > 1e-20f)) {
    b[0] = b[1] = b[2] = 0.0f;
    b[3] = 1.0f;
    b[4] = b[5] = b[6] = b[7] = 0.0f;
    norm = 1.0f;
  }
  const float inv = 1.0f / norm;
  const float x = b[0] * inv, y = b[1] * inv, z = b[2] * inv, w = b[3] * inv;
  const float dx = b[4] * inv, dy = b[5] * inv, dz = b[6] * inv, dw = b[7] * inv;
  // Translation t = 2 · dual ⊗ conj(real), vector part.
  const float tx = 2.0f * (-dw * x + dx * w - dy * z + dz * y);
  const float ty = 2.0f * (-dw * y + dx * z + dy * w - dz * x);
  const float tz = 2.0f * (-dw * z - dx * y + dy * x + dz * w);
  const float r[9] = {1.0f - 2.0f * (y * y + z * z), 2.0f * (x * y - w * z),        2.0f * (x * z + w * y),
                      2.0f * (x * y + w * z),        1.0f - 2.0f * (x * x + z * z), 2.0f * (y * z - w * x),
                      2.0f * (x * z - w * y),        2.0f * (y * z + w * x),        1.0f - 2.0f * (x * x + y * y)};
  const float* s = b + 8;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col)
      out[4 * row + col] = r[3 * row] * s[col] + r[3 * row + 1] * s[3 + col] + r[3 * row + 2] * s[6 + col];
  }
  out[3] = tx;
  out[7] = ty;
  out[11] = tz;
}

inline glm::vec3 transform_point(const float m[12], const glm::vec3& p) {
  return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
          m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
}

inline glm::vec3 transform_vector(const float m[12], const glm::vec3& v) {
  return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
          m[8] * v.x + m[9] * v.y + m[10] * v.z};
}

// Unit `v`, or `fallback` when v has no usable length (a collapsed blend): never NaN.
inline glm::vec3 normalize_or(const glm::vec3& v, const glm::vec3& fallback) {
  const float length = std::sqrt(glm::dot(v, v));
  return length > 1e-30f && std::isfinite(length) ? v / length : fallback;
}

// The matrix that carries normals under the affine's linear part L: the inverse transpose,
// up to a positive factor (normals are renormalised after): the cofactor matrix
// [b×c, c×a, a×b] of L's columns (a, b, c), negated for a mirroring L (det < 0) so an
// outward normal stays outward. Finite for singular L (it then collapses some normals to
// zero, which the caller's normalize_or catches).
inline glm::mat3 normal_matrix(const float m[12]) {
  const glm::vec3 a(m[0], m[4], m[8]), b(m[1], m[5], m[9]), c(m[2], m[6], m[10]);
  const glm::vec3 bc = glm::cross(b, c);
  const float sign = glm::dot(a, bc) < 0.0f ? -1.0f : 1.0f;
  return glm::mat3(sign * bc, sign * glm::cross(c, a), sign * glm::cross(a, b));
}

}  // namespace skelform::runtime
