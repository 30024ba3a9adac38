// The asset half of the C API: argument checks, the allocator, and the one place where the
// loader's exceptions become sf_result codes and messages (nothing crosses the C boundary).
#include "asset.h"
#include "asset_load.h"
#include "file_read.h"
#include "skelform/core/gltf_read.h"
#include "memory.h"

#include "skelform/skelform.h"

#include <algorithm>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

using skelform::runtime::AllocatorRef;

namespace {

// Copies `message` into the caller's buffer, truncated to its capacity, always terminated.
void report(const sf_load_options* options, const std::string& message) {
  if (!options || !options->error_message || options->error_message_capacity == 0) return;
  const size_t length = std::min(message.size(), options->error_message_capacity - 1);
  std::memcpy(options->error_message, message.data(), length);
  options->error_message[length] = '\0';
}

sf_result fail(const sf_load_options* options, sf_result result, const std::string& message) {
  report(options, message);
  return result;
}

sf_result result_of(const skelform::gltf::GltfError& error) {
  switch (error.kind()) {
    case skelform::gltf::GltfError::unsupported:
      return SF_ERROR_UNSUPPORTED;
    case skelform::gltf::GltfError::io:
      return SF_ERROR_IO;
    case skelform::gltf::GltfError::invalid:
      break;
  }
  return SF_ERROR_INVALID_DATA;
}

// The allocator of a load: the caller's, or malloc/free. Half a pair of callbacks is a
// caller bug (memory from one heap freed into another), refused up front.
bool allocator_of(const sf_load_options* options, AllocatorRef& out, std::string& problem) {
  out = AllocatorRef{};
  if (!options || !options->allocator) return true;
  const sf_allocator& callbacks = *options->allocator;
  if (!callbacks.alloc && !callbacks.free) return true;
  if (!callbacks.alloc || !callbacks.free) {
    problem = "sf_load_options.allocator needs both alloc and free (or neither)";
    return false;
  }
  out.callbacks = callbacks;
  return true;
}

// Runs a load with every exception turned into its sf_result.
template <class Load>
sf_result guarded_load(const sf_load_options* options, Load&& load) {
  try {
    load();
    report(options, "");
    return SF_OK;
  } catch (const skelform::runtime::LoadError& error) {
    return fail(options, error.result(), error.what());
  } catch (const skelform::gltf::GltfError& error) {
    return fail(options, result_of(error), error.what());
  } catch (const std::bad_alloc&) {
    return fail(options, SF_ERROR_OUT_OF_MEMORY, "out of memory while loading the asset");
  } catch (const std::length_error&) {
    return fail(options, SF_ERROR_OUT_OF_MEMORY, "the asset needs more memory than can be addressed");
  } catch (const std::exception& error) {
    return fail(options, SF_ERROR_INVALID_DATA, std::string("the asset could not be loaded: ") + error.what());
  } catch (...) {
    return fail(options, SF_ERROR_INVALID_DATA, "the asset could not be loaded (unknown error)");
  }
}

}  // namespace

