// sf_instance_write into caller-owned strided buffers (skelform.h sf_vertex_output), tested
// the meshoptimizer way: every buffer is a heap block of exactly the bytes the description
// covers ((count − 1)·stride + element), so an ASan build catches any write past it, and the
// gap bytes of a wide stride are checked untouched. Strides larger than the element and not
// multiples of 4 (unaligned floats), capacity one short, NULL streams skipped, tangents only
// where authored, SF_EVAL_SKIP_NORMALS leaving normal streams alone.
#include "runtime/runtime_models.h"

#include <cstring>
#include <memory>

namespace {

constexpr unsigned char kSentinel = 0xA5;

// A heap block of exactly `size` bytes, filled with the sentinel.
struct Block {
  std::unique_ptr<unsigned char[]> bytes;
  size_t size;
  explicit Block(size_t n) : bytes(new unsigned char[n ? n : 1]), size(n) { std::memset(bytes.get(), kSentinel, n); }
  float* floats() { return reinterpret_cast<float*>(bytes.get()); }
};

size_t exact_size(size_t count, size_t stride, size_t element) { return count ? (count - 1) * stride + element : 0; }

// Element i of a strided stream equals `expected` (floats compared bitwise) and every gap byte
// still holds the sentinel.
bool stream_matches(const Block& block, size_t count, size_t stride, size_t element, const float* expected) {
  for (size_t i = 0; i < count; ++i) {
    if (std::memcmp(block.bytes.get() + i * stride, expected + i * (element / 4), element) != 0) return false;
    if (i + 1 < count)
      for (size_t b = element; b < stride; ++b)
        if (block.bytes[i * stride + b] != kSentinel) return false;
  }
  return true;
}

bool untouched(const Block& block) {
  for (size_t b = 0; b < block.size; ++b)
    if (block.bytes[b] != kSentinel) return false;
  return true;
}

struct Posed {
  sf_instance* instance = nullptr;
  skelform::test::Evaluated packed;  // the tightly packed reference output
  ~Posed() { sf_instance_destroy(instance); }
};

// The capsule bent at its child joint, evaluated with skelform; `packed` written with stride 0.
void make_posed(Posed& posed) {
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  REQUIRE(sf_instance_create(model.asset, 0, &posed.instance) == SF_OK);
  const std::vector<glm::mat4> pose = skelform::test::bend_pose(model, 1, 0.7f, glm::vec3(0, 1, 0));
  REQUIRE(sf_instance_set_joint_matrices(posed.instance, &pose[0][0][0], pose.size(), 0) == SF_OK);
  REQUIRE(sf_instance_evaluate(posed.instance, nullptr) == SF_OK);
  posed.packed = skelform::test::write_all(posed.instance, model.asset);
}

}  // namespace

TEST_CASE("output: exact-size buffers at every stride get exactly the packed values with gaps untouched") {
  Posed posed;
  make_posed(posed);
  const sf_asset* asset = skelform::test::capsule_model().asset;
  sf_primitive_info info{};
  REQUIRE(sf_asset_primitive_info(asset, 0, 0, &info) == SF_OK);
  REQUIRE(info.has_tangents == 1);
  const size_t n = info.vertex_count;
  const float* positions = &posed.packed.positions[info.first_vertex].x;
  const float* normals = &posed.packed.normals[info.first_vertex].x;
  const float* tangents = &posed.packed.tangents[info.first_vertex].x;
  for (const size_t stride :
       {size_t(0), size_t(12), size_t(13), size_t(16), size_t(17), size_t(20), size_t(32), size_t(48)}) {
    const size_t position_stride = stride ? stride : 12;
    const size_t tangent_stride = stride == 0 ? 16 : std::max<size_t>(stride, 16) + (stride == 13 ? 1 : 0);
    Block p(exact_size(n, position_stride, 12)), nb(exact_size(n, position_stride, 12)),
        t(exact_size(n, tangent_stride, 16));
    sf_vertex_output o{};
    o.positions = p.floats();
    o.position_stride = stride;
    o.normals = nb.floats();
    o.normal_stride = stride;
    o.tangents = t.floats();
    o.tangent_stride = stride == 0 ? 0 : tangent_stride;
    o.vertex_capacity = n;
    INFO("stride " << stride);
    REQUIRE(sf_instance_write(posed.instance, 0, &o) == SF_OK);
    CHECK(stream_matches(p, n, position_stride, 12, positions));
    CHECK(stream_matches(nb, n, position_stride, 12, normals));
    CHECK(stream_matches(t, n, tangent_stride, 16, tangents));
  }
}

