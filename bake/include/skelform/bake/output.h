// Output files of the baker: written whole or not at all.
#pragma once

#include "skelform/bake/mesh.h"

#include <string>
#include <vector>

namespace skelform::bake {

// Writes `contents` to `path` atomically: into a temporary file beside it, flushed, then
// renamed over `path`. On any failure the temporary file is removed, an existing `path` is
// left untouched, and Error(ErrorKind::io) is thrown.
void write_file_atomically(const std::string& path, const std::string& contents);

// Wavefront OBJ text of a triangle mesh: `v` lines in vertex order (shortest round-trip
// decimal of each double), then `f` lines (1-based). `comment` lines go first, prefixed "# ".
std::string obj_text(const TriangleMesh& mesh, const std::vector<std::string>& comment = {});

// OBJ text of a point set: `v` lines and one `p` element per point.
std::string obj_points_text(const std::vector<Vec3>& points, const std::vector<std::string>& comment = {});

// True when both paths name the same existing file (so an output would overwrite an input).
bool same_file(const std::string& a, const std::string& b);

}  // namespace skelform::bake
