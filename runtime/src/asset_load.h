// Loading and validating a baked asset (sf_asset) from glTF bytes: the runtime's only
// parser of the SKELFORM_skeletal_deformation extension (docs/, extension_layout.h). The C
// entry points (api_asset.cpp) catch everything thrown here and turn it into an sf_result.
#pragma once

#include "asset.h"
#include "skelform/core/gltf_read.h"
#include "memory.h"

#include <stdexcept>
#include <string>

namespace skelform::runtime {

// A load failure the loader names itself (missing extension, newer major version, broken
// invariant of the extension's arrays). The accessor readers throw gltf::GltfError instead;
// allocation failures throw std::bad_alloc.
class LoadError : public std::runtime_error {
 public:
  LoadError(sf_result result, const std::string& message) : std::runtime_error(message), result_(result) {}
  sf_result result() const noexcept { return result_; }

 private:
  sf_result result_;
};

// Parses `bytes` (.glb or .gltf, detected by the GLB magic), validates every array of every
// deformable, reads the dense vertices from the glTF primitives and derives the rest frames
// and handle control vertices. `name` prefixes messages; for a file it also locates external
// buffers (`external` = read_io_errors), from memory nothing outside `bytes` is read
// (`external` = refuse). Every array of the result uses `allocator`; tinygltf's document
// and this function's temporaries use the default heap and are freed before it returns.
sf_asset* load_asset(const unsigned char* bytes, size_t size, const std::string& name, gltf::ExternalFiles external,
                     const AllocatorRef& allocator);

}  // namespace skelform::runtime
