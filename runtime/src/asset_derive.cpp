// What the loader derives from a deformable it has read and checked (asset_derive.h): the
// refined vertices renumbered for locality and their stencils grouped for refine_surface, the
// rest frames and handle control vertices of the dense vertices, and the fairing's rest data.
#include "asset_derive.h"

#include "skelform/core/dss_frame.h"
#include "refine.h"
#include "skin_blend.h"

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace skelform::runtime::loader {
namespace {

// Renumbers the refined vertices in the order the dense vertices first name them as corners of
// their bound triangles (then the unnamed ones, in baked order; Deformable::
// named_refined_count counts the named): the per-frame DSS loop (displace.cpp) walks the dense
// vertices in order, and in the baked numbering their corners lie all over the refined arrays
// (several cache lines per dense vertex). A pure renaming: stencil rows move with their vertex,
// refined triangles keep their order and their corners' roles, so every refined position and
// normal is computed with the same operations in the same order, and the evaluation gives the
// same bits.
void renumber_refined_vertices(Deformable& deformable) {
  const uint32_t count = deformable.refined_vertex_count;
  constexpr uint32_t kUnnamed = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> new_of_old(count, kUnnamed), old_of_new;
  old_of_new.reserve(count);
  for (uint32_t v = 0; v < deformable.vertex_count; ++v)
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t old = deformable.refined_indices[3 * size_t{deformable.binding_triangle[v]} + k];
      if (new_of_old[old] != kUnnamed) continue;
      new_of_old[old] = static_cast<uint32_t>(old_of_new.size());
      old_of_new.push_back(old);
    }
  deformable.named_refined_count = static_cast<uint32_t>(old_of_new.size());
  for (uint32_t old = 0; old < count; ++old)
    if (new_of_old[old] == kUnnamed) {
      new_of_old[old] = static_cast<uint32_t>(old_of_new.size());
      old_of_new.push_back(old);
    }
  Array<uint32_t> offsets(deformable.stencil_offsets.get_allocator());
  Array<uint32_t> indices(deformable.stencil_indices.get_allocator());
  Array<float> weights(deformable.stencil_weights.get_allocator());
  offsets.reserve(deformable.stencil_offsets.size());
  indices.reserve(deformable.stencil_indices.size());
  weights.reserve(deformable.stencil_weights.size());
  offsets.push_back(0);
  for (uint32_t old : old_of_new) {
    for (uint32_t s = deformable.stencil_offsets[old]; s < deformable.stencil_offsets[old + 1]; ++s) {
      indices.push_back(deformable.stencil_indices[s]);
      weights.push_back(deformable.stencil_weights[s]);
    }
    offsets.push_back(static_cast<uint32_t>(indices.size()));
  }
  deformable.stencil_offsets.swap(offsets);
  deformable.stencil_indices.swap(indices);
  deformable.stencil_weights.swap(weights);
  for (uint32_t& index : deformable.refined_indices) index = new_of_old[index];
}

// Regroups the stencil rows of the named refined vertices for refine_surface
// (Deformable::stencil_group_rows; the others no dense vertex reads, and a Loop-refined control
// mesh finer than its dense mesh has many: 19 % of CesiumMan's at level 1, 36 % of
// CesiumMan_loop2's at level 3): a stable sort of the rows by length, then kStencilLanes rows
// per group, entries lane-interleaved.
// Each row keeps its entries in stencil order, so it sums to the same bits as from the CSR;
// the sums of a group are independent, which hides their addition latency, and the inner
// loop's trip count is the same group after group (rows come in mixed lengths, in no order).
void group_stencils(Deformable& deformable) {
  const uint32_t count = deformable.named_refined_count;
  std::vector<uint32_t> by_length(count);
  for (uint32_t v = 0; v < count; ++v) by_length[v] = v;
  const auto length = [&](uint32_t v) { return deformable.stencil_offsets[v + 1] - deformable.stencil_offsets[v]; };
  std::stable_sort(by_length.begin(), by_length.end(), [&](uint32_t l, uint32_t r) { return length(l) < length(r); });
  deformable.stencil_group_rows.clear();
  deformable.stencil_group_lengths.clear();
  deformable.stencil_group_indices.clear();
  deformable.stencil_group_weights.clear();
  for (size_t first = 0; first < count;) {
    const uint32_t rows_length = length(by_length[first]);
    uint32_t lanes[kStencilLanes];
    for (uint32_t lane = 0; lane < kStencilLanes; ++lane) {
      // A short last group of this length repeats its last row.
      if (first < count && length(by_length[first]) == rows_length) ++first;
      lanes[lane] = by_length[first - 1];
      deformable.stencil_group_rows.push_back(lanes[lane]);
    }
    deformable.stencil_group_lengths.push_back(rows_length);
    for (uint32_t s = 0; s < rows_length; ++s)
      for (uint32_t lane = 0; lane < kStencilLanes; ++lane) {
        const uint32_t entry = deformable.stencil_offsets[lanes[lane]] + s;
        deformable.stencil_group_indices.push_back(deformable.stencil_indices[entry]);
        deformable.stencil_group_weights.push_back(deformable.stencil_weights[entry]);
      }
  }
}

}  // namespace