TEST_CASE("output: capacity one short or strides below the element or missing tangents are refused untouched") {
  Posed posed;
  make_posed(posed);
  const sf_asset* asset = skelform::test::capsule_model().asset;
  sf_primitive_info info{};
  REQUIRE(sf_asset_primitive_info(asset, 0, 0, &info) == SF_OK);
  const size_t n = info.vertex_count;
  Block p(n * 12), nb(n * 12), t(n * 16);
  sf_vertex_output o{};
  o.positions = p.floats();
  o.normals = nb.floats();
  o.tangents = t.floats();
  o.vertex_capacity = n - 1;
  CHECK(sf_instance_write(posed.instance, 0, &o) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(std::string(sf_instance_last_error(posed.instance)).find("capacity") != std::string::npos);
  o.vertex_capacity = n;
  o.position_stride = 8;
  CHECK(sf_instance_write(posed.instance, 0, &o) == SF_ERROR_INVALID_ARGUMENT);
  o.position_stride = 0;
  o.tangent_stride = 12;
  CHECK(sf_instance_write(posed.instance, 0, &o) == SF_ERROR_INVALID_ARGUMENT);
  o.tangent_stride = 0;
  o.normal_stride = 11;
  CHECK(sf_instance_write(posed.instance, 0, &o) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(untouched(p));
  CHECK(untouched(nb));
  CHECK(untouched(t));

  // Primitive 1 (the sphere) has no authored tangents: asking for them is unsupported, and
  // nothing is written, not even the positions.
  sf_primitive_info sphere{};
  REQUIRE(sf_asset_primitive_info(asset, 0, 1, &sphere) == SF_OK);
  REQUIRE(sphere.has_tangents == 0);
  REQUIRE(sphere.has_normals == 0);
  Block sp(sphere.vertex_count * 12), st(sphere.vertex_count * 16);
  sf_vertex_output so{};
  so.positions = sp.floats();
  so.tangents = st.floats();
  so.vertex_capacity = sphere.vertex_count;
  CHECK(sf_instance_write(posed.instance, 1, &so) == SF_ERROR_UNSUPPORTED);
  CHECK(untouched(sp));
  CHECK(untouched(st));
}

TEST_CASE(
    "output: NULL streams are skipped and normals of a primitive without authored normals are computed and unit") {
  Posed posed;
  make_posed(posed);
  const sf_asset* asset = skelform::test::capsule_model().asset;
  for (uint32_t primitive = 0; primitive < 2; ++primitive) {
    sf_primitive_info info{};
    REQUIRE(sf_asset_primitive_info(asset, 0, primitive, &info) == SF_OK);
    const size_t n = info.vertex_count;
    Block nb(n * 12);
    sf_vertex_output o{};
    o.normals = nb.floats();
    o.vertex_capacity = n;
    REQUIRE(sf_instance_write(posed.instance, primitive, &o) == SF_OK);
    CHECK(stream_matches(nb, n, 12, 12, &posed.packed.normals[info.first_vertex].x));
    bool unit = true;
    for (size_t i = 0; i < n; ++i)
      unit = unit && std::abs(glm::length(posed.packed.normals[info.first_vertex + i]) - 1.0f) < 1e-4f;
    CHECK(unit);
    sf_vertex_output nothing{};
    nothing.vertex_capacity = n;
    CHECK(sf_instance_write(posed.instance, primitive, &nothing) == SF_OK);
  }
}

TEST_CASE("output: after SF_EVAL_SKIP_NORMALS positions are written and normal/tangent streams are left alone") {
  Posed posed;
  make_posed(posed);
  const sf_asset* asset = skelform::test::capsule_model().asset;
  // From rest twice, the second without normals: an evaluation from rest depends on its input
  // only, so the positions are the first one's bits again.
  sf_eval_options options{};
  options.flags = SF_EVAL_FROM_REST;
  REQUIRE(sf_instance_evaluate(posed.instance, &options) == SF_OK);
  posed.packed = skelform::test::write_all(posed.instance, asset);
  options.flags = SF_EVAL_SKIP_NORMALS | SF_EVAL_FROM_REST;
  REQUIRE(sf_instance_evaluate(posed.instance, &options) == SF_OK);
  sf_primitive_info info{};
  REQUIRE(sf_asset_primitive_info(asset, 0, 0, &info) == SF_OK);
  const size_t n = info.vertex_count;
  Block p(n * 12), nb(n * 12), t(n * 16);
  sf_vertex_output o{};
  o.positions = p.floats();
  o.normals = nb.floats();
  o.tangents = t.floats();
  o.vertex_capacity = n;
  REQUIRE(sf_instance_write(posed.instance, 0, &o) == SF_OK);
  CHECK(stream_matches(p, n, 12, 12, &posed.packed.positions[info.first_vertex].x));
  CHECK(untouched(nb));
  CHECK(untouched(t));
}

TEST_CASE("output: the coarse meshes are the control and skeletal meshes of the last skelform evaluation") {
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model.asset, 0, &info) == SF_OK);
  REQUIRE(info.control_triangle_count > 0);
  std::vector<uint32_t> triangles(size_t(info.control_triangle_count) * 3, 0xffffffffu);
  CHECK(sf_asset_control_triangles(model.asset, 0, triangles.data(), triangles.size() - 1) ==
        SF_ERROR_INVALID_ARGUMENT);
  REQUIRE(sf_asset_control_triangles(model.asset, 0, triangles.data(), triangles.size()) == SF_OK);
  for (uint32_t index : triangles) CHECK(index < info.control_vertex_count);

  sf_instance* instance = nullptr;
  REQUIRE(sf_instance_create(model.asset, 0, &instance) == SF_OK);
  const size_t n = info.control_vertex_count, stride = 20;
  Block control(exact_size(n, stride, 12)), skeletal(exact_size(n, stride, 12));
  CHECK(sf_instance_write_coarse(instance, SF_COARSE_CONTROL, control.floats(), stride, n) == SF_ERROR_NOT_READY);
  // At rest the control mesh is the surface and the skeletal mesh lies strictly inside it,
  // at each vertex's medial radius: |M − S'| > 0 for every vertex of the closed capsule.
  REQUIRE(sf_instance_evaluate(instance, nullptr) == SF_OK);
  CHECK(sf_instance_write_coarse(instance, SF_COARSE_CONTROL, control.floats(), stride, n - 1) ==
        SF_ERROR_INVALID_ARGUMENT);
  CHECK(sf_instance_write_coarse(instance, 7, control.floats(), stride, n) == SF_ERROR_INVALID_ARGUMENT);
  CHECK(untouched(control));
  REQUIRE(sf_instance_write_coarse(instance, SF_COARSE_CONTROL, control.floats(), stride, n) == SF_OK);
  REQUIRE(sf_instance_write_coarse(instance, SF_COARSE_SKELETAL, skeletal.floats(), stride, n) == SF_OK);
  size_t inside = 0;
  for (size_t i = 0; i < n; ++i) {
    glm::vec3 m, s;
    std::memcpy(&m, control.bytes.get() + i * stride, 12);
    std::memcpy(&s, skeletal.bytes.get() + i * stride, 12);
    if (glm::length(m - s) > 1e-4 * model.diagonal) ++inside;
    if (i + 1 < n) CHECK(control.bytes[i * stride + 12] == kSentinel);
  }
  CHECK(inside == n);
  sf_instance_destroy(instance);
}
