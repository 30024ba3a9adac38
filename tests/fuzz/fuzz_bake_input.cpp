// fuzz_bake_input: the baker's input readers on hostile files. The first byte picks the
// format (byte % 5: .glb, .gltf, .obj, .ply, .off) and whether glTF loads every mesh
// (byte / 5 odd); the rest of the bytes are the file. The readers' contract (input.h): they
// throw skelform::bake::Error, or return a non-empty mesh whose indices, positions and
// influence sets are valid. Any other exception escapes to libFuzzer as a finding.
#include "fuzz_check.h"
#include "skelform/bake/input.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace {

using skelform::fuzz::require;

void check_mesh(const skelform::bake::InputMesh& mesh) {
  const size_t n = mesh.positions.size();
  require(n > 0 && !mesh.triangles.empty(), "a loader returned an empty mesh");
  require(n <= skelform::bake::kMaxInputVertices && mesh.triangles.size() <= skelform::bake::kMaxInputTriangles,
          "a loader returned a mesh beyond the input limits");
  for (const auto& p : mesh.positions)
    require(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z), "a loader returned a non-finite position");
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) require(size_t(t[k]) < n, "a loader returned a triangle index out of range");
  require(mesh.joint_sets.size() == mesh.weight_sets.size(), "JOINTS_n and WEIGHTS_n set counts differ");
  require(mesh.joint_sets.size() <= skelform::bake::kMaxInfluenceSets, "more influence sets than the limit");
  for (size_t s = 0; s < mesh.joint_sets.size(); ++s) {
    require(mesh.joint_sets[s].size() == n && mesh.weight_sets[s].size() == n,
            "an influence set does not cover every vertex");
    for (const auto& w : mesh.weight_sets[s])
      for (float x : w) require(std::isfinite(x), "a loader returned a non-finite skin weight");
  }
  require(mesh.skelform_weight_override.empty() || mesh.skelform_weight_override.size() == n,
          "the skelform weight override does not cover every vertex");
  for (const auto& p : mesh.primitives) {
    require(p.first_vertex <= n && p.vertex_count <= n - p.first_vertex,
            "a primitive's vertex range is outside the mesh");
    require(p.first_triangle <= mesh.triangles.size() && p.triangle_count <= mesh.triangles.size() - p.first_triangle,
            "a primitive's triangle range is outside the mesh");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const char* const kExtensions[] = {".glb", ".gltf", ".obj", ".ply", ".off"};
  const std::string extension = kExtensions[data[0] % 5];
  skelform::bake::LoadOptions options;
  options.all_meshes = (data[0] / 5) % 2 == 1;
  const std::vector<unsigned char> bytes(data + 1, data + size);
  // A directory that does not exist: a .gltf's relative buffer URIs resolve to nothing, so
  // the result never depends on the files around the fuzzer.
  const std::string name = "/nonexistent-skelform-fuzz/input" + extension;
  try {
    check_mesh(skelform::bake::load_mesh_from_memory(bytes, extension, name, options));
  } catch (const skelform::bake::Error&) {
    // The documented way to refuse a file.
  }
  return 0;
}
