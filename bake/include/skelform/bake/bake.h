// The whole bake (DESIGN.md bake steps 2-7) of every skinned mesh of a loaded model.
#pragma once

#include "skelform/bake/baked.h"
#include "skelform/bake/input.h"

#include <functional>
#include <string>
#include <vector>

namespace skelform::bake {

struct BakeOptions {
  // Control-mesh size: meshes with more than twice as many triangles are decimated to it
  // (decimate.h). The paper used 2K-6K; docs/tuning.md "Control-mesh size" has the corpus
  // measured at 1K-4K.
  size_t target_triangles = 2000;
  int subdivision_level = -1;    // Loop level k; -1 chooses it so 4^k·control ≈ dense
  int tangent_flow_steps = 100;  // bilaplacian tangent flow on the control mesh
  // Called at the start of each stage of each deformable (stage name, deformable index,
  // deformable count); may be empty. Runs on the calling thread.
  std::function<void(const char* stage, size_t deformable, size_t count)> progress;
};

// What the bake measured, per deformable, for the summary line and the tests.
struct DeformableReport {
  int mesh = -1;
  size_t dense_vertices = 0;  // original glTF vertices of its primitives
  size_t dense_triangles = 0;
  size_t welded_vertices = 0;
  size_t control_vertices = 0;
  size_t control_triangles = 0;
  bool decimated = false;
  int subdivision_level = 0;
  size_t refined_triangles = 0;
  bool flat = false;           // no volume: zero-radius skeleton S = M (see bake_model.cpp)
  double skeleton_inside = 0;  // fraction of skeletal vertices inside the control mesh
  double residual_share = 0;   // share of dense vertices with tangential residual > 1e-3·diag
  double rest_error = 0;       // max rest-pose reconstruction error / diagonal (float path)
  // Share of dense vertices with a skelform weight above 0: those the runtime pays skelform's
  // work for (the rest are exactly LBS). 1 for an unskinned mesh (handles only).
  double skelform_share = 1;
};

struct BakeResult {
  std::vector<BakedDeformable> deformables;
  std::vector<DeformableReport> reports;
};

// Bakes every deformable of `input`: one per glTF mesh (its primitives welded together), or
// one for a whole OBJ/PLY/OFF. Throws Error on input it cannot bake.
BakeResult bake_model(const InputMesh& input, const BakeOptions& options = {});

}  // namespace skelform::bake
