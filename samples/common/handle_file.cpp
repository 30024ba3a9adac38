#include "handle_file.h"

#include "cli.h"
#include "gltf_animation.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <exception>
#include <limits>

namespace skelform::samples {

using cli::fail;
using cli::kExitInvalidInput;
using cli::kExitIo;

HandleSet parse_handles(const std::string& text, const std::string& name) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    fail(kExitInvalidInput, name + ": " + e.what());
  }
  auto index_of = [&](const nlohmann::json& value, const std::string& where) -> uint32_t {
    if (!value.is_number_unsigned() || value.get<uint64_t>() > 0xffffffffULL)
      fail(kExitInvalidInput, name + ": " + where + " must be a non-negative integer vertex index");
    return value.get<uint32_t>();
  };
  if (!doc.is_object()) fail(kExitInvalidInput, name + ": expected a JSON object");
  for (const auto& item : doc.items())
    if (item.key() != "handles" && item.key() != "pinned")
      fail(kExitInvalidInput, name + ": unknown member \"" + item.key() + "\"");
  const auto handles = doc.find("handles");
  if (handles == doc.end() || !handles->is_array() || handles->empty())
    fail(kExitInvalidInput, name + ": \"handles\" must be a non-empty array");
  HandleSet set;
  for (size_t i = 0; i < handles->size(); ++i) {
    const nlohmann::json& handle = (*handles)[i];
    const std::string where = "handles[" + std::to_string(i) + "]";
    if (!handle.is_object() || !handle.contains("vertex") || !handle.contains("target"))
      fail(kExitInvalidInput, name + ": " + where + " must be an object with \"vertex\" and \"target\"");
    set.vertices.push_back(index_of(handle["vertex"], where + ".vertex"));
    const nlohmann::json& target = handle["target"];
    if (!target.is_array() || target.size() != 3)
      fail(kExitInvalidInput, name + ": " + where + ".target must be [x, y, z]");
    for (const nlohmann::json& c : target) {
      if (!c.is_number() || !std::isfinite(c.get<double>()) ||
          std::fabs(c.get<double>()) > std::numeric_limits<float>::max())
        fail(kExitInvalidInput, name + ": " + where + ".target must hold three finite numbers");
      set.targets.push_back(c.get<float>());
    }
  }
  if (const auto pinned = doc.find("pinned"); pinned != doc.end()) {
    if (!pinned->is_array()) fail(kExitInvalidInput, name + ": \"pinned\" must be an array of vertex indices");
    for (size_t i = 0; i < pinned->size(); ++i)
      set.pinned.push_back(index_of((*pinned)[i], "pinned[" + std::to_string(i) + "]"));
  }
  return set;
}

HandleSet read_handles(const std::string& path) {
  std::vector<unsigned char> bytes;
  try {
    bytes = read_bounded_file(path);
  } catch (const GltfError& e) {
    fail(kExitIo, std::string("cannot read ") + e.what());
  }
  return parse_handles(std::string(bytes.begin(), bytes.end()), path);
}

}  // namespace skelform::samples