extern "C" {

sf_result sf_asset_load_memory(const void* data, size_t size, const sf_load_options* options, sf_asset** out_asset) {
  if (!out_asset) return fail(options, SF_ERROR_INVALID_ARGUMENT, "sf_asset_load_memory: out_asset is NULL");
  *out_asset = nullptr;
  if (!data) return fail(options, SF_ERROR_INVALID_ARGUMENT, "sf_asset_load_memory: data is NULL");
  if (size == 0) return fail(options, SF_ERROR_INVALID_ARGUMENT, "sf_asset_load_memory: size is 0");
  AllocatorRef allocator;
  std::string problem;
  if (!allocator_of(options, allocator, problem)) return fail(options, SF_ERROR_INVALID_ARGUMENT, problem);
  return guarded_load(options, [&] {
    *out_asset = skelform::runtime::load_asset(static_cast<const unsigned char*>(data), size, "<memory>",
                                               skelform::gltf::ExternalFiles::refuse, allocator);
  });
}

sf_result sf_asset_load_file(const char* path, const sf_load_options* options, sf_asset** out_asset) {
  if (!out_asset) return fail(options, SF_ERROR_INVALID_ARGUMENT, "sf_asset_load_file: out_asset is NULL");
  *out_asset = nullptr;
  if (!path) return fail(options, SF_ERROR_INVALID_ARGUMENT, "sf_asset_load_file: path is NULL");
  if (!*path) return fail(options, SF_ERROR_INVALID_ARGUMENT, "sf_asset_load_file: path is empty");
  AllocatorRef allocator;
  std::string problem;
  if (!allocator_of(options, allocator, problem)) return fail(options, SF_ERROR_INVALID_ARGUMENT, problem);
  return guarded_load(options, [&] {
    const std::string name = path;
    // The file's bytes are a load-time temporary (default heap), like tinygltf's document.
    const std::vector<unsigned char> bytes = skelform::runtime::read_asset_file(name);
    *out_asset = skelform::runtime::load_asset(bytes.data(), bytes.size(), name,
                                               skelform::gltf::ExternalFiles::read_io_errors, allocator);
  });
}

void sf_asset_destroy(sf_asset* asset) {
  if (!asset) return;
  const AllocatorRef allocator = asset->allocator;  // the asset's own copy dies with it
  skelform::runtime::destroy_object(allocator, asset);
}

uint32_t sf_asset_deformable_count(const sf_asset* asset) {
  return asset ? static_cast<uint32_t>(asset->deformables.size()) : 0;
}

sf_result sf_asset_deformable_info(const sf_asset* asset, uint32_t deformable, sf_deformable_info* out_info) {
  if (!asset || !out_info || deformable >= asset->deformables.size()) return SF_ERROR_INVALID_ARGUMENT;
  const skelform::runtime::Deformable& d = asset->deformables[deformable];
  sf_deformable_info info{};
  info.mesh = d.mesh;
  info.node = d.node;
  info.skin = d.skin;
  info.joint_count = d.joint_count;
  info.primitive_count = static_cast<uint32_t>(d.primitives.size());
  info.vertex_count = d.vertex_count;
  info.control_vertex_count = d.control_vertex_count;
  info.subdivision_level = d.subdivision_level;
  info.control_triangle_count = static_cast<uint32_t>(d.control_indices.size() / 3);
  *out_info = info;
  return SF_OK;
}

sf_result sf_asset_primitive_info(const sf_asset* asset, uint32_t deformable, uint32_t primitive,
                                  sf_primitive_info* out_info) {
  if (!asset || !out_info || deformable >= asset->deformables.size()) return SF_ERROR_INVALID_ARGUMENT;
  const skelform::runtime::Deformable& d = asset->deformables[deformable];
  if (primitive >= d.primitives.size()) return SF_ERROR_INVALID_ARGUMENT;
  const skelform::runtime::PrimitiveRecord& record = d.primitives[primitive];
  sf_primitive_info info{};
  info.gltf_primitive = record.primitive;
  info.vertex_count = record.vertex_count;
  info.first_vertex = record.first_vertex;
  info.has_normals = record.has_normals ? 1u : 0u;
  info.has_tangents = record.has_tangents ? 1u : 0u;
  *out_info = info;
  return SF_OK;
}

sf_result sf_asset_control_triangles(const sf_asset* asset, uint32_t deformable, uint32_t* indices,
                                     size_t index_capacity) {
  if (!asset || !indices || deformable >= asset->deformables.size()) return SF_ERROR_INVALID_ARGUMENT;
  const skelform::runtime::Deformable& d = asset->deformables[deformable];
  if (index_capacity < d.control_indices.size()) return SF_ERROR_INVALID_ARGUMENT;
  std::memcpy(indices, d.control_indices.data(), d.control_indices.size() * sizeof(uint32_t));
  return SF_OK;
}

}  // extern "C"
