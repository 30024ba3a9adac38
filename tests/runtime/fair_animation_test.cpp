// The fairing through the C API on real animations (the fairing issue: "every animation of
// CesiumMan, RiggedFigure and Fox sampled at 30 fps in incremental mode"): per frame, the
// dense mesh's intersecting non-adjacent triangle pairs with skelform never exceed LBS's, and
// on closed models skelform's mean volume change is at most LBS's (below it over a model); the same with the contact
// pass on (sf_instance_set_contacts), which moreover never adds a pair to the frame it gets.
// Also: a held pose stops moving (jitter) and the same pose sequence gives the same bits.
#include "gltf_animation.h"
#include "mesh_checks.h"
#include "runtime/runtime_models.h"
#include "runtime/welded_surface.h"
#include "skelform/bake/metrics.h"
#include "skelform/bake/self_intersection.h"

#include <cmath>
#include <cstring>
#include <map>
#include <sstream>
#include <tuple>

namespace {

using skelform::bake::TriangleMesh;
using skelform::bake::Vec3;

using Instance = skelform::test::InstancePtr;

// What check_animations() asserts: the per-frame intersection bound, or the mean volume change.
enum class Property { intersections, volume };

// With `contacts`, the skelform instance has the contact pass on, and a second instance
// without it, fed the same frames, shows what the pass got.
void check_animations(const char* relative, Property property, bool contacts = false) {
  const skelform::test::RuntimeModel* model = skelform::test::sample_model(relative);
  if (!model) return;
  const skelform::samples::GltfAnimation gltf =
      skelform::samples::GltfAnimation::load_file(skelform::test::data_file(relative).string());
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model->asset, 0, &info) == SF_OK);
  const skelform::test::WeldedSurface surface = skelform::test::welded_surface(*model, gltf);
  REQUIRE(!gltf.animations().empty());

  double model_skelform_volume = 0, model_lbs_volume = 0;
  for (size_t a = 0; a < gltf.animations().size(); ++a) {
    const skelform::samples::AnimationInfo& anim = gltf.animations()[a];
    Instance skelform(model->asset), lbs(model->asset), plain(model->asset);
    // The pass is on by default: `plain`, and `skelform` without `contacts`, turn it off.
    REQUIRE(sf_instance_set_contacts(skelform.instance, contacts ? 1 : 0) == SF_OK);
    REQUIRE(sf_instance_set_contacts(plain.instance, 0) == SF_OK);
    size_t added_frames = 0, plain_pairs = 0;
    sf_eval_options lbs_options{};
    lbs_options.method = SF_METHOD_LBS;
    const int frames = int(std::floor(anim.duration() * 30.0 + 1e-9)) + 1;
    size_t worse_frames = 0, lbs_pairs = 0, skelform_pairs = 0, max_excess = 0;
    double lbs_volume = 0, skelform_volume = 0;
    uint32_t iterations = 0;
    for (int k = 0; k < frames; ++k) {
      const std::vector<float> joints = gltf.joint_matrices(size_t(info.skin), a, anim.start + k / 30.0);
      REQUIRE(sf_instance_set_joint_matrices(skelform.instance, joints.data(), info.joint_count, 0) == SF_OK);
      REQUIRE(sf_instance_set_joint_matrices(lbs.instance, joints.data(), info.joint_count, 0) == SF_OK);
      sf_eval_options options{};
      if (k == 0) options.flags = SF_EVAL_FROM_REST;
      REQUIRE(sf_instance_evaluate(skelform.instance, &options) == SF_OK);
      REQUIRE(sf_instance_evaluate(lbs.instance, &lbs_options) == SF_OK);
      if (contacts) {
        REQUIRE(sf_instance_set_joint_matrices(plain.instance, joints.data(), info.joint_count, 0) == SF_OK);
        REQUIRE(sf_instance_evaluate(plain.instance, &options) == SF_OK);
      }
      uint32_t it = 0;
      sf_instance_fairing_stats(skelform.instance, &it, nullptr);
      iterations += it;
      const TriangleMesh s =
          skelform::test::posed(surface, skelform::test::write_all(skelform.instance, model->asset).positions);
      const TriangleMesh l =
          skelform::test::posed(surface, skelform::test::write_all(lbs.instance, model->asset).positions);
      // Counting intersecting pairs is the slow part; the volume check does without it.
      const bool count = property == Property::intersections;
      const size_t sp = count ? skelform::bake::count_self_intersections(s) : 0;
      const size_t lp = count ? skelform::bake::count_self_intersections(l) : 0;
      skelform_pairs += sp;
      lbs_pairs += lp;
      if (contacts && count) {
        const size_t pp = skelform::bake::count_self_intersections(
            skelform::test::posed(surface, skelform::test::write_all(plain.instance, model->asset).positions));
        plain_pairs += pp;
        if (sp > pp) ++added_frames;
      }
      if (sp > lp) {
        ++worse_frames;
        max_excess = std::max(max_excess, sp - lp);
      }
      if (surface.closed) {
        skelform_volume += std::fabs(skelform::bake::enclosed_volume(s) / surface.rest_volume - 1.0);
        lbs_volume += std::fabs(skelform::bake::enclosed_volume(l) / surface.rest_volume - 1.0);
      }
    }
    std::ostringstream report;
    report << relative << " '" << anim.name << "' " << frames << " frames" << (contacts ? " (contact pass on)" : "")
           << ": ";
    if (property == Property::intersections) {
      report << "intersecting pairs skelform " << skelform_pairs << " / LBS " << lbs_pairs
             << " (sum over frames), frames where skelform > LBS: " << worse_frames << " (by at most " << max_excess
             << ")";
      if (contacts)
        report << "; without the pass " << plain_pairs
               << " pairs, frames with more pairs than without: " << added_frames;
    } else if (surface.closed)
      report << "mean |volume change| skelform " << 100 * skelform_volume / frames << " % / LBS "
             << 100 * lbs_volume / frames << " %";
    else
      report << "not closed: volume not compared";
    report << "; fairing iterations " << double(iterations) / frames << " per frame";
    MESSAGE(report.str());
    if (property == Property::intersections) CHECK(worse_frames == 0);
    // The pass works on the blended output before the guard (lbs_guard.h): whatever it
    // moves, the output keeps within LBS's pairs (above), and over an animation it has fewer
    // pairs than without it.
    if (contacts && property == Property::intersections) CHECK(skelform_pairs <= plain_pairs);
    // Per animation, the contract (lbs_guard.h: frame by frame, never further from the rest
    // volume than LBS); over a model's animations, an improvement.
    if (property == Property::volume && surface.closed) CHECK(skelform_volume <= lbs_volume);
    model_skelform_volume += skelform_volume;
    model_lbs_volume += lbs_volume;
  }
  if (property == Property::volume && surface.closed) CHECK(model_skelform_volume < model_lbs_volume);
}

}  // namespace

