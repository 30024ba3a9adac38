// Everything the baker precomputes for one deformable (one skinned mesh, all its triangle
// primitives welded together), ready to be stored as the SKELFORM_skeletal_deformation
// extension. Field meanings follow core/include/skelform/core/extension_layout.h, the format's one definition.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace skelform::bake {

struct BakedDeformable {
  int mesh = -1;                    // glTF mesh index
  int node = -1;                    // skinned node instancing the mesh (-1: none)
  int skin = -1;                    // glTF skin (-1: unskinned, handles only)
  std::vector<int> primitives;      // baked primitive indices of the mesh, in binding order
  uint32_t dense_vertex_count = 0;  // sum of the primitives' POSITION counts

  // Control mesh (decimated, tangent-flowed) and its skeletal mesh: M = S + d·N.
  std::vector<glm::vec3> control_positions;
  std::vector<glm::vec3> control_normals;
  std::vector<uint32_t> control_indices;  // 3 per triangle
  std::vector<glm::vec3> skeletal_positions;
  std::vector<float> medial_radius;
  // Skin of the control vertices, 4 influences per set (weights of a vertex sum to 1 over
  // all sets). Empty when skin == -1.
  std::vector<std::vector<std::array<uint16_t, 4>>> joint_sets;
  std::vector<std::vector<std::array<float, 4>>> weight_sets;

  // Loop subdivision stencils from control vertices straight to level `level`.
  uint32_t subdivision_level = 0;
  std::vector<uint32_t> stencil_offsets;  // refined vertex count + 1
  std::vector<uint32_t> stencil_indices;
  std::vector<float> stencil_weights;
  std::vector<uint32_t> refined_indices;  // 3 per refined triangle

  // DSS binding of every original vertex (primitives concatenated in `primitives` order).
  std::vector<uint32_t> binding_triangle;
  std::vector<glm::vec2> binding_barycentric;
  std::vector<float> binding_displacement;
  std::vector<glm::vec2> binding_residual;

  // The skelform weight of every original vertex (core/include/skelform/core/skelform_weight.h, or the
  // artist's _SKELFORM_WEIGHT). Empty when skin == -1.
  std::vector<float> skelform_weight;
};

}  // namespace skelform::bake
