// Limb joints bent along arcs (joint_arcs.h).
#include "joint_arcs.h"

#include "asset.h"
#include "asset_read.h"
#include "skelform/core/gltf_read.h"

#include <tiny_gltf.h>

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace skelform::runtime {
namespace {

constexpr float kPinch = 0.95f;  // the bulged limb's radius stays within this part of the arc's
constexpr float kFit = 0.9f;     // the fillet's tangent points stay within this part of the zone
// The arc replaces the linear blend from 0.75 to 1.25 of the joint's fold bend (the bend or
// twist where linear blending starts to fold the reconstruction), the fold bend taken at
// most 60 degrees: past about 75 degrees two limb segments press into each other on the
// inner side whatever the blend's width (a wide blend's fold bend can reach 160-240 degrees,
// and the arcs would never come in; the cap's trade-off is in docs/tuning.md).
constexpr float kArcOnset = 0.75f, kArcFull = 1.25f;
constexpr float kLargestFoldBend = glm::pi<float>() / 3.0f;
constexpr double kBlendedWeight = 0.1;    // both of a pair above this: a vertex of the joint's blend
constexpr double kLongestRestBend = 0.5;  // cos 60°: straighter joints only
constexpr double kSharedBone = 0.45;      // a zone's cap on a bone with a joint at each end
constexpr double kEndBone = 0.9;          // ... on a bone that ends in the skin's first or last joint

// Any unit vector perpendicular to unit `u`.
glm::vec3 perpendicular(const glm::vec3& u) {
  const glm::vec3 a = std::fabs(u.x) < 0.7f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  return glm::normalize(a - glm::dot(a, u) * u);
}

// Rotation by `angle` about unit `axis`, as a matrix.
glm::mat3 rotation_about(const glm::vec3& axis, float angle) { return glm::mat3_cast(glm::angleAxis(angle, axis)); }

// Joint j's total weight in vertex v's skin (`influences` slots per vertex).
double skin_weight(const uint16_t* joint_index, const float* weight, uint32_t influences, uint32_t v, size_t j) {
  double w = 0.0;
  for (uint32_t k = 0; k < influences; ++k)
    if (joint_index[size_t(v) * influences + k] == j) w += double(weight[size_t(v) * influences + k]);
  return w;
}

glm::mat4 to_mat4(const JointAffine& a) {
  glm::mat4 m(1.0f);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) m[c][r] = a.m[4 * r + c];
  return m;
}

}  // namespace

ArcPose make_arc_pose(const ArcJoint& joint, const glm::mat4& parent, const glm::mat4& child) {
  ArcPose pose;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) pose.parent.m[4 * r + c] = parent[c][r];
  // The child relative to the parent, in bind space: X = A_P⁻¹·A_C (identity at bind).
  const glm::mat4 relative = glm::inverse(parent) * child;
  const glm::mat3 rotation = rotation_part(glm::mat3(relative));  // skin_blend.h
  const glm::vec3 u = joint.axis;
  const glm::vec3 moved = glm::vec3(relative * glm::vec4(joint.center, 1.0f));
  pose.translation = std::isfinite(moved.x + moved.y + moved.z) ? moved - joint.center : glm::vec3(0.0f);
  // Swing: the shortest rotation taking u to R·u, by θ about e; twist: the rest, about u.
  const glm::vec3 turned = rotation * u;
  const glm::vec3 cross = glm::cross(u, turned);
  const float sine = glm::length(cross);
  const float bend = std::atan2(sine, glm::dot(u, turned));
  pose.bend = std::isfinite(bend) ? bend : 0.0f;
  pose.bend_axis = sine > 1e-12f && std::isfinite(sine) ? cross / sine : perpendicular(u);
  pose.inward = glm::cross(pose.bend_axis, u);
  const glm::mat3 swing = rotation_about(pose.bend_axis, pose.bend);
  pose.bent_axis = swing * u;
  const glm::vec3 a = perpendicular(u);
  const glm::vec3 b = glm::transpose(swing) * (rotation * a);
  const float twist = std::atan2(glm::dot(u, glm::cross(a, b)), glm::dot(a, b));
  pose.twist = std::isfinite(twist) ? twist : 0.0f;
  // The fillet of the corner at J: radius ρ, tangent to both lines at distance t from J,
  // shrunk where it would not fit in the zone.
  const float zone = joint.zone;
  // (θ/2 kept below π/2: float π/2 lies above it, where tan turns negative.)
  const float tan_half = std::tan(std::min(0.5f * pose.bend, 1.5707f));
  pose.arc_radius = tan_half > 0.0f ? std::min(joint.radius, kFit * zone / tan_half) : joint.radius;
  pose.tangent = pose.arc_radius * tan_half;
  pose.path = 2.0f * (zone - pose.tangent) + pose.arc_radius * pose.bend;
  // Bulge k(z) = 1 + q·cos²(πz/2F): mean k² = 1 + q + 3q²/8 = 2F / path.
  const float gain = pose.path > 0.0f ? std::max(2.0f * zone / pose.path - 1.0f, 0.0f) : 0.0f;
  const float fold = std::min(joint.fold_bend, kLargestFoldBend);
  const float onset = kArcOnset * fold, full = kArcFull * fold;
  const float angle = std::max(pose.bend, std::fabs(pose.twist));
  const float ramp = std::clamp((angle - onset) / std::max(full - onset, 1e-6f), 0.0f, 1.0f);
  pose.weight = ramp * ramp * (3.0f - 2.0f * ramp);
  pose.bulge = joint.section * (std::sqrt(1.0f + 1.5f * gain) - 1.0f) / 0.75f;
  // ... but the bulged limb stays inside the arc's radius (else its inner side would pinch
  // through the arc's centre and fold): past that the zone gives up volume instead.
  if (joint.limb > 0.0f)
    pose.bulge = std::min(pose.bulge, std::max(kPinch * pose.arc_radius / joint.limb - 1.0f, 0.0f));
  return pose;
}

