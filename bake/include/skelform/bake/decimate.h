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
// they stay where they are. Meshes with at most 2 · target_triangles triangles are only
// compacted (no decimation): decimated to the target, they would be bound at Loop level 0
// (choose_subdivision_level: 4^k · control nearest the input in log scale), their dense
// vertices displaced off a coarser faceted surface that the fairing moves but does not fit.
// Above that, a control mesh decimated to the target (meshoptimizer may stop above it) is
// refined at least once. Deterministic.
DecimatedMesh decimate(const TriangleMesh& mesh, size_t target_triangles);

}  // namespace skelform::bake
