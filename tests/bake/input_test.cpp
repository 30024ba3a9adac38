// Mesh input: the real models load with their documented counts, and every kind of bad
// input ends in skelform::bake::Error with a message naming the problem, never a crash.
#include "skelform/bake/glb.h"
#include "skelform/bake/input.h"
#include "skelform/bake/weld.h"

#include "test_support.h"

#include <doctest/doctest.h>
#include <tiny_gltf.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

using namespace skelform::bake;

namespace {

std::vector<unsigned char> bytes_of(const std::string& text) { return {text.begin(), text.end()}; }

[[maybe_unused]] std::vector<unsigned char> read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string write_scratch(const std::string& file_name, const std::vector<unsigned char>& bytes) {
  const std::filesystem::path path = skelform::test::scratch_dir("input") / file_name;
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return path.string();
}

// Runs `load` and reports the Error it throws; fails the test if it throws nothing or
// anything else.
struct Outcome {
  bool threw_error = false;
  ErrorKind kind = ErrorKind::usage;
  std::string message;
};
Outcome outcome_of(const std::function<void()>& load) {
  Outcome o;
  try {
    load();
  } catch (const Error& e) {
    o.threw_error = true;
    o.kind = e.kind();
    o.message = e.what();
  }
  return o;
}

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

// Loads the same bytes from a scratch file and from memory; both must fail the same way,
// with `kind`, a message containing `substring` and no line break.
void check_rejected(const std::string& file_name, const std::vector<unsigned char>& bytes, ErrorKind kind,
                    const std::string& substring, const LoadOptions& options = {}) {
  const std::string path = write_scratch(file_name, bytes);
  const std::string ext = file_name.substr(file_name.find_last_of('.'));
  for (int from_memory = 0; from_memory < 2; ++from_memory) {
    CAPTURE(file_name);
    CAPTURE(from_memory);
    const Outcome o = outcome_of([&] {
      if (from_memory)
        load_mesh_from_memory(bytes, ext, file_name, options);
      else
        load_mesh(path, options);
    });
    REQUIRE(o.threw_error);
    CAPTURE(o.message);
    CHECK(o.kind == kind);
    CHECK(contains(o.message, substring));
    CHECK(contains(o.message, file_name));
    CHECK(o.message.find('\n') == std::string::npos);
  }
}

void check_rejected(const std::string& file_name, const std::string& text, ErrorKind kind, const std::string& substring,
                    const LoadOptions& options = {}) {
  check_rejected(file_name, bytes_of(text), kind, substring, options);
}

}  // namespace

// ---------------------------------------------------------------------------------------
// OBJ

TEST_CASE("input: OBJ with v, v/vt, v//vn, v/vt/vn corners, negative indices and a quad") {
  const std::string text =
      "# comment\n"
      "mtllib none.mtl\n"
      "o thing\n"
      "v 0 0 0\n"
      "v 1 0 0\r\n"
      "v 1 1 0 1.0\n"  // optional w
      "v 0 1 0\n"
      "v +2 -0.5e1 3.25\n"
      "vt 0 0\n"
      "vn 0 0 1\n"
      "usemtl x\n"
      "s off\n"
      "f 1/1/1 2/1/1 3/1/1\n"
      "f 1//1 3//1 4//1\n"
      "f -5/1 -3/1 -2/1 -1/1\n"  // quad through relative indices: 1 3 4 5
      "l 1 2\n";
  const InputMesh mesh = load_mesh_from_memory(bytes_of(text), ".obj", "inline.obj");
  REQUIRE(mesh.positions.size() == 5);
  CHECK(mesh.positions[4] == Vec3(2, -5, 3.25));
  REQUIRE(mesh.triangles.size() == 4);
  CHECK(mesh.triangles[0] == Triangle{0, 1, 2});
  CHECK(mesh.triangles[1] == Triangle{0, 2, 3});
  CHECK(mesh.triangles[2] == Triangle{0, 2, 3});
  CHECK(mesh.triangles[3] == Triangle{0, 3, 4});
  REQUIRE(mesh.primitives.size() == 1);
  CHECK(mesh.primitives[0].mesh == -1);
  CHECK(mesh.primitives[0].vertex_count == 5);
  CHECK(mesh.primitives[0].triangle_count == 4);
  CHECK(mesh.source_path == "inline.obj");
}

TEST_CASE("input: OBJ positions keep full double precision") {
  const std::string text = "v 0.1 1e-300 123456789.123456789\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  const InputMesh mesh = load_mesh_from_memory(bytes_of(text), ".OBJ", "precise.obj");
  CHECK(mesh.positions[0].x == 0.1);
  CHECK(mesh.positions[0].y == 1e-300);
  CHECK(mesh.positions[0].z == 123456789.123456789);
}

