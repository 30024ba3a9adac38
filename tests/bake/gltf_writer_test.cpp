// The baked glTF writer (bake/src/gltf_writer.cpp): the input stays intact, the extension's
// arrays round-trip bit-exactly, output is deterministic and atomic, bad input is refused.
// Every baked file written under the scratch directory "gltf_validator" is afterwards checked
// by the Khronos glTF-Validator (CTest test gltf_validator_baked).
#include "skelform/bake/gltf_writer.h"

#include "skelform/core/extension_layout.h"
#include "skelform/bake/glb.h"
#include "skelform/bake/mesh.h"
#include "test_support.h"

#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <stdexcept>

#include <unistd.h>

namespace {

namespace fs = std::filesystem;
namespace format = skelform::format;
using skelform::bake::BakedDeformable;
using skelform::bake::Error;
using skelform::bake::ErrorKind;
using Json = nlohmann::ordered_json;

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE_MESSAGE(in.good(), "cannot open " << path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void write_bytes(const fs::path& path, const std::string& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  REQUIRE(out.good());
}

uint32_t u32_at(const std::string& bytes, size_t at) {
  uint32_t v;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;  // little-endian host (x86-64, aarch64)
}

std::string make_glb(const std::string& json_text, const std::string& bin) {
  return skelform::bake::glb_container(json_text, bin);
}

std::string base64_decode(const std::string& text) {
  static const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  uint32_t acc = 0;
  int bits = 0;
  for (const char c : text) {
    if (c == '=') break;
    const size_t v = alphabet.find(c);
    REQUIRE(v != std::string::npos);
    acc = (acc << 6) | uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(char((acc >> bits) & 0xFF));
    }
  }
  return out;
}

// A glTF file as the test reads it: its JSON and the bytes of buffer 0.
struct GltfFile {
  Json document;
  std::string buffer0;
};

GltfFile read_gltf(const fs::path& path) {
  const std::string bytes = read_bytes(path);
  GltfFile file;
  if (bytes.size() >= 4 && u32_at(bytes, 0) == 0x46546C67) {
    REQUIRE(bytes.size() >= 20);
    REQUIRE(u32_at(bytes, 8) == bytes.size());
    const uint32_t json_length = u32_at(bytes, 12);
    REQUIRE(u32_at(bytes, 16) == 0x4E4F534A);
    file.document = Json::parse(bytes.substr(20, json_length));
    const size_t bin_at = 20 + json_length;
    if (bin_at + 8 <= bytes.size() && u32_at(bytes, bin_at + 4) == 0x004E4942) {
      file.buffer0 = bytes.substr(bin_at + 8, u32_at(bytes, bin_at));
    }
  } else {
    file.document = Json::parse(bytes);
  }
  if (file.document.contains("buffers") && !file.document["buffers"].empty()) {
    const Json& buffer = file.document["buffers"][0];
    if (buffer.contains("uri")) {
      const std::string uri = buffer["uri"];
      if (uri.rfind("data:", 0) == 0) {
        file.buffer0 = base64_decode(uri.substr(uri.find(',') + 1));
      } else {
        file.buffer0 = read_bytes(path.parent_path() / uri);
      }
    }
    const size_t byte_length = buffer["byteLength"];
    REQUIRE(file.buffer0.size() >= byte_length);
    REQUIRE(file.buffer0.size() <= byte_length + 3);
    file.buffer0.resize(byte_length);
  }
  return file;
}

// The bytes of an accessor of the output, after checking its type against the layout.
std::string accessor_bytes(const GltfFile& file, const Json& index, const format::ArraySpec& spec, size_t count) {
  REQUIRE(index.is_number_unsigned());
  const Json& accessor = file.document["accessors"][index.get<size_t>()];
  CHECK(accessor["componentType"] == int(spec.component));
  static const char* const types[] = {"", "SCALAR", "VEC2", "VEC3", "VEC4"};
  CHECK(accessor["type"] == types[spec.components]);
  CHECK(accessor["count"] == count);
  CHECK_FALSE(accessor.contains("byteOffset"));
  const Json& view = file.document["bufferViews"][accessor["bufferView"].get<size_t>()];
  CHECK(view["buffer"] == 0);
  CHECK_FALSE(view.contains("target"));
  CHECK_FALSE(view.contains("byteStride"));
  const size_t offset = view["byteOffset"], length = view["byteLength"];
  CHECK(offset % 4 == 0);
  REQUIRE(offset + length <= file.buffer0.size());
  return file.buffer0.substr(offset, length);
}

template <typename T>
void check_array(const GltfFile& file, const Json& group, const char* group_name, const char* name,
                 const std::vector<T>& expected) {
  INFO(group_name << "." << name);
  const format::ArraySpec* spec = nullptr;
  for (const format::ArraySpec& s : format::kArrays) {
    if (std::strcmp(s.group, group_name) == 0 && std::strcmp(s.name, name) == 0) spec = &s;
  }
  REQUIRE(spec != nullptr);
  REQUIRE(group.contains(name));
  const std::string bytes = accessor_bytes(file, group[name], *spec, expected.size());
  REQUIRE(bytes.size() == expected.size() * sizeof(T));
  CHECK(std::memcmp(bytes.data(), expected.data(), bytes.size()) == 0);  // bit-exact
}

// Checks the extension of `output` against the deformables written into it.
void check_extension(const GltfFile& output, const std::vector<BakedDeformable>& deformables) {
  const Json& document = output.document;
  REQUIRE(document.contains("extensionsUsed"));
  CHECK(std::count(document["extensionsUsed"].begin(), document["extensionsUsed"].end(), format::kExtensionName) == 1);
  if (document.contains("extensionsRequired")) {
    CHECK(std::count(document["extensionsRequired"].begin(), document["extensionsRequired"].end(),
                     format::kExtensionName) == 0);
  }
  REQUIRE(document["extensions"].contains(format::kExtensionName));
  const Json& extension = document["extensions"][format::kExtensionName];
  CHECK(extension[format::kMajorVersionKey] == format::kMajorVersion);
  CHECK(extension[format::kMinorVersionKey] == format::kMinorVersion);
  REQUIRE(extension[format::kDeformables].size() == deformables.size());
  for (size_t i = 0; i < deformables.size(); ++i) {
    const BakedDeformable& d = deformables[i];
    const Json& json = extension[format::kDeformables][i];
    CHECK(json[format::kMesh] == d.mesh);
    CHECK(json.value(format::kNode, -1) == d.node);
    CHECK(json.value(format::kSkin, -1) == d.skin);
    CHECK(json[format::kPrimitives] == Json(d.primitives));
    CHECK(json[format::kVertexCount] == d.dense_vertex_count);
    const Json& control = json["control"];
    check_array(output, control, "control", "positions", d.control_positions);
    check_array(output, control, "control", "normals", d.control_normals);
    check_array(output, control, "control", "indices", d.control_indices);
    check_array(output, control, "control", "skeletalPositions", d.skeletal_positions);
    check_array(output, control, "control", "medialRadius", d.medial_radius);
    REQUIRE(control.value("joints", Json::array()).size() == d.joint_sets.size());
    REQUIRE(control.value("weights", Json::array()).size() == d.weight_sets.size());
    for (size_t s = 0; s < d.joint_sets.size(); ++s) {
      const std::string j = accessor_bytes(output, control["joints"][s], format::kJointSet, d.joint_sets[s].size());
      const std::string w = accessor_bytes(output, control["weights"][s], format::kWeightSet, d.weight_sets[s].size());
      CHECK(std::memcmp(j.data(), d.joint_sets[s].data(), j.size()) == 0);
      CHECK(std::memcmp(w.data(), d.weight_sets[s].data(), w.size()) == 0);
    }
    const Json& subdivision = json["subdivision"];
    CHECK(subdivision[format::kSubdivisionLevel] == d.subdivision_level);
    check_array(output, subdivision, "subdivision", "stencilOffsets", d.stencil_offsets);
    check_array(output, subdivision, "subdivision", "stencilIndices", d.stencil_indices);
    check_array(output, subdivision, "subdivision", "stencilWeights", d.stencil_weights);
    check_array(output, subdivision, "subdivision", "indices", d.refined_indices);
    const Json& binding = json["binding"];
    check_array(output, binding, "binding", "triangle", d.binding_triangle);
    check_array(output, binding, "binding", "barycentric", d.binding_barycentric);
    check_array(output, binding, "binding", "displacement", d.binding_displacement);
    check_array(output, binding, "binding", "residual", d.binding_residual);
  }
}

// Everything the input had is still there, JSON-equal, at the same index; buffer 0's
// original bytes are a prefix of the output's.
void check_original_kept(const GltfFile& input, const GltfFile& output) {
  // Not structured bindings: doctest's macros capture in lambdas, which clang 14 refuses for
  // bindings (a C++20 feature).
  for (const auto& item : input.document.items()) {
    const std::string key = item.key();
    const Json& value = item.value();
    INFO("member " << key);
    REQUIRE(output.document.contains(key));
    if (key == "accessors" || key == "bufferViews") {
      REQUIRE(output.document[key].size() > value.size());
      for (size_t i = 0; i < value.size(); ++i) CHECK(output.document[key][i] == value[i]);
    } else if (key == "buffers") {
      REQUIRE(output.document[key].size() == value.size());
      for (size_t i = 1; i < value.size(); ++i) CHECK(output.document[key][i] == value[i]);
    } else if (key == "extensions" || key == "extensionsUsed" || key == "extensionsRequired") {
      continue;
    } else {
      CHECK(output.document[key] == value);
    }
  }
  REQUIRE(output.buffer0.size() >= input.buffer0.size());
  CHECK(output.buffer0.compare(0, input.buffer0.size(), input.buffer0) == 0);
}

// The whole file loads with tinygltf, the loader the runtime uses.
void check_tinygltf_loads(const fs::path& path) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string error, warning;
  const bool ok = path.extension() == ".glb" ? loader.LoadBinaryFromFile(&model, &error, &warning, path.string())
                                             : loader.LoadASCIIFromFile(&model, &error, &warning, path.string());
  INFO(error);
  CHECK(ok);
  CHECK(model.extensions.count(format::kExtensionName) == 1);
}

