#include "baked_asset.h"

#include "cli_bake.h"
#include "gltf_animation.h"
#include "skelform/bake/gltf_writer.h"
#include "skelform/bake/input.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace skelform::samples {

using cli::exit_code_of;
using cli::fail;
using cli::kExitInvalidInput;
using cli::kExitIo;

namespace {

constexpr const char* kExtensionName = "SKELFORM_skeletal_deformation";

uint32_t read_u32(const std::string& bytes, size_t offset) {
  uint32_t value = 0;
  for (int i = 3; i >= 0; --i) value = (value << 8) | static_cast<unsigned char>(bytes[offset + size_t(i)]);
  return value;
}

}  // namespace

std::string read_file_bytes(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    fail(kExitIo,
         "cannot read " + path + (std::filesystem::exists(path, error) ? ": not a regular file" : ": no such file"));
  const uintmax_t size = std::filesystem::file_size(path, error);
  if (!error && size > kMaxFileBytes)
    fail(kExitInvalidInput,
         path + ": larger than " + std::to_string(kMaxFileBytes >> 20) + " MiB, the most the sample tools read");
  std::ifstream file(path, std::ios::binary);
  std::ostringstream contents;
  contents << file.rdbuf();
  if (!file) fail(kExitIo, "cannot read " + path);
  return contents.str();
}

nlohmann::json gltf_document(const std::string& bytes, const std::string& name) {
  std::string text = bytes;
  if (bytes.size() >= 4 && bytes.compare(0, 4, "glTF") == 0) {
    if (bytes.size() < 20 || read_u32(bytes, 16) != 0x4E4F534Au)
      fail(kExitInvalidInput, name + ": truncated GLB or no JSON chunk");
    const size_t length = read_u32(bytes, 12);
    if (length > bytes.size() - 20) fail(kExitInvalidInput, name + ": the GLB's JSON chunk exceeds the file");
    text = bytes.substr(20, length);
  }
  nlohmann::json document = nlohmann::json::parse(text, nullptr, false);
  if (document.is_discarded() || !document.is_object())
    fail(kExitInvalidInput, name + ": not a glTF file (no JSON object)");
  return document;
}

bool has_skelform_extension(const std::string& bytes, const std::string& name) {
  const nlohmann::json document = gltf_document(bytes, name);
  const auto used = document.find("extensionsUsed");
  if (used == document.end() || !used->is_array()) return false;
  return std::any_of(used->begin(), used->end(), [](const nlohmann::json& e) { return e == kExtensionName; });
}

LoadedAsset load_or_bake(const std::string& path,
                         const std::function<void(const char* stage, size_t deformable, size_t count)>& progress,
                         const std::function<void()>& baking) {
  LoadedAsset loaded;
  loaded.bytes = read_file_bytes(path);
  char message[512] = "";
  sf_load_options load_options{};
  load_options.error_message = message;
  load_options.error_message_capacity = sizeof(message);
  const bool glb = loaded.bytes.compare(0, 4, "glTF") == 0;
  sf_result result = SF_OK;
  if (has_skelform_extension(loaded.bytes, path)) {
    result = glb ? sf_asset_load_memory(loaded.bytes.data(), loaded.bytes.size(), &load_options, &loaded.asset.asset)
                 : sf_asset_load_file(path.c_str(), &load_options, &loaded.asset.asset);
  } else {
    if (baking) baking();
    const auto start = std::chrono::steady_clock::now();
    const bake::InputMesh input = bake::load_mesh_from_memory(
        std::vector<unsigned char>(loaded.bytes.begin(), loaded.bytes.end()), glb ? ".glb" : ".gltf", path);
    loaded.warnings = input.warnings;
    bake::BakeOptions options;
    options.progress = progress;
    loaded.bake = bake::bake_model(input, options);
    const std::filesystem::path directory = std::filesystem::path(path).parent_path();
    const std::string baked =
        bake::baked_glb(loaded.bytes, directory.empty() ? "." : directory.string(), loaded.bake.deformables);
    loaded.baked_here = true;
    loaded.bake_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result = sf_asset_load_memory(baked.data(), baked.size(), &load_options, &loaded.asset.asset);
  }
  if (result != SF_OK) {
    const std::string text = message[0] ? message : sf_result_string(result);
    fail(exit_code_of(result), text.rfind(path, 0) == 0 ? text : path + ": " + text);
  }
  return loaded;
}

int classify_sample_error(const std::exception& e) {
  const int code = classify_gltf_error(e);
  return code >= 0 ? code : cli::classify_bake_error(e);
}

}  // namespace skelform::samples
