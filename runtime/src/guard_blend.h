// The LBS guard's output (lbs_guard.cpp guard_and_blend), every dense vertex on every
// evaluation: x = L + s·(K − L) with s = w·λ (the skelform weight of the vertex, λ of its
// welded vertex), and with normals LBS's and skelform's blended the same way and renormalised
// (normalize_or: LBS's where the blend has no length); s = 0 gives LBS's vectors as they are.
//
// A plain loop: an AVX2 form eight vertices at a time (λ gathered through the weld) took longer
// on CesiumMan and CesiumMan_loop1 (14.7 against 12.9 us per CesiumMan evaluation), and about as
// long on CesiumMan_loop2, where two runs split.
#pragma once

#include "contact.h"
#include "instance.h"
#include "skin_blend.h"

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstdint>

namespace skelform::runtime {

struct BlendInput {
  const float* weight;   // per dense vertex
  const float* factor;   // λ per welded vertex, or null (λ = 1)
  const uint32_t* weld;  // per dense vertex: its welded vertex (read with factor)
  DenseOutput skelform;  // K
  DenseOutput lbs;       // L
};

// Dense vertices [first, end); `out` may be in.skelform itself (a vertex is written after its
// own K is read).
inline void blend_output(uint32_t first, uint32_t end, const BlendInput& in, bool normals, bool tangents,
                         const DenseOutput& out) {
  for (uint32_t v = first; v < end; ++v) {
    const float s = in.weight[v] * (in.factor ? in.factor[in.weld[v]] : 1.0f);
    if (s == 0.0f) {
      out.positions[v] = in.lbs.positions[v];
      if (normals) out.normals[v] = in.lbs.normals[v];
      if (tangents) out.tangents[v] = in.lbs.tangents[v];
      continue;
    }
    out.positions[v] = blend_with_lbs(in.lbs.positions[v], in.skelform.positions[v], s);
    if (normals)
      out.normals[v] =
          normalize_or(in.lbs.normals[v] + s * (in.skelform.normals[v] - in.lbs.normals[v]), in.lbs.normals[v]);
    if (tangents) {
      const glm::vec3 t(in.lbs.tangents[v]);
      out.tangents[v] =
          glm::vec4(normalize_or(t + s * (glm::vec3(in.skelform.tangents[v]) - t), t), in.lbs.tangents[v].w);
    }
  }
}

}  // namespace skelform::runtime