// Small, valid-shaped synthetic bake data: 4 control vertices, 2 triangles, level-1-like
// stencils (4 copies + 1 edge midpoint), 3 refined triangles, a binding per dense vertex.
// Values have full mantissas (thirds) so a lossy path would show.
BakedDeformable synthetic_deformable(int mesh, int node, int skin, std::vector<int> primitives, uint32_t dense,
                                     float seed) {
  BakedDeformable d;
  d.mesh = mesh;
  d.node = node;
  d.skin = skin;
  d.primitives = std::move(primitives);
  d.dense_vertex_count = dense;
  d.control_positions = {{0, 0, 0}, {1, 0, seed / 3}, {0, 1, 0}, {1, 1, 1.0f / 3}};
  d.control_normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0.6f, 0, 0.8f}};
  d.control_indices = {0, 1, 2, 1, 3, 2};
  for (size_t i = 0; i < 4; ++i) {
    d.skeletal_positions.push_back(d.control_positions[i] - 0.1f * d.control_normals[i]);
    d.medial_radius.push_back(0.1f + seed / 7);
  }
  if (skin >= 0) {
    d.joint_sets = {{{0, 1, 0, 0}, {1, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}}};
    d.weight_sets = {{{0.75f, 0.25f, 0, 0}, {1, 0, 0, 0}, {1, 0, 0, 0}, {2.0f / 3, 1.0f / 3, 0, 0}}};
  }
  d.subdivision_level = 1;
  d.stencil_offsets = {0, 1, 2, 3, 4, 6};
  d.stencil_indices = {0, 1, 2, 3, 1, 2};
  d.stencil_weights = {1, 1, 1, 1, 0.5f, 0.5f};
  d.refined_indices = {0, 1, 4, 0, 4, 2, 1, 3, 2};
  for (uint32_t i = 0; i < dense; ++i) {
    d.binding_triangle.push_back(i % 3);
    d.binding_barycentric.push_back({1.0f / (3 + float(i)), seed / (5 + float(i))});
    d.binding_displacement.push_back(-float(i) / 9 + seed);
    d.binding_residual.push_back({1e-7f * float(i), -1e-8f / 3});
  }
  return d;
}

