#include "delta_mush.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

namespace skelform::bench {

namespace {

inline void cross(const float* a, const float* b, float* out) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

inline float dot(const float* a, const float* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

inline bool normalize(float* v) {
  const float length = std::sqrt(dot(v, v));
  if (!(length > 1e-20f)) return false;
  v[0] /= length, v[1] /= length, v[2] /= length;
  return true;
}

}  // namespace

DeltaMush::DeltaMush(const std::vector<float>& rest_positions, const std::vector<uint32_t>& triangles,
                     const std::vector<uint16_t>& joints, const std::vector<float>& weights,
                     size_t influences_per_vertex, const DeltaMushOptions& options)
    : options_(options), influences_(influences_per_vertex) {
  const size_t vertex_count = rest_positions.size() / 3;
  if (rest_positions.size() % 3 != 0 || triangles.size() % 3 != 0 || influences_ == 0 ||
      joints.size() != vertex_count * influences_ || weights.size() != joints.size())
    throw std::invalid_argument("DeltaMush: inconsistent array sizes");
  for (uint32_t index : triangles)
    if (index >= vertex_count) throw std::invalid_argument("DeltaMush: triangle index out of range");

  // Weld by exact position: glTF splits vertices at UV and normal seams, which smoothing
  // must not see as boundaries.
  std::map<std::array<float, 3>, uint32_t> welded_index;
  original_to_welded_.resize(vertex_count);
  for (size_t v = 0; v < vertex_count; ++v) {
    const std::array<float, 3> key{rest_positions[3 * v], rest_positions[3 * v + 1], rest_positions[3 * v + 2]};
    const auto [it, inserted] = welded_index.emplace(key, static_cast<uint32_t>(welded_rest_.size() / 3));
    if (inserted) {
      welded_rest_.insert(welded_rest_.end(), key.begin(), key.end());
      joints_.insert(joints_.end(), joints.begin() + v * influences_, joints.begin() + (v + 1) * influences_);
      weights_.insert(weights_.end(), weights.begin() + v * influences_, weights.begin() + (v + 1) * influences_);
    }
    original_to_welded_[v] = it->second;
  }
  const size_t welded = welded_rest_.size() / 3;
  for (size_t t = 0; t < triangles.size(); t += 3) {
    const uint32_t a = original_to_welded_[triangles[t]], b = original_to_welded_[triangles[t + 1]],
                   c = original_to_welded_[triangles[t + 2]];
    if (a == b || b == c || a == c) continue;  // collapsed by the weld
    welded_triangles_.insert(welded_triangles_.end(), {a, b, c});
  }

  // Unique neighbours of every welded vertex (CSR).
  std::vector<std::vector<uint32_t>> adjacency(welded);
  for (size_t t = 0; t < welded_triangles_.size(); t += 3)
    for (int e = 0; e < 3; ++e) {
      const uint32_t a = welded_triangles_[t + e], b = welded_triangles_[t + (e + 1) % 3];
      adjacency[a].push_back(b);
      adjacency[b].push_back(a);
    }
  neighbour_offsets_.assign(1, 0);
  for (std::vector<uint32_t>& list : adjacency) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    neighbours_.insert(neighbours_.end(), list.begin(), list.end());
    neighbour_offsets_.push_back(static_cast<uint32_t>(neighbours_.size()));
  }

  skinned_.resize(3 * welded);
  scratch_.resize(3 * welded);
  frames_.resize(9 * welded);
  local_delta_.resize(3 * welded);

