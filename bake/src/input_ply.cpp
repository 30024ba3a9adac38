// Placeholder until the ply loader lands.
#include "input_formats.h"

namespace skelform::bake::detail {

InputMesh load_ply(const std::vector<unsigned char>&, const std::string& name) {
  throw Error(ErrorKind::unsupported, name + ": .ply input is not implemented yet");
}

}  // namespace skelform::bake::detail
