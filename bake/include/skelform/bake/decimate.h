// Control-mesh decimation (DESIGN.md bake step 3): the DSS base mesh of paper section 4.
#pragma once

#include "skelform/bake/mesh.h"

#include <vector>

namespace skelform::bake {

struct DecimatedMesh {
  // Every control vertex is one of the input vertices (edge collapses keep a survivor, they
  // create no new positions); vertices no kept triangle uses are dropped.
  TriangleMesh mesh;
  std::vector<uint32_t> source_vertex;  // input vertex index of each control vertex
  bool decimated = false;               // false when the input was already small enough
  double result_error = 0.0;            // meshoptimizer's relative error of the result
};

// Decimates `mesh` towards `target_triangles` with meshoptimizer, open borders locked so
// they stay where they are. Meshes with at most target_triangles · 1.25 triangles are only
// compacted (no decimation): DSS gains nothing from a control mesh nearly as dense as the
// input. Deterministic.
DecimatedMesh decimate(const TriangleMesh& mesh, size_t target_triangles);

}  // namespace skelform::bake
