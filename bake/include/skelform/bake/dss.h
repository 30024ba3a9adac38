// DSS binding (DESIGN.md bake step 6; paper section 4, displaced subdivision surfaces after
// Lee et al. 2000): every original dense vertex becomes a point on the level-k Loop-refined
// control mesh plus a scalar displacement along the smooth normal field, with a small
// tangential residual where the normal field alone cannot reach it. Evaluated through
// core/include/skelform/core/dss_frame.h, at rest it reproduces the original vertex to float precision.
#pragma once

#include "skelform/bake/mesh.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace skelform::bake {

// One entry per dense vertex, in the order of the dense positions given to the binder; the
// layout of the extension's "binding" group (core/include/skelform/core/extension_layout.h).
struct DssBinding {
  std::vector<uint32_t> triangle;      // refined triangle the vertex is bound to
  std::vector<glm::vec2> barycentric;  // (b1, b2) in that triangle, b0 = 1 - b1 - b2, all in [0, 1]
  std::vector<float> displacement;     // h along the interpolated unit normal n(b), model units
  std::vector<glm::vec2> residual;     // tangential residual along the frame's (tangent, bitangent)
  size_t residual_vertices = 0;        // vertices with |residual| > 1e-3 · diagonal
  double max_rest_error = 0.0;         // max |evaluated − original| / diagonal, evaluated in
                                       // float through dss_frame.h (DESIGN.md "rest error")
};

// Binds every dense vertex to the refined mesh (positions in float as apply_stencils
// produced them, vertex normals as refined_normals produced them, triangles of
// SubdivisionStencils::refined_triangles). For each vertex p:
// closest point on the refined mesh, then Newton on (b1, b2, h) for p = q(b) + h·n(b),
// walking across edges when b leaves its triangle; where that does not converge (a vertex
// beyond the normal field's focal distance, across a border, off a separate component),
// the best b is kept and the rest goes into the tangential residual. h and the residual
// are finally corrected in float so the dss_frame.h evaluation reproduces p.
// Vertices with equal positions (glTF seam copies) get identical bindings.
// `diagonal`: the dense mesh's bounding-box diagonal (scale of tolerances and errors; > 0).
// Throws Error(invalid_input) for an empty refined mesh, normals that do not match the
// positions, out-of-range indices or a non-finite dense position.
DssBinding bind_dense_vertices(const std::vector<glm::vec3>& refined_positions,
                               const std::vector<glm::vec3>& refined_normals,
                               const std::vector<Triangle>& refined_triangles, const std::vector<Vec3>& dense_positions,
                               double diagonal);

}  // namespace skelform::bake
