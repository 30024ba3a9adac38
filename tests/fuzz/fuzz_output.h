// Output checks shared by fuzz_asset and fuzz_handles: every primitive written through
// sf_instance_write, and the coarse meshes, after an evaluation the runtime accepted.
#pragma once

#include "fuzz_check.h"
#include "skelform/skelform.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace skelform::fuzz {

// One interleaved buffer (position, normal, tangent per vertex) exercises the strides; it is
// exactly vertex_count long, so a write past the last vertex is an ASan report.
inline constexpr size_t kFloatsPerVertex = 3 + 3 + 4;

inline void write_primitives(sf_instance* instance, const sf_asset* asset, uint32_t deformable,
                             const sf_deformable_info& info) {
  for (uint32_t p = 0; p < info.primitive_count; ++p) {
    sf_primitive_info primitive{};
    require(sf_asset_primitive_info(asset, deformable, p, &primitive) == SF_OK,
            "sf_asset_primitive_info failed for an index below primitive_count");
    require(primitive.first_vertex <= info.vertex_count &&
                primitive.vertex_count <= info.vertex_count - primitive.first_vertex,
            "a primitive's vertices lie outside its deformable's");
    // NaN first: a vertex an SF_OK write leaves untouched is caught like a NaN it writes.
    std::vector<float> buffer(size_t(primitive.vertex_count) * kFloatsPerVertex,
                              std::numeric_limits<float>::quiet_NaN());
    sf_vertex_output output{};
    output.positions = buffer.data();
    output.position_stride = kFloatsPerVertex * sizeof(float);
    output.normals = buffer.data() + 3;
    output.normal_stride = kFloatsPerVertex * sizeof(float);
    output.tangents = primitive.has_tangents ? buffer.data() + 6 : nullptr;
    output.tangent_stride = kFloatsPerVertex * sizeof(float);
    output.vertex_capacity = primitive.vertex_count;
    if (sf_instance_write(instance, p, &output) != SF_OK) continue;
    for (size_t v = 0; v < primitive.vertex_count; ++v) {
      const float* vertex = buffer.data() + v * kFloatsPerVertex;
      require(all_finite(vertex, primitive.has_tangents ? kFloatsPerVertex : 6),
              "sf_instance_write returned SF_OK with a non-finite position, normal or tangent");
    }
  }
}

// After an SF_OK evaluation by `method` (LBS or DQS): sf_instance_skin_range over each
// primitive in two ranges gives sf_instance_write's floats bit for bit, in exact-size buffers.
inline void check_skin_ranges(sf_instance* instance, const sf_asset* asset, uint32_t deformable,
                              const sf_deformable_info& info, uint32_t method) {
  for (uint32_t p = 0; p < info.primitive_count; ++p) {
    sf_primitive_info primitive{};
    require(sf_asset_primitive_info(asset, deformable, p, &primitive) == SF_OK,
            "sf_asset_primitive_info failed for an index below primitive_count");
    const size_t n = primitive.vertex_count;
    std::vector<float> written(n * kFloatsPerVertex, 0.0f), ranged(n * kFloatsPerVertex, 0.0f);
    auto output = [&](std::vector<float>& buffer, size_t first, size_t count) {
      sf_vertex_output o{};
      o.positions = buffer.data() + first * kFloatsPerVertex;
      o.position_stride = kFloatsPerVertex * sizeof(float);
      o.normals = o.positions + 3;
      o.normal_stride = o.position_stride;
      o.tangents = primitive.has_tangents ? o.positions + 6 : nullptr;
      o.tangent_stride = o.position_stride;
      o.vertex_capacity = count;
      return o;
    };
    const sf_vertex_output whole = output(written, 0, n);
    require(sf_instance_write(instance, p, &whole) == SF_OK, "sf_instance_write failed after an SF_OK evaluation");
    const uint32_t half = uint32_t(n / 2);
    const sf_vertex_output low = output(ranged, 0, half), high = output(ranged, half, n - half);
    require(sf_instance_skin_range(instance, method, p, 0, half, &low) == SF_OK &&
                sf_instance_skin_range(instance, method, p, half, uint32_t(n) - half, &high) == SF_OK,
            "sf_instance_skin_range refused a pose sf_instance_evaluate accepted");
    require(std::memcmp(written.data(), ranged.data(), written.size() * sizeof(float)) == 0,
            "sf_instance_skin_range differs from sf_instance_evaluate + sf_instance_write");
  }
}

inline void check_coarse(const sf_instance* instance, const sf_deformable_info& info) {
  std::vector<float> positions(size_t(info.control_vertex_count) * 3);
  for (uint32_t mesh : {uint32_t(SF_COARSE_CONTROL), uint32_t(SF_COARSE_SKELETAL)})
    if (sf_instance_write_coarse(instance, mesh, positions.data(), 0, info.control_vertex_count) == SF_OK)
      require(all_finite(positions.data(), positions.size()),
              "sf_instance_write_coarse returned SF_OK with a non-finite position");
  uint32_t iterations = 0;
  float residual = 0;
  if (sf_instance_fairing_stats(instance, &iterations, &residual) == SF_OK)
    require(std::isfinite(residual), "sf_instance_fairing_stats returned a non-finite residual");
}

}  // namespace skelform::fuzz