// A deformable for each skinned node of a real model: mesh, node, skin, all its triangle
// primitives, their POSITION counts summed.
std::vector<BakedDeformable> deformables_for(const Json& document) {
  std::vector<BakedDeformable> out;
  const Json& nodes = document["nodes"];
  for (size_t n = 0; n < nodes.size(); ++n) {
    if (!nodes[n].contains("mesh") || !nodes[n].contains("skin")) continue;
    const int mesh = nodes[n]["mesh"];
    std::vector<int> primitives;
    uint32_t dense = 0;
    const Json& list = document["meshes"][size_t(mesh)]["primitives"];
    for (size_t p = 0; p < list.size(); ++p) {
      if (list[p].value("mode", 4) != 4) continue;
      primitives.push_back(int(p));
      dense += list[p]["attributes"]["POSITION"].get<uint32_t>() < document["accessors"].size()
                   ? document["accessors"][list[p]["attributes"]["POSITION"].get<size_t>()]["count"].get<uint32_t>()
                   : 0;
    }
    out.push_back(synthetic_deformable(mesh, int(n), nodes[n]["skin"], primitives, dense, float(out.size() + 1)));
  }
  return out;
}

// Bakes `input` into `output`, reads both back and checks every property of the writer.
void bake_and_check(const fs::path& input, const std::vector<BakedDeformable>& deformables, const fs::path& output) {
  INFO(input << " -> " << output);
  const std::string input_before = read_bytes(input);
  skelform::bake::write_baked_gltf(input.string(), deformables, output.string());
  CHECK(read_bytes(input) == input_before);
  const GltfFile in = read_gltf(input), out = read_gltf(output);
  check_extension(out, deformables);
  check_original_kept(in, out);
  check_tinygltf_loads(output);

  // Determinism: the same bake again gives the same bytes.
  const std::string first = read_bytes(output);
  fs::path again = output;
  again.replace_filename("again-" + output.filename().string());
  skelform::bake::write_baked_gltf(input.string(), deformables, again.string());
  std::string second = read_bytes(again);
  const bool external_bin =
      output.extension() == ".gltf" && out.document["buffers"][0]["uri"].get<std::string>().rfind("data:", 0) != 0;
  if (external_bin) {
    // The document names its own .bin; only that name differs.
    CHECK(read_bytes(fs::path(again).replace_extension(".bin")) ==
          read_bytes(fs::path(output).replace_extension(".bin")));
    Json a = Json::parse(first), b = Json::parse(second);
    a["buffers"][0].erase("uri");
    b["buffers"][0].erase("uri");
    CHECK(a == b);
    fs::remove(fs::path(again).replace_extension(".bin"));
  } else {
    CHECK(first == second);
  }
  fs::remove(again);
}