TEST_CASE("input: bad OBJ files are rejected with the file, the line and the problem") {
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  check_rejected("index_high.obj", tri + "f 1 2 4\n", ErrorKind::invalid_input,
                 "index_high.obj:4: face index 4 out of range");
  check_rejected("index_low.obj", tri + "f -1 -2 -4\n", ErrorKind::invalid_input,
                 "index_low.obj:4: face index -4 out of range");
  check_rejected("index_zero.obj", tri + "f 0 1 2\n", ErrorKind::invalid_input, "face index 0");
  check_rejected("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", ErrorKind::invalid_input,
                 "nan.obj:2: non-finite");
  check_rejected("inf.obj", "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n", ErrorKind::invalid_input,
                 "inf.obj:3: non-finite");
  check_rejected("overflow.obj", "v 0 0 1e999\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", ErrorKind::invalid_input,
                 "overflow.obj:1:");
  check_rejected("short_vertex.obj", "v 0 0\n", ErrorKind::invalid_input,
                 "short_vertex.obj:1: vertex has fewer than 3");
  check_rejected("bad_number.obj", "v 0 0 x1\n", ErrorKind::invalid_input, "bad vertex coordinate 'x1'");
  check_rejected("bad_index.obj", tri + "f 1 2 three\n", ErrorKind::invalid_input, "bad face index 'three'");
  check_rejected("two_corners.obj", tri + "f 1 2\n", ErrorKind::invalid_input, "face with 2 vertices");
  check_rejected("empty.obj", "", ErrorKind::invalid_input, "no vertices");
  check_rejected("no_faces.obj", tri + "vn 0 0 1\n", ErrorKind::invalid_input, "no faces");
  std::vector<unsigned char> garbage(4096);
  uint32_t state = 12345;
  for (unsigned char& b : garbage) {
    state = state * 1664525u + 1013904223u;
    b = static_cast<unsigned char>(state >> 24);
  }
  check_rejected("garbage.obj", garbage, ErrorKind::invalid_input, "garbage.obj");
}

TEST_CASE("input: missing files and unknown extensions are clear errors") {
  const Outcome missing = outcome_of([] { load_mesh("/nonexistent/dir/model.obj"); });
  REQUIRE(missing.threw_error);
  CHECK(missing.kind == ErrorKind::io);
  CHECK(contains(missing.message, "/nonexistent/dir/model.obj"));
  const Outcome directory = outcome_of([] { load_mesh(skelform::test::scratch_dir("input_dir.obj").string()); });
  REQUIRE(directory.threw_error);
  CHECK(directory.kind == ErrorKind::io);
  const Outcome unknown = outcome_of([] { load_mesh("model.stl"); });
  REQUIRE(unknown.threw_error);
  CHECK(unknown.kind == ErrorKind::unsupported);
  CHECK(contains(unknown.message, ".stl"));
}

TEST_CASE("input: spot.obj (f v/vt) loads 2,930 vertices, 5,856 triangles and the weld keeps its order") {
  SKELFORM_REQUIRE_DATA(path, "spot/spot.obj");
  const InputMesh mesh = load_mesh(path.string());
  CHECK(mesh.positions.size() == 2930);
  CHECK(mesh.triangles.size() == 5856);
  const WeldedMesh welded = weld(mesh);
  CHECK(welded.mesh.positions == mesh.positions);
  CHECK(welded.mesh.triangles == mesh.triangles);
  CHECK(welded.degenerate_triangles_removed == 0);
  CHECK(welded.duplicate_triangles_removed == 0);
}

TEST_CASE("input: bunny.obj (f v//vn) loads 3,301 vertices, 6,598 triangles") {
  SKELFORM_REQUIRE_DATA(path, "bunny/bunny.obj");
  const InputMesh mesh = load_mesh(path.string());
  CHECK(mesh.positions.size() == 3301);
  CHECK(mesh.triangles.size() == 6598);
  const WeldedMesh welded = weld(mesh);
  CHECK(welded.mesh.positions.size() == 3301);
  CHECK(welded.mesh.triangles == mesh.triangles);
}

TEST_CASE("input: hand_closed.obj loads 7,993 vertices, 15,982 triangles") {
  // Load speed is measured in bench/ (skelform-bench-bake), not asserted here.
  SKELFORM_REQUIRE_DATA(path, "hand/hand_closed.obj");
  const InputMesh mesh = load_mesh(path.string());
  CHECK(mesh.positions.size() == 7993);
  CHECK(mesh.triangles.size() == 15982);
  const WeldedMesh welded = weld(mesh);
  CHECK(welded.mesh.positions.size() == 7993);
  CHECK(welded.mesh.triangles.size() == 15982);
}

// ---------------------------------------------------------------------------------------
// glTF

namespace {

std::string base64(const std::vector<unsigned char>& data) {
  static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < data.size(); i += 3) {
    const uint32_t b0 = data[i];
    const uint32_t b1 = i + 1 < data.size() ? data[i + 1] : 0;
    const uint32_t b2 = i + 2 < data.size() ? data[i + 2] : 0;
    const uint32_t triple = b0 << 16 | b1 << 8 | b2;
    out += alphabet[triple >> 18 & 63];
    out += alphabet[triple >> 12 & 63];
    out += i + 1 < data.size() ? alphabet[triple >> 6 & 63] : '=';
    out += i + 2 < data.size() ? alphabet[triple & 63] : '=';
  }
  return out;
}

template <typename T>
void append_raw(std::vector<unsigned char>& out, const std::vector<T>& values) {
  const size_t at = out.size();
  out.resize(at + values.size() * sizeof(T));
  if (!values.empty()) std::memcpy(out.data() + at, values.data(), values.size() * sizeof(T));
  while (out.size() % 4) out.push_back(0);
}

// A small skinned glTF built from parts, so each test breaks exactly one thing. Buffer 0
// holds the positions (bufferView 0) then the indices (bufferView 1); accessor 0 is
// POSITION, accessor 1 the indices.
struct GltfParts {
  std::vector<float> positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  std::vector<uint16_t> indices = {0, 1, 2, 0, 2, 3};
  int mode = 4;
  bool skinned = true;
  bool indexed = true;
  std::string position_accessor = "0";     // the primitive's POSITION value
  long position_count = -1;                // -1: positions.size() / 3
  long position_view_offset = 0;           // bufferView 0 byteOffset
  std::string extra_accessors;             // appended to the accessors array
  std::string extra_views;                 // appended to the bufferViews array
  std::vector<unsigned char> extra_bytes;  // appended to buffer 0 (after the indices)
  std::string position_accessor_extra;     // extra members of accessor 0, e.g. sparse

