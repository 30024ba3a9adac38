// Denser versions of a skinned input for benchmarks and tests: the paper's DSS examples are
// 38K-100K triangles, denser than the glTF sample characters.
#pragma once

#include "skelform/bake/input.h"

namespace skelform::bake {

// Welds `input` and Loop-subdivides it `levels` times (OpenSubdiv stencils). Positions are
// the subdivided positions; skin influences are interpolated with the same stencils, then
// the four largest are kept and renormalised (one JOINTS/WEIGHTS set). The result is one
// indexed primitive carrying the first primitive's mesh/node/skin, so it bakes like the
// original. Unskinned input gives unskinned output.
InputMesh loop_subdivide_input(const InputMesh& input, int levels);

}  // namespace skelform::bake
