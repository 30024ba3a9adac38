// Stage 2 of a frame: reconstruct the control mesh from the deformed skeletal mesh,
// M = S' + d·N (paper eq. (1)), with one of two normal fields N (DESIGN.md runtime step 2 and
// "Measured before any code"):
//  - carried: the rest normals turned by each skeletal vertex's blended skin transform, one
//    step. Stable: the normals do not feed back, so the skeleton's small crumple stays small.
//  - paper: the homotopy (2)/(3), S_j = S_0 + j(S_L − S_0)/L, M_j = S_j + d·N(M_{j−1}), with
//    N the area-weighted vertex normals of the control mesh. As the paper says; it amplifies
//    high-frequency wobble of S' on dense control meshes (DESIGN.md table), hence not default.
//
// Both add the bake's own residual of eq. (1), e_i = M_i − S_i − d_i·N_i (float rounding of
// S = M − d·N, about 1e-7 of d), so the rest pose gives back the stored control mesh
// exactly instead of up to that rounding: algebraically M = S' + d·N as in the paper.
#include "skelform/core/dss_frame.h"
#include "instance.h"

#include <cmath>

namespace skelform::runtime {

namespace {

inline glm::vec3 rest_residual(const Deformable& d, uint32_t v) {
  return d.control_positions[v] - d.skeletal_positions[v] - d.medial_radius[v] * d.control_normals[v];
}

// The paper's N(M) (section 2: "the normalized area-weighting mean of the normals of the mesh
// triangles incident to the vertex"; dss_frame.h's vertex_normals), shifted by
// the per-vertex `rest_offset` = N_rest − N_area(M_rest) so that N(M_rest) = N_rest exactly.
// Without it, eq. (3) iterated at rest is M ← S + d·N_area(M): the runtime's float normals
// differ from the bake's by up to a few tenths of a degree, and the homotopy, which amplifies
// such differences (DESIGN.md), walks off the rest pose frame by frame. The offset is a model-space constant: under deformation it
// is off by at most its own size (the same few tenths of a degree). A vertex whose normal vanishes (collapsed neighbourhood)
// keeps `fallback`'s, so N stays unit and finite.
void paper_normals(const Deformable& d, const glm::vec3* positions, const glm::vec3* rest_offset,
                   const glm::vec3* fallback, glm::vec3* out) {
  dss::vertex_normals(positions, d.control_vertex_count, d.control_indices.data(), d.control_indices.size() / 3, out);
  for (uint32_t v = 0; v < d.control_vertex_count; ++v) {
    const bool vanished = out[v].x == 0.0f && out[v].y == 0.0f && out[v].z == 0.0f;
    out[v] = vanished ? fallback[v] : normalize_or(out[v] + rest_offset[v], fallback[v]);
  }
}

}  // namespace

void reconstruct_carried(const Deformable& d, const glm::vec3* skeletal, const glm::mat3* normal_matrices,
                         const float* radius, glm::vec3* control_out) {
  for (uint32_t v = 0; v < d.control_vertex_count; ++v) {
    const glm::vec3 rest_normal = d.control_normals[v];
    const glm::vec3 normal = normalize_or(normal_matrices[v] * rest_normal, rest_normal);
    control_out[v] = skeletal[v] + radius[v] * normal + rest_residual(d, v);
  }
}

void reconstruct_predicted(const Deformable& d, const glm::vec3* rest_offset, const glm::vec3* skeletal,
                           glm::vec3* predicted, glm::vec3* normals, glm::vec3* control_out) {
  // The handle driver has no per-vertex transform to carry normals by. The surface the
  // skeletal motion predicts, M_rest + (S' − S), gives them in one shot: like eq. (3) with
  // L = 1, but from a surface that moves exactly with the skeleton, so a normal changes only
  // where its one-ring's skeleton moved (no ring-by-ring spread per homotopy step, no
  // amplification), and where nothing moved M' is the rest pose exactly.
  for (uint32_t v = 0; v < d.control_vertex_count; ++v)
    predicted[v] = d.control_positions[v] + (skeletal[v] - d.skeletal_positions[v]);
  paper_normals(d, predicted, rest_offset, d.control_normals.data(), normals);
  for (uint32_t v = 0; v < d.control_vertex_count; ++v) {
    const bool unmoved = skeletal[v] == d.skeletal_positions[v] && normals[v] == d.control_normals[v];
    control_out[v] =
        unmoved ? d.control_positions[v] : skeletal[v] + d.medial_radius[v] * normals[v] + rest_residual(d, v);
  }
}

void rest_normal_offsets(const Deformable& d, glm::vec3* offsets) {
  dss::vertex_normals(d.control_positions.data(), d.control_vertex_count, d.control_indices.data(),
                      d.control_indices.size() / 3, offsets);
  for (uint32_t v = 0; v < d.control_vertex_count; ++v) offsets[v] = d.control_normals[v] - offsets[v];
}

void reconstruct_homotopy(const Deformable& d, const glm::vec3* rest_offset, const glm::vec3* start_skeletal,
                          const glm::vec3* start_control, const glm::vec3* start_normals, const glm::vec3* skeletal,
                          const float* radius, uint32_t steps, glm::vec3* normals_a, glm::vec3* normals_b,
                          glm::vec3* control_out) {
  const uint32_t count = d.control_vertex_count;
  // A homotopy from S_0 to S_L = S_0 is constant: M_0 already is the reconstruction of S_0.
  // Not only a shortcut: eq. (3) iterated on a still skeleton is the map M ← S + d·N(M),
  // whose gain on high frequencies is about d / edge length (> 1 on thick parts of a coarse
  // control mesh), so float rounding alone would grow about 2× per step (DESIGN.md "Measured
  // before any code"; docs/tuning.md). A held pose must not drift.
  bool still = true;
  for (uint32_t v = 0; v < count && still; ++v) still = skeletal[v] == start_skeletal[v];
  if (still && !start_normals) {
    for (uint32_t v = 0; v < count; ++v) control_out[v] = start_control[v];
    return;
  }
  // N_0: the rest normals when starting from rest (they are exactly the N of eq. (1)),
  // else the normals of the previous evaluation's M.
  glm::vec3* previous_normals = normals_a;
  glm::vec3* next_normals = normals_b;
  if (start_normals)
    for (uint32_t v = 0; v < count; ++v) previous_normals[v] = start_normals[v];
  else
    paper_normals(d, start_control, rest_offset, d.control_normals.data(), previous_normals);

  const float inverse_steps = 1.0f / float(steps);
  for (uint32_t j = 1; j <= steps; ++j) {
    const float t = float(j) * inverse_steps;  // j/L of eq. (2)
    for (uint32_t v = 0; v < count; ++v) {
      const glm::vec3 skeletal_j = start_skeletal[v] + t * (skeletal[v] - start_skeletal[v]);  // eq. (2)
      control_out[v] = skeletal_j + radius[v] * previous_normals[v] + rest_residual(d, v);     // eq. (3)
    }
    if (j < steps) {
      paper_normals(d, control_out, rest_offset, previous_normals, next_normals);  // N_j from M_j
      glm::vec3* swap = previous_normals;
      previous_normals = next_normals;
      next_normals = swap;
    }
  }
}

}  // namespace skelform::runtime