  // A skinned node's primitives need JOINTS_0/WEIGHTS_0: every vertex fully on joint 0.
  // They go after everything else so the tests' extra accessor/view indices stay 2, 3, ...
  std::vector<unsigned char> buffer(size_t* indices_offset = nullptr, size_t* extra_offset = nullptr,
                                    size_t* skin_offset = nullptr) const {
    std::vector<unsigned char> data;
    append_raw(data, positions);
    if (indices_offset) *indices_offset = data.size();
    append_raw(data, indices);
    if (extra_offset) *extra_offset = data.size();
    data.insert(data.end(), extra_bytes.begin(), extra_bytes.end());
    while (data.size() % 4) data.push_back(0);
    if (skin_offset) *skin_offset = data.size();
    if (skinned) {
      const size_t vertices = positions.size() / 3;
      append_raw(data, std::vector<uint16_t>(vertices * 4, 0));
      std::vector<float> weights(vertices * 4, 0.0f);
      for (size_t v = 0; v < vertices; ++v) weights[4 * v] = 1.0f;
      append_raw(data, weights);
    }
    return data;
  }

  static size_t occurrences(const std::string& text, const std::string& what) {
    size_t count = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++count;
    return count;
  }

  // `uri` empty: the GLB form, buffer 0 is the BIN chunk.
  std::string json(const std::string& uri) const {
    size_t indices_offset = 0, skin_offset = 0;
    const std::vector<unsigned char> data = buffer(&indices_offset, nullptr, &skin_offset);
    const long count = position_count >= 0 ? position_count : static_cast<long>(positions.size() / 3);
    const size_t vertices = positions.size() / 3;
    const size_t skin_accessor = 2 + occurrences(extra_accessors, "\"componentType\"");
    const size_t skin_view = 2 + occurrences(extra_views, "\"buffer\"");
    std::string skin_attributes, skin_accessors, skin_views;
    if (skinned) {
      skin_attributes =
          ",\"JOINTS_0\":" + std::to_string(skin_accessor) + ",\"WEIGHTS_0\":" + std::to_string(skin_accessor + 1);
      skin_accessors = ",{\"bufferView\":" + std::to_string(skin_view) +
                       ",\"componentType\":5123,\"type\":\"VEC4\",\"count\":" + std::to_string(vertices) +
                       "},{\"bufferView\":" + std::to_string(skin_view + 1) +
                       ",\"componentType\":5126,\"type\":\"VEC4\",\"count\":" + std::to_string(vertices) + "}";
      skin_views = ",{\"buffer\":0,\"byteOffset\":" + std::to_string(skin_offset) +
                   ",\"byteLength\":" + std::to_string(vertices * 8) +
                   "},{\"buffer\":0,\"byteOffset\":" + std::to_string(skin_offset + vertices * 8) +
                   ",\"byteLength\":" + std::to_string(vertices * 16) + "}";
    }
    std::string primitive = "{\"attributes\":{\"POSITION\":" + position_accessor + skin_attributes + "}";
    if (indexed) primitive += ",\"indices\":1";
    primitive += ",\"mode\":" + std::to_string(mode) + "}";
    std::string j = "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0,1]}],";
    j += "\"nodes\":[{\"mesh\":0" + std::string(skinned ? ",\"skin\":0" : "") + "},{\"name\":\"joint\"}],";
    if (skinned) j += "\"skins\":[{\"joints\":[1]}],";
    j += "\"meshes\":[{\"name\":\"thing\",\"primitives\":[" + primitive + "]}],";
    j +=
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"type\":\"VEC3\",\"count\":" + std::to_string(count) +
        position_accessor_extra + "},";
    j += "{\"bufferView\":1,\"componentType\":5123,\"type\":\"SCALAR\",\"count\":" + std::to_string(indices.size()) +
         "}" + extra_accessors + skin_accessors + "],";
    j += "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":" + std::to_string(position_view_offset) +
         ",\"byteLength\":" + std::to_string(positions.size() * 4) + "},";
    j += "{\"buffer\":0,\"byteOffset\":" + std::to_string(indices_offset) +
         ",\"byteLength\":" + std::to_string(indices.size() * 2) + "}" + extra_views + skin_views + "],";
    j += "\"buffers\":[{\"byteLength\":" + std::to_string(data.size());
    if (!uri.empty()) j += ",\"uri\":\"" + uri + "\"";
    j += "}]}";
    return j;
  }

  std::vector<unsigned char> gltf() const {
    return bytes_of(json("data:application/octet-stream;base64," + base64(buffer())));
  }

  std::vector<unsigned char> glb() const {
    const std::vector<unsigned char> bin = buffer();
    return bytes_of(skelform::bake::glb_container(json(""), std::string(bin.begin(), bin.end())));
  }
};

