// Mesh input: the real models load with their documented counts, and every kind of bad
// input ends in skelform::bake::Error with a message naming the problem, never a crash.
#include "skelform/bake/input.h"
#include "skelform/bake/weld.h"

#include "test_support.h"

#include <doctest/doctest.h>

#include <chrono>
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

void check_rejected(const std::string& file_name, const std::string& text, ErrorKind kind,
                    const std::string& substring, const LoadOptions& options = {}) {
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
  check_rejected("index_high.obj", tri + "f 1 2 4\n", ErrorKind::invalid_input, "index_high.obj:4: face index 4 out of range");
  check_rejected("index_low.obj", tri + "f -1 -2 -4\n", ErrorKind::invalid_input, "index_low.obj:4: face index -4 out of range");
  check_rejected("index_zero.obj", tri + "f 0 1 2\n", ErrorKind::invalid_input, "face index 0");
  check_rejected("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", ErrorKind::invalid_input, "nan.obj:2: non-finite");
  check_rejected("inf.obj", "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n", ErrorKind::invalid_input, "inf.obj:3: non-finite");
  check_rejected("overflow.obj", "v 0 0 1e999\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", ErrorKind::invalid_input, "overflow.obj:1:");
  check_rejected("short_vertex.obj", "v 0 0\n", ErrorKind::invalid_input, "short_vertex.obj:1: vertex has fewer than 3");
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

TEST_CASE("input: hand_closed.obj loads 7,993 vertices, 15,982 triangles, quickly") {
  SKELFORM_REQUIRE_DATA(path, "hand/hand_closed.obj");
  const auto start = std::chrono::steady_clock::now();
  const InputMesh mesh = load_mesh(path.string());
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  MESSAGE("hand_closed.obj loaded in " << ms << " ms");
  CHECK(mesh.positions.size() == 7993);
  CHECK(mesh.triangles.size() == 15982);
  const WeldedMesh welded = weld(mesh);
  CHECK(welded.mesh.positions.size() == 7993);
  CHECK(welded.mesh.triangles.size() == 15982);
#if defined(NDEBUG) && !defined(__SANITIZE_ADDRESS__)
  CHECK(ms < 50.0);
#else
  CHECK(ms < 1000.0);  // unoptimised or instrumented builds: only catch pathological slowness
#endif
}
