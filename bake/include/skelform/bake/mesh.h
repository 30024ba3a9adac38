// Core value types of the baker: positions in double precision, triangles as index triples.
#pragma once

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace skelform::bake {

using Vec3 = glm::dvec3;
using Triangle = std::array<uint32_t, 3>;

// An indexed triangle mesh. Indices are in [0, positions.size()).
struct TriangleMesh {
  std::vector<Vec3> positions;
  std::vector<Triangle> triangles;
};

// Why a bake step refused its input. The CLI maps each kind to an exit code (see --help).
enum class ErrorKind {
  usage,          // bad command-line arguments
  io,             // a file could not be read or written
  invalid_input,  // the input file is malformed or its data is invalid (indices, NaN, ...)
  unsupported,    // valid input that the baker does not handle (e.g. points/lines primitives)
};

// The one exception type the baker library throws for bad input. Internal invariant
// violations are not reported through it. The message is one line, ready for a user.
class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const noexcept { return kind_; }

 private:
  ErrorKind kind_;
};

// Axis-aligned bounding box of a point set; an empty set gives min > max.
struct Bounds {
  Vec3 min{1e300, 1e300, 1e300};
  Vec3 max{-1e300, -1e300, -1e300};
  void grow(const Vec3& p);
  double diagonal() const;  // 0 for an empty box
};
Bounds bounds_of(const std::vector<Vec3>& points);

}  // namespace skelform::bake