// A tiny skinned scene: mesh 0 one indexed triangle, mesh 1 a non-indexed primitive and an
// indexed one sharing attributes; inverse bind matrices in a second external buffer; an
// image under a subdirectory. Valid for the Khronos validator.
struct TinyModel {
  Json document;
  std::string bin, extra_bin, png;
};

TinyModel tiny_model() {
  TinyModel model;
  auto f32 = [](std::string& out, float v) { out.append(reinterpret_cast<const char*>(&v), 4); };
  auto u16 = [](std::string& out, uint16_t v) { out.append(reinterpret_cast<const char*>(&v), 2); };
  for (const float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) f32(model.bin, v);  // 0..36 positions
  for (const uint16_t v : {0, 1, 2}) u16(model.bin, v);                                   // 36..42 indices
  model.bin.append(2, '\0');
  for (int i = 0; i < 3; ++i)
    for (const uint16_t v : {0, 1, 0, 0}) u16(model.bin, v);  // 44..68 joints
  for (int i = 0; i < 3; ++i)
    for (const float v : {0.5f, 0.5f, 0.f, 0.f}) f32(model.bin, v);  // 68..116 weights
  for (int m = 0; m < 2; ++m)
    for (int i = 0; i < 16; ++i) f32(model.extra_bin, i % 5 == 0 ? 1.f : 0.f);  // identity
  model.png = std::string(
      "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x00\x00\x00\x01\x00\x00\x00\x01\x08\x02\x00\x00"
      "\x00\x90"
      "\x77\x53\xde\x00\x00\x00\x0c\x49\x44\x41\x54\x78\x9c\x63\xf8\xdf\xc0\x00\x00\x04\x01\x01\x80\xc5\x2a\x18\x5d\x00"
      "\x00\x00"
      "\x00\x49\x45\x4e\x44\xae\x42\x60\x82",
      69);
  model.document = Json::parse(R"({
    "asset": {"version": "2.0", "generator": "skelform gltf_writer_test"},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2]}],
    "nodes": [
      {"name": "triangle", "mesh": 0, "skin": 0, "extras": {"note": "kept as is", "value": 0.1}},
      {"name": "strip", "mesh": 1, "skin": 0},
      {"name": "root joint", "translation": [0.0, 0.25, 0.0], "children": [3]},
      {"name": "tip joint", "rotation": [0.0, 0.0, 0.3826834, 0.9238795]}
    ],
    "meshes": [
      {"name": "indexed", "primitives": [{"attributes": {"POSITION": 0, "JOINTS_0": 2, "WEIGHTS_0": 3}, "indices": 1}]},
      {"name": "mixed", "primitives": [
        {"attributes": {"POSITION": 0, "JOINTS_0": 2, "WEIGHTS_0": 3}, "mode": 4},
        {"attributes": {"POSITION": 0, "JOINTS_0": 2, "WEIGHTS_0": 3}, "indices": 1}]}
    ],
    "skins": [{"joints": [2, 3], "inverseBindMatrices": 4, "skeleton": 2}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
      {"bufferView": 2, "componentType": 5123, "count": 3, "type": "VEC4"},
      {"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC4"},
      {"bufferView": 4, "componentType": 5126, "count": 2, "type": "MAT4"}
    ],
    "bufferViews": [
      {"buffer": 0, "byteOffset": 0, "byteLength": 36, "target": 34962},
      {"buffer": 0, "byteOffset": 36, "byteLength": 6, "target": 34963},
      {"buffer": 0, "byteOffset": 44, "byteLength": 24, "target": 34962},
      {"buffer": 0, "byteOffset": 68, "byteLength": 48, "target": 34962},
      {"buffer": 1, "byteLength": 128}
    ],
    "buffers": [{"uri": "tiny.bin", "byteLength": 116}, {"uri": "skin%20matrices.bin", "byteLength": 128}],
    "images": [{"uri": "textures/pixel.png"}],
    "samplers": [{"magFilter": 9729}],
    "textures": [{"source": 0, "sampler": 0}],
    "extensionsUsed": ["KHR_materials_emissive_strength"]
  })");
  return model;
}

