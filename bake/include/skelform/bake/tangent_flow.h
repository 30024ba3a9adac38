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
  // Optional surface the vertices must stay on. The tangent plane is only a first-order
  // picture of the surface: on a coarse mesh (a decimated DSS control mesh) 100 tangential
  // steps slide vertices off curved regions, e.g. from a cylinder onto the chord of its cap,
  // and the skeleton of the drifted mesh pokes out of the real one. When set, every
  // `projection_interval` steps and after the last one each vertex is moved to its closest
  // point on this surface (the baker passes the dense input), keeping the shape exact.
  const TriangleMesh* reference_surface = nullptr;
  int projection_interval = 10;
};

// Moves mesh.positions in place. Border vertices of open meshes stay fixed. Vertices without
// neighbours stay fixed. Never produces NaN on finite input.
void apply_tangent_flow(TriangleMesh& mesh, const TangentFlowOptions& options = {});

}  // namespace skelform::bake
