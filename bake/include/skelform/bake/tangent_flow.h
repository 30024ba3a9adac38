// Bilaplacian tangent flow (paper section 2, its reference [24]): each step moves every vertex
// along the tangential part of the negative bi-umbrella vector only, so the shape stays put
// while triangle aspect ratios improve.
#pragma once

#include "skelform/bake/mesh.h"

namespace skelform::bake {

struct TangentFlowOptions {
  int steps = 100;  // the paper's Fig. 5: 100 small steps
  // Step size as a fraction of the stable bi-umbrella step 1/nu (Kobbelt et al. 1998).
  double step_fraction = 0.1;
};

// Moves mesh.positions in place. Border vertices of open meshes stay fixed. Vertices without
// neighbours stay fixed. Never produces NaN on finite input.
void apply_tangent_flow(TriangleMesh& mesh, const TangentFlowOptions& options = {});

}  // namespace skelform::bake