// The rest evaluation, once: refined rest surface, the corners of every bound triangle, the
// rest normal and tangent in the frame at every bound point, and the control vertex a handle
// on each dense vertex moves.
void derive_rest_data(Deformable& deformable) {
  renumber_refined_vertices(deformable);
  group_stencils(deformable);
  std::vector<glm::vec3> refined(deformable.named_refined_count);
  std::vector<glm::vec3> normals(deformable.named_refined_count);
  refine_rest_surface(deformable, refined.data(), normals.data());

  deformable.binding_corners.resize(3 * size_t{deformable.vertex_count});
  for (uint32_t v = 0; v < deformable.vertex_count; ++v)
    for (uint32_t k = 0; k < 3; ++k)
      deformable.binding_corners[3 * size_t{v} + k] =
          deformable.refined_indices[3 * size_t{deformable.binding_triangle[v]} + k];
  deformable.rest_normal_coords.resize(deformable.vertex_count);
  deformable.rest_tangent_coords.resize(deformable.vertex_count);
  deformable.handle_control_vertex.resize(deformable.vertex_count);
  std::vector<bool> computed_normal(deformable.vertex_count, false);
  for (const PrimitiveRecord& record : deformable.primitives)
    if (!record.has_normals)
      for (uint32_t v = 0; v < record.vertex_count; ++v) computed_normal[record.first_vertex + v] = true;

  for (uint32_t v = 0; v < deformable.vertex_count; ++v) {
    const dss::SurfaceFrame frame = bound_frame(deformable, refined.data(), normals.data(), v);
    if (computed_normal[v] && deformable.rest_normals[v] == glm::vec3(0.0f)) deformable.rest_normals[v] = frame.normal;
    // Coordinates in the rest frame F (columns tangent, bitangent, normal): F^T x.
    const glm::mat3 to_frame = glm::transpose(glm::mat3(frame.tangent, frame.bitangent, frame.normal));
    deformable.rest_normal_coords[v] = normalize_or(to_frame * deformable.rest_normals[v], glm::vec3(0, 0, 1));
    deformable.rest_tangent_coords[v] =
        normalize_or(to_frame * glm::vec3(deformable.rest_tangents[v]), glm::vec3(1, 0, 0));

    // Corner with the largest barycentric, then its heaviest stencil entry. Corners whose
    // stencil is empty (legal, if odd) are skipped in barycentric order.
    const uint32_t* corner = deformable.binding_corners.data() + 3 * size_t{v};
    const glm::vec2 b = deformable.binding_barycentric[v];
    std::array<std::pair<float, uint32_t>, 3> by_weight = {
        {{1.0f - b.x - b.y, corner[0]}, {b.x, corner[1]}, {b.y, corner[2]}}};
    std::stable_sort(by_weight.begin(), by_weight.end(),
                     [](const auto& l, const auto& r) { return l.first > r.first; });
    uint32_t control = 0;
    for (const auto& [weight, refined_vertex] : by_weight) {
      (void)weight;
      const uint32_t begin = deformable.stencil_offsets[refined_vertex],
                     end = deformable.stencil_offsets[refined_vertex + 1];
      if (begin == end) continue;
      uint32_t best = begin;
      for (uint32_t s = begin + 1; s < end; ++s)
        if (deformable.stencil_weights[s] > deformable.stencil_weights[best]) best = s;
      control = deformable.stencil_indices[best];
      break;
    }
    deformable.handle_control_vertex[v] = control;
  }
  // The evaluation reads the grouped stencils only.
  Array<uint32_t>(deformable.stencil_offsets.get_allocator()).swap(deformable.stencil_offsets);
  Array<uint32_t>(deformable.stencil_indices.get_allocator()).swap(deformable.stencil_indices);
  Array<float>(deformable.stencil_weights.get_allocator()).swap(deformable.stencil_weights);
}

