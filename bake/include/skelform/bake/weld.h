// Welding: glTF splits vertices at normal/UV seams; topology work needs them merged.
#pragma once

#include "skelform/bake/input.h"
#include "skelform/bake/mesh.h"

#include <vector>

namespace skelform::bake {

struct WeldedMesh {
  // Unique positions (equal coordinates, bit for bit after -0 == +0, are one vertex), in
  // the order of their first occurrence in the original vertex array: an input that is
  // already welded keeps exactly its vertex order, unreferenced vertices included.
  // Triangles: the original triangles mapped to welded indices, in original order, minus
  // degenerate ones (two equal welded corners) and exact duplicates (same vertex set, any
  // orientation; the first is kept).
  TriangleMesh mesh;
  std::vector<uint32_t> welded_of_original;  // size = original vertex count
  std::vector<uint32_t> original_of_welded;  // first original vertex of each welded vertex
  std::vector<uint32_t> original_triangle;   // for each kept triangle, its index in the input
  size_t degenerate_triangles_removed = 0;
  size_t duplicate_triangles_removed = 0;
};

WeldedMesh weld(const InputMesh& input);

}  // namespace skelform::bake
