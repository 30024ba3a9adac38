// Stage 4 of a frame: refine and displace (DESIGN.md runtime step 4; paper section 4, DSS
// after its reference [18]). The faired control mesh is Loop-refined with the baked stencils,
// and every original vertex is put back at its bound point of the refined surface plus its
// displacement, in the deformed local frame (dss_frame.h, the formula the baker bound with).
//
// Normals and tangents: the rotation R = F' · F^T from the rest frame F (tangent, bitangent,
// normal) to the deformed frame F' at the bound point carries the authored normal (R·n) and
// tangent (R·t, w kept). The loader stores the rest vectors in rest-frame coordinates
// (Deformable::rest_normal_coords, rest_tangent_coords: c = F^T n, unit), so R·n = F'·c =
// c.x t' + c.y b' + c.z n'. At rest R = I to float rounding, so authored data comes back as
// authored; under deformation the frame varies smoothly over the refined surface, so the
// carried normals stay continuous. A primitive without authored normals gets the
// area-weighted normals of its deformed triangles, the same rule the loader used for its rest
// normals (refine.h's add_face_normals and normalise_vectors: SSE2 and block-wise, the bits
// of dss::add_face_normals and of the scalar division).
//
// The per-vertex loop works in blocks of kBlock dense vertices: one pass gathers the bound
// triangles' corners and interpolates them (the point q(b), the unnormalised normal, the edge
// p1 - p0: 9 floats per vertex stored where 18 were gathered) into structure-of-arrays
// scratch on the stack, one branch-free pass evaluates the rest of dss_frame.h's formula for
// the whole block (the compiler vectorises it: plain C++, no intrinsics, four lanes wide and,
// where the CPU has AVX2, eight; sqrt and division are correctly rounded in every lane, so a
// vertex's bits depend neither on its place in a block nor on the lanes' width), and one pass
// writes the outputs. The
// branch-free pass takes the formula's main branch (interpolated normal, tangent from
// p1 - p0) and flags every vertex whose guards would pick a fallback; those vertices are
// recomputed with dss::surface_frame itself, fallbacks included. The fast pass normalises
// by one division and three products where dss_frame.h divides three times: the same
// vectors to float rounding (the rest pose still reproduces the bake to ~3e-7 of the
// diagonal). This file is compiled with -fno-math-errno (runtime/CMakeLists.txt): sqrt of a
// negative number never reaches it, the runtime never reads errno, and GCC only vectorises
// sqrt without errno.
#include "cpu.h"
#include "displace_block.h"
#include "instance.h"
#include "refine.h"
#include "vec3_sse.h"

#include <cfloat>
#include <cmath>

