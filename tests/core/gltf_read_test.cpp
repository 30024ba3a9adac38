// The validated glTF reader both the runtime and the baker use (skelform/core/gltf_read.h):
// accessors read through interleaved and normalized views, and refused with a message naming
// the accessor when their layout is wrong. Its use on whole files is tested through the
// runtime's loader (tests/runtime/asset_test.cpp, hostile_input_test.cpp) and the baker's
// (tests/bake/input_test.cpp).
#include "skelform/core/gltf_read.h"

#include <doctest/doctest.h>
#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>
#include <tiny_gltf.h>

#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

namespace {

// Whether `read` threw the reader's error, and its message.
struct Refusal {
  bool refused = false;
  std::string message;
};

Refusal refusal_of(const std::function<void()>& read) {
  Refusal r;
  try {
    read();
  } catch (const skelform::gltf::GltfError& e) {
    r.refused = true;
    r.message = e.what();
  }
  return r;
}

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

}  // namespace

TEST_CASE("gltf reader: interleaved joints, normalized weights and matrices are read and checked") {
  // One bufferView, stride 24: JOINTS_0 as 4 UNSIGNED_BYTE at 0, WEIGHTS_0 as 4 normalized
  // UNSIGNED_SHORT at 4, 12 bytes of something else; then an inverse-bind MAT4 view.
  tinygltf::Model model;
  model.buffers.resize(1);
  std::vector<unsigned char>& data = model.buffers[0].data;
  for (int vertex = 0; vertex < 2; ++vertex) {
    const unsigned char joints[4] = {static_cast<unsigned char>(vertex), 3, 0, 200};
    const uint16_t weights[4] = {65535, 0, 0, static_cast<uint16_t>(vertex * 32768)};
    data.insert(data.end(), joints, joints + 4);
    for (uint16_t w : weights) {
      data.push_back(static_cast<unsigned char>(w & 0xff));
      data.push_back(static_cast<unsigned char>(w >> 8));
    }
    data.resize(data.size() + 12, 0xAB);
  }
  std::vector<float> matrix(16, 0.0f);
  for (int i = 0; i < 4; ++i) matrix[static_cast<size_t>(5 * i)] = 2.0f;
  matrix[12] = 7.0f;  // translation x: column 3, row 0 in glTF's column-major order
  const size_t matrix_offset = data.size();
  data.resize(matrix_offset + 64);
  std::memcpy(data.data() + matrix_offset, matrix.data(), 64);

  tinygltf::BufferView interleaved;
  interleaved.buffer = 0;
  interleaved.byteLength = 48;
  interleaved.byteStride = 24;
  tinygltf::BufferView matrices;
  matrices.buffer = 0;
  matrices.byteOffset = matrix_offset;
  matrices.byteLength = 64;
  model.bufferViews = {interleaved, matrices};
  tinygltf::Accessor joints;
  joints.bufferView = 0;
  joints.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
  joints.type = TINYGLTF_TYPE_VEC4;
  joints.count = 2;
  tinygltf::Accessor weights = joints;
  weights.byteOffset = 4;
  weights.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
  weights.normalized = true;
  tinygltf::Accessor inverse_bind;
  inverse_bind.bufferView = 1;
  inverse_bind.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  inverse_bind.type = TINYGLTF_TYPE_MAT4;
  inverse_bind.count = 1;
  model.accessors = {joints, weights, inverse_bind};

  const std::vector<glm::uvec4> j = skelform::gltf::read_joints(model, 0, "test JOINTS_0");
  REQUIRE(j.size() == 2);
  CHECK(j[1] == glm::uvec4(1, 3, 0, 200));
  const std::vector<glm::dvec4> w = skelform::gltf::read_weights(model, 1, "test WEIGHTS_0");
  REQUIRE(w.size() == 2);
  CHECK(w[0] == glm::dvec4(1, 0, 0, 0));
  CHECK(w[1].w == doctest::Approx(32768.0 / 65535.0));
  const std::vector<glm::dmat4> m = skelform::gltf::read_mat4(model, 2, "test inverseBindMatrices");
  REQUIRE(m.size() == 1);
  CHECK(m[0][3][0] == 7.0);
  CHECK(m[0][1][1] == 2.0);
  CHECK(skelform::gltf::accessor_count(model, 1, "test") == 2);

  // Weights stored as integers must be normalized; joints must not be.
  model.accessors[1].normalized = false;
  const Refusal unnormalized = refusal_of([&] { skelform::gltf::read_weights(model, 1, "test WEIGHTS_0"); });
  CHECK(unnormalized.refused);
  CHECK(contains(unnormalized.message, "test WEIGHTS_0: accessor 1"));
  // A stride shorter than the element is refused.
  model.bufferViews[0].byteStride = 2;
  const Refusal short_stride = refusal_of([&] { skelform::gltf::read_joints(model, 0, "test JOINTS_0"); });
  CHECK(short_stride.refused);
  CHECK(contains(short_stride.message, "byteStride 2"));
  // Joints read as weights through a too-short view: the third element would end past it.
  model.bufferViews[0].byteStride = 24;
  model.accessors[0].count = 3;
  const Refusal past_end = refusal_of([&] { skelform::gltf::read_joints(model, 0, "test JOINTS_0"); });
  CHECK(past_end.refused);
  CHECK(contains(past_end.message, "runs past the end of bufferView 0"));
}