// Checks the welded counts the data README documents and that every original vertex maps
// to a welded vertex at the very same position.
void check_model(const std::filesystem::path& path, size_t vertices, size_t welded_vertices, size_t triangles,
                 bool indexed) {
  const InputMesh mesh = load_mesh(path.string());
  CHECK(mesh.positions.size() == vertices);
  CHECK(mesh.triangles.size() == triangles);
  REQUIRE(mesh.primitives.size() == 1);
  const InputPrimitive& p = mesh.primitives[0];
  CHECK(p.mesh == 0);
  CHECK(p.primitive == 0);
  CHECK(p.node >= 0);
  CHECK(p.skin == 0);
  CHECK(p.first_vertex == 0);
  CHECK(p.vertex_count == vertices);
  CHECK(p.first_triangle == 0);
  CHECK(p.triangle_count == triangles);
  CHECK(p.indexed == indexed);
  const WeldedMesh welded = weld(mesh);
  CHECK(welded.mesh.positions.size() == welded_vertices);
  CHECK(welded.mesh.triangles.size() == triangles);
  REQUIRE(welded.welded_of_original.size() == vertices);
  size_t mismatched = 0;
  for (size_t i = 0; i < vertices; ++i)
    if (welded.mesh.positions[welded.welded_of_original[i]] != mesh.positions[i]) ++mismatched;
  CHECK(mismatched == 0);
  // The same bytes from memory give the same mesh.
  const InputMesh again = load_mesh_from_memory(read_bytes(path), path.extension().string(), path.string());
  CHECK(again.positions == mesh.positions);
  CHECK(again.triangles == mesh.triangles);
}

}  // namespace

TEST_CASE("input: CesiumMan.glb 3273 vertices weld to 2338 with 4672 triangles") {
  SKELFORM_REQUIRE_DATA(path, "CesiumMan/CesiumMan.glb");
  check_model(path, 3273, 2338, 4672, true);
}

TEST_CASE("input: Fox.glb has no index buffer and 1728 vertices weld to 290 with 576 triangles") {
  SKELFORM_REQUIRE_DATA(path, "Fox/Fox.glb");
  check_model(path, 1728, 290, 576, false);
  const InputMesh mesh = load_mesh(path.string());
  CHECK(mesh.triangles[0] == Triangle{0, 1, 2});
  CHECK(mesh.triangles[575] == Triangle{1725, 1726, 1727});
}

TEST_CASE("input: RiggedFigure.glb 370 vertices weld to 130 with 256 triangles") {
  SKELFORM_REQUIRE_DATA(path, "RiggedFigure/RiggedFigure.glb");
  check_model(path, 370, 130, 256, true);
}

TEST_CASE("input: RiggedSimple.glb 160 vertices weld to 96 with 188 triangles") {
  SKELFORM_REQUIRE_DATA(path, "RiggedSimple/RiggedSimple.glb");
  check_model(path, 160, 96, 188, true);
}

TEST_CASE("input: SimpleSkin.gltf with data-URI buffers has 10 vertices and 8 triangles") {
  SKELFORM_REQUIRE_DATA(path, "SimpleSkin/SimpleSkin.gltf");
  check_model(path, 10, 10, 8, true);
}

TEST_CASE("input: a generated skinned glTF loads the same as .gltf (data URI) and .glb") {
  const GltfParts parts;
  // Not structured bindings: doctest's macros capture in lambdas (clang 14 refuses bindings).
  for (const auto& input :
       {std::pair{parts.gltf(), std::string(".gltf")}, std::pair{parts.glb(), std::string(".glb")}}) {
    const std::vector<unsigned char>& bytes = input.first;
    const std::string& ext = input.second;
    CAPTURE(ext);
    const InputMesh mesh = load_mesh_from_memory(bytes, ext, "generated" + ext);
    REQUIRE(mesh.positions.size() == 4);
    CHECK(mesh.positions[2] == Vec3(1, 1, 0));
    REQUIRE(mesh.triangles.size() == 2);
    CHECK(mesh.triangles[1] == Triangle{0, 2, 3});
    REQUIRE(mesh.primitives.size() == 1);
    CHECK(mesh.primitives[0].node == 0);
    CHECK(mesh.primitives[0].skin == 0);
    CHECK(mesh.primitives[0].indexed);
  }
}

TEST_CASE("input: glTF TRIANGLE_STRIP and TRIANGLE_FAN become triangles with the glTF winding") {
  GltfParts strip;
  strip.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 2, 0};
  strip.indices = {0, 1, 2, 3, 4};
  strip.mode = 5;
  const InputMesh s = load_mesh_from_memory(strip.gltf(), ".gltf", "strip.gltf");
  REQUIRE(s.triangles.size() == 3);
  CHECK(s.triangles[0] == Triangle{0, 1, 2});
  CHECK(s.triangles[1] == Triangle{1, 3, 2});
  CHECK(s.triangles[2] == Triangle{2, 3, 4});
  GltfParts fan = strip;
  fan.mode = 6;
  fan.indexed = false;
  const InputMesh f = load_mesh_from_memory(fan.gltf(), ".gltf", "fan.gltf");
  REQUIRE(f.triangles.size() == 3);
  CHECK(f.triangles[0] == Triangle{1, 2, 0});
  CHECK(f.triangles[2] == Triangle{3, 4, 0});
  CHECK_FALSE(f.primitives[0].indexed);
}

