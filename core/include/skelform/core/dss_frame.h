// Evaluation of the displaced-subdivision-surface (DSS) binding, shared by the baker and the
// runtime (DESIGN.md bake step 6, runtime step 4, Math notes "DSS binding" and "Carrying
// normals"; paper section 4, after Lee et al. 2000, the paper's reference [18]).
//
// A dense vertex is bound to a refined triangle (p0, p1, p2) with vertex normals (n0, n1, n2),
// barycentrics b = (b0, b1, b2), b0 = 1 - b1 - b2, a displacement h and a tangential
// residual (r_t, r_b):
//     q(b) = b0 p0 + b1 p1 + b2 p2                      the point on the refined surface
//     n(b) = normalize(b0 n0 + b1 n1 + b2 n2)           DSS's smooth normal field
//     t    = normalize(d - (d·n) n), d = ∂q/∂b1 = p1 - p0, and  s = n × t
//     p    = q(b) + h n(b) + r_t t + r_b s
// The baker binds at rest with exactly these functions, in float; the runtime evaluates them
// on the deformed refined mesh. Both include this header, so the rest pose reproduces the
// original vertices to float precision and the frame (n, t, s) turns with the surface.
//
// Header-only, GLM only, no allocation, no exceptions: safe in the runtime's per-frame path.
// Every function returns finite values for finite input, degenerate triangles and zero
// normals included (fallbacks below). Compile with floating-point contraction off (the
// default for ISO C++ on GCC/Clang x86-64) so baker and runtime round identically.
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace skelform::dss {

// Area-weighted vertex normals, in two halves with a fixed order (baker and runtime get the
// same bits):
//  - add_face_normals: each triangle adds its unnormalised normal (p1 - p0) × (p2 - p0)
//    (length = twice its area) to its three corners, in triangle order;
//  - normalise_or_zero: each sum divided by its length; a vertex with no non-degenerate
//    incident triangle, or whose sums cancel, gets (0, 0, 0) (surface_frame falls back).
// `indices` holds 3 * triangle_count vertex indices < vertex_count; `sums` / `out_normals`
// hold vertex_count entries and may not alias `positions`.
inline void add_face_normals(const glm::vec3* positions, const uint32_t* indices, size_t triangle_count,
                             glm::vec3* sums) {
  for (size_t t = 0; t < triangle_count; ++t) {
    const uint32_t i0 = indices[3 * t], i1 = indices[3 * t + 1], i2 = indices[3 * t + 2];
    const glm::vec3 face = glm::cross(positions[i1] - positions[i0], positions[i2] - positions[i0]);
    sums[i0] += face;
    sums[i1] += face;
    sums[i2] += face;
  }
}

inline glm::vec3 normalise_or_zero(const glm::vec3& v) {
  const float length = std::sqrt(glm::dot(v, v));
  // A normal computed from float noise can be tiny but non-zero; normalising it is still
  // exact enough (it is a direction), only a true zero or a denormal is dropped.
  return length > 1e-30f ? v / length : glm::vec3(0.0f);
}

// Turns each control vertex's normal sum A[c] (add_face_normals) halfway onto its medial
// direction P[c] − S[c], keeping the sum's length (the area weight the stencils interpolate
// with): with a = A[c]/|A[c]| and m = (P[c] − S[c])/|P[c] − S[c]|,
//   A[c] ← |A[c]| (a + m) / |a + m|
// where |A[c]|, |P[c] − S[c]| and |a + m| are > 1e-30 and finite; elsewhere (a zero medial
// radius, a flat deformable with S = M, a vanishing normal) A[c] is left as it is.
// At rest P − S = d·N with N the area-weighted normal itself (the skeleton is built as
// S = M − d·N), so a = m to float rounding and the field is the area-weighted one there. Away
// from rest the two disagree, each wrong in its own way, and the dense vertices are displaced
// along their bisector (docs/SKELFORM_skeletal_deformation.md "Stencil evaluation", version
// 2.1):
//  - a, the faired control mesh's own normal, swings where the flows tilt its triangles at a
//    pressed contact (a running fox's leg against its chest), and the detail displaced along
//    it swings into the other part;
//  - m, the direction the reconstruction M = S + d·N rebuilt the vertex along, does not see
//    that tilt, but it turns with the skeleton's blend rather than with the surface.
// Their bisector: m alone loses more volume than LBS on some animations, a alone adds pairs
// LBS lacks on others; the bisector does neither (docs/tuning.md has the figures).
inline void medial_normal_sums(const glm::vec3* positions, const glm::vec3* skeletal, size_t vertex_count,
                               glm::vec3* sums) {
  for (size_t c = 0; c < vertex_count; ++c) {
    const glm::vec3 medial = positions[c] - skeletal[c];
    const float medial_length = std::sqrt(glm::dot(medial, medial));
    const float weight = std::sqrt(glm::dot(sums[c], sums[c]));
    if (!(medial_length > 1e-30f) || !(weight > 1e-30f) || !std::isfinite(medial_length) || !std::isfinite(weight))
      continue;
    const glm::vec3 bisector = sums[c] * (1.0f / weight) + medial * (1.0f / medial_length);
    const float bisector_length = std::sqrt(glm::dot(bisector, bisector));
    if (bisector_length > 1e-30f) sums[c] = bisector * (weight / bisector_length);
  }
}

// Unit area-weighted vertex normals of a triangle mesh (the control mesh's N(M) of the
// paper's eq. (3), reconstruct.cpp).
inline void vertex_normals(const glm::vec3* positions, size_t vertex_count, const uint32_t* indices,
                           size_t triangle_count, glm::vec3* out_normals) {
  for (size_t v = 0; v < vertex_count; ++v) out_normals[v] = glm::vec3(0.0f);
  add_face_normals(positions, indices, triangle_count, out_normals);
  for (size_t v = 0; v < vertex_count; ++v) out_normals[v] = normalise_or_zero(out_normals[v]);
}

// The refined mesh's vertex normals n0, n1, n2 above (extension version 2.1, docs/
// SKELFORM_skeletal_deformation.md "Stencil evaluation"): the control mesh's area-weighted
// normal sums (add_face_normals over the control triangles), turned halfway onto the medial
// directions (medial_normal_sums), refined by the same stencils as
// the positions, each refined sum then normalised (normalise_or_zero). The stencil sums are
// the positions' arithmetic (float, from zero, in stencil order), which the baker
// (bake/src/subdivision.cpp refined_normals) and the runtime (runtime/src/refine.cpp) each
// implement; at level 0 (identity stencils) this is vertex_normals of the control mesh.
// (Extension version 1 took the area-weighted normals of the refined triangles instead: the
// same field to within the refined mesh's faceting, at four times the runtime cost.)

// Orthonormal frame at a bound point: `point` = q(b), `normal` = n(b), `tangent` along
// ∂q/∂b1 made orthogonal to the normal, `bitangent` = normal × tangent.
struct SurfaceFrame {
  glm::vec3 point;
  glm::vec3 normal;
  glm::vec3 tangent;
  glm::vec3 bitangent;
};

namespace detail {

// Unit vector along v, or false when v has no usable direction.
inline bool normalize_if_possible(const glm::vec3& v, glm::vec3& out) {
  const float length = std::sqrt(glm::dot(v, v));
  if (!(length > 1e-30f) || !std::isfinite(length)) return false;
  out = v / length;
  return true;
}

// Component of `direction` orthogonal to unit `normal`, normalised; false when `direction`
// is (nearly) parallel to the normal or zero: a tangent from it would be rounding noise.
inline bool tangent_from(const glm::vec3& direction, const glm::vec3& normal, glm::vec3& out) {
  const float length = std::sqrt(glm::dot(direction, direction));
  if (!(length > 1e-30f)) return false;
  const glm::vec3 in_plane = direction - glm::dot(direction, normal) * normal;
  const float in_plane_length = std::sqrt(glm::dot(in_plane, in_plane));
  if (!(in_plane_length > 1e-4f * length)) return false;
  out = in_plane / in_plane_length;
  return true;
}

}  // namespace detail

// The frame of the binding at barycentrics (b1, b2) of triangle (p0, p1, p2) with vertex
// normals (n0, n1, n2) (unit or zero). Fallbacks, each used only when the previous one has
// no direction: normal = interpolated normal, then the face normal, then +z; tangent from
// p1 - p0, then p2 - p0, then the coordinate axis least aligned with the normal. The
// fallbacks depend only on the inputs, so bake and runtime take the same branch at rest.
inline SurfaceFrame surface_frame(const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2, const glm::vec3& n0,
                                  const glm::vec3& n1, const glm::vec3& n2, float b1, float b2) {
  const float b0 = 1.0f - b1 - b2;
  SurfaceFrame frame;
  frame.point = b0 * p0 + b1 * p1 + b2 * p2;
  if (!detail::normalize_if_possible(b0 * n0 + b1 * n1 + b2 * n2, frame.normal) &&
      !detail::normalize_if_possible(glm::cross(p1 - p0, p2 - p0), frame.normal))
    frame.normal = glm::vec3(0.0f, 0.0f, 1.0f);
  if (!detail::tangent_from(p1 - p0, frame.normal, frame.tangent) &&
      !detail::tangent_from(p2 - p0, frame.normal, frame.tangent)) {
    const glm::vec3 a = glm::abs(frame.normal);
    const glm::vec3 axis = a.x <= a.y && a.x <= a.z ? glm::vec3(1, 0, 0)
                           : a.y <= a.z             ? glm::vec3(0, 1, 0)
                                                    : glm::vec3(0, 0, 1);
    // The least aligned axis makes an angle of at least ~35° with a unit normal: always
    // a usable tangent.
    detail::tangent_from(axis, frame.normal, frame.tangent);
  }
  frame.bitangent = glm::cross(frame.normal, frame.tangent);
  return frame;
}

// The bound vertex: the surface point displaced by h along the normal (DSS's scalar
// displacement) plus the tangential residual in the frame's tangent/bitangent.
inline glm::vec3 displaced_point(const SurfaceFrame& frame, float h, glm::vec2 residual) {
  return frame.point + h * frame.normal + residual.x * frame.tangent + residual.y * frame.bitangent;
}

}  // namespace skelform::dss