// On the closed models, skelform's mean |volume change| is no more than LBS's on every
// animation (the volume guard's contract), and below it over all of a model's animations.
TEST_CASE("fair animation: CesiumMan at 30 fps - skelform loses less volume than LBS") {
  check_animations("CesiumMan/CesiumMan.glb", Property::volume);
}
TEST_CASE("fair animation: RiggedFigure at 30 fps - skelform loses less volume than LBS") {
  check_animations("RiggedFigure/RiggedFigure.glb", Property::volume);
}
TEST_CASE("fair animation: Fox at 30 fps - skelform loses less volume than LBS") {
  check_animations("Fox/Fox.glb", Property::volume);
}

// The intersection target, on every animation of the three models. Fox 'Run' was the
// last one over (frame 22: 7 pairs, LBS 4, where the top of a front leg meets the chest): the
// dense vertices were displaced along the faired control mesh's normals, which the flows tilt
// there. They are now displaced along the bisector of those normals and the medial direction
// M − S (dss_frame.h medial_normal_sums, extension 2.1): Fox 'Run' 219 pairs, no frame over.
TEST_CASE("fair animation: CesiumMan at 30 fps - skelform never intersects more than LBS") {
  check_animations("CesiumMan/CesiumMan.glb", Property::intersections);
}
TEST_CASE("fair animation: RiggedFigure at 30 fps - skelform never intersects more than LBS") {
  check_animations("RiggedFigure/RiggedFigure.glb", Property::intersections);
}
TEST_CASE("fair animation: Fox at 30 fps - skelform never intersects more than LBS") {
  check_animations("Fox/Fox.glb", Property::intersections);
}

