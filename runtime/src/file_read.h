// Reading an asset file into memory for sf_asset_load_file (api_asset.cpp), bounded: a file
// without an end (a device such as /dev/zero, a FIFO whose writer never closes it) must not
// make the loader read until memory runs out.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace skelform::runtime {

// The most bytes sf_asset_load_file reads (skelform.h): 2^32 − 1, the largest a GLB can
// declare (its header's length is 32 bits) and the most tinygltf parses from memory.
constexpr size_t kMaxFileBytes = 0xFFFFFFFFu;

// The bytes of the file `path`. A regular file is read to the size the file system reports.
// Anything else (a FIFO, a device) is read as a stream: a GLB (its first four bytes "glTF")
// to the total length its header states, never further, anything else to its end; and refused
// at its first byte when that can start neither a GLB nor a JSON document. More than `limit`
// bytes (a file that large, a header that says so, a stream that has not ended by then) are
// refused before they are read.
// Throws LoadError: SF_ERROR_IO (cannot be opened or read, a directory), SF_ERROR_UNSUPPORTED
// (beyond `limit`), SF_ERROR_INVALID_DATA (empty, or a stream that is no glTF); std::bad_alloc.
std::vector<unsigned char> read_asset_file(const std::string& path, size_t limit = kMaxFileBytes);

}  // namespace skelform::runtime
