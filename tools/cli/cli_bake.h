// The exit code of a baker failure (skelform/bake/mesh.h's Error), for the tools that bake:
// skelform-bake and the samples that bake in memory. Header-only: skelform_cli itself does
// not depend on the baker.
#pragma once

#include "cli.h"
#include "skelform/bake/mesh.h"

#include <exception>

namespace skelform::cli {

inline int exit_code_of(bake::ErrorKind kind) {
  switch (kind) {
    case bake::ErrorKind::usage:
      return kExitUsage;
    case bake::ErrorKind::io:
      return kExitIo;
    case bake::ErrorKind::invalid_input:
    case bake::ErrorKind::unsupported:
      return kExitInvalidInput;
  }
  return kExitInternal;
}

// run_main's `classify` for a baker error (-1 for any other exception).
inline int classify_bake_error(const std::exception& e) {
  const auto* error = dynamic_cast<const bake::Error*>(&e);
  return error ? exit_code_of(error->kind()) : -1;
}

}  // namespace skelform::cli