ArcMap arc_map(const ArcJoint& joint, const ArcPose& pose, float axial) {
  const glm::vec3 J = joint.center, u = joint.axis;
  const float F = joint.zone, z = axial;
  glm::vec3 centre;
  float phi;
  if (z <= -F) {
    centre = J + z * u;
    phi = 0.0f;
  } else if (z >= F) {
    centre = J + z * pose.bent_axis;
    phi = pose.bend;
  } else {
    const float s = (z + F) * pose.path / (2.0f * F);  // arc length along the bent centre line
    const float straight = F - pose.tangent;
    const float rho = pose.arc_radius;
    if (s <= straight) {
      centre = J + (s - F) * u;
      phi = 0.0f;
    } else if (s < straight + rho * pose.bend) {
      phi = (s - straight) / rho;
      centre = J - pose.tangent * u + rho * pose.inward - rho * std::cos(phi) * pose.inward + rho * std::sin(phi) * u;
    } else {
      centre = J + (pose.tangent + s - straight - rho * pose.bend) * pose.bent_axis;
      phi = pose.bend;
    }
  }
  ArcMap map;
  if (z > -F && z < F) {
    const float c = std::cos(0.5f * glm::pi<float>() * z / F);
    map.scale = 1.0f + pose.bulge * c * c;
  }
  // The twist (and any translation in the joint) spreads over the whole zone: over the skin's
  // blend alone it shears the surface (150 degrees within one radius folds the bent capsule).
  const float t = std::clamp((z + F) / (2.0f * F), 0.0f, 1.0f);
  const float twist = t * t * (3.0f - 2.0f * t);
  map.rotation = rotation_about(pose.bend_axis, phi) * rotation_about(u, twist * pose.twist);
  // x ↦ centre + k·R·(x − J − z·u) + twist·translation.
  map.translation = centre - map.scale * (map.rotation * (J + z * u)) + twist * pose.translation;
  return map;
}

namespace {

// build_joint_arcs's steps over one deformable: the skin's joint heads and hierarchy, the
// heaviest joint of each control vertex, the limb joints that qualify for an arc (candidate)
// and the control vertices each arc moves (assign).
class ArcBuilder {
 public:
  struct Candidate {
    ArcJoint joint;
    double lateral;  // limb radius bound: vertices farther from the axis are not the limb's
  };

  ArcBuilder(const tinygltf::Model& model, const Deformable& d)
      : model_(model),
        d_(d),
        skin_(model.skins[static_cast<size_t>(d.skin)]),
        joints_(skin_.joints.size()),
        count_(d.control_vertex_count),
        influences_(d.influences) {}

