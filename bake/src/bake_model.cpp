// Orchestrates the bake of each deformable: weld, decimate, tangent flow, skeleton,
// subdivision stencils, DSS binding, skin weights (DESIGN.md bake steps 2-7).
#include "skelform/bake/bake.h"

#include "skelform/bake/decimate.h"
#include "skelform/bake/dss.h"
#include "skelform/bake/metrics.h"
#include "skelform/bake/skeleton.h"
#include "skelform/bake/subdivision.h"
#include "skelform/bake/tangent_flow.h"
#include "skelform/bake/topology.h"
#include "skelform/bake/weld.h"

#include "skelform/core/skelform_weight.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <map>

namespace skelform::bake {
namespace {

// The primitives of one glTF mesh (or the whole of an OBJ/PLY/OFF), as an InputMesh of its
// own so that welding and binding see only them.
InputMesh select_primitives(const InputMesh& input, const std::vector<size_t>& primitive_indices) {
  InputMesh out;
  out.source_path = input.source_path;
  out.joint_sets.resize(input.joint_sets.size());
  out.weight_sets.resize(input.weight_sets.size());
  for (size_t index : primitive_indices) {
    InputPrimitive primitive = input.primitives[index];
    const uint32_t vertex_offset = static_cast<uint32_t>(out.positions.size());
    for (uint32_t v = 0; v < primitive.vertex_count; ++v) {
      const size_t source = primitive.first_vertex + v;
      out.positions.push_back(input.positions[source]);
      for (size_t s = 0; s < input.joint_sets.size(); ++s) {
        out.joint_sets[s].push_back(input.joint_sets[s][source]);
        out.weight_sets[s].push_back(input.weight_sets[s][source]);
      }
      if (!input.skelform_weight_override.empty()) {
        out.skelform_weight_override.resize(out.positions.size() - 1, -1.0f);
        out.skelform_weight_override.push_back(input.skelform_weight_override[source]);
      }
    }
    const uint32_t triangle_offset = static_cast<uint32_t>(out.triangles.size());
    for (uint32_t t = 0; t < primitive.triangle_count; ++t) {
      Triangle tri = input.triangles[primitive.first_triangle + t];
      for (uint32_t& corner : tri) corner = corner - primitive.first_vertex + vertex_offset;
      out.triangles.push_back(tri);
    }
    primitive.first_vertex = vertex_offset;
    primitive.first_triangle = triangle_offset;
    out.primitives.push_back(primitive);
  }
  return out;
}

// A mesh with no volume (all vertices in one plane, like SimpleSkin's strip) has no inner
// Voronoi vertices. Its skeleton degenerates to the surface itself: S = M, d = 0, so the
// runtime drives the control mesh directly (the reconstruction M = S + d·N is then exact
// for any pose).
bool is_flat(const TriangleMesh& mesh) {
  if (mesh.positions.size() < 4) return true;
  Vec3 best_normal(0.0);
  Vec3 origin(0.0);
  for (const Triangle& t : mesh.triangles) {
    const Vec3 n = glm::cross(mesh.positions[t[1]] - mesh.positions[t[0]], mesh.positions[t[2]] - mesh.positions[t[0]]);
    if (glm::dot(n, n) > glm::dot(best_normal, best_normal)) {
      best_normal = n;
      origin = mesh.positions[t[0]];
    }
  }
  const double length = glm::length(best_normal);
  if (!(length > 0)) return true;
  const double tolerance = 1e-9 * bounds_of(mesh.positions).diagonal();
  for (const Vec3& p : mesh.positions)
    if (std::abs(glm::dot(p - origin, best_normal / length)) > tolerance) return false;
  return true;
}

SkeletalMesh surface_skeleton(const TriangleMesh& mesh) {
  SkeletalMesh skeleton;
  skeleton.skeletal_positions = mesh.positions;
  skeleton.medial_radius.assign(mesh.positions.size(), 0.0);
  skeleton.normals = area_weighted_normals(mesh);
  skeleton.voronoi_vertex_count.assign(mesh.positions.size(), 0);
  skeleton.vertices_without_candidates = mesh.positions.size();
  return skeleton;
}

std::vector<glm::vec3> to_float(const std::vector<Vec3>& points) {
  std::vector<glm::vec3> out(points.size());
  for (size_t i = 0; i < points.size(); ++i) out[i] = glm::vec3(points[i]);
  return out;
}

BakedDeformable bake_deformable(const InputMesh& group, const BakeOptions& options, size_t index, size_t count,
                                DeformableReport& report) {
  auto stage = [&](const char* name) {
    if (options.progress) options.progress(name, index, count);
  };
  BakedDeformable baked;
  const InputPrimitive& first = group.primitives.front();
  baked.mesh = first.mesh;
  baked.node = first.node;
  baked.skin = first.skin;
  for (const InputPrimitive& p : group.primitives) baked.primitives.push_back(p.primitive);
  baked.dense_vertex_count = static_cast<uint32_t>(group.positions.size());

  stage("weld");
  const WeldedMesh welded = weld(group);
  if (welded.mesh.triangles.empty()) throw Error(ErrorKind::invalid_input, "mesh has no non-degenerate triangle");
  const double diagonal = bounds_of(group.positions).diagonal();
  if (!(diagonal > 0)) throw Error(ErrorKind::invalid_input, "mesh has zero extent");

  stage("decimate");
  DecimatedMesh control = decimate(welded.mesh, options.target_triangles);
  // Refused here rather than by the skeleton stage, before the tangent flow's work on it.
  if (control.mesh.positions.size() > kMaxSkeletonVertices)
    throw Error(ErrorKind::unsupported, "the control mesh has " + std::to_string(control.mesh.positions.size()) +
                                            " vertices, more than the " + std::to_string(kMaxSkeletonVertices) +
                                            " the skeleton stage takes (ask for fewer control triangles)");

  stage("tangent flow");
  TangentFlowOptions flow;
  flow.steps = options.tangent_flow_steps;
  flow.reference_surface = &welded.mesh;  // the control mesh stays on the dense surface
  apply_tangent_flow(control.mesh, flow);

  stage("skeleton");
  report.flat = is_flat(control.mesh);
  const SkeletalMesh skeleton = report.flat ? surface_skeleton(control.mesh) : extract_skeleton(control.mesh);

  stage("subdivision");
  const int level = options.subdivision_level >= 0
                        ? options.subdivision_level
                        : choose_subdivision_level(control.mesh.triangles.size(), welded.mesh.triangles.size());
  SubdivisionStencils stencils = build_loop_stencils(control.mesh, level);
  baked.control_positions = to_float(control.mesh.positions);
  baked.skeletal_positions = to_float(skeleton.skeletal_positions);
  const std::vector<glm::vec3> refined = apply_stencils(stencils, baked.control_positions);
  const std::vector<glm::vec3> normals =
      refined_normals(stencils, baked.control_positions, control.mesh.triangles, &baked.skeletal_positions);

  stage("binding");
  DssBinding binding = bind_dense_vertices(refined, normals, stencils.refined_triangles, group.positions, diagonal);

  stage("skin weights");
  baked.control_normals = to_float(skeleton.normals);
  baked.medial_radius.assign(skeleton.medial_radius.begin(), skeleton.medial_radius.end());
  for (const Triangle& t : control.mesh.triangles)
    baked.control_indices.insert(baked.control_indices.end(), t.begin(), t.end());
  if (baked.skin >= 0) {
    // Each control vertex is a surviving dense vertex (decimate() makes no new positions), so
    // it takes the influences of the original vertex it came from.
    for (size_t s = 0; s < group.joint_sets.size(); ++s) {
      std::vector<std::array<uint16_t, 4>> joints;
      std::vector<std::array<float, 4>> weights;
      for (uint32_t welded_vertex : control.source_vertex) {
        const uint32_t original = welded.original_of_welded[welded_vertex];
        joints.push_back(group.joint_sets[s][original]);
        weights.push_back(group.weight_sets[s][original]);
      }
      baked.joint_sets.push_back(std::move(joints));
      baked.weight_sets.push_back(std::move(weights));
    }
    // The skelform weight of every original vertex: the artist's, else the skin's rule.
    baked.skelform_weight.resize(group.positions.size());
    std::vector<uint16_t> joints(4 * group.joint_sets.size());
    std::vector<float> weights(4 * group.joint_sets.size());
    for (size_t v = 0; v < group.positions.size(); ++v) {
      const float artist = v < group.skelform_weight_override.size() ? group.skelform_weight_override[v] : -1.0f;
      if (artist >= 0.0f) {
        baked.skelform_weight[v] = artist;
        continue;
      }
      for (size_t s = 0; s < group.joint_sets.size(); ++s)
        for (size_t k = 0; k < 4; ++k) {
          joints[4 * s + k] = group.joint_sets[s][v][k];
          weights[4 * s + k] = group.weight_sets[s][v][k];
        }
      baked.skelform_weight[v] = skin::skelform_weight(joints.data(), weights.data(), uint32_t(joints.size()));
    }
  }

  baked.subdivision_level = stencils.level;
  baked.stencil_offsets = std::move(stencils.offsets);
  baked.stencil_indices = std::move(stencils.indices);
  baked.stencil_weights = std::move(stencils.weights);
  for (const Triangle& t : stencils.refined_triangles)
    baked.refined_indices.insert(baked.refined_indices.end(), t.begin(), t.end());
  baked.binding_triangle = std::move(binding.triangle);
  baked.binding_barycentric = std::move(binding.barycentric);
  baked.binding_displacement = std::move(binding.displacement);
  baked.binding_residual = std::move(binding.residual);

  report.mesh = baked.mesh;
  report.dense_vertices = group.positions.size();
  report.dense_triangles = group.triangles.size();
  report.welded_vertices = welded.mesh.positions.size();
  report.control_vertices = control.mesh.positions.size();
  report.control_triangles = control.mesh.triangles.size();
  report.decimated = control.decimated;
  report.subdivision_level = static_cast<int>(baked.subdivision_level);
  report.refined_triangles = baked.refined_indices.size() / 3;
  // Measured against the control mesh, which the tangent flow keeps on the dense surface:
  // the winding number costs a solid angle per (query, triangle), and against a 300K-triangle
  // input it would dominate the whole bake.
  report.skeleton_inside = report.flat ? 0.0 : inside_fraction(control.mesh, skeleton.skeletal_positions);
  report.residual_share =
      group.positions.empty() ? 0.0 : double(binding.residual_vertices) / double(group.positions.size());
  report.rest_error = binding.max_rest_error;
  if (!baked.skelform_weight.empty())
    report.skelform_share = double(std::count_if(baked.skelform_weight.begin(), baked.skelform_weight.end(),
                                                 [](float w) { return w > 0.0f; })) /
                            double(baked.skelform_weight.size());
  return baked;
}

}  // namespace

BakeResult bake_model(const InputMesh& input, const BakeOptions& options) {
  if (options.tangent_flow_steps < 0) throw Error(ErrorKind::usage, "tangent flow steps must be >= 0");
  if (options.subdivision_level > 6) throw Error(ErrorKind::usage, "subdivision level must be at most 6");
  // One deformable per glTF mesh; its primitives keep file order.
  std::map<int, std::vector<size_t>> groups;
  for (size_t p = 0; p < input.primitives.size(); ++p) groups[input.primitives[p].mesh].push_back(p);
  BakeResult result;
  size_t index = 0;
  for (const auto& entry : groups) {
    const InputMesh group = select_primitives(input, entry.second);
    DeformableReport report;
    result.deformables.push_back(bake_deformable(group, options, index++, groups.size(), report));
    result.reports.push_back(report);
  }
  return result;
}

}  // namespace skelform::bake