TEST_CASE("input: glTF sparse POSITION accessors are applied") {
  GltfParts parts;
  // Sparse: replace vertex 2 by (5, 6, 7). Indices (one UNSIGNED_SHORT) then values.
  std::vector<unsigned char> extra;
  append_raw(extra, std::vector<uint16_t>{2});
  append_raw(extra, std::vector<float>{5, 6, 7});
  parts.extra_bytes = extra;
  size_t extra_offset = 0;
  parts.buffer(nullptr, &extra_offset);
  parts.extra_views = ",{\"buffer\":0,\"byteOffset\":" + std::to_string(extra_offset) + ",\"byteLength\":2}" +
                      ",{\"buffer\":0,\"byteOffset\":" + std::to_string(extra_offset + 4) + ",\"byteLength\":12}";
  parts.position_accessor_extra =
      ",\"sparse\":{\"count\":1,\"indices\":{\"bufferView\":2,\"componentType\":5123},\"values\":{\"bufferView\":3}}";
  const InputMesh mesh = load_mesh_from_memory(parts.gltf(), ".gltf", "sparse.gltf");
  REQUIRE(mesh.positions.size() == 4);
  CHECK(mesh.positions[1] == Vec3(1, 0, 0));
  CHECK(mesh.positions[2] == Vec3(5, 6, 7));

  // A sparse index beyond the accessor is refused, not written out of bounds.
  GltfParts bad = parts;
  std::vector<unsigned char> bad_extra;
  append_raw(bad_extra, std::vector<uint16_t>{9});
  append_raw(bad_extra, std::vector<float>{5, 6, 7});
  bad.extra_bytes = bad_extra;
  check_rejected("sparse_index.gltf", bad.gltf(), ErrorKind::invalid_input, "sparse");
}

TEST_CASE("input: bad glTF files are rejected with a message naming the problem") {
  GltfParts parts;
  parts.indices = {0, 1, 7, 0, 2, 3};
  check_rejected("index_range.gltf", parts.gltf(), ErrorKind::invalid_input, "index 7 at position 2");

  parts = GltfParts();
  parts.positions[4] = std::nanf("");
  check_rejected("nan.gltf", parts.gltf(), ErrorKind::invalid_input, "element 1 has a non-finite value");

  parts = GltfParts();
  parts.positions[6] = -INFINITY;
  check_rejected("inf.glb", parts.glb(), ErrorKind::invalid_input, "POSITION");

  parts = GltfParts();
  parts.mode = 1;
  check_rejected("lines.gltf", parts.gltf(), ErrorKind::unsupported, "mesh 0 ('thing') primitive 0 has mode LINES");
  parts.mode = 0;
  check_rejected("points.gltf", parts.gltf(), ErrorKind::unsupported, "mode POINTS");

  parts = GltfParts();
  parts.position_count = 5;
  check_rejected("accessor_past_view.gltf", parts.gltf(), ErrorKind::invalid_input,
                 "runs past the end of bufferView 0");

  parts = GltfParts();
  // 48 bytes of positions starting 16 bytes before the end overrun the buffer.
  parts.position_view_offset = static_cast<long>(parts.buffer().size()) - 16;
  check_rejected("view_past_buffer.gltf", parts.gltf(), ErrorKind::invalid_input, "past the end of buffer 0");

  parts = GltfParts();
  parts.position_accessor = "1";  // the UNSIGNED_SHORT SCALAR index accessor
  check_rejected("wrong_type.gltf", parts.gltf(), ErrorKind::unsupported,
                 "is UNSIGNED_SHORT SCALAR; expected FLOAT VEC3");

  parts = GltfParts();
  parts.position_accessor = "7";
  check_rejected("bad_accessor.gltf", parts.gltf(), ErrorKind::invalid_input, "accessor 7 does not exist");

  parts = GltfParts();
  parts.skinned = false;
  check_rejected("unskinned.gltf", parts.gltf(), ErrorKind::invalid_input,
                 "unskinned.gltf (use --all-meshes to bake unskinned meshes)");
  LoadOptions all;
  all.all_meshes = true;
  const InputMesh unskinned = load_mesh_from_memory(parts.gltf(), ".gltf", "unskinned.gltf", all);
  CHECK(unskinned.triangles.size() == 2);
  CHECK(unskinned.primitives[0].skin == -1);
  CHECK(unskinned.primitives[0].node == 0);

  parts = GltfParts();
  parts.indices = {0, 1, 2, 0, 2};
  check_rejected("five_indices.gltf", parts.gltf(), ErrorKind::invalid_input, "not a multiple of 3");
  parts.indexed = false;
  parts.positions.resize(15, 0.5f);
  check_rejected("five_vertices.glb", parts.glb(), ErrorKind::invalid_input, "not a multiple of 3");

  check_rejected("garbage.gltf", "{\"asset\": [1, 2", ErrorKind::invalid_input, "garbage.gltf");
  check_rejected("empty.gltf", "", ErrorKind::invalid_input, "empty.gltf");
  check_rejected("not_glb.glb", "glTX this is not a binary glTF", ErrorKind::invalid_input, "bad magic");
}

