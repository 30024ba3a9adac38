// An open surface for the tests of boundary rules: a capsule of skelform::bake::make_capsule
// (along z, cylinder from -length/2 to length/2) with its top cap's triangles removed, so its
// rim is the cylinder's top loop. The cap's vertices stay in the vertex list, unreferenced.
#pragma once

#include "skelform/bake/mesh.h"

#include <cstdint>

namespace skelform::test {

inline skelform::bake::TriangleMesh without_top_cap(const skelform::bake::TriangleMesh& capsule, double length) {
  skelform::bake::TriangleMesh open = capsule;
  open.triangles.clear();
  for (const skelform::bake::Triangle& t : capsule.triangles) {
    bool in_cap = true;
    for (uint32_t v : t) in_cap = in_cap && capsule.positions[v].z > length / 2 - 1e-9;
    if (!in_cap) open.triangles.push_back(t);
  }
  return open;
}

}  // namespace skelform::test