  // Heads at bind: the origins of the inverse bind matrices' inverses (identity if absent).
  // False when they are missing or not finite (the loader's skin checks report it; no arcs).
  bool read_heads() {
    head_.assign(joints_, glm::dvec3(0.0));
    if (skin_.inverseBindMatrices >= 0) {
      const std::vector<glm::dmat4> inverse_bind = gltf::read_mat4(
          model_, skin_.inverseBindMatrices, "skin " + std::to_string(d_.skin) + " inverseBindMatrices");
      if (inverse_bind.size() < joints_) return false;
      for (size_t j = 0; j < joints_; ++j) head_[j] = glm::dvec3(glm::inverse(inverse_bind[j])[3]);
    }
    // A head beyond the asset's length limit (an inverse bind matrix that is nearly singular,
    // or garbage) would give an arc whose lengths and their squares overflow float: no arcs,
    // the skin's linear blend everywhere, as for a skin without limb joints.
    for (const glm::dvec3& h : head_)
      if (!(std::fabs(h.x) <= loader::kMaxLength && std::fabs(h.y) <= loader::kMaxLength &&
            std::fabs(h.z) <= loader::kMaxLength))
        return false;
    return true;
  }

  // The joint hierarchy within the skin, and each control vertex's heaviest joint.
  void read_hierarchy() {
    const size_t nodes = model_.nodes.size();
    std::vector<int> joint_of_node(nodes, -1), parent_node(nodes, -1);
    for (size_t j = 0; j < joints_; ++j)
      if (skin_.joints[j] >= 0 && static_cast<size_t>(skin_.joints[j]) < nodes)
        joint_of_node[static_cast<size_t>(skin_.joints[j])] = static_cast<int>(j);
    for (size_t n = 0; n < nodes; ++n)
      for (int c : model_.nodes[n].children)
        if (c >= 0 && static_cast<size_t>(c) < nodes) parent_node[static_cast<size_t>(c)] = static_cast<int>(n);
    parent_.assign(joints_, -1);
    children_.assign(joints_, {});
    for (size_t j = 0; j < joints_; ++j) {
      const int node = skin_.joints[j];
      if (node < 0 || static_cast<size_t>(node) >= nodes) continue;
      const int p = parent_node[static_cast<size_t>(node)];
      if (p >= 0 && joint_of_node[static_cast<size_t>(p)] >= 0) {
        parent_[j] = joint_of_node[static_cast<size_t>(p)];
        children_[static_cast<size_t>(parent_[j])].push_back(static_cast<int>(j));
      }
    }
    heaviest_.assign(count_, -1);
    for (uint32_t v = 0; v < count_; ++v) {
      float best = 0.0f;
      for (uint32_t k = 0; k < influences_; ++k)
        if (d_.control_weights[size_t(v) * influences_ + k] > best) {
          best = d_.control_weights[size_t(v) * influences_ + k];
          heaviest_[v] = d_.control_joints[size_t(v) * influences_ + k];
        }
    }
  }