// The same targets with the contact pass on (off by default: it costs a broad phase over the
// dense mesh every frame, see skelform.h): the intersection bound holds on all three models,
// the pass leaves fewer pairs than its absence over each animation, and the volume stays
// below LBS's.
TEST_CASE(
    "fair animation with the contact pass: CesiumMan - never more pairs than LBS, fewer than without it, less volume "
    "lost") {
  check_animations("CesiumMan/CesiumMan.glb", Property::intersections, true);
  check_animations("CesiumMan/CesiumMan.glb", Property::volume, true);
}
TEST_CASE(
    "fair animation with the contact pass: RiggedFigure - never more pairs than LBS, fewer than without it, less "
    "volume lost") {
  check_animations("RiggedFigure/RiggedFigure.glb", Property::intersections, true);
  check_animations("RiggedFigure/RiggedFigure.glb", Property::volume, true);
}
TEST_CASE(
    "fair animation with the contact pass: Fox - never more pairs than LBS, fewer than without it, less volume lost") {
  check_animations("Fox/Fox.glb", Property::intersections, true);
  check_animations("Fox/Fox.glb", Property::volume, true);
}

namespace {

// Max vertex motion between consecutive incremental evaluations of a held pose, after
// `warm_up` evaluations, over `measured` more; / the bounding-box diagonal. `contacts`: with
// the contact pass on.
double held_pose_jitter(const skelform::test::RuntimeModel& model, const std::vector<float>& joints, int warm_up,
                        int measured, bool contacts = false) {
  Instance held(model.asset);
  REQUIRE(sf_instance_set_contacts(held.instance, contacts ? 1 : 0) == SF_OK);
  REQUIRE(sf_instance_set_joint_matrices(held.instance, joints.data(), model.inverse_bind.size(), 0) == SF_OK);
  std::vector<glm::vec3> previous;
  double jitter = 0.0;
  for (int k = 0; k < warm_up + measured; ++k) {
    REQUIRE(sf_instance_evaluate(held.instance, nullptr) == SF_OK);
    const std::vector<glm::vec3> now = skelform::test::write_all(held.instance, model.asset).positions;
    if (k > warm_up)
      for (size_t v = 0; v < now.size(); ++v) jitter = std::max(jitter, double(glm::length(now[v] - previous[v])));
    previous = now;
  }
  return jitter / model.diagonal;
}

// Two instances fed the same pose sequence give the same bits, frame by frame.
bool repeatable(const skelform::test::RuntimeModel& model, const std::vector<std::vector<float>>& poses) {
  Instance a(model.asset), b(model.asset);
  for (const std::vector<float>& joints : poses) {
    for (sf_instance* i : {a.instance, b.instance}) {
      REQUIRE(sf_instance_set_joint_matrices(i, joints.data(), model.inverse_bind.size(), 0) == SF_OK);
      REQUIRE(sf_instance_evaluate(i, nullptr) == SF_OK);
    }
    const skelform::test::Evaluated x = skelform::test::write_all(a.instance, model.asset);
    const skelform::test::Evaluated y = skelform::test::write_all(b.instance, model.asset);
    if (std::memcmp(x.positions.data(), y.positions.data(), x.positions.size() * sizeof(glm::vec3)) != 0 ||
        std::memcmp(x.normals.data(), y.normals.data(), x.normals.size() * sizeof(glm::vec3)) != 0)
      return false;
  }
  return true;
}

std::vector<float> flat(const std::vector<glm::mat4>& pose) {
  std::vector<float> out;
  for (const glm::mat4& m : pose) out.insert(out.end(), &m[0][0], &m[0][0] + 16);
  return out;
}

}  // namespace

