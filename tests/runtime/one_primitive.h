// A Deformable for the guard's and the contact pass's own test scenes: one primitive with
// normals over all of its vertices, each at a skelform weight of 1 (its other fields empty).
#pragma once

#include "asset.h"

#include <cstdint>

namespace skelform::test {

inline void make_one_primitive(skelform::runtime::Deformable& d, uint32_t vertices, uint32_t triangles) {
  d.vertex_count = vertices;
  d.skelform_weight.assign(vertices, 1.0f);
  skelform::runtime::PrimitiveRecord primitive;
  primitive.primitive = 0;
  primitive.vertex_count = vertices;
  primitive.triangle_count = triangles;
  primitive.has_normals = true;
  d.primitives.push_back(primitive);
}

}  // namespace skelform::test