  // Joint c's arc, when c is a limb joint (a parent, at most one child) with room for one.
  bool candidate(size_t c, Candidate& arc) const {
    const int p = parent_[c];
    if (p < 0 || children_[c].size() > 1) return false;
    const glm::dvec3 J = head_[c];
    const double parent_length = glm::length(J - head_[static_cast<size_t>(p)]);
    if (!(parent_length > 0.0)) return false;
    const glm::dvec3 parent_axis = (J - head_[static_cast<size_t>(p)]) / parent_length;
    glm::dvec3 child_axis;
    double child_cap;
    if (!child_bone(c, J, child_axis, child_cap)) return false;
    if (glm::dot(parent_axis, child_axis) < kLongestRestBend) return false;
    const glm::dvec3 u = glm::normalize(parent_axis + child_axis);
    const double parent_cap = parent_[static_cast<size_t>(p)] >= 0
                                  ? kSharedBone * parent_length
                                  : kEndBone * std::max(parent_length, reach(static_cast<size_t>(p), J, -parent_axis));
    const size_t pj = static_cast<size_t>(p);
    // The limb's radius at the joint: over its blended skeletal vertices, distance from the
    // axis plus medial radius.
    double radius_sum = 0.0;
    size_t blended = 0;
    for (uint32_t v = 0; v < count_; ++v) {
      const double wp = weight_of(v, pj), wc = weight_of(v, c);
      if (wp < kBlendedWeight || wc < kBlendedWeight) continue;
      const glm::dvec3 x = glm::dvec3(d_.skeletal_positions[v]) - J;
      radius_sum += glm::length(x - glm::dot(x, u) * u) + double(d_.medial_radius[v]);
      ++blended;
    }
    if (blended == 0) return false;
    const double limb = radius_sum / double(blended);
    // The dense surface around the control mesh: mean distance from the axis of the blended
    // dense vertices over that of the blended control vertices.
    const double control_section = section_radius(d_.control_positions.data(), d_.control_joints.data(),
                                                  d_.control_weights.data(), count_, pj, c, J, u);
    const double dense_section = section_radius(d_.rest_positions.data(), d_.dense_joints.data(),
                                                d_.dense_weights.data(), d_.vertex_count, pj, c, J, u);
    const double fold_bend = fold_bend_of(pj, c, J, u, limb);
    const double section = control_section > 0.0 && dense_section > 0.0 ? dense_section / control_section : 1.0;
    const double zone = std::min({double(kArcZone) * limb, parent_cap, child_cap});
    if (!(limb > 0.0) || zone < limb) return false;  // no room for an arc
    arc.joint.parent = static_cast<uint16_t>(p);
    arc.joint.child = static_cast<uint16_t>(c);
    arc.joint.center = glm::vec3(J);
    arc.joint.axis = glm::vec3(u);
    arc.joint.zone = float(zone);
    arc.joint.radius = float(kArcRadius * limb);
    arc.joint.limb = float(limb);
    arc.joint.fold_bend = float(fold_bend);
    arc.joint.section = float(std::clamp(section, 1.0, 4.0));
    arc.lateral = 2.0 * limb;
    return true;
  }

  // Each control vertex takes the arc joint nearest to it (relative to the zone) among those
  // whose pair has part of its skin and whose limb it lies in. Outside the zone only vertices
  // blended between the two joints take it (elsewhere the map is the vertex's rigid bone).
  // False when no vertex takes one.
  bool assign(const std::vector<Candidate>& arcs, std::vector<ArcVertex>& parts) const {
    parts.assign(count_, ArcVertex{});
    bool any = false;
    for (uint32_t v = 0; v < count_; ++v) {
      double best = std::numeric_limits<double>::max();
      for (size_t a = 0; a < arcs.size(); ++a) {
        const ArcJoint& joint = arcs[a].joint;
        const double wp = weight_of(v, joint.parent), wc = weight_of(v, joint.child);
        if (!(wp + wc > 0.0)) continue;
        const glm::dvec3 x = glm::dvec3(d_.skeletal_positions[v]) - glm::dvec3(joint.center);
        const double z = glm::dot(x, glm::dvec3(joint.axis));
        if (glm::length(x - z * glm::dvec3(joint.axis)) > arcs[a].lateral) continue;
        const double relative = std::fabs(z) / double(joint.zone);
        if (relative >= 1.0 && !(wp > 0.0 && wc > 0.0)) continue;
        if (relative >= best) continue;
        best = relative;
        parts[v].joint = static_cast<uint32_t>(a);
        parts[v].axial = float(z);
        parts[v].share = float(wp + wc);
        any = true;
      }
    }
    return any;
  }

  size_t joints() const { return joints_; }

 private:
  double weight_of(uint32_t v, size_t j) const {
    return skin_weight(d_.control_joints.data(), d_.control_weights.data(), influences_, v, j);
  }

  // How far the skeletal vertices joint j moves most reach from `from` along `direction`:
  // the far ends of root and leaf bones.
  double reach(size_t j, const glm::dvec3& from, const glm::dvec3& direction) const {
    double far = 0.0;
    for (uint32_t v = 0; v < count_; ++v)
      if (heaviest_[v] == static_cast<int>(j))
        far = std::max(far, glm::dot(glm::dvec3(d_.skeletal_positions[v]) - from, direction));
    return far;
  }

