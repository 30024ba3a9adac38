// SF_METHOD_LBS's kernels (runtime/src/dense_skinning.cpp): SSE2 and AVX2 (when this build
// and CPU have them) give the portable loop's floats bit for bit, positions, normals and
// tangents, on the capsule (authored tangents, a primitive without) and the Khronos samples,
// under random similarity poses, non-uniform scale and shear, and joints collapsed to a point
// (whose normals fall back to the rest normal). The kernel the runtime picks is one of them.
#include "instance.h"
#include "runtime/runtime_models.h"

#include <doctest/doctest.h>
#include <glm/gtc/matrix_transform.hpp>

#include <cstring>
#include <random>
#include <string>
#include <vector>

namespace {

using skelform::runtime::Blend;
using skelform::runtime::DenseOutput;
using skelform::runtime::LinearKernel;

struct Output {
  explicit Output(size_t n)
      : positions(n, glm::vec3(7.0f)), normals(n, glm::vec3(7.0f)), tangents(n, glm::vec4(7.0f)) {}
  DenseOutput view() { return {positions.data(), normals.data(), tangents.data()}; }
  bool operator==(const Output& o) const {
    return std::memcmp(positions.data(), o.positions.data(), positions.size() * sizeof(glm::vec3)) == 0 &&
           std::memcmp(normals.data(), o.normals.data(), normals.size() * sizeof(glm::vec3)) == 0 &&
           std::memcmp(tangents.data(), o.tangents.data(), tangents.size() * sizeof(glm::vec4)) == 0;
  }
  std::vector<glm::vec3> positions, normals;
  std::vector<glm::vec4> tangents;
};

// Per joint: a random rotation and translation, times a uniform scale (kind 0), a
// non-uniform scale with shear (kind 1), or every second joint collapsed to a point (kind 2).
std::vector<glm::mat4> random_pose(size_t joints, int kind, std::mt19937& random) {
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), scale(0.5f, 2.0f);
  std::vector<glm::mat4> pose(joints);
  for (size_t j = 0; j < joints; ++j) {
    const glm::vec3 axis = glm::normalize(glm::vec3(unit(random), unit(random), unit(random)) + glm::vec3(0, 0, 1e-3f));
    glm::mat4 m = glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(unit(random), unit(random), unit(random))),
                              3.0f * unit(random), axis);
    if (kind == 0) m = glm::scale(m, glm::vec3(scale(random)));
    if (kind == 1) {
      m = glm::scale(m, glm::vec3(scale(random), scale(random), scale(random)));
      m[1][0] += 0.3f * unit(random);  // shear
    }
    if (kind == 2 && j % 2 == 1) m = glm::mat4(glm::vec4(0.0f), glm::vec4(0.0f), glm::vec4(0.0f), m[3]);
    pose[j] = m;
  }
  return pose;
}

void check_kernels(const skelform::test::RuntimeModel& model) {
  INFO(model.name);
  sf_instance* instance = nullptr;
  REQUIRE(sf_instance_create(model.asset, 0, &instance) == SF_OK);
  const skelform::runtime::Deformable& d = *instance->deformable;
  REQUIRE(d.joint_count > 0);
  std::mt19937 random(20261127);
  for (int kind = 0; kind < 3; ++kind)
    for (int trial = 0; trial < 3; ++trial) {
      CAPTURE(kind);
      const std::vector<glm::mat4> pose = random_pose(d.joint_count, kind, random);
      REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0) == SF_OK);
      for (bool with_normals : {true, false}) {
        Output portable(d.vertex_count);
        skelform::runtime::dense_skinning_linear(d, instance->joints, LinearKernel::portable, with_normals,
                                                 portable.view());
        for (LinearKernel kernel : {LinearKernel::sse2, LinearKernel::avx2}) {
          if (!skelform::runtime::linear_kernel_available(kernel)) continue;
          CAPTURE(int(kernel));
          Output out(d.vertex_count);
          skelform::runtime::dense_skinning_linear(d, instance->joints, kernel, with_normals, out.view());
          CHECK(out == portable);
        }
        Output chosen(d.vertex_count);
        skelform::runtime::dense_skinning(d, instance->joints, Blend::linear, with_normals, chosen.view());
        CHECK(chosen == portable);
      }
    }
  sf_instance_destroy(instance);
}

}  // namespace

TEST_CASE("dense skinning: every LBS kernel gives the portable loop's bits") {
  MESSAGE("kernels compared with the portable loop: "
          << (skelform::runtime::linear_kernel_available(LinearKernel::sse2) ? "sse2 " : "")
          << (skelform::runtime::linear_kernel_available(LinearKernel::avx2) ? "avx2" : "(no avx2 on this CPU/build)"));
  check_kernels(skelform::test::capsule_model());
  for (const std::string& name : skelform::test::sample_names())
    if (const skelform::test::RuntimeModel* model = skelform::test::sample_model(name)) check_kernels(*model);
}