TEST_CASE("input: limits: JSON nesting, influence sets and PLY row counts are refused before the work") {
  const GltfParts parts;
  const std::string text = parts.json("data:application/octet-stream;base64," + base64(parts.buffer()));
  // 65 levels of arrays in the root's extras: valid JSON, beyond the 64 a glTF may nest.
  std::string deep = text;
  deep.insert(1, "\"extras\":" + std::string(65, '[') + std::string(65, ']') + ",");
  check_rejected("deep.gltf", deep, ErrorKind::invalid_input, "nested deeper than 64");
  std::string fine = text;
  fine.insert(1, "\"extras\":" + std::string(60, '[') + std::string(60, ']') + ",");
  REQUIRE_NOTHROW(load_mesh_from_memory(bytes_of(fine), ".gltf", "fine.gltf"));

  // JOINTS_1 .. JOINTS_16 naming the same accessors: 17 sets, one beyond the limit.
  const size_t at = text.find("\"JOINTS_0\"");
  REQUIRE(at != std::string::npos);
  const size_t end = text.find('}', at);
  const std::string pair = text.substr(at, end - at);  // "JOINTS_0":a,"WEIGHTS_0":b
  std::string sets;
  for (int s = 1; s <= 16; ++s) {
    std::string copy = pair;
    for (const char* name : {"JOINTS_0", "WEIGHTS_0"}) {
      const std::string from(name), to = from.substr(0, from.size() - 1) + std::to_string(s);
      copy.replace(copy.find(from), from.size(), to);
    }
    sets += "," + copy;
  }
  std::string many = text;
  many.insert(end, sets);
  check_rejected("influences.gltf", many, ErrorKind::unsupported, "more than 16 JOINTS_n/WEIGHTS_n sets");

  // Two elements of 60 rows each in a body of 100 bytes: each alone fits, together they cannot.
  const std::string head =
      "ply\nformat binary_little_endian 1.0\nelement extra 60\nproperty uchar a\n"
      "element vertex 60\nproperty uchar x\nproperty uchar y\nproperty uchar z\nend_header\n";
  check_rejected("rows.ply", head + std::string(100, '\0'), ErrorKind::invalid_input,
                 "element 'vertex' declares 60 rows");
}

TEST_CASE("input: a generated .glb cut at every length fails with an Error, never a crash") {
  const std::vector<unsigned char> whole = GltfParts().glb();
  REQUIRE_NOTHROW(load_mesh_from_memory(whole, ".glb", "whole.glb"));
  size_t rejected = 0;
  for (size_t cut = 0; cut < whole.size(); ++cut) {
    const std::vector<unsigned char> part(whole.begin(), whole.begin() + static_cast<std::ptrdiff_t>(cut));
    const Outcome o = outcome_of([&] { load_mesh_from_memory(part, ".glb", "cut.glb"); });
    if (o.threw_error && o.kind == ErrorKind::invalid_input && contains(o.message, "cut.glb")) ++rejected;
  }
  CHECK(rejected == whole.size());
  check_rejected("truncated.glb", std::vector<unsigned char>(whole.begin(), whole.end() - 4), ErrorKind::invalid_input,
                 "truncated .glb");
}

TEST_CASE("input: CesiumMan.glb cut at several lengths fails with an Error, never a crash") {
  SKELFORM_REQUIRE_DATA(path, "CesiumMan/CesiumMan.glb");
  const std::vector<unsigned char> whole = read_bytes(path);
  for (size_t cut : {size_t{0}, size_t{1}, size_t{11}, size_t{12}, size_t{19}, size_t{20}, size_t{100}, size_t{4000},
                     whole.size() / 2, whole.size() - 100, whole.size() - 1}) {
    CAPTURE(cut);
    const std::vector<unsigned char> part(whole.begin(), whole.begin() + static_cast<std::ptrdiff_t>(cut));
    const Outcome o = outcome_of([&] { load_mesh_from_memory(part, ".glb", "CesiumMan-cut.glb"); });
    CHECK(o.threw_error);
    CHECK(o.kind == ErrorKind::invalid_input);
    CHECK(contains(o.message, "CesiumMan-cut.glb"));
  }
}

// ---------------------------------------------------------------------------------------
// PLY and OFF

namespace {

// A cube with quad faces as PLY: `vertex` with x/y/z of `coordinate` type plus an ignored
// property, `face` lists of uchar count and `index` type, plus an unrelated element after.
std::vector<unsigned char> cube_ply(const std::string& format, const std::string& coordinate, const std::string& index,
                                    size_t truncate_body_by = 0) {
  const double corners[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const int quads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}};
  std::string header = "ply\r\nformat " + format + " 1.0\ncomment made by the test\nelement vertex 8\n";
  header += "property " + coordinate + " x\nproperty " + coordinate + " y\nproperty uchar red\nproperty " + coordinate +
            " z\n";
  header += "element face 6\nproperty list uchar " + index + " vertex_indices\nproperty float quality\n";
  header += "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n";
  std::vector<unsigned char> out = bytes_of(header);
  if (format == "ascii") {
    std::string body;
    for (const auto& c : corners)
      body += std::to_string(c[0]) + " " + std::to_string(c[1]) + " 255 " + std::to_string(c[2]) + "\n";
    for (const auto& q : quads)
      body += "4 " + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " + std::to_string(q[2]) + " " +
              std::to_string(q[3]) + " 0.5\n";
    body += "0 1\n";
    out.insert(out.end(), body.begin(), body.end());
  } else {
    const bool big = format == "binary_big_endian";
    auto put = [&](const void* p, size_t size) {
      const auto* b = static_cast<const unsigned char*>(p);
      for (size_t i = 0; i < size; ++i) out.push_back(b[big ? size - 1 - i : i]);
    };
    auto put_coordinate = [&](double v) {
      if (coordinate == "double")
        put(&v, 8);
      else {
        const float f = static_cast<float>(v);
        put(&f, 4);
      }
    };
    auto put_index = [&](int v) {
      if (index == "int" || index == "uint")
        put(&v, 4);
      else if (index == "ushort" || index == "short") {
        const uint16_t s = static_cast<uint16_t>(v);
        put(&s, 2);
      } else {
        const uint8_t u = static_cast<uint8_t>(v);
        put(&u, 1);
      }
    };
    const uint8_t red = 255;
    const float quality = 0.5f;
    const int edge[2] = {0, 1};
    for (const auto& c : corners) {
      put_coordinate(c[0]);
      put_coordinate(c[1]);
      put(&red, 1);
      put_coordinate(c[2]);
    }
    for (const auto& q : quads) {
      const uint8_t n = 4;
      put(&n, 1);
      for (int v : q) put_index(v);
      put(&quality, 4);
    }
    put(&edge[0], 4);
    put(&edge[1], 4);
  }
  out.resize(out.size() - truncate_body_by);
  return out;
}

