// Output files of the sample tools: written whole or not at all.
#pragma once

#include <stdexcept>
#include <string>

namespace skelform::samples {

// Writes `contents` to `path` through a temporary file beside it (flushed, then renamed over
// `path`), so a reader never sees a partial file and a failure leaves an existing `path`
// untouched. Throws std::runtime_error naming the path on failure.
void write_file_atomically(const std::string& path, const std::string& contents);

}  // namespace skelform::samples