  // Bake: the rest delta in the frame of the smoothed rest mesh.
  std::vector<float> smoothed = welded_rest_;
  smooth(smoothed);
  compute_frames(smoothed);
  for (size_t v = 0; v < welded; ++v) {
    const float delta[3] = {welded_rest_[3 * v] - smoothed[3 * v], welded_rest_[3 * v + 1] - smoothed[3 * v + 1],
                            welded_rest_[3 * v + 2] - smoothed[3 * v + 2]};
    const float* frame = &frames_[9 * v];
    for (int axis = 0; axis < 3; ++axis) local_delta_[3 * v + axis] = dot(delta, frame + 3 * axis);
  }
}

void DeltaMush::smooth(std::vector<float>& positions) {
  const size_t welded = positions.size() / 3;
  const float factor = options_.factor;
  for (int iteration = 0; iteration < options_.iterations; ++iteration) {
    for (size_t v = 0; v < welded; ++v) {
      const uint32_t begin = neighbour_offsets_[v], end = neighbour_offsets_[v + 1];
      const float* p = &positions[3 * v];
      float* out = &scratch_[3 * v];
      if (begin == end) {  // isolated vertex: nothing to average
        out[0] = p[0], out[1] = p[1], out[2] = p[2];
        continue;
      }
      float sum[3] = {0, 0, 0};
      for (uint32_t i = begin; i < end; ++i) {
        const float* q = &positions[3 * neighbours_[i]];
        sum[0] += q[0], sum[1] += q[1], sum[2] += q[2];
      }
      const float inverse = 1.0f / static_cast<float>(end - begin);
      for (int c = 0; c < 3; ++c) out[c] = p[c] + factor * (sum[c] * inverse - p[c]);
    }
    positions.swap(scratch_);
  }
}

void DeltaMush::compute_frames(const std::vector<float>& positions) {
  const size_t welded = positions.size() / 3;
  std::fill(frames_.begin(), frames_.end(), 0.0f);
  // Area-weighted vertex normals into the n slot (frame + 6).
  for (size_t t = 0; t < welded_triangles_.size(); t += 3) {
    const float* a = &positions[3 * welded_triangles_[t]];
    const float* b = &positions[3 * welded_triangles_[t + 1]];
    const float* c = &positions[3 * welded_triangles_[t + 2]];
    const float ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const float ac[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    float n[3];
    cross(ab, ac, n);
    for (int k = 0; k < 3; ++k) {
      float* slot = &frames_[9 * welded_triangles_[t + k] + 6];
      slot[0] += n[0], slot[1] += n[1], slot[2] += n[2];
    }
  }
  for (size_t v = 0; v < welded; ++v) {
    float* t = &frames_[9 * v];
    float* b = t + 3;
    float* n = t + 6;
    if (!normalize(n)) n[0] = 0, n[1] = 0, n[2] = 1;
    // Tangent: the edge to the first neighbour, minus its normal part.
    const uint32_t begin = neighbour_offsets_[v];
    bool have_tangent = false;
    if (begin != neighbour_offsets_[v + 1]) {
      const float* p = &positions[3 * v];
      const float* q = &positions[3 * neighbours_[begin]];
      const float edge[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
      const float along = dot(edge, n);
      for (int c = 0; c < 3; ++c) t[c] = edge[c] - along * n[c];
      have_tangent = normalize(t);
    }
    if (!have_tangent) {  // any unit vector orthogonal to n
      const float axis[3] = {std::fabs(n[0]) < 0.9f ? 1.0f : 0.0f, std::fabs(n[0]) < 0.9f ? 0.0f : 1.0f, 0.0f};
      cross(axis, n, t);
      normalize(t);
    }
    cross(n, t, b);
  }
}

void DeltaMush::deform(const float* joint_matrices, size_t joint_count, float* out_positions) {
  const size_t welded = welded_rest_.size() / 3;
  // Linear blend skinning of the welded vertices.
  for (size_t v = 0; v < welded; ++v) {
    const float* p = &welded_rest_[3 * v];
    float out[3] = {0, 0, 0};
    for (size_t i = 0; i < influences_; ++i) {
      const float w = weights_[v * influences_ + i];
      const size_t joint = joints_[v * influences_ + i];
      if (w == 0.0f || joint >= joint_count) continue;
      const float* m = joint_matrices + 16 * joint;
      for (int r = 0; r < 3; ++r) out[r] += w * (m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
    }
    skinned_[3 * v] = out[0], skinned_[3 * v + 1] = out[1], skinned_[3 * v + 2] = out[2];
  }
  // Smoothed in place (scratch_ is the smoother's second buffer).
  std::vector<float>& smoothed = skinned_;
  smooth(smoothed);
  compute_frames(smoothed);
  for (size_t original = 0; original < original_to_welded_.size(); ++original) {
    const size_t v = original_to_welded_[original];
    const float* frame = &frames_[9 * v];
    const float* d = &local_delta_[3 * v];
    for (int c = 0; c < 3; ++c)
      out_positions[3 * original + c] =
          smoothed[3 * v + c] + d[0] * frame[c] + d[1] * frame[3 + c] + d[2] * frame[6 + c];
  }
}

}  // namespace skelform::bench
