// Welding (DESIGN.md bake step 2): exact position equality, so the weld never merges two
// vertices an artist kept apart and the map back to the original vertices stays lossless.
#include "skelform/bake/weld.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <unordered_map>
#include <unordered_set>

namespace skelform::bake {
namespace {

struct PositionKey {
  uint64_t bits[3];
  bool operator==(const PositionKey& o) const {
    return bits[0] == o.bits[0] && bits[1] == o.bits[1] && bits[2] == o.bits[2];
  }
};

PositionKey key_of(const Vec3& p) {
  PositionKey key;
  for (int axis = 0; axis < 3; ++axis) {
    // -0.0 and +0.0 compare equal but differ in bits; mirrored exports produce both.
    const double c = p[axis] == 0.0 ? 0.0 : p[axis];
    std::memcpy(&key.bits[axis], &c, sizeof c);
  }
  return key;
}

uint64_t mix(uint64_t h) {
  // splitmix64 finaliser: coordinates often differ only in low mantissa bits.
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebULL;
  h ^= h >> 31;
  return h;
}

struct PositionHash {
  size_t operator()(const PositionKey& k) const {
    return static_cast<size_t>(mix(k.bits[0] ^ mix(k.bits[1] ^ mix(k.bits[2]))));
  }
};

// A triangle's corner set regardless of orientation or rotation: sorted indices.
struct CornerSetHash {
  size_t operator()(const Triangle& t) const {
    return static_cast<size_t>(mix((uint64_t{t[0]} << 32 | t[1]) ^ mix(t[2])));
  }
};

}  // namespace

WeldedMesh weld(const InputMesh& input) {
  WeldedMesh out;
  const size_t vertex_count = input.positions.size();
  out.welded_of_original.resize(vertex_count);

  std::unordered_map<PositionKey, uint32_t, PositionHash> index_of_position;
  index_of_position.reserve(vertex_count);
  for (size_t i = 0; i < vertex_count; ++i) {
    const Vec3& p = input.positions[i];
    auto [it, inserted] = index_of_position.try_emplace(key_of(p), static_cast<uint32_t>(out.mesh.positions.size()));
    if (inserted) {
      out.mesh.positions.push_back(p);
      out.original_of_welded.push_back(static_cast<uint32_t>(i));
    }
    out.welded_of_original[i] = it->second;
  }

  std::unordered_set<Triangle, CornerSetHash> seen;
  seen.reserve(input.triangles.size());
  out.mesh.triangles.reserve(input.triangles.size());
  out.original_triangle.reserve(input.triangles.size());
  for (size_t t = 0; t < input.triangles.size(); ++t) {
    Triangle welded;
    for (int corner = 0; corner < 3; ++corner) {
      const uint32_t original = input.triangles[t][corner];
      if (original >= vertex_count)
        throw Error(ErrorKind::invalid_input, "weld: triangle " + std::to_string(t) + " uses vertex " +
                                                  std::to_string(original) + " of " + std::to_string(vertex_count));
      welded[corner] = out.welded_of_original[original];
    }
    if (welded[0] == welded[1] || welded[1] == welded[2] || welded[0] == welded[2]) {
      ++out.degenerate_triangles_removed;
      continue;
    }
    Triangle corners = welded;
    std::sort(corners.begin(), corners.end());
    if (!seen.insert(corners).second) {
      ++out.duplicate_triangles_removed;
      continue;
    }
    out.mesh.triangles.push_back(welded);
    out.original_triangle.push_back(static_cast<uint32_t>(t));
  }
  return out;
}

}  // namespace skelform::bake