namespace skelform::runtime {

using displace_detail::Block;
using displace_detail::kBlock;

namespace {

// c in the frame's coordinates: c.x t + c.y b + c.z n (unit for unit c: the frame is
// orthonormal).
glm::vec3 in_frame(const dss::SurfaceFrame& frame, const glm::vec3& c) {
  return c.x * frame.tangent + c.y * frame.bitangent + c.z * frame.normal;
}

// One vertex through dss_frame.h itself, fallbacks included.
template <bool kNormals, bool kTangents>
void exact_vertex(const Deformable& d, const glm::vec3* refined, const glm::vec3* refined_normal, uint32_t v,
                  const DenseOutput& out) {
  const dss::SurfaceFrame frame = bound_frame(d, refined, refined_normal, v);
  out.positions[v] = dss::displaced_point(frame, d.binding_displacement[v], d.binding_residual[v]);
  if (kNormals) out.normals[v] = in_frame(frame, d.rest_normal_coords[v]);
  if (kTangents) out.tangents[v] = glm::vec4(in_frame(frame, d.rest_tangent_coords[v]), d.rest_tangents[v].w);
}

// interpolate_block (displace_block.h): with SSE2 four at a time, each corner
// read as one vector (vec3_sse.h; the refined buffers are padded, instance.h), x, y and z
// interpolated together (lane by lane the scalar loop's operations in its order, so its bits)
// and the four results transposed into the block's rows; the rest one at a time. (An AVX2 form
// that gathered eight vertices' corners took longer: 13.2 against 9.6 us per CesiumMan
// evaluation, 164 against 117 us on CesiumMan_loop2.)
void interpolate(const uint32_t* corners, const glm::vec2* barycentric, const glm::vec3* refined,
                 const glm::vec3* refined_normal, uint32_t count, Block& b) {
  const uint32_t* corner = corners;
  uint32_t i = 0;
#if defined(__SSE2__)
  const sse::PaddedVec3Reader read(refined), read_normal(refined_normal);
  for (; i + 4 <= count; i += 4) {
    __m128 q[4], m[4], e[4];
    for (uint32_t j = 0; j < 4; ++j, corner += 3) {
      const glm::vec2 bary = barycentric[i + j];
      const float b1 = bary.x, b2 = bary.y, b0 = 1.0f - b1 - b2;
      const __m128 w0 = _mm_set1_ps(b0), w1 = _mm_set1_ps(b1), w2 = _mm_set1_ps(b2);
      const __m128 p0 = read(corner[0]), p1 = read(corner[1]), p2 = read(corner[2]);
      const __m128 n0 = read_normal(corner[0]), n1 = read_normal(corner[1]), n2 = read_normal(corner[2]);
      q[j] = _mm_add_ps(_mm_add_ps(_mm_mul_ps(w0, p0), _mm_mul_ps(w1, p1)), _mm_mul_ps(w2, p2));
      m[j] = _mm_add_ps(_mm_add_ps(_mm_mul_ps(w0, n0), _mm_mul_ps(w1, n1)), _mm_mul_ps(w2, n2));
      e[j] = _mm_sub_ps(p1, p0);
    }
    _MM_TRANSPOSE4_PS(q[0], q[1], q[2], q[3]);
    _MM_TRANSPOSE4_PS(m[0], m[1], m[2], m[3]);
    _MM_TRANSPOSE4_PS(e[0], e[1], e[2], e[3]);
    for (int k = 0; k < 3; ++k) {
      _mm_storeu_ps(&b.q[k][i], q[k]);
      _mm_storeu_ps(&b.m[k][i], m[k]);
      _mm_storeu_ps(&b.e[k][i], e[k]);
    }
  }
#endif
  for (; i < count; ++i, corner += 3) {
    const glm::vec3 &p0 = refined[corner[0]], &p1 = refined[corner[1]], &p2 = refined[corner[2]];
    const glm::vec3 &n0 = refined_normal[corner[0]], &n1 = refined_normal[corner[1]], &n2 = refined_normal[corner[2]];
    const float b1 = barycentric[i].x, b2 = barycentric[i].y, b0 = 1.0f - b1 - b2;
    for (int k = 0; k < 3; ++k) {
      b.q[k][i] = b0 * p0[k] + b1 * p1[k] + b2 * p2[k];
      b.m[k][i] = b0 * n0[k] + b1 * n1[k] + b2 * n2[k];
      b.e[k][i] = p1[k] - p0[k];
    }
  }
}

template <bool kNormals, bool kTangents>
void gather(const Deformable& d, const glm::vec3* refined, const glm::vec3* refined_normal, uint32_t first,
            uint32_t count, Block& b) {
  interpolate(d.binding_corners.data() + 3 * size_t{first}, d.binding_barycentric.data() + first, refined,
              refined_normal, count, b);
  // The per-vertex data, contiguous: plain copies the compiler vectorises.
  const float* displacement = d.binding_displacement.data() + first;
  const glm::vec2* residual = d.binding_residual.data() + first;
  uint32_t i;
  for (i = 0; i < count; ++i) {
    b.h[i] = displacement[i];
    b.rt[i] = residual[i].x;
    b.rb[i] = residual[i].y;
  }
  if (kNormals) {
    const glm::vec3* c = d.rest_normal_coords.data() + first;
    for (i = 0; i < count; ++i)
      for (int k = 0; k < 3; ++k) b.cn[k][i] = c[i][k];
  }
  if (kTangents) {
    const glm::vec3* c = d.rest_tangent_coords.data() + first;
    for (i = 0; i < count; ++i)
      for (int k = 0; k < 3; ++k) b.ct[k][i] = c[i][k];
  }
}

// dss::surface_frame's main branch and dss::displaced_point, lane by lane, in the same
// operation order (normalisation by a reciprocal aside), from the gathered q, m and e. `fast`
// is 0 where one of surface_frame's guards fails: interpolated normal of length ≤ 1e-30 or not
// finite, p1 - p0 of length ≤ 1e-30, or its part in the tangent plane ≤ 1e-4 of its length.
// Those lanes may hold inf/NaN; the caller recomputes them.
template <bool kNormals, bool kTangents>
__attribute__((always_inline)) inline void evaluate(uint32_t count, Block& b) {
  for (uint32_t i = 0; i < count; ++i) {
    float q[3], m[3], e[3];
    for (int k = 0; k < 3; ++k) {
      q[k] = b.q[k][i];
      m[k] = b.m[k][i];
      e[k] = b.e[k][i];
    }
    const float m_length = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
    const float m_inverse = 1.0f / m_length;
    const float n[3] = {m[0] * m_inverse, m[1] * m_inverse, m[2] * m_inverse};
    const float e_length = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    const float e_dot_n = e[0] * n[0] + e[1] * n[1] + e[2] * n[2];
    const float w[3] = {e[0] - e_dot_n * n[0], e[1] - e_dot_n * n[1], e[2] - e_dot_n * n[2]};
    const float w_length = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    const float w_inverse = 1.0f / w_length;
    const float t[3] = {w[0] * w_inverse, w[1] * w_inverse, w[2] * w_inverse};
    const float s[3] = {n[1] * t[2] - t[1] * n[2], n[2] * t[0] - t[2] * n[0], n[0] * t[1] - t[0] * n[1]};
    b.fast[i] = (m_length > 1e-30f) & (m_length <= FLT_MAX) & (e_length > 1e-30f) & (w_length > 1e-4f * e_length);
    const float h = b.h[i], rt = b.rt[i], rb = b.rb[i];
    for (int k = 0; k < 3; ++k) b.position[k][i] = q[k] + h * n[k] + rt * t[k] + rb * s[k];
    if (kNormals) {
      const float cx = b.cn[0][i], cy = b.cn[1][i], cz = b.cn[2][i];
      for (int k = 0; k < 3; ++k) b.normal[k][i] = cx * t[k] + cy * s[k] + cz * n[k];
    }
    if (kTangents) {
      const float cx = b.ct[0][i], cy = b.ct[1][i], cz = b.ct[2][i];
      for (int k = 0; k < 3; ++k) b.tangent[k][i] = cx * t[k] + cy * s[k] + cz * n[k];
    }
  }
}

#if defined(SKELFORM_HAS_AVX2_KERNELS)
// The same loop compiled for AVX2: the compiler vectorises it eight lanes wide, each lane the
// same operations (and none fused: the project compiles with -ffp-contract=off,
// cmake/SkelformTargets.cmake, even where the target has FMA), so the same bits.
template <bool kNormals, bool kTangents>
__attribute__((target("avx2"))) void evaluate_avx2(uint32_t count, Block& b) {
  evaluate<kNormals, kTangents>(count, b);
}
#endif

#if defined(__SSE2__)
// Rows [k][i, i + 4) of a block's output into the four vectors out[0..3].
inline void store_rows(const float (&rows)[3][kBlock], uint32_t i, glm::vec3* out) {
  __m128 x = _mm_loadu_ps(&rows[0][i]), y = _mm_loadu_ps(&rows[1][i]), z = _mm_loadu_ps(&rows[2][i]),
         w = _mm_setzero_ps();
  _MM_TRANSPOSE4_PS(x, y, z, w);
  sse::store3(out[0], x);
  sse::store3(out[1], y);
  sse::store3(out[2], z);
  sse::store3(out[3], w);
}

// Rows [k][i, i + 4) of a block's tangents, each with the w of its rest tangent, into out[0..3].
inline void store_tangents(const float (&rows)[3][kBlock], uint32_t i, const glm::vec4* rest, glm::vec4* out) {
  __m128 x = _mm_loadu_ps(&rows[0][i]), y = _mm_loadu_ps(&rows[1][i]), z = _mm_loadu_ps(&rows[2][i]),
         w = _mm_setr_ps(rest[0].w, rest[1].w, rest[2].w, rest[3].w);
  _MM_TRANSPOSE4_PS(x, y, z, w);
  _mm_storeu_ps(&out[0].x, x);
  _mm_storeu_ps(&out[1].x, y);
  _mm_storeu_ps(&out[2].x, z);
  _mm_storeu_ps(&out[3].x, w);
}
#endif

template <bool kNormals, bool kTangents>
void displace_vertices(const Deformable& d, const glm::vec3* refined, const glm::vec3* refined_normal, uint32_t first,
                       uint32_t end, const DenseOutput& out) {
  Block b;
  for (uint32_t start = first; start < end; start += kBlock) {
    const uint32_t count = end - start < kBlock ? end - start : kBlock;
    gather<kNormals, kTangents>(d, refined, refined_normal, start, count, b);
#if defined(SKELFORM_HAS_AVX2_KERNELS)
    if (cpu_has_avx2())
      evaluate_avx2<kNormals, kTangents>(count, b);
    else
#endif
      evaluate<kNormals, kTangents>(count, b);
    for (uint32_t i = 0; i < count;) {
      const uint32_t v = start + i;
#if defined(__SSE2__)
      // Four vertices whose main branch held: their rows transposed back into vectors and
      // stored 12 bytes each (vec3_sse.h), the same floats as the scalar stores below.
      if (i + 4 <= count && (b.fast[i] & b.fast[i + 1] & b.fast[i + 2] & b.fast[i + 3])) {
        store_rows(b.position, i, out.positions + v);
        if (kNormals) store_rows(b.normal, i, out.normals + v);
        if (kTangents) store_tangents(b.tangent, i, d.rest_tangents.data() + v, out.tangents + v);
        i += 4;
        continue;
      }
#endif
      if (!b.fast[i]) {
        exact_vertex<kNormals, kTangents>(d, refined, refined_normal, v, out);
      } else {
        out.positions[v] = glm::vec3(b.position[0][i], b.position[1][i], b.position[2][i]);
        if (kNormals) out.normals[v] = glm::vec3(b.normal[0][i], b.normal[1][i], b.normal[2][i]);
        if (kTangents)
          out.tangents[v] = glm::vec4(b.tangent[0][i], b.tangent[1][i], b.tangent[2][i], d.rest_tangents[v].w);
      }
      ++i;
    }
  }
}

// Area-weighted vertex normals of one primitive's deformed triangles; a vertex they leave at
// zero (unreferenced or collapsed) takes its rest normal carried by its frame's rotation.
void primitive_face_normals(const Deformable& d, const PrimitiveRecord& primitive, const glm::vec3* refined,
                            const glm::vec3* refined_normal, const DenseOutput& out) {
  const uint32_t first = primitive.first_vertex, end = primitive.first_vertex + primitive.vertex_count;
  for (uint32_t v = first; v < end; ++v) out.normals[v] = glm::vec3(0.0f);
  add_face_normals(out.positions, d.vertex_count, d.dense_triangles.data() + 3 * size_t(primitive.first_triangle),
                   primitive.triangle_count, out.normals);
  // The rare vertex without a usable sum is redone with its frame afterwards.
  uint8_t usable[kBlock];
  for (uint32_t start = first; start < end; start += kBlock) {
    const uint32_t count = end - start < kBlock ? end - start : kBlock;
    normalise_vectors(out.normals + start, count, usable);
    for (uint32_t i = 0; i < count; ++i)
      if (!usable[i]) {
        const dss::SurfaceFrame frame = bound_frame(d, refined, refined_normal, start + i);
        out.normals[start + i] = in_frame(frame, d.rest_normal_coords[start + i]);
      }
  }
}

}  // namespace

void displace_detail::interpolate_block(const uint32_t* corners, const glm::vec2* barycentric, const glm::vec3* refined,
                                        const glm::vec3* refined_normal, uint32_t count, Block& b) {
  interpolate(corners, barycentric, refined, refined_normal, count, b);
}

void displace_detail::evaluate_block(bool avx2, uint32_t count, Block& b) {
#if defined(SKELFORM_HAS_AVX2_KERNELS)
  if (avx2 && cpu_has_avx2()) return evaluate_avx2<true, true>(count, b);
#else
  (void)avx2;
#endif
  evaluate<true, true>(count, b);
}

void displace(const Deformable& d, const glm::vec3* control, const glm::vec3* skeletal, glm::vec3* control_normal_sums,
              float* refine_lanes, glm::vec3* refined_positions, glm::vec3* refined_normal_buffer, bool with_normals,
              const DenseOutput& out) {
  refine_surface(d, control, skeletal, control_normal_sums, refined_positions, refined_normal_buffer, refine_lanes);

  for (const PrimitiveRecord& primitive : d.primitives) {
    const uint32_t first = primitive.first_vertex, end = primitive.first_vertex + primitive.vertex_count;
    const bool carry_normals = with_normals && primitive.has_normals;
    const bool carry_tangents = with_normals && primitive.has_tangents && out.tangents;
    const glm::vec3* p = refined_positions;
    const glm::vec3* n = refined_normal_buffer;
    if (carry_normals && carry_tangents)
      displace_vertices<true, true>(d, p, n, first, end, out);
    else if (carry_normals)
      displace_vertices<true, false>(d, p, n, first, end, out);
    else if (carry_tangents)
      displace_vertices<false, true>(d, p, n, first, end, out);
    else
      displace_vertices<false, false>(d, p, n, first, end, out);
    if (with_normals && !primitive.has_normals) primitive_face_normals(d, primitive, p, n, out);
  }
}

}  // namespace skelform::runtime
