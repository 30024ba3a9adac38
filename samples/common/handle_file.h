// The handle file of skelform-pose --handles (docs/handles-json.md): the vertices to drag,
// their targets and the vertices pinned where they are.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace skelform::samples {

struct HandleSet {
  std::vector<uint32_t> vertices;
  std::vector<float> targets;  // x, y, z per handle, finite floats
  std::vector<uint32_t> pinned;
};

// Parses a handle file's text; `name` starts every message. Throws Failure (cli.h,
// kExitInvalidInput) naming what is wrong. Vertex indices are checked against the asset by
// the runtime (sf_instance_set_handle_set), not here.
HandleSet parse_handles(const std::string& text, const std::string& name);

// Reads and parses the file at `path` (at most kMaxFileBytes, gltf_animation.h). Throws
// Failure: kExitIo when it cannot be read, kExitInvalidInput as parse_handles.
HandleSet read_handles(const std::string& path);

}  // namespace skelform::samples
