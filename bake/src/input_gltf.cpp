// Placeholder until the glTF loader lands.
#include "input_formats.h"

namespace skelform::bake::detail {

InputMesh load_gltf(const std::vector<unsigned char>&, bool, const std::string& name, const LoadOptions&) {
  throw Error(ErrorKind::unsupported, name + ": glTF input is not implemented yet");
}

}  // namespace skelform::bake::detail
