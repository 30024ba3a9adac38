// gltf_access.h: the runtime's validated glTF reader (gltf_read.h) with its GltfError turned
// into the baker's Error, kind for kind and word for word, so both halves of skelform refuse
// the same files with the same sentences.
#include "skelform/bake/gltf_access.h"

#include "skelform/core/gltf_read.h"

#include <tiny_gltf.h>

#include <utility>

namespace skelform::bake::gltf {

static_assert(kMaxJsonNesting == skelform::gltf::kMaxJsonNesting, "the baker states the runtime reader's limit");

namespace {

ErrorKind kind_of(const skelform::gltf::GltfError& error) {
  switch (error.kind()) {
    case skelform::gltf::GltfError::unsupported:
      return ErrorKind::unsupported;
    case skelform::gltf::GltfError::io:
      return ErrorKind::io;
    case skelform::gltf::GltfError::invalid:
      break;
  }
  return ErrorKind::invalid_input;
}

// Runs one reader, translating its error.
template <class Read>
auto translated(Read&& read) -> decltype(read()) {
  try {
    return std::forward<Read>(read)();
  } catch (const skelform::gltf::GltfError& error) {
    throw Error(kind_of(error), error.what());
  }
}

}  // namespace

void parse_model(const std::vector<unsigned char>& bytes, bool binary, const std::string& name,
                 tinygltf::Model& model) {
  translated([&] { skelform::gltf::parse_model(bytes.data(), bytes.size(), binary, name, model); });
}

size_t accessor_count(const tinygltf::Model& model, int accessor, const std::string& what) {
  return translated([&] { return skelform::gltf::accessor_count(model, accessor, what); });
}

std::vector<Vec3> read_vec3(const tinygltf::Model& model, int accessor, const std::string& what) {
  return translated([&] { return skelform::gltf::read_vec3(model, accessor, what); });
}

std::vector<glm::dvec4> read_vec4(const tinygltf::Model& model, int accessor, const std::string& what) {
  return translated([&] { return skelform::gltf::read_vec4(model, accessor, what); });
}

std::vector<glm::dmat4> read_mat4(const tinygltf::Model& model, int accessor, const std::string& what) {
  return translated([&] { return skelform::gltf::read_mat4(model, accessor, what); });
}

std::vector<glm::uvec4> read_joints(const tinygltf::Model& model, int accessor, const std::string& what) {
  return translated([&] { return skelform::gltf::read_joints(model, accessor, what); });
}

std::vector<glm::dvec4> read_weights(const tinygltf::Model& model, int accessor, const std::string& what) {
  return translated([&] { return skelform::gltf::read_weights(model, accessor, what); });
}

std::vector<float> read_unit_scalars(const tinygltf::Model& model, int accessor, const std::string& what) {
  return translated([&] { return skelform::gltf::read_unit_scalars(model, accessor, what); });
}

std::vector<uint32_t> read_indices(const tinygltf::Model& model, int accessor, size_t vertex_count,
                                   const std::string& what) {
  return translated([&] { return skelform::gltf::read_indices(model, accessor, vertex_count, what); });
}

}  // namespace skelform::bake::gltf