std::vector<BakedDeformable> tiny_deformables() {
  return {synthetic_deformable(0, 0, 0, {0}, 3, 1), synthetic_deformable(1, 1, 0, {1, 0}, 6, 2)};
}

// Writes the tiny model as DIR/tiny.gltf (external buffers) and DIR/tiny.glb; returns DIR.
fs::path write_tiny_inputs(const std::string& name) {
  const fs::path dir = skelform::test::scratch_dir(name);
  const TinyModel model = tiny_model();
  write_bytes(dir / "tiny.gltf", model.document.dump(2));
  write_bytes(dir / "tiny.bin", model.bin);
  write_bytes(dir / "skin matrices.bin", model.extra_bin);
  write_bytes(dir / "textures" / "pixel.png", model.png);
  Json glb_document = model.document;
  glb_document["buffers"][0].erase("uri");
  write_bytes(dir / "tiny.glb", make_glb(glb_document.dump(), model.bin));
  return dir;
}

fs::path validator_dir() { return skelform::test::scratch_dir("gltf_validator"); }

template <typename F>
ErrorKind error_kind_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    MESSAGE("refused: " << std::string(e.what()));
    return e.kind();
  }
  FAIL("no Error thrown");
  return ErrorKind::usage;
}

}  // namespace

TEST_SUITE("gltf_writer") {
  TEST_CASE("gltf_writer: tiny .gltf with external buffers -> .gltf elsewhere resolves its copied resources") {
    const fs::path in = write_tiny_inputs("gltf_writer_tiny_in");
    const fs::path out = validator_dir() / "tiny-gltf" / "tiny.skf.gltf";
    fs::create_directories(out.parent_path());
    bake_and_check(in / "tiny.gltf", tiny_deformables(), out);
    const GltfFile baked = read_gltf(out);
    CHECK(baked.document["buffers"][0]["uri"] == "tiny.skf.bin");
    CHECK(fs::exists(out.parent_path() / "tiny.skf.bin"));
    CHECK(read_bytes(out.parent_path() / "skin matrices.bin") == read_bytes(in / "skin matrices.bin"));
    CHECK(read_bytes(out.parent_path() / "textures" / "pixel.png") == read_bytes(in / "textures" / "pixel.png"));
    CHECK(baked.document["extensionsUsed"] == Json::array({"KHR_materials_emissive_strength", format::kExtensionName}));
  }

  TEST_CASE("gltf_writer: tiny .gltf and .glb -> .glb keep buffer 0 in the BIN chunk") {
    const fs::path in = write_tiny_inputs("gltf_writer_tiny_in");
    const fs::path out_dir = validator_dir() / "tiny-glb";
    fs::create_directories(out_dir);
    bake_and_check(in / "tiny.gltf", tiny_deformables(), out_dir / "tiny-from-gltf.skf.glb");
    bake_and_check(in / "tiny.glb", tiny_deformables(), out_dir / "tiny-from-glb.skf.glb");
    for (const char* name : {"tiny-from-gltf.skf.glb", "tiny-from-glb.skf.glb"}) {
      const GltfFile baked = read_gltf(out_dir / name);
      CHECK_FALSE(baked.document["buffers"][0].contains("uri"));
    }
    // Both containers of the same model give the same BIN bytes.
    CHECK(read_gltf(out_dir / "tiny-from-gltf.skf.glb").buffer0 ==
          read_gltf(out_dir / "tiny-from-glb.skf.glb").buffer0);
  }

  TEST_CASE("gltf_writer: baked_glb from memory equals the file written") {
    const fs::path in = write_tiny_inputs("gltf_writer_tiny_in");
    const fs::path out = skelform::test::scratch_dir("gltf_writer_memory") / "tiny.glb";
    skelform::bake::write_baked_gltf((in / "tiny.glb").string(), tiny_deformables(), out.string());
    CHECK(skelform::bake::baked_glb(read_bytes(in / "tiny.glb"), in.string(), tiny_deformables()) == read_bytes(out));
  }

  TEST_CASE("gltf_writer: extensionsRequired never lists the extension, a re-bake keeps one entry") {
    const fs::path in = write_tiny_inputs("gltf_writer_required");
    TinyModel model = tiny_model();
    model.document["extensionsUsed"].push_back(format::kExtensionName);
    model.document["extensionsRequired"] = Json::array({format::kExtensionName});
    write_bytes(in / "required.gltf", model.document.dump());
    const fs::path out = in / "out" / "required.glb";
    fs::create_directories(out.parent_path());
    skelform::bake::write_baked_gltf((in / "required.gltf").string(), tiny_deformables(), out.string());
    const GltfFile baked = read_gltf(out);
    CHECK_FALSE(baked.document.contains("extensionsRequired"));
    check_extension(baked, tiny_deformables());
  }

  TEST_CASE("gltf_writer: real models, every container") {
    struct Case {
      const char* input;
      const char* output;
    };
    const Case cases[] = {
        {"CesiumMan/CesiumMan.glb", "CesiumMan.skf.glb"},
        {"CesiumMan/CesiumMan.glb", "CesiumMan.skf.gltf"},
        {"Fox/Fox.glb", "Fox.skf.glb"},
        {"SimpleSkin/SimpleSkin.gltf", "SimpleSkin.skf.glb"},
        {"SimpleSkin/SimpleSkin.gltf", "SimpleSkin.skf.gltf"},
        {"RiggedFigure/RiggedFigure.glb", "RiggedFigure.skf.glb"},
    };
    for (const Case& c : cases) {
      SKELFORM_REQUIRE_DATA(input, c.input);
      const GltfFile original = read_gltf(input);
      const std::vector<BakedDeformable> deformables = deformables_for(original.document);
      REQUIRE(!deformables.empty());
      bake_and_check(input, deformables, validator_dir() / c.output);
    }
    SKELFORM_REQUIRE_DATA(simple_skin, "SimpleSkin/SimpleSkin.gltf");
    const Json baked = read_gltf(validator_dir() / "SimpleSkin.skf.gltf").document;
    CHECK(baked["buffers"][0]["uri"].get<std::string>().rfind("data:application/octet-stream;base64,", 0) == 0);
  }

  TEST_CASE("gltf_writer: a failed write leaves no file and an existing output untouched") {
    const fs::path in = write_tiny_inputs("gltf_writer_atomic");
    // A directory that does not exist cannot be written to.
    const fs::path missing = in / "no such directory" / "out.glb";
    CHECK(error_kind_of([&] {
            skelform::bake::write_baked_gltf((in / "tiny.glb").string(), tiny_deformables(), missing.string());
          }) == ErrorKind::io);
    CHECK_FALSE(fs::exists(missing));

    // An existing output, and its temporary file's name taken by a directory: the write fails
    // (even as root) and the old output stays as it was.
    const fs::path existing = in / "existing.glb";
    write_bytes(existing, "previous output");
    fs::path blocker = existing;
    blocker += ".tmp-skelform-" + std::to_string(::getpid());
    fs::create_directories(blocker);
    CHECK(error_kind_of([&] {
            skelform::bake::write_baked_gltf((in / "tiny.glb").string(), tiny_deformables(), existing.string());
          }) == ErrorKind::io);
    CHECK(read_bytes(existing) == "previous output");
    fs::remove_all(blocker);

    // Bad bake data is refused before anything is written.
    std::vector<BakedDeformable> bad = tiny_deformables();
    bad[0].binding_triangle.pop_back();
    CHECK_THROWS_AS(skelform::bake::write_baked_gltf((in / "tiny.glb").string(), bad, existing.string()),
                    std::invalid_argument);
    bad = tiny_deformables();
    bad[1].dense_vertex_count = 5;
    CHECK_THROWS_AS(skelform::bake::write_baked_gltf((in / "tiny.glb").string(), bad, existing.string()),
                    std::invalid_argument);
    bad = tiny_deformables();
    bad[0].mesh = 7;
    CHECK_THROWS_AS(skelform::bake::write_baked_gltf((in / "tiny.glb").string(), bad, existing.string()),
                    std::invalid_argument);
    CHECK(read_bytes(existing) == "previous output");
  }

  TEST_CASE("gltf_writer: the input and the files it uses are never overwritten") {
    const fs::path in = write_tiny_inputs("gltf_writer_inplace");
    const std::string gltf = read_bytes(in / "tiny.gltf"), bin = read_bytes(in / "tiny.bin");
    CHECK(error_kind_of([&] {
            skelform::bake::write_baked_gltf((in / "tiny.gltf").string(), tiny_deformables(),
                                             (in / "tiny.gltf").string());
          }) == ErrorKind::usage);
    // out "tiny.gltf" beside "tiny.bin" in another name: tiny.bin is the input's buffer 0.
    CHECK(error_kind_of([&] {
            skelform::bake::write_baked_gltf((in / "tiny.gltf").string(), tiny_deformables(),
                                             (in / "tiny.GLTF").string());
          }) == ErrorKind::usage);
    CHECK(read_bytes(in / "tiny.gltf") == gltf);
    CHECK(read_bytes(in / "tiny.bin") == bin);
    CHECK(error_kind_of([&] {
            skelform::bake::write_baked_gltf((in / "tiny.gltf").string(), tiny_deformables(),
                                             (in / "tiny.obj").string());
          }) == ErrorKind::usage);
  }

  TEST_CASE("gltf_writer: malformed input is refused with invalid_input, never a crash") {
    const fs::path dir = skelform::test::scratch_dir("gltf_writer_malformed");
    const TinyModel model = tiny_model();
    Json glb_document = model.document;
    glb_document["buffers"][0].erase("uri");
    const std::string glb = make_glb(glb_document.dump(), model.bin);

    std::vector<std::pair<std::string, std::string>> inputs = {
        {"empty.glb", ""},
        {"array.gltf", "[1, 2, 3]"},
        {"number.gltf", "42"},
        {"truncated-json.gltf", model.document.dump().substr(0, 100)},
        {"glb-header-only.glb", glb.substr(0, 12)},
        {"glb-truncated.glb", glb.substr(0, glb.size() / 2)},
        {"glb-short-bin.glb", make_glb(glb_document.dump(), model.bin.substr(0, 40))},
        {"glb-no-bin.glb", make_glb(glb_document.dump(), "")},
        {"buffers-not-array.gltf", R"({"asset": {"version": "2.0"}, "buffers": {"uri": "x"}})"},
        {"bad-byte-length.gltf",
         R"({"asset": {"version": "2.0"}, "buffers": [{"uri": "tiny.bin", "byteLength": -1}]})"},
        {"bad-base64.gltf",
         R"({"asset": {"version": "2.0"}, "buffers": [{"uri": "data:application/octet-stream;base64,@@@@", "byteLength": 3}]})"},
    };
    std::string bad_length = glb;
    const uint32_t huge = 0x7FFFFFF0;
    std::memcpy(&bad_length[12], &huge, 4);
    inputs.emplace_back("glb-bad-chunk-length.glb", bad_length);
    std::string bad_version = glb;
    bad_version[4] = 1;
    inputs.emplace_back("glb-version-1.glb", bad_version);

    for (const auto& input : inputs) {
      const std::string& name = input.first;
      const std::string& bytes = input.second;
      INFO(name);
      write_bytes(dir / name, bytes);
      const fs::path out = dir / ("out-" + name + ".glb");
      CHECK(error_kind_of([&] {
              skelform::bake::write_baked_gltf((dir / name).string(), tiny_deformables(), out.string());
            }) == ErrorKind::invalid_input);
      CHECK_FALSE(fs::exists(out));
      CHECK_THROWS_AS(skelform::bake::baked_glb(bytes, dir.string(), tiny_deformables()), Error);
    }
    CHECK(error_kind_of([&] {
            skelform::bake::write_baked_gltf((dir / "absent.gltf").string(), tiny_deformables(),
                                             (dir / "x.glb").string());
          }) == ErrorKind::io);
  }

  TEST_CASE("gltf_writer: the JSON schema is valid JSON and the written extension has its required members") {
    const fs::path schema_path = fs::path(SKELFORM_SOURCE_DIR) / "docs" / "SKELFORM_skeletal_deformation.schema.json";
    const Json schema = Json::parse(read_bytes(schema_path));
    REQUIRE(schema.is_object());
    CHECK(schema.contains("$schema"));
    CHECK(schema["title"] == format::kExtensionName);

    const fs::path in = write_tiny_inputs("gltf_writer_schema");
    const fs::path out = in / "out.glb";
    skelform::bake::write_baked_gltf((in / "tiny.glb").string(), tiny_deformables(), out.string());
    const Json extension = read_gltf(out).document["extensions"][format::kExtensionName];

    // A hand check of the schema's "required" and property types on each object level (no
    // JSON Schema library is available): definitions are resolved through "$defs" by name.
    std::function<void(const Json&, const Json&, const std::string&)> check_object =
        [&](const Json& object_schema, const Json& value, const std::string& where) {
          INFO(where);
          const Json* resolved = &object_schema;
          if (resolved->contains("$ref")) {
            const std::string ref = (*resolved)["$ref"];
            REQUIRE(ref.rfind("#/$defs/", 0) == 0);
            resolved = &schema["$defs"][ref.substr(8)];
          }
          const std::string type = resolved->value("type", "");
          if (type == "object") {
            REQUIRE(value.is_object());
            for (const Json& key : resolved->value("required", Json::array()))
              CHECK_MESSAGE(value.contains(key.get<std::string>()), key);
            const Json properties = resolved->value("properties", Json::object());
            for (const auto& item : value.items()) {
              const std::string key = item.key();
              const Json& member = item.value();
              CHECK_MESSAGE(properties.contains(key), "member not in the schema: " << where << "." << key);
              if (properties.contains(key)) check_object(properties[key], member, where + "." + key);
            }
          } else if (type == "array") {
            REQUIRE(value.is_array());
            CHECK(value.size() >= resolved->value("minItems", size_t(0)));
            for (size_t i = 0; i < value.size(); ++i)
              check_object((*resolved)["items"], value[i], where + "[" + std::to_string(i) + "]");
          } else if (type == "integer") {
            CHECK(value.is_number_integer());
            if (resolved->contains("minimum")) CHECK(value.get<int64_t>() >= (*resolved)["minimum"].get<int64_t>());
          } else {
            FAIL("schema type not handled by this check: " << type);
          }
        };
    check_object(schema, extension, format::kExtensionName);
  }

}  // TEST_SUITE
