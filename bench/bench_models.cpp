#include "bench_models.h"

#include "atomic_file.h"
#include "skelform/bake/bake.h"
#include "skelform/bake/densify.h"
#include "skelform/bake/gltf_writer.h"
#include "skelform/bake/procedural_rig.h"
#include "skelform/bake/weld.h"

#include <tiny_gltf.h>  // the TinyGLTF::TinyGLTF shared library: no TINYGLTF_IMPLEMENTATION here

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace skelform::bench {

namespace {

// A cached file is reused only if it is newer than this executable (a rebuilt baker re-bakes)
// and than `source`, when given (an edited input re-bakes).
bool fresh(const std::filesystem::path& path, const std::filesystem::path& source = {}) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) return false;
  const auto written = std::filesystem::last_write_time(path, error);
  if (error) return false;
  if (!source.empty()) {
    const auto source_time = std::filesystem::last_write_time(source, error);
    if (!error && source_time > written) return false;  // the source changed since
  }
  const auto executable = std::filesystem::last_write_time("/proc/self/exe", error);
  if (error) return true;
  return written >= executable;
}

template <typename T>
int append_view(tinygltf::Model& model, const std::vector<T>& values, int target) {
  std::vector<unsigned char>& data = model.buffers[0].data;
  while (data.size() % 4) data.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = data.size();
  view.byteLength = values.size() * sizeof(T);
  view.target = target;
  const auto* bytes = reinterpret_cast<const unsigned char*>(values.data());
  data.insert(data.end(), bytes, bytes + view.byteLength);
  model.bufferViews.push_back(view);
  return static_cast<int>(model.bufferViews.size() - 1);
}

int append_accessor(tinygltf::Model& model, int view, int component_type, int type, size_t count,
                    bool normalized = false) {
  tinygltf::Accessor accessor;
  accessor.bufferView = view;
  accessor.componentType = component_type;
  accessor.type = type;
  accessor.count = count;
  accessor.normalized = normalized;
  model.accessors.push_back(accessor);
  return static_cast<int>(model.accessors.size() - 1);
}

bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

}  // namespace

std::filesystem::path data_dir() {
  if (const char* env = std::getenv("SKELFORM_DATA_DIR")) return env;
  return SKELFORM_DATA_DIR;
}

std::optional<std::filesystem::path> cesium_man_path() {
  const std::filesystem::path path = data_dir() / "CesiumMan" / "CesiumMan.glb";
  if (!std::filesystem::exists(path)) return std::nullopt;
  return path;
}

std::filesystem::path cache_dir() {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "skelform-bench-cache";
  std::filesystem::create_directories(dir);
  return dir;
}

