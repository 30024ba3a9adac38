// Stage 4 of a frame: refine and displace (DESIGN.md runtime step 4; paper section 4, DSS
// after its reference [18]). The faired control mesh is Loop-refined with the baked stencils,
// and every original vertex is put back at its bound point of the refined surface plus its
// displacement, in the deformed local frame (dss_frame.h, the formula the baker bound with).
//
// Normals and tangents: the rotation R = F' · F^T from the rest frame F (Deformable::
// rest_frames, columns tangent, bitangent, normal) to the deformed frame F' at the bound
// point carries the authored normal (R·n) and tangent (R·t, w kept). At rest R = I to float
// rounding, so authored data comes back as authored; under deformation the frame varies
// smoothly over the refined surface, so the carried normals stay continuous. A primitive
// without authored normals gets the area-weighted normals of its deformed triangles, the
// same rule the loader used for its rest normals.
#include "instance.h"
#include "refine.h"

#include <cmath>

namespace skelform::runtime {

namespace {

glm::mat3 frame_rotation(const dss::SurfaceFrame& frame, const glm::mat3& rest_frame) {
  return glm::mat3(frame.tangent, frame.bitangent, frame.normal) * glm::transpose(rest_frame);
}

// Area-weighted vertex normals of one primitive's deformed triangles; a vertex they leave at
// zero (unreferenced or collapsed) takes its rest normal turned by its frame's rotation.
void primitive_face_normals(const Deformable& d, const PrimitiveRecord& primitive, const glm::vec3* refined,
                            const glm::vec3* refined_normal, const DenseOutput& out) {
  const uint32_t first = primitive.first_vertex, end = primitive.first_vertex + primitive.vertex_count;
  for (uint32_t v = first; v < end; ++v) out.normals[v] = glm::vec3(0.0f);
  const uint32_t* corner = d.dense_triangles.data() + 3 * size_t(primitive.first_triangle);
  for (uint32_t t = 0; t < primitive.triangle_count; ++t, corner += 3) {
    const glm::vec3 p0 = out.positions[corner[0]];
    const glm::vec3 face = glm::cross(out.positions[corner[1]] - p0, out.positions[corner[2]] - p0);
    out.normals[corner[0]] += face;
    out.normals[corner[1]] += face;
    out.normals[corner[2]] += face;
  }
  for (uint32_t v = first; v < end; ++v) {
    const float length = std::sqrt(glm::dot(out.normals[v], out.normals[v]));
    if (length > 1e-30f && std::isfinite(length)) {
      out.normals[v] /= length;
    } else {
      const dss::SurfaceFrame frame = bound_frame(d, refined, refined_normal, v);
      out.normals[v] = normalize_or(frame_rotation(frame, d.rest_frames[v]) * d.rest_normals[v], frame.normal);
    }
  }
}

}  // namespace

void displace(const Deformable& d, const glm::vec3* control, glm::vec3* refined_positions,
              glm::vec3* refined_normal_buffer, bool with_normals, const DenseOutput& out) {
  refine_positions(d, control, refined_positions);
  refined_normals(d, refined_positions, refined_normal_buffer);

  for (const PrimitiveRecord& primitive : d.primitives) {
    const uint32_t first = primitive.first_vertex, end = primitive.first_vertex + primitive.vertex_count;
    const bool carry_normals = with_normals && primitive.has_normals;
    const bool carry_tangents = with_normals && primitive.has_tangents && out.tangents;
    for (uint32_t v = first; v < end; ++v) {
      const dss::SurfaceFrame frame = bound_frame(d, refined_positions, refined_normal_buffer, v);
      out.positions[v] = dss::displaced_point(frame, d.binding_displacement[v], d.binding_residual[v]);
      if (carry_normals || carry_tangents) {
        const glm::mat3 rotation = frame_rotation(frame, d.rest_frames[v]);
        if (carry_normals) out.normals[v] = normalize_or(rotation * d.rest_normals[v], frame.normal);
        if (carry_tangents) {
          const glm::vec4 rest = d.rest_tangents[v];
          out.tangents[v] = glm::vec4(normalize_or(rotation * glm::vec3(rest), frame.tangent), rest.w);
        }
      }
    }
    if (with_normals && !primitive.has_normals)
      primitive_face_normals(d, primitive, refined_positions, refined_normal_buffer, out);
  }
}

}  // namespace skelform::runtime
