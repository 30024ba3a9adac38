// tests/data/capsule.skf.glb is the runtime tests' capsule (tests/capsule_glb.h) baked ahead of
// time, for runtime-only builds (tests/data/README.md). This checks that it still is what the
// baker makes of that capsule today: the same original data, and the runtime's output on the
// committed file within 1e-6 of the diagonal of its output on a fresh bake, at rest and bent,
// with every method. When the baker changes on purpose,
//   SKELFORM_UPDATE_FIXTURES=1 ctest --test-dir build -R data/capsule_fixture
// writes the fresh bake over the committed file (review and commit it).
#include "runtime/runtime_models.h"

#include <cstdlib>
#include <fstream>

namespace {

using skelform::test::Evaluated;
using skelform::test::RuntimeModel;

double largest_distance(const Evaluated& a, const Evaluated& b) {
  double worst = 0;
  for (size_t v = 0; v < a.positions.size(); ++v)
    worst = std::max(worst, double(glm::length(a.positions[v] - b.positions[v])));
  return worst;
}

Evaluated evaluate(const RuntimeModel& model, const std::vector<glm::mat4>& pose, sf_method method) {
  skelform::test::InstancePtr instance(model.asset);
  REQUIRE(sf_instance_set_joint_matrices(instance, &pose[0][0][0], pose.size(), 0) == SF_OK);
  sf_eval_options options{};
  options.method = uint32_t(method);
  REQUIRE(sf_instance_evaluate(instance, &options) == SF_OK);
  return skelform::test::write_all(instance, model.asset);
}

}  // namespace

TEST_CASE("capsule fixture: tests/data/capsule.skf.glb is the capsule as the baker bakes it today") {
  const RuntimeModel& fresh = skelform::test::capsule_model();
  const std::filesystem::path committed_path =
      std::filesystem::path(SKELFORM_SOURCE_DIR) / "tests/data/capsule.skf.glb";
  if (const char* update = std::getenv("SKELFORM_UPDATE_FIXTURES"); update && std::string(update) == "1") {
    std::ofstream out(committed_path, std::ios::binary);
    out.write(fresh.baked_glb.data(), std::streamsize(fresh.baked_glb.size()));
    REQUIRE_MESSAGE(out.flush(), "cannot write " << committed_path);
    MESSAGE("wrote " << committed_path);
  }
  const std::unique_ptr<RuntimeModel> committed = skelform::test::detail::load_capsule_fixture();

  // The same source model: the baked file keeps its input's accessors.
  REQUIRE(committed->primitives.size() == fresh.primitives.size());
  for (size_t p = 0; p < fresh.primitives.size(); ++p) {
    CHECK(committed->primitives[p].positions == fresh.primitives[p].positions);
    CHECK(committed->primitives[p].normals == fresh.primitives[p].normals);
    CHECK(committed->primitives[p].tangents == fresh.primitives[p].tangents);
    CHECK(committed->primitives[p].joints == fresh.primitives[p].joints);
    CHECK(committed->primitives[p].weights == fresh.primitives[p].weights);
  }
  CHECK(committed->inverse_bind == fresh.inverse_bind);

  // The same deformation.
  const std::vector<glm::mat4> rest(fresh.inverse_bind.size(), glm::mat4(1.0f));
  const std::vector<glm::mat4> bent = skelform::test::bend_pose(fresh, 1, 1.2f, glm::vec3(1.0f, 0.0f, 0.0f));
  for (sf_method method : {SF_METHOD_SKELFORM, SF_METHOD_LBS, SF_METHOD_DQS}) {
    for (const std::vector<glm::mat4>* pose : {&rest, &bent}) {
      CAPTURE(int(method));
      CAPTURE(pose == &bent);
      const double distance = largest_distance(evaluate(*committed, *pose, method), evaluate(fresh, *pose, method));
      CHECK_MESSAGE(distance <= 1e-6 * fresh.diagonal,
                    "tests/data/capsule.skf.glb no longer matches the baker's capsule: if the baker changed on "
                    "purpose, regenerate it (SKELFORM_UPDATE_FIXTURES=1, see this file)");
    }
  }
}