TEST_CASE("fair animation: the capsule bent and held stops moving and the same poses give the same bits") {
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  std::vector<std::vector<float>> poses;
  for (int k = 0; k <= 20; ++k)
    poses.push_back(flat(skelform::test::bend_pose(model, 1, 0.08f * k, glm::vec3(0, 1, 0))));
  CHECK(repeatable(model, poses));
  const double jitter = held_pose_jitter(model, poses.back(), 30, 10);
  MESSAGE("capsule bent 1.6 rad and held: jitter " << jitter << " of the diagonal after 30 evaluations");
  CHECK(jitter < 1e-6);
}

TEST_CASE("fair animation: CesiumMan held mid-animation stops moving and its animation repeats bit for bit") {
  const char* relative = "CesiumMan/CesiumMan.glb";
  const skelform::test::RuntimeModel* model = skelform::test::sample_model(relative);
  if (!model) return;
  const skelform::samples::GltfAnimation gltf =
      skelform::samples::GltfAnimation::load_file(skelform::test::data_file(relative).string());
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model->asset, 0, &info) == SF_OK);
  const skelform::samples::AnimationInfo& anim = gltf.animations()[0];
  std::vector<std::vector<float>> poses;
  for (int k = 0; k < 30; ++k) poses.push_back(gltf.joint_matrices(size_t(info.skin), 0, anim.start + k / 30.0));
  CHECK(repeatable(*model, poses));
  const double jitter = held_pose_jitter(*model, poses.back(), 30, 10);
  MESSAGE("CesiumMan held at frame 29: jitter " << jitter << " of the diagonal after 30 evaluations");
  CHECK(jitter < 1e-6);
  // With the contact pass: the pass sees the same converged input every evaluation, so it
  // adds no motion of its own.
  const double with_contacts = held_pose_jitter(*model, poses.back(), 30, 10, true);
  MESSAGE("with the contact pass: jitter " << with_contacts << " of the diagonal");
  CHECK(with_contacts < 1e-6);
}