void check_cube(const InputMesh& mesh) {
  REQUIRE(mesh.positions.size() == 8);
  CHECK(mesh.positions[6] == Vec3(1, 1, 1));
  CHECK(mesh.positions[3] == Vec3(0, 1, 0));
  REQUIRE(mesh.triangles.size() == 12);
  CHECK(mesh.triangles[0] == Triangle{0, 3, 2});
  CHECK(mesh.triangles[1] == Triangle{0, 2, 1});
  CHECK(mesh.triangles[11] == Triangle{0, 7, 3});
  const WeldedMesh welded = weld(mesh);
  CHECK(welded.mesh.positions.size() == 8);
  CHECK(welded.mesh.triangles.size() == 12);
}

}  // namespace

TEST_CASE("input: PLY in ASCII and both binary byte orders with float or double coordinates and any index type") {
  for (const std::string format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    for (const std::string coordinate : {"float", "double"}) {
      for (const std::string index : {"int", "uint", "ushort", "uchar"}) {
        CAPTURE(format);
        CAPTURE(coordinate);
        CAPTURE(index);
        const std::vector<unsigned char> bytes = cube_ply(format, coordinate, index);
        check_cube(load_mesh_from_memory(bytes, ".ply", "cube.ply"));
        check_cube(load_mesh(write_scratch("cube.PLY", bytes)));
      }
    }
  }
  // The face list may also be called vertex_index, and the header may use sized type names.
  std::string text =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float32 x\nproperty float32 y\n"
      "property float32 z\nelement face 1\nproperty list uint8 int32 vertex_index\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  CHECK(load_mesh_from_memory(bytes_of(text), ".ply", "named.ply").triangles.size() == 1);
}

TEST_CASE("input: bad PLY files are rejected with the element and the problem") {
  const std::vector<unsigned char> whole = cube_ply("binary_little_endian", "float", "int");
  check_rejected("truncated_body.ply", cube_ply("binary_little_endian", "float", "int", 9), ErrorKind::invalid_input,
                 "truncated binary body: file ends inside element 'face' 5");
  check_rejected("truncated_vertices.ply", std::vector<unsigned char>(whole.begin(), whole.end() - 150),
                 ErrorKind::invalid_input, "truncated binary body: file ends inside element 'vertex'");
  // Every cut of a binary PLY fails cleanly.
  size_t rejected = 0;
  for (size_t cut = 0; cut < whole.size(); ++cut) {
    const Outcome o = outcome_of([&] {
      load_mesh_from_memory(std::vector<unsigned char>(whole.begin(), whole.begin() + static_cast<std::ptrdiff_t>(cut)),
                            ".ply", "cut.ply");
    });
    if (o.threw_error && contains(o.message, "cut.ply")) ++rejected;
  }
  CHECK(rejected == whole.size());

  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  check_rejected("index_range.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", ErrorKind::invalid_input,
                 "element 'face' 0: vertex index 3 out of range (3 vertices)");
  check_rejected("negative_index.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", ErrorKind::invalid_input,
                 "element 'face' 0: bad vertex index");
  check_rejected("nan.ply", head + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", ErrorKind::invalid_input,
                 "element 'vertex' 1: non-finite coordinate");
  check_rejected("short_ascii.ply", head + "0 0 0\n1 0 0\n0 1\n", ErrorKind::invalid_input,
                 "file ends inside element 'vertex' 2");
  check_rejected("no_faces.ply",
                 "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                 "property float z\nend_header\n0 0 0\n",
                 ErrorKind::invalid_input, "no faces");
  check_rejected("no_end.ply", "ply\nformat ascii 1.0\nelement vertex 1\n", ErrorKind::invalid_input, "no end_header");
  check_rejected("huge_count.ply",
                 "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                 "property float y\nproperty float z\nend_header\n",
                 ErrorKind::invalid_input, "declares 4000000000 rows");
  check_rejected("not.ply", "solid cube\nfacet normal 0 0 1\n", ErrorKind::invalid_input, "not a PLY file");
}

TEST_CASE("input: OFF with comments, a quad, colours and counts on the header line") {
  const std::string text =
      "OFF\n# a comment\n\n4 2 0\n0 0 0\n1 0 0  # trailing comment\n1 1 0\n0 1 0\n4 0 1 2 3\n3 0 2 3 255 0 0\n";
  const InputMesh mesh = load_mesh_from_memory(bytes_of(text), ".off", "quad.off");
  REQUIRE(mesh.positions.size() == 4);
  CHECK(mesh.positions[1] == Vec3(1, 0, 0));
  REQUIRE(mesh.triangles.size() == 3);
  CHECK(mesh.triangles[1] == Triangle{0, 2, 3});
  CHECK(mesh.triangles[2] == Triangle{0, 2, 3});
  const std::string coff = "COFF 3 1 3\n0 0 0 1 0 0 1\n1 0 0 0 1 0 1\n0 1 0 0 0 1 1\n3 0 1 2\n";
  CHECK(load_mesh(write_scratch("colour.off", bytes_of(coff))).triangles.size() == 1);
}

