// The skelform weight of a vertex: how much of skelform's result it takes over linear blend
// skinning (output = LBS + w·(skelform − LBS)). One rule for the baker (which stores it in the
// extension) and the runtime (which derives it for assets baked before the weight existed).
//
// LBS is exact where one joint carries the whole skin: the vertex moves rigidly with it, and
// no reconstruction can do better. It goes wrong in the blend zones, where joints share a
// vertex and the blended matrix shrinks and folds the surface. So w follows how shared the
// skin is: x = 1 − (the largest share one joint holds, slots naming one joint summed), w = 0
// while x ≤ kRigidShare (a vertex weighted ≥ 0.999 to one joint: DESIGN.md's single-influence
// vertices), rising smoothly (smoothstep) to 1 at x = kFullBlendShare: a vertex sharing 5 % of
// its skin with another joint already takes skelform's result whole. Artist-painted weights
// are smooth across the surface, so w is. (Measured over the corpus, docs/quality.md: the
// sooner w reaches 1, the fewer intersections remain; the ramp keeps w continuous.)
#pragma once

#include <cstdint>

namespace skelform::skin {

constexpr float kRigidShare = 0.001f;     // 1 − 0.999: a single-influence vertex
constexpr float kFullBlendShare = 0.05f;  // another joint carries 5 %

// `count` (joint, weight) slots of one vertex; weights need not be normalised (zero and
// negative weights are ignored). A vertex without weight gets 0.
inline float skelform_weight(const uint16_t* joints, const float* weights, uint32_t count) {
  float total = 0.0f, largest = 0.0f;
  for (uint32_t k = 0; k < count; ++k) {
    if (!(weights[k] > 0.0f)) continue;
    total += weights[k];
    float same = 0.0f;  // this joint's share over every slot naming it
    for (uint32_t i = 0; i < count; ++i)
      if (joints[i] == joints[k] && weights[i] > 0.0f) same += weights[i];
    largest = same > largest ? same : largest;
  }
  if (!(total > 0.0f)) return 0.0f;
  const float shared = 1.0f - largest / total;
  if (!(shared > kRigidShare)) return 0.0f;
  float t = (shared - kRigidShare) / (kFullBlendShare - kRigidShare);
  t = t < 1.0f ? t : 1.0f;
  return t * t * (3.0f - 2.0f * t);
}

}  // namespace skelform::skin