TEST_CASE("fair animation: one iteration per incremental evaluation by default; a pose jump or from_rest converges") {
  // The budget the C API documents (skelform.h sf_eval_options, docs/runtime-api.md
  // "Fairing"): fairing_iterations = 0 means 1 per incremental evaluation. The first evaluation
  // and a detected pose jump start a convergence of at most 32 iterations (or
  // fairing_iterations if larger): 16 in that evaluation, then a chunk of 8 in each next one
  // until it is done. SF_EVAL_FROM_REST runs the whole convergence in its evaluation.
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  Instance instance(model.asset);
  float angle = 0.0f;
  const auto set_bend = [&](float a) {
    angle = a;
    const std::vector<float> joints = flat(skelform::test::bend_pose(model, 1, angle, glm::vec3(0, 1, 0)));
    REQUIRE(sf_instance_set_joint_matrices(instance.instance, joints.data(), model.inverse_bind.size(), 0) == SF_OK);
  };
  const auto evaluate = [&](const sf_eval_options& options) {
    REQUIRE(sf_instance_evaluate(instance.instance, &options) == SF_OK);
    uint32_t iterations = 0;
    float residual = -1.0f;
    REQUIRE(sf_instance_fairing_stats(instance.instance, &iterations, &residual) == SF_OK);
    CHECK(std::isfinite(residual));
    return iterations;
  };
  const sf_eval_options defaults{};
  // A convergence begun by `first` iterations: the next frames of the motion (`step` apart)
  // go on with it, 8 at most each, then one iteration per evaluation. Returns the
  // convergence's iterations in all.
  const auto converge = [&](uint32_t first, float step) {
    CHECK(first > 1);
    CHECK(first <= 16);
    uint32_t total = first;
    for (int evaluation = 0;; ++evaluation) {
      REQUIRE(evaluation < 4);  // 16 + 8 + 8 = 32: done in at most two more evaluations
      set_bend(angle + step);
      const uint32_t iterations = evaluate(defaults);
      if (iterations == 1) break;
      CHECK(iterations == 8);
      total += iterations;
    }
    CHECK(total <= 32);
    CHECK(total > first);  // the capsule does not converge within 16: the next frames went on
    return total;
  };
  set_bend(1.2f);
  const uint32_t first = evaluate(defaults);  // no previous evaluation: a fresh start
  const uint32_t first_total = converge(first, 0.05f);
  MESSAGE("first evaluation (capsule bent 1.2 rad): " << first << " iterations, " << first_total << " in all");
  sf_eval_options three{};
  three.fairing_iterations = 3;
  set_bend(angle + 0.05f);
  CHECK(evaluate(three) == 3);
  set_bend(-1.3f);  // a teleport into the opposite bend: detected, converged afresh
  const uint32_t jump = evaluate(defaults);
  const uint32_t jump_total = converge(jump, 0.05f);
  MESSAGE("pose jump to -1.3 rad: " << jump << " iterations, " << jump_total << " in all");
  sf_eval_options from_rest{};
  from_rest.flags = SF_EVAL_FROM_REST;
  const uint32_t fresh = evaluate(from_rest);  // same pose, but the caller asks for a fresh start
  MESSAGE("SF_EVAL_FROM_REST: " << fresh << " iterations");
  CHECK(fresh > 16);  // the whole convergence, in this evaluation (the capsule takes more than 16)
  CHECK(fresh <= 32);
  set_bend(angle + 0.05f);
  CHECK(evaluate(defaults) == 1);  // nothing left of it for the next evaluation

  // A budget above the fresh start's share: a convergence evaluation never runs fewer
  // iterations than the caller's fairing_iterations (here 24 of the 32, then the 8 left).
  Instance budget(model.asset);
  sf_eval_options many{};
  many.fairing_iterations = 24;
  uint32_t per_evaluation[3] = {};
  for (int k = 0; k < 3; ++k) {
    const std::vector<float> joints =
        flat(skelform::test::bend_pose(model, 1, 1.2f + 0.05f * float(k), glm::vec3(0, 1, 0)));
    REQUIRE(sf_instance_set_joint_matrices(budget.instance, joints.data(), model.inverse_bind.size(), 0) == SF_OK);
    REQUIRE(sf_instance_evaluate(budget.instance, &many) == SF_OK);
    REQUIRE(sf_instance_fairing_stats(budget.instance, &per_evaluation[k], nullptr) == SF_OK);
  }
  CHECK(per_evaluation[0] == 24);
  CHECK(per_evaluation[1] == 8);
  CHECK(per_evaluation[2] == 24);  // warm: the budget
}