TEST_CASE("input: bad OFF files are rejected with the line and the problem") {
  check_rejected("bad_counts.off", "OFF\n3 x 0\n", ErrorKind::invalid_input, "bad_counts.off:2: bad counts");
  check_rejected("negative_counts.off", "OFF\n-3 1 0\n", ErrorKind::invalid_input, "bad counts");
  check_rejected("huge_counts.off", "OFF\n3000000 1 0\n0 0 0\n", ErrorKind::invalid_input, "cannot fit");
  check_rejected("missing_counts.off", "OFF\n", ErrorKind::invalid_input, "no counts line");
  check_rejected("few_vertices.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", ErrorKind::invalid_input,
                 "3 vertices declared, file ends after 2");
  check_rejected("few_faces.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", ErrorKind::invalid_input,
                 "2 faces declared, file ends after 1");
  check_rejected("index_range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", ErrorKind::invalid_input,
                 "index_range.off:6: face 0: vertex index 3 out of range");
  check_rejected("inf.off", "OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n", ErrorKind::invalid_input,
                 "inf.off:4: vertex 1: non-finite");
  check_rejected("short_face.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", ErrorKind::invalid_input,
                 "4 vertices declared, 3 given");
  check_rejected("no_faces.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", ErrorKind::invalid_input, "no faces");
  check_rejected("empty.off", "", ErrorKind::invalid_input, "empty file");
  check_rejected("no_header.off", "3 1 0\n", ErrorKind::invalid_input, "not an OFF file");
}

// ---------------------------------------------------------------------------------------
// Robustness

TEST_CASE("input: randomly corrupted files of every format load or throw Error and nothing else") {
  // Digits are the interesting bytes in text formats (counts, offsets, indices): they are
  // replaced by other digits or by huge numbers; other bytes are flipped at random.
  uint64_t state = 0x9E3779B97F4A7C15ULL;
  auto next = [&state]() {
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return state;
  };
  const std::vector<std::pair<std::string, std::vector<unsigned char>>> originals = {
      {".glb", GltfParts().glb()},
      {".gltf", bytes_of(GltfParts().json("data:application/octet-stream;base64," + base64(GltfParts().buffer())))},
      {".ply", cube_ply("binary_big_endian", "float", "ushort")},
      {".ply", cube_ply("ascii", "double", "int")},
      {".off", bytes_of("OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n3 0 2 3\n")},
      {".obj", bytes_of("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1 2/2 3/3 4/4\nf -4 -2 -1\n")},
  };
  size_t loaded = 0;
  size_t rejected = 0;
  size_t other_exceptions = 0;
  for (const auto& [ext, original] : originals) {
    for (int round = 0; round < 300; ++round) {
      std::vector<unsigned char> bytes = original;
      const int edits = 1 + static_cast<int>(next() % 4);
      for (int e = 0; e < edits; ++e) {
        const size_t at = next() % bytes.size();
        if (bytes[at] >= '0' && bytes[at] <= '9') {
          if (next() % 4 == 0) {
            const std::string huge = std::to_string(next() % 5000000000ULL);
            bytes.insert(bytes.begin() + static_cast<std::ptrdiff_t>(at), huge.begin(), huge.end());
          } else {
            bytes[at] = static_cast<unsigned char>('0' + next() % 10);
          }
        } else if (next() % 3 == 0) {
          bytes[at] = static_cast<unsigned char>(next());
        }
      }
      try {
        load_mesh_from_memory(bytes, ext, "corrupt" + ext);
        ++loaded;
      } catch (const Error&) {
        ++rejected;
      } catch (const std::exception& e) {
        ++other_exceptions;
        MESSAGE(ext << " round " << round << " threw a non-Error exception: " << e.what());
      }
    }
  }
  MESSAGE(loaded << " corrupted files loaded, " << rejected << " rejected");
  CHECK(other_exceptions == 0);
  CHECK(rejected > 0);
}

TEST_CASE("input: skin influences of every skinned model are read, in range and normalised") {
  for (const auto& model : std::vector<std::pair<const char*, size_t>>{{"CesiumMan/CesiumMan.glb", 19},
                                                                       {"Fox/Fox.glb", 24},
                                                                       {"RiggedFigure/RiggedFigure.glb", 19},
                                                                       {"RiggedSimple/RiggedSimple.glb", 2},
                                                                       {"SimpleSkin/SimpleSkin.gltf", 2}}) {
    const char* name = model.first;
    const size_t joint_count = model.second;
    SKELFORM_REQUIRE_DATA(path, name);
    CAPTURE(name);
    const InputMesh mesh = load_mesh(path.string());
    REQUIRE(mesh.joint_sets.size() == 1);  // none of the sample files has JOINTS_1
    REQUIRE(mesh.weight_sets.size() == 1);
    REQUIRE(mesh.joint_sets[0].size() == mesh.positions.size());
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
      float sum = 0;
      for (int k = 0; k < 4; ++k) {
        sum += mesh.weight_sets[0][v][k];
        CHECK(mesh.joint_sets[0][v][k] < joint_count);
      }
      CHECK(sum == doctest::Approx(1.0f).epsilon(1e-5));
    }
  }
}

TEST_CASE("input: OBJ, PLY and OFF carry no skin influences") {
  const std::filesystem::path file = skelform::test::scratch_dir("input_noskin") / "tri.obj";
  {
    std::ofstream out(file);
    out << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  }
  const InputMesh mesh = load_mesh(file.string());
  CHECK(mesh.joint_sets.empty());
  CHECK(mesh.weight_sets.empty());
}
