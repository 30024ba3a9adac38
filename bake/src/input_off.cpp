// Placeholder until the off loader lands.
#include "input_formats.h"

namespace skelform::bake::detail {

InputMesh load_off(std::string_view, const std::string& name) {
  throw Error(ErrorKind::unsupported, name + ": .off input is not implemented yet");
}

}  // namespace skelform::bake::detail