// A fresh start spread over evaluations ends where one run whole in its evaluation ends: on a
// held pose, the first evaluation and the two that go on with its convergence leave the control
// mesh within 1e-7 of the diagonal of SF_EVAL_FROM_REST's (the warm start turns the correction
// into each vertex's frame and back, which rounds: 4e-9 here).
TEST_CASE("fair animation: a spread fresh start ends where SF_EVAL_FROM_REST does") {
  const skelform::test::RuntimeModel& model = skelform::test::capsule_model();
  sf_deformable_info info{};
  REQUIRE(sf_asset_deformable_info(model.asset, 0, &info) == SF_OK);
  const std::vector<float> joints = flat(skelform::test::bend_pose(model, 1, 1.2f, glm::vec3(0, 1, 0)));
  const auto control = [&](sf_instance* instance) {
    std::vector<glm::vec3> positions(info.control_vertex_count);
    REQUIRE(sf_instance_write_coarse(instance, SF_COARSE_CONTROL, &positions[0].x, 0, info.control_vertex_count) ==
            SF_OK);
    return positions;
  };
  Instance spread(model.asset), whole(model.asset);
  REQUIRE(sf_instance_set_joint_matrices(spread.instance, joints.data(), model.inverse_bind.size(), 0) == SF_OK);
  REQUIRE(sf_instance_set_joint_matrices(whole.instance, joints.data(), model.inverse_bind.size(), 0) == SF_OK);
  const sf_eval_options defaults{};
  uint32_t total = 0, iterations = 0;
  std::vector<glm::vec3> first;
  for (int evaluation = 0; evaluation < 3; ++evaluation) {
    REQUIRE(sf_instance_evaluate(spread.instance, &defaults) == SF_OK);
    REQUIRE(sf_instance_fairing_stats(spread.instance, &iterations, nullptr) == SF_OK);
    total += iterations;
    if (evaluation == 0) first = control(spread.instance);
  }
  sf_eval_options from_rest{};
  from_rest.flags = SF_EVAL_FROM_REST;
  REQUIRE(sf_instance_evaluate(whole.instance, &from_rest) == SF_OK);
  REQUIRE(sf_instance_fairing_stats(whole.instance, &iterations, nullptr) == SF_OK);
  CHECK(total == iterations);  // the same schedule, in parts
  const std::vector<glm::vec3> a = control(spread.instance), b = control(whole.instance);
  glm::vec3 lo(1e30f), hi(-1e30f);
  float largest = 0.0f, first_largest = 0.0f;
  for (size_t v = 0; v < b.size(); ++v) {
    lo = glm::min(lo, b[v]);
    hi = glm::max(hi, b[v]);
    largest = std::max(largest, glm::length(a[v] - b[v]));
    first_largest = std::max(first_largest, glm::length(first[v] - b[v]));
  }
  const float diagonal = glm::length(hi - lo);
  MESSAGE("spread against whole: " << largest / diagonal << " of the diagonal after three evaluations, "
                                   << first_largest / diagonal << " after the first");
  CHECK(largest <= 1e-7f * diagonal);
  CHECK(largest < first_largest);  // the evaluations after the first did converge further
}

// sf_instance_set_contacts acts: where skelform's own result has pairs the pass resolves
// (CesiumMan's walk), an instance with the pass on writes other positions than one without.
TEST_CASE("fair animation with the contact pass: CesiumMan - the pass changes the output") {
  const skelform::test::RuntimeModel* cesium = skelform::test::sample_model("CesiumMan/CesiumMan.glb");
  if (!cesium) return;
  const skelform::samples::GltfAnimation gltf =
      skelform::samples::GltfAnimation::load_file(skelform::test::data_file("CesiumMan/CesiumMan.glb").string());
  Instance with(cesium->asset), without(cesium->asset);
  REQUIRE(sf_instance_set_contacts(without.instance, 0) == SF_OK);  // `with` has it by default
  bool differed = false;
  for (int k = 0; k < 60 && !differed; k += 5) {
    const std::vector<float> joints = gltf.joint_matrices(0, 0, gltf.animations()[0].start + k / 30.0);
    for (sf_instance* i : {with.instance, without.instance}) {
      REQUIRE(sf_instance_set_joint_matrices(i, joints.data(), joints.size() / 16, 0) == SF_OK);
      REQUIRE(sf_instance_evaluate(i, nullptr) == SF_OK);
    }
    const skelform::test::Evaluated a = skelform::test::write_all(with.instance, cesium->asset);
    const skelform::test::Evaluated b = skelform::test::write_all(without.instance, cesium->asset);
    differed = std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(glm::vec3)) != 0;
  }
  CHECK(differed);
}