  // Joint c's bone beyond the joint at J: its axis and the zone's cap along it. A leaf's axis
  // points towards the centroid of the skeletal vertices it moves most. False when degenerate.
  bool child_bone(size_t c, const glm::dvec3& J, glm::dvec3& axis, double& cap) const {
    if (children_[c].size() == 1) {
      const double length = glm::length(head_[static_cast<size_t>(children_[c][0])] - J);
      if (!(length > 0.0)) return false;
      axis = (head_[static_cast<size_t>(children_[c][0])] - J) / length;
      cap = kSharedBone * length;
      return true;
    }
    glm::dvec3 sum(0.0);
    size_t n = 0;
    for (uint32_t v = 0; v < count_; ++v)
      if (heaviest_[v] == static_cast<int>(c)) {
        sum += glm::dvec3(d_.skeletal_positions[v]);
        ++n;
      }
    if (n == 0) return false;
    const glm::dvec3 to = sum / double(n) - J;
    const double length = glm::length(to);
    if (!(length > 0.0)) return false;
    axis = to / length;
    cap = kEndBone * reach(c, J, axis);
    return true;
  }

  // Mean distance from the axis (J, u) of the vertices blended between joints p and c.
  double section_radius(const glm::vec3* positions, const uint16_t* joint_index, const float* weight, uint32_t n,
                        size_t p, size_t c, const glm::dvec3& J, const glm::dvec3& u) const {
    double sum = 0.0;
    size_t used = 0;
    for (uint32_t v = 0; v < n; ++v) {
      const double wp = skin_weight(joint_index, weight, influences_, v, p);
      const double wc = skin_weight(joint_index, weight, influences_, v, c);
      if (wp < kBlendedWeight || wc < kBlendedWeight) continue;
      const glm::dvec3 x = glm::dvec3(positions[v]) - J;
      sum += glm::length(x - glm::dot(x, u) * u);
      ++used;
    }
    return used ? sum / double(used) : 0.0;
  }

  // Where linear blending folds: the inner side at the limb's radius r runs backwards once
  // r·θ·max dw/dz > 1 (fair_test.cpp, the bent capsule), w the child's share of the pair.
  // max dw/dz from the axial extent of the vertices with w in (0.02, 0.98): 0.83 of a
  // smoothstep's width b, whose steepest slope is 1.5 / b. A coarse mesh samples less of the
  // blend, which only brings the arcs in earlier; a blend no vertex samples (a step between
  // the bones) folds at once.
  double fold_bend_of(size_t p, size_t c, const glm::dvec3& J, const glm::dvec3& u, double limb) const {
    double z_low = std::numeric_limits<double>::max(), z_high = -z_low;
    for (uint32_t v = 0; v < count_; ++v) {
      const double wp = weight_of(v, p), wc = weight_of(v, c);
      if (!(wp + wc > 0.0)) continue;
      const double share = wc / (wp + wc);
      if (share <= 0.02 || share >= 0.98) continue;
      const double z = glm::dot(glm::dvec3(d_.skeletal_positions[v]) - J, u);
      z_low = std::min(z_low, z);
      z_high = std::max(z_high, z);
    }
    return z_high > z_low ? (z_high - z_low) / (1.25 * limb) : 0.0;
  }

  const tinygltf::Model& model_;
  const Deformable& d_;
  const tinygltf::Skin& skin_;
  size_t joints_;
  uint32_t count_, influences_;
  std::vector<glm::dvec3> head_;
  std::vector<int> parent_, heaviest_;
  std::vector<std::vector<int>> children_;
};

}  // namespace

void build_joint_arcs(const tinygltf::Model& model, Deformable& d) {
  d.arc_joints.clear();
  d.arc_vertices.clear();
  if (d.skin < 0 || d.joint_count == 0 || d.influences == 0) return;
  ArcBuilder builder(model, d);
  if (!builder.read_heads()) return;
  builder.read_hierarchy();
  std::vector<ArcBuilder::Candidate> arcs;
  for (size_t c = 0; c < builder.joints(); ++c) {
    ArcBuilder::Candidate arc;
    if (builder.candidate(c, arc)) arcs.push_back(arc);
  }
  if (arcs.empty()) return;
  std::vector<ArcVertex> parts;
  if (!builder.assign(arcs, parts)) return;
  for (const ArcBuilder::Candidate& arc : arcs) d.arc_joints.push_back(arc.joint);
  d.arc_vertices.assign(parts.begin(), parts.end());
}

void pose_joint_arcs(const Deformable& d, const JointAffine* joints, ArcPose* poses) {
  for (size_t a = 0; a < d.arc_joints.size(); ++a) {
    const ArcJoint& joint = d.arc_joints[a];
    poses[a] = make_arc_pose(joint, to_mat4(joints[joint.parent]), to_mat4(joints[joint.child]));
  }
}

}  // namespace skelform::runtime
