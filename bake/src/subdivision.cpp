// Loop subdivision stencils (DESIGN.md bake step 6): OpenSubdiv refines the control mesh's
// topology uniformly to level k and factorizes the stencils of every level into one table
// from control vertices straight to level k. Displaced subdivision surfaces (the paper's
// reference [18], Lee et al. 2000) bind the dense mesh to this refined surface; the runtime
// replays the table on the deformed control mesh.
#include "skelform/bake/subdivision.h"

#include "skelform/core/dss_frame.h"

#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/stencilTableFactory.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>
#include <opensubdiv/sdc/options.h>
#include <opensubdiv/sdc/types.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>

namespace skelform::bake {
namespace {

namespace Far = OpenSubdiv::Far;
namespace Sdc = OpenSubdiv::Sdc;

constexpr int kMaxLevel = 8;  // 4^8 = 65536 refined triangles per control triangle

SubdivisionStencils identity_stencils(const TriangleMesh& control, const std::vector<Triangle>& triangles) {
  SubdivisionStencils stencils;
  stencils.level = 0;
  stencils.control_vertex_count = static_cast<uint32_t>(control.positions.size());
  stencils.offsets.resize(control.positions.size() + 1);
  stencils.indices.resize(control.positions.size());
  stencils.weights.assign(control.positions.size(), 1.0f);
  for (size_t v = 0; v <= control.positions.size(); ++v) stencils.offsets[v] = static_cast<uint32_t>(v);
  for (size_t v = 0; v < control.positions.size(); ++v) stencils.indices[v] = static_cast<uint32_t>(v);
  stencils.refined_triangles = triangles;
  return stencils;
}

}  // namespace

SubdivisionStencils build_loop_stencils(const TriangleMesh& control, int level) {
  if (level < 0 || level > kMaxLevel)
    throw Error(ErrorKind::usage,
                "subdivision level " + std::to_string(level) + " is outside [0, " + std::to_string(kMaxLevel) + "]");
  if (control.positions.empty() || control.triangles.empty())
    throw Error(ErrorKind::invalid_input, "cannot subdivide an empty control mesh");
  if (control.positions.size() > static_cast<size_t>(std::numeric_limits<int>::max()) ||
      control.triangles.size() > static_cast<size_t>(std::numeric_limits<int>::max() / 3))
    throw Error(ErrorKind::invalid_input, "control mesh too large for OpenSubdiv (2^31 vertices or faces)");

  // Loop's rules need real triangles; a face with a repeated corner has no surface and
  // OpenSubdiv would have to treat it as a degenerate non-manifold face, so drop it here.
  std::vector<Triangle> triangles;
  triangles.reserve(control.triangles.size());
  for (size_t t = 0; t < control.triangles.size(); ++t) {
    const Triangle& tri = control.triangles[t];
    for (uint32_t corner : tri)
      if (corner >= control.positions.size())
        throw Error(ErrorKind::invalid_input, "control triangle " + std::to_string(t) + " has vertex index " +
                                                  std::to_string(corner) + " out of range (" +
                                                  std::to_string(control.positions.size()) + " vertices)");
    if (tri[0] != tri[1] && tri[1] != tri[2] && tri[2] != tri[0]) triangles.push_back(tri);
  }
  if (triangles.empty())
    throw Error(ErrorKind::invalid_input, "control mesh has no non-degenerate triangle to subdivide");
  if (level == 0) return identity_stencils(control, triangles);

  std::vector<int> vertices_per_face(triangles.size(), 3);
  std::vector<Far::Index> face_vertices;
  face_vertices.reserve(triangles.size() * 3);
  for (const Triangle& tri : triangles)
    for (uint32_t corner : tri) face_vertices.push_back(static_cast<Far::Index>(corner));

  Far::TopologyDescriptor descriptor;
  descriptor.numVertices = static_cast<int>(control.positions.size());
  descriptor.numFaces = static_cast<int>(triangles.size());
  descriptor.numVertsPerFace = vertices_per_face.data();
  descriptor.vertIndicesPerFace = face_vertices.data();

  // EDGE_ONLY: border edges and vertices follow the boundary curve rules (the refined rim
  // is a cubic B-spline of the control rim, depending on rim vertices only), so an open
  // control mesh (a mouth, a cut-off neck) keeps a well-defined rim; VTX_BOUNDARY_NONE
  // would leave the border faces without a limit surface.
  Sdc::Options sdc_options;
  sdc_options.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  std::unique_ptr<Far::TopologyRefiner> refiner(
      Factory::Create(descriptor, Factory::Options(Sdc::SCHEME_LOOP, sdc_options)));
  if (!refiner)
    throw Error(ErrorKind::invalid_input, "OpenSubdiv refused the control mesh topology for Loop subdivision");

  Far::TopologyRefiner::UniformOptions uniform(level);
  refiner->RefineUniform(uniform);
  if (refiner->GetMaxLevel() != level)
    throw Error(ErrorKind::invalid_input,
                "OpenSubdiv could not refine the control mesh to level " + std::to_string(level));

  // Stencils from the control vertices to the last level only, with the intermediate levels
  // factorized away: the runtime never sees levels 1..k-1. StencilTableReal<float> is used
  // as is: the non-template StencilTableFactory downcasts to StencilTable, which UBSan's vptr
  // check reports (DEPENDENCIES.md pitfall 2).
  Far::StencilTableFactoryReal<float>::Options options;
  options.interpolationMode = Far::StencilTableFactoryReal<float>::INTERPOLATE_VERTEX;
  options.generateOffsets = true;
  options.generateControlVerts = false;
  options.generateIntermediateLevels = false;
  options.factorizeIntermediateLevels = true;
  options.maxLevel = static_cast<unsigned int>(level);
  std::unique_ptr<const Far::StencilTableReal<float>> table(
      Far::StencilTableFactoryReal<float>::Create(*refiner, options));
  const Far::TopologyLevel& last = refiner->GetLevel(level);
  if (!table || table->GetNumStencils() != last.GetNumVertices())
    throw Error(ErrorKind::invalid_input, "OpenSubdiv produced no stencil table for the control mesh");

  SubdivisionStencils stencils;
  stencils.level = static_cast<uint32_t>(level);
  stencils.control_vertex_count = static_cast<uint32_t>(control.positions.size());
  const int refined_count = table->GetNumStencils();
  const std::vector<int>& sizes = table->GetSizes();
  const std::vector<Far::Index>& table_offsets = table->GetOffsets();
  const std::vector<Far::Index>& table_indices = table->GetControlIndices();
  const std::vector<float>& table_weights = table->GetWeights();
  stencils.offsets.resize(static_cast<size_t>(refined_count) + 1);
  stencils.indices.reserve(table_indices.size());
  stencils.weights.reserve(table_weights.size());
  stencils.offsets[0] = 0;
  for (int v = 0; v < refined_count; ++v) {
    // Copied stencil by stencil (not as one block) so the stored table is contiguous and in
    // refined-vertex order whatever layout OpenSubdiv chose internally.
    const size_t begin = static_cast<size_t>(table_offsets[static_cast<size_t>(v)]);
    const size_t size = static_cast<size_t>(sizes[static_cast<size_t>(v)]);
    for (size_t s = begin; s < begin + size; ++s) {
      stencils.indices.push_back(static_cast<uint32_t>(table_indices[s]));
      stencils.weights.push_back(table_weights[s]);
    }
    stencils.offsets[static_cast<size_t>(v) + 1] = static_cast<uint32_t>(stencils.indices.size());
  }

  stencils.refined_triangles.resize(static_cast<size_t>(last.GetNumFaces()));
  for (int f = 0; f < last.GetNumFaces(); ++f) {
    const Far::ConstIndexArray corners = last.GetFaceVertices(f);
    if (corners.size() != 3) throw Error(ErrorKind::invalid_input, "Loop refinement produced a non-triangular face");
    stencils.refined_triangles[static_cast<size_t>(f)] = {
        static_cast<uint32_t>(corners[0]), static_cast<uint32_t>(corners[1]), static_cast<uint32_t>(corners[2])};
  }
  return stencils;
}

int choose_subdivision_level(size_t control_triangles, size_t dense_triangles) {
  if (control_triangles == 0 || dense_triangles == 0) return 0;
  const double target = std::log(static_cast<double>(dense_triangles));
  int best_level = 0;
  double best_distance = std::numeric_limits<double>::infinity();
  for (int level = 0; level <= 4; ++level) {
    const double refined = std::log(static_cast<double>(control_triangles)) + level * std::log(4.0);
    const double distance = std::fabs(refined - target);
    // Strictly better only (with a relative tolerance for rounding of the logs): a tie keeps
    // the lower level, which costs a quarter of the runtime work.
    if (distance < best_distance - 1e-12) {
      best_distance = distance;
      best_level = level;
    }
  }
  return best_level;
}

std::vector<glm::vec3> apply_stencils(const SubdivisionStencils& stencils, const std::vector<glm::vec3>& control) {
  if (control.size() != stencils.control_vertex_count)
    throw Error(ErrorKind::invalid_input, "apply_stencils: " + std::to_string(control.size()) +
                                              " control positions for stencils over " +
                                              std::to_string(stencils.control_vertex_count));
  const size_t refined_count = stencils.refined_vertex_count();
  std::vector<glm::vec3> refined(refined_count);
  for (size_t v = 0; v < refined_count; ++v) {
    glm::vec3 sum(0.0f);
    for (uint32_t s = stencils.offsets[v]; s < stencils.offsets[v + 1]; ++s)
      sum += stencils.weights[s] * control[stencils.indices[s]];
    refined[v] = sum;
  }
  return refined;
}

std::vector<glm::vec3> refined_normals(const SubdivisionStencils& stencils, const std::vector<glm::vec3>& control,
                                       const std::vector<Triangle>& control_triangles,
                                       const std::vector<glm::vec3>* skeletal) {
  if (skeletal && skeletal->size() != control.size())
    throw Error(ErrorKind::invalid_input, "refined_normals: " + std::to_string(skeletal->size()) +
                                              " skeletal positions for " + std::to_string(control.size()) +
                                              " control vertices");
  std::vector<uint32_t> indices;
  indices.reserve(3 * control_triangles.size());
  for (const Triangle& t : control_triangles)
    for (uint32_t corner : t) {
      if (corner >= control.size())
        throw Error(ErrorKind::invalid_input, "refined_normals: control triangle corner " + std::to_string(corner) +
                                                  " out of range (" + std::to_string(control.size()) + " vertices)");
      indices.push_back(corner);
    }
  std::vector<glm::vec3> sums(control.size(), glm::vec3(0.0f));
  dss::add_face_normals(control.data(), indices.data(), control_triangles.size(), sums.data());
  if (skeletal) dss::medial_normal_sums(control.data(), skeletal->data(), control.size(), sums.data());
  std::vector<glm::vec3> normals = apply_stencils(stencils, sums);
  for (glm::vec3& n : normals) n = dss::normalise_or_zero(n);
  return normals;
}

}  // namespace skelform::bake