// The fairing's connectivity and rest values (fair.h), once per deformable.
void derive_fairing_data(Deformable& deformable, const AllocatorRef& allocator) {
  float largest_radius = 0.0f;
  for (float r : deformable.medial_radius) largest_radius = std::max(largest_radius, r);
  deformable.fairing_topology =
      build_fairing_topology(deformable.control_indices.data(), deformable.control_indices.size() / 3,
                             deformable.control_vertex_count, allocator);
  deformable.fairing_supported = largest_radius > 0.0f;
  if (!deformable.fairing_supported) return;
  FairingWorkspace scratch = make_fairing_workspace(deformable.fairing_topology, 0, allocator);
  deformable.fairing_rest =
      make_fairing_rest(deformable.fairing_topology, deformable.skeletal_positions.data(),
                        deformable.medial_radius.data(), deformable.control_positions.data(), 0, scratch, allocator);
}

void derive_junction_anchors(Deformable& d) {
  const ContactMesh& mesh = d.welded;
  if (d.influences == 0 || d.joint_count == 0 || mesh.weld.size() != d.vertex_count || mesh.rest_pairs.empty()) return;
  constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max(), kMixed = kNone - 1;
  // Per welded vertex: the joint all its copies follow alone (skelform weight 0, one dominant
  // joint), kMixed if they do not; and whether every copy may move (weight >= kContactMinWeight).
  std::vector<uint32_t> rigid_joint(mesh.vertex_count, kNone);
  std::vector<uint8_t> movable(mesh.vertex_count, 1);
  for (uint32_t i = 0; i < d.vertex_count; ++i) {
    const uint32_t v = mesh.weld[i];
    const float w = d.skelform_weight[i];
    if (!(w >= kContactMinWeight)) movable[v] = 0;
    uint32_t joint = kMixed;
    if (w == 0.0f) {
      const uint16_t* joints = d.dense_joints.data() + size_t{i} * d.influences;
      const float* weights = d.dense_weights.data() + size_t{i} * d.influences;
      float largest = 0.0f;
      for (uint32_t k = 0; k < d.influences; ++k)
        if (weights[k] > largest) largest = weights[k], joint = joints[k];
    }
    rigid_joint[v] = rigid_joint[v] == kNone || rigid_joint[v] == joint ? joint : kMixed;
  }
  auto rigid = [&](uint32_t t) {
    const uint32_t* c = mesh.triangles.data() + 3 * size_t{t};
    const uint32_t j = rigid_joint[c[0]];
    return j < kMixed && rigid_joint[c[1]] == j && rigid_joint[c[2]] == j;
  };
  // Parts: connected pieces of the welded mesh (union-find over the triangles' corners).
  std::vector<uint32_t> root(mesh.vertex_count);
  for (uint32_t v = 0; v < mesh.vertex_count; ++v) root[v] = v;
  auto find = [&](uint32_t v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  for (uint32_t t = 0; t < mesh.triangle_count; ++t)
    for (int k = 1; k < 3; ++k) {
      const uint32_t a = find(mesh.triangles[3 * size_t{t}]), b = find(mesh.triangles[3 * size_t{t} + size_t(k)]);
      if (a != b) root[std::max(a, b)] = std::min(a, b);
    }
  std::vector<uint32_t> part_size(mesh.vertex_count, 0);
  for (uint32_t t = 0; t < mesh.triangle_count; ++t) ++part_size[find(mesh.triangles[3 * size_t{t}])];
  auto size_of = [&](uint32_t t) { return part_size[find(mesh.triangles[3 * size_t{t}])]; };
  // Per welded vertex: the welded vertex whose skin it follows (its host): the first rigid one
  // met, else the first.
  std::vector<uint32_t> host(mesh.vertex_count, kNone);
  std::vector<uint8_t> host_rigid(mesh.vertex_count, 0);
  auto attach = [&](uint32_t guest, uint32_t by, bool by_rigid) {
    const uint32_t h = mesh.triangles[3 * size_t{by}];
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.triangles[3 * size_t{guest} + size_t(k)];
      if (!movable[v] || (host[v] != kNone && (host_rigid[v] || !by_rigid))) continue;
      host[v] = h;
      host_rigid[v] = by_rigid;
    }
  };
  for (uint64_t key : mesh.rest_pairs) {
    const uint32_t s = uint32_t(key >> 32), t = uint32_t(key);
    const bool rs = rigid(s), rt = rigid(t);
    if (rs && rt) continue;
    // The rigid side hosts; else the larger part (a leg pushed into a body follows the body).
    const bool s_hosts = rs || (!rt && size_of(s) > size_of(t));
    const bool t_hosts = rt || (!rs && size_of(t) > size_of(s));
    if (s_hosts) attach(t, s, rs);
    if (t_hosts) attach(s, t, rt);
  }
  for (uint32_t i = 0; i < d.vertex_count; ++i) {
    const uint32_t h = host[mesh.weld[i]];
    if (h >= kMixed) continue;
    d.anchor_vertices.push_back(i);
    d.anchor_hosts.push_back(mesh.representative[h]);
  }
}

}  // namespace skelform::runtime::loader
