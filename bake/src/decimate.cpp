#include "skelform/bake/decimate.h"

#include <meshoptimizer.h>

#include <limits>

namespace skelform::bake {
namespace {

// Keeps the vertices the triangles use, in input order, and renumbers the triangles.
DecimatedMesh compact(const TriangleMesh& mesh, const std::vector<uint32_t>& indices) {
  DecimatedMesh out;
  constexpr uint32_t kUnused = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> remap(mesh.positions.size(), kUnused);
  for (uint32_t index : indices) remap[index] = 0;
  for (uint32_t v = 0; v < mesh.positions.size(); ++v) {
    if (remap[v] == kUnused) continue;
    remap[v] = static_cast<uint32_t>(out.mesh.positions.size());
    out.mesh.positions.push_back(mesh.positions[v]);
    out.source_vertex.push_back(v);
  }
  out.mesh.triangles.reserve(indices.size() / 3);
  for (size_t i = 0; i + 2 < indices.size(); i += 3)
    out.mesh.triangles.push_back({remap[indices[i]], remap[indices[i + 1]], remap[indices[i + 2]]});
  return out;
}

}  // namespace

DecimatedMesh decimate(const TriangleMesh& mesh, size_t target_triangles) {
  std::vector<uint32_t> indices;
  indices.reserve(mesh.triangles.size() * 3);
  for (const Triangle& t : mesh.triangles) indices.insert(indices.end(), t.begin(), t.end());
  if (target_triangles == 0 || (mesh.triangles.size() + 1) / 2 <= target_triangles) return compact(mesh, indices);

  // meshoptimizer works on float positions; the error it reports is relative to the mesh
  // extent. A generous error bound lets the triangle count, not the error, stop it (the
  // paper's control meshes are 2K-6K triangles whatever the input).
  std::vector<float> positions(mesh.positions.size() * 3);
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    positions[3 * v + 0] = static_cast<float>(mesh.positions[v].x);
    positions[3 * v + 1] = static_cast<float>(mesh.positions[v].y);
    positions[3 * v + 2] = static_cast<float>(mesh.positions[v].z);
  }
  constexpr float kMaxRelativeError = 0.05f;
  std::vector<uint32_t> simplified(indices.size());
  float result_error = 0.0f;
  const size_t count = meshopt_simplify(simplified.data(), indices.data(), indices.size(), positions.data(),
                                        mesh.positions.size(), sizeof(float) * 3, target_triangles * 3,
                                        kMaxRelativeError, meshopt_SimplifyLockBorder, &result_error);
  simplified.resize(count);
  if (simplified.empty()) throw Error(ErrorKind::invalid_input, "decimation removed every triangle");
  DecimatedMesh out = compact(mesh, simplified);
  out.decimated = true;
  out.result_error = result_error;
  return out;
}

}  // namespace skelform::bake