void write_skinned_glb(const std::string& source_gltf, const skelform::bake::InputMesh& mesh,
                       const std::string& output_path) {
  if (mesh.primitives.empty() || mesh.joint_sets.empty())
    throw std::invalid_argument("write_skinned_glb: the mesh is empty or unskinned");
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(skip_image, nullptr);
  std::string error, warning;
  const bool binary = source_gltf.size() > 4 && source_gltf.substr(source_gltf.size() - 4) == ".glb";
  if (!(binary ? loader.LoadBinaryFromFile(&model, &error, &warning, source_gltf)
               : loader.LoadASCIIFromFile(&model, &error, &warning, source_gltf)))
    throw std::runtime_error(source_gltf + ": " + error);
  const int mesh_index = mesh.primitives.front().mesh;
  if (mesh_index < 0 || static_cast<size_t>(mesh_index) >= model.meshes.size() || model.buffers.empty())
    throw std::runtime_error(source_gltf + ": the mesh to replace does not exist");

  // Images/materials would refer to texture coordinates the new mesh lacks.
  model.images.clear();
  model.textures.clear();
  model.samplers.clear();
  model.materials.clear();
  model.buffers.resize(1);
  model.buffers[0].uri.clear();  // everything goes into the GLB's BIN chunk

  const size_t n = mesh.positions.size();
  std::vector<float> positions(3 * n);
  std::vector<double> lo(3, 1e300), hi(3, -1e300);
  for (size_t v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c) {
      positions[3 * v + c] = static_cast<float>(mesh.positions[v][c]);
      lo[c] = std::min(lo[c], double(positions[3 * v + c]));
      hi[c] = std::max(hi[c], double(positions[3 * v + c]));
    }
  // Smooth normals as an exporter writes them: area-weighted over the welded mesh, so the
  // copies of a vertex split at a UV seam share one normal.
  const skelform::bake::WeldedMesh welded = skelform::bake::weld(mesh);
  const std::vector<skelform::bake::Vec3> welded_normals = skelform::bake::vertex_normals(welded.mesh);
  std::vector<float> normals(3 * n);
  for (size_t v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c)
      normals[3 * v + c] = static_cast<float>(welded_normals[welded.welded_of_original[v]][c]);
  std::vector<uint32_t> indices;
  indices.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles) indices.insert(indices.end(), t.begin(), t.end());
  std::vector<uint16_t> joints;
  std::vector<float> weights;
  joints.reserve(4 * n);
  weights.reserve(4 * n);
  for (size_t v = 0; v < n; ++v) {
    joints.insert(joints.end(), mesh.joint_sets[0][v].begin(), mesh.joint_sets[0][v].end());
    weights.insert(weights.end(), mesh.weight_sets[0][v].begin(), mesh.weight_sets[0][v].end());
  }

  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  const int position_accessor = append_accessor(model, append_view(model, positions, TINYGLTF_TARGET_ARRAY_BUFFER),
                                                TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
  model.accessors[static_cast<size_t>(position_accessor)].minValues = lo;
  model.accessors[static_cast<size_t>(position_accessor)].maxValues = hi;
  primitive.attributes["POSITION"] = position_accessor;
  primitive.attributes["NORMAL"] = append_accessor(model, append_view(model, normals, TINYGLTF_TARGET_ARRAY_BUFFER),
                                                   TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
  primitive.attributes["JOINTS_0"] = append_accessor(model, append_view(model, joints, TINYGLTF_TARGET_ARRAY_BUFFER),
                                                     TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC4, n);
  primitive.attributes["WEIGHTS_0"] = append_accessor(model, append_view(model, weights, TINYGLTF_TARGET_ARRAY_BUFFER),
                                                      TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, n);
  primitive.indices = append_accessor(model, append_view(model, indices, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
                                      TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, indices.size());
  model.meshes[static_cast<size_t>(mesh_index)].primitives = {primitive};
  model.buffers[0].data.resize((model.buffers[0].data.size() + 3) / 4 * 4, 0);

  std::ostringstream stream;
  if (!loader.WriteGltfSceneToStream(&model, stream, false, true))
    throw std::runtime_error("cannot serialise " + output_path);
  skelform::samples::write_file_atomically(output_path, stream.str());
}

std::filesystem::path cesium_man_subdivided(int levels) {
  const std::optional<std::filesystem::path> source = cesium_man_path();
  if (!source) throw std::runtime_error("CesiumMan/CesiumMan.glb not found under " + data_dir().string());
  if (levels == 0) return *source;
  const std::filesystem::path path = cache_dir() / ("CesiumMan_loop" + std::to_string(levels) + ".glb");
  if (!fresh(path)) {
    const skelform::bake::InputMesh input = skelform::bake::load_mesh(source->string());
    write_skinned_glb(source->string(), skelform::bake::loop_subdivide_input(input, levels), path.string());
  }
  return path;
}

std::filesystem::path cesium_man_baked(int levels) {
  return baked_file(cesium_man_subdivided(levels), "CesiumMan_loop" + std::to_string(levels));
}

std::filesystem::path baked_file(const std::filesystem::path& source, const std::string& cache_name) {
  const std::filesystem::path path = cache_dir() / (cache_name + ".skf.glb");
  if (!fresh(path, source)) {
    const skelform::bake::InputMesh input = skelform::bake::load_mesh(source.string());
    const skelform::bake::BakeResult result = skelform::bake::bake_model(input);
    skelform::bake::write_baked_gltf(source.string(), result.deformables, path.string());
  }
  return path;
}

}  // namespace skelform::bench
