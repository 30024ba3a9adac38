// Loop subdivision of the DSS control mesh as stencils (DESIGN.md bake step 6, runtime
// step 4; paper section 4): every vertex of the level-k refined mesh is a fixed weighted sum
// of control vertices, so the runtime refines a deformed control mesh with one sparse
// matrix-vector product and no topology work.
#pragma once

#include "skelform/bake/mesh.h"

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace skelform::bake {

// Loop stencils from the control vertices straight to level `level` (no intermediate
// levels), in the layout of the extension's "subdivision" group
// (core/include/skelform/core/extension_layout.h): refined vertex v = sum over s in [offsets[v], offsets[v+1]) of
// weights[s] * control[indices[s]].
struct SubdivisionStencils {
  uint32_t level = 0;                       // uniform refinement level k (0 = the control mesh)
  uint32_t control_vertex_count = 0;        // vertices of the control mesh the stencils read
  std::vector<uint32_t> offsets;            // refined vertex count + 1 entries, offsets[0] = 0
  std::vector<uint32_t> indices;            // control vertex of each stencil entry
  std::vector<float> weights;               // weight of each stencil entry; a stencil sums to 1
  std::vector<Triangle> refined_triangles;  // faces of level k, orientation of their parents

  size_t refined_vertex_count() const { return offsets.empty() ? 0 : offsets.size() - 1; }
};

// Builds Loop subdivision stencils with OpenSubdiv (uniform refinement, vertex
// interpolation, VTX_BOUNDARY_EDGE_ONLY so open borders follow the boundary curve rule).
// `level` in [0, 8]; level 0 gives identity stencils and the control triangles.
// Non-manifold edges and vertices, open borders, several components and unreferenced
// vertices are accepted (OpenSubdiv tags them and applies its non-manifold rules).
// Triangles with a repeated corner carry no surface and are skipped.
// Throws Error(usage) for a level out of range, Error(invalid_input) for an empty mesh, an
// out-of-range index, more than 2^31 vertices or a topology OpenSubdiv refuses.
SubdivisionStencils build_loop_stencils(const TriangleMesh& control, int level);

// The level k in [0, 4] whose refined triangle count control_triangles * 4^k is closest to
// dense_triangles in log scale (ties go to the lower, cheaper level): DSS wants about one
// refined triangle per dense triangle. 0 when either count is 0.
int choose_subdivision_level(size_t control_triangles, size_t dense_triangles);

// Applies the stencils to control positions in float, each sum starting at zero and
// accumulating weights[s] * control[indices[s]] in stencil order: exactly what the runtime
// does every frame, so the baker's rest evaluation and the runtime's agree to the bit.
// `control` must hold control_vertex_count positions (else Error(invalid_input)).
std::vector<glm::vec3> apply_stencils(const SubdivisionStencils& stencils, const std::vector<glm::vec3>& control);

// The refined mesh's vertex normals the DSS binding displaces along (dss_frame.h, extension
// version 2.1): the area-weighted normal sums of the control mesh given by `control`
// (positions, float) and `control_triangles`, with `skeletal` (the skeletal positions S, float,
// one per control vertex) turned onto the medial directions control − S
// (dss::medial_normal_sums), refined by apply_stencils, each normalised (zero where the refined
// sum vanishes). The runtime's bits at rest. Error(invalid_input) for a size that does not
// match the stencils or a triangle corner out of range.
std::vector<glm::vec3> refined_normals(const SubdivisionStencils& stencils, const std::vector<glm::vec3>& control,
                                       const std::vector<Triangle>& control_triangles,
                                       const std::vector<glm::vec3>* skeletal = nullptr);

}  // namespace skelform::bake
