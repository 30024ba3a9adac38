// samples/common/gltf_animation: glTF animation sampling into joint matrices, checked against
// analytic values on hand-made glTFs, on the real sample characters, and on invalid input.
#include "gltf_animation.h"
#include "test_support.h"

#include <glm/gtc/constants.hpp>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

using nlohmann::json;
using skelform::samples::GltfAnimation;
using skelform::samples::GltfError;
using skelform::samples::kStaticPose;

namespace {

std::string base64(const std::string& bytes) {
  static const char* const alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v =
        (uint32_t(uint8_t(bytes[i])) << 16) | (uint32_t(uint8_t(bytes[i + 1])) << 8) | uint8_t(bytes[i + 2]);
    out += {alphabet[v >> 18], alphabet[(v >> 12) & 63], alphabet[(v >> 6) & 63], alphabet[v & 63]};
  }
  if (i + 1 == bytes.size()) {
    const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
    out += {alphabet[v >> 18], alphabet[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == bytes.size()) {
    const uint32_t v = (uint32_t(uint8_t(bytes[i])) << 16) | (uint32_t(uint8_t(bytes[i + 1])) << 8);
    out += {alphabet[v >> 18], alphabet[(v >> 12) & 63], alphabet[(v >> 6) & 63], '='};
  }
  return out;
}

// A hand-made glTF: float accessors in one data-URI buffer, one bufferView each.
struct GltfBuilder {
  std::string bytes;
  json accessors = json::array();
  json views = json::array();
  json doc = {{"asset", {{"version", "2.0"}}}};

  int add(const std::vector<float>& values, const char* type) {
    const size_t components = std::strcmp(type, "SCALAR") == 0 ? 1
                              : std::strcmp(type, "VEC3") == 0 ? 3
                              : std::strcmp(type, "VEC4") == 0 ? 4
                                                               : 16;
    const size_t offset = bytes.size();
    bytes.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
    views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", values.size() * sizeof(float)}});
    json accessor = {{"bufferView", views.size() - 1},
                     {"componentType", 5126},
                     {"count", values.size() / components},
                     {"type", type}};
    if (std::strcmp(type, "SCALAR") == 0 && !values.empty()) {  // glTF requires min/max on sampler inputs
      accessor["min"] = {values.front()};
      accessor["max"] = {values.back()};
    }
    accessors.push_back(accessor);
    return static_cast<int>(accessors.size() - 1);
  }

  // One animation with one channel on `node`.
  void animate(int node, const char* path, const char* interpolation, const std::vector<float>& times,
               const std::vector<float>& values) {
    const int input = add(times, "SCALAR");
    const int output = add(values, std::strcmp(path, "rotation") == 0 ? "VEC4" : "VEC3");
    doc["animations"].push_back(
        {{"samplers", {{{"input", input}, {"output", output}, {"interpolation", interpolation}}}},
         {"channels", {{{"sampler", 0}, {"target", {{"node", node}, {"path", path}}}}}}});
  }

  std::string text() {
    json out = doc;
    if (!bytes.empty()) {
      out["buffers"] = {
          {{"byteLength", bytes.size()}, {"uri", "data:application/octet-stream;base64," + base64(bytes)}}};
      out["bufferViews"] = views;
      out["accessors"] = accessors;
    }
    return out.dump();
  }

  GltfAnimation load() { return GltfAnimation::load_memory(text(), "test.gltf"); }
};

std::vector<float> quat_z(double degrees) {  // glTF order x, y, z, w
  const double half = degrees * glm::pi<double>() / 360.0;
  return {0.0f, 0.0f, static_cast<float>(std::sin(half)), static_cast<float>(std::cos(half))};
}

std::vector<float> concat(std::initializer_list<std::vector<float>> parts) {
  std::vector<float> out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

// Angle about z of a column-major rotation matrix.
double z_angle_degrees(const float* m) { return std::atan2(m[1], m[0]) * 180.0 / glm::pi<double>(); }

bool near(double a, double b, double tolerance = 1e-5) { return std::fabs(a - b) <= tolerance; }

}  // namespace

TEST_SUITE("gltf_animation") {
  TEST_CASE("a document without nodes or animations loads; out-of-range requests throw") {
    GltfBuilder builder;
    const GltfAnimation gltf = builder.load();
    CHECK(gltf.node_count() == 0);
    CHECK(gltf.animations().empty());
    CHECK_THROWS_AS(gltf.joint_matrices(0, kStaticPose, 0.0), GltfError);
    CHECK_THROWS_AS(gltf.node_world_matrices(0, 0.0), GltfError);
    CHECK_THROWS_AS(GltfAnimation::load_memory("not a gltf", "garbage.gltf"), GltfError);
    CHECK_THROWS_AS(GltfAnimation::load_memory(std::string("glTF\2\0\0\0", 8), "short.glb"), GltfError);
    CHECK_THROWS_AS(GltfAnimation::load_file("/nonexistent/file.glb"), GltfError);
  }

  TEST_CASE("external URIs are taken literally: no shell expansion of $(...) or ~") {
    const std::filesystem::path dir = skelform::test::scratch_dir("gltf_animation_uri");
    const std::filesystem::path marker = dir / "expanded";
    std::filesystem::remove(marker);
    GltfBuilder builder;
    builder.doc["buffers"] = {{{"byteLength", 4}, {"uri", "$(touch " + marker.string() + ").bin"}}};
    const std::string text = builder.doc.dump();
    CHECK_THROWS_AS(GltfAnimation::load_memory(text, "uri.gltf", dir.string()), GltfError);  // no such file
    CHECK_FALSE(std::filesystem::exists(marker));
  }

  TEST_CASE("LINEAR rotation: 0 to 90 degrees about z sampled at the midpoint gives 45 degrees (slerp)") {
    GltfBuilder builder;
    // json::array({x}), not {x}: with one element, clang takes the braces for x itself.
    builder.doc["nodes"] = json::array({json::object()});
    builder.doc["skins"] = {{{"joints", {0}}}};
    builder.animate(0, "rotation", "LINEAR", {0.0f, 1.0f}, concat({quat_z(0), quat_z(90)}));
    const GltfAnimation gltf = builder.load();
    REQUIRE(gltf.animations().size() == 1);
    CHECK(gltf.animations()[0].start == 0.0);
    CHECK(gltf.animations()[0].duration() == doctest::Approx(1.0));
    for (double t : {0.0, 0.25, 0.5, 0.75, 1.0}) {
      const std::vector<float> m = gltf.joint_matrices(0, 0, t);
      CHECK(near(z_angle_degrees(m.data()), 90.0 * t));  // slerp: constant angular speed
      CHECK(near(m[0] * m[0] + m[1] * m[1], 1.0));       // a rotation, no shrinking as with nlerp
    }
    // Clamped to the animation's range.
    CHECK(near(z_angle_degrees(gltf.joint_matrices(0, 0, -3.0).data()), 0.0));
    CHECK(near(z_angle_degrees(gltf.joint_matrices(0, 0, 7.0).data()), 90.0));
    // The bind pose ignores the animation.
    CHECK(near(z_angle_degrees(gltf.bind_pose_joint_matrices(0).data()), 0.0));
    CHECK_THROWS_AS(gltf.joint_matrices(0, 0, std::nan("")), GltfError);
    CHECK_THROWS_AS(gltf.joint_matrices(0, 1, 0.0), GltfError);
    CHECK_THROWS_AS(gltf.joint_matrices(1, 0, 0.0), GltfError);
  }

  TEST_CASE("LINEAR rotation takes the shorter arc between q and -q neighbours") {
    GltfBuilder builder;
    builder.doc["nodes"] = json::array({json::object()});
    std::vector<float> end = quat_z(90);
    for (float& c : end) c = -c;  // the same rotation, opposite hemisphere
    builder.animate(0, "rotation", "LINEAR", {0.0f, 1.0f}, concat({quat_z(0), end}));
    const GltfAnimation gltf = builder.load();
    CHECK(near(z_angle_degrees(gltf.node_world_matrices(0, 0.5).data()), 45.0));
  }

  TEST_CASE("LINEAR translation interpolates component-wise") {
    GltfBuilder builder;
    builder.doc["nodes"] = json::array({json::object()});
    builder.animate(0, "translation", "LINEAR", {1.0f, 3.0f}, {0, 0, 0, 2, -4, 6});
    const GltfAnimation gltf = builder.load();
    CHECK(gltf.animations()[0].start == 1.0);
    CHECK(gltf.animations()[0].end == 3.0);
    const std::vector<float> m = gltf.node_world_matrices(0, 1.5);
    CHECK(near(m[12], 0.5));
    CHECK(near(m[13], -1.0));
    CHECK(near(m[14], 1.5));
  }

  TEST_CASE("STEP holds each keyframe until the next one") {
    GltfBuilder builder;
    builder.doc["nodes"] = json::array({json::object()});
    builder.animate(0, "translation", "STEP", {0.0f, 1.0f, 2.0f}, {0, 0, 0, 1, 0, 0, 2, 0, 0});
    const GltfAnimation gltf = builder.load();
    CHECK(near(gltf.node_world_matrices(0, 0.0)[12], 0.0));
    CHECK(near(gltf.node_world_matrices(0, 0.999)[12], 0.0));
    CHECK(near(gltf.node_world_matrices(0, 1.0)[12], 1.0));
    CHECK(near(gltf.node_world_matrices(0, 1.5)[12], 1.0));
    CHECK(near(gltf.node_world_matrices(0, 2.0)[12], 2.0));
    CHECK(near(gltf.node_world_matrices(0, 9.0)[12], 2.0));
  }

  TEST_CASE("a repeated key time, as exporters write at the end of a clip, is a jump at that instant") {
    // glTF asks for strictly increasing times; files in the wild repeat the last one.
    GltfBuilder builder;
    builder.doc["nodes"] = json::array({json::object()});
    builder.animate(0, "translation", "LINEAR", {0.0f, 1.0f, 1.0f}, {0, 0, 0, 2, 0, 0, 5, 0, 0});
    const GltfAnimation gltf = builder.load();
    CHECK(near(gltf.node_world_matrices(0, 0.5)[12], 1.0));
    CHECK(near(gltf.node_world_matrices(0, 0.999)[12], 1.998));
    CHECK(near(gltf.node_world_matrices(0, 1.0)[12], 5.0));
    CHECK(near(gltf.node_world_matrices(0, 3.0)[12], 5.0));
    CHECK(near(gltf.animations()[0].duration(), 1.0));
  }

  TEST_CASE("CUBICSPLINE with zero tangents is the Hermite smoothstep 3s^2 - 2s^3") {
    GltfBuilder builder;
    builder.doc["nodes"] = json::array({json::object()});
    // Per keyframe: in-tangent, value, out-tangent.
    builder.animate(0, "translation", "CUBICSPLINE", {0.0f, 2.0f},
                    {0, 0, 0, 0, 0, 0, 0, 0, 0,  //
                     0, 0, 0, 1, 1, 1, 0, 0, 0});
    const GltfAnimation gltf = builder.load();
    for (double s : {0.0, 0.1, 0.25, 0.5, 0.8, 1.0}) {
      const std::vector<float> m = gltf.node_world_matrices(0, 2.0 * s);
      CHECK(near(m[12], 3 * s * s - 2 * s * s * s));
    }
  }

  TEST_CASE("CUBICSPLINE tangents are scaled by the keyframe interval: unit slopes reproduce a line") {
    GltfBuilder builder;
    builder.doc["nodes"] = json::array({json::object()});
    // x(t) = t on [0, 2]: values 0 and 2, tangents dx/dt = 1 (per second, as glTF stores them).
    builder.animate(0, "translation", "CUBICSPLINE", {0.0f, 2.0f},
                    {1, 0, 0, 0, 0, 0, 1, 0, 0,  //
                     1, 0, 0, 2, 0, 0, 1, 0, 0});
    const GltfAnimation gltf = builder.load();
    for (double t : {0.3, 1.0, 1.7}) CHECK(near(gltf.node_world_matrices(0, t)[12], t));
  }

  TEST_CASE("CUBICSPLINE rotation is normalised") {
    GltfBuilder builder;
    builder.doc["nodes"] = json::array({json::object()});
    const std::vector<float> zero(4, 0.0f);
    builder.animate(0, "rotation", "CUBICSPLINE", {0.0f, 1.0f},
                    concat({zero, quat_z(0), zero, zero, quat_z(90), zero}));
    const GltfAnimation gltf = builder.load();
    const std::vector<float> m = gltf.node_world_matrices(0, 0.5);
    CHECK(near(m[0] * m[0] + m[1] * m[1], 1.0));
    CHECK(near(z_angle_degrees(m.data()), 45.0, 1e-4));  // symmetric spline: midpoint is 45 degrees
    CHECK(near(z_angle_degrees(gltf.node_world_matrices(0, 0.25).data()), 90.0 * 0.15625, 2.0));
  }

  TEST_CASE("the hierarchy composes parent × local, with TRS as T × R × S and matrices as given") {
    GltfBuilder builder;
    const std::vector<float> r90 = quat_z(90);
    builder.doc["nodes"] = {
        {{"children", {1}},
         {"translation", {1, 0, 0}},
         {"rotation", {r90[0], r90[1], r90[2], r90[3]}},
         {"scale", {2, 2, 2}}},
        {{"children", {2}}, {"translation", {1, 0, 0}}},
        // column-major translation by (0, 0, 3)
        {{"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 3, 1}}},
    };
    const GltfAnimation gltf = builder.load();
    const std::vector<float> world = gltf.node_world_matrices(kStaticPose, 0.0);
    // Node 1's origin: parent translation + parent rotation of (scale 2 × (1, 0, 0)) = (1, 2, 0).
    CHECK(near(world[16 + 12], 1.0));
    CHECK(near(world[16 + 13], 2.0));
    CHECK(near(world[16 + 14], 0.0));
    // Node 2: a further (0, 0, 3) scaled by 2 → z = 6.
    CHECK(near(world[32 + 12], 1.0));
    CHECK(near(world[32 + 13], 2.0));
    CHECK(near(world[32 + 14], 6.0));
    CHECK(near(world[32 + 0], 0.0));  // x axis turned onto y, scaled
    CHECK(near(world[32 + 1], 2.0));
  }

  TEST_CASE("joint matrices are jointWorld × inverseBind in skin order, and an animated child follows its parent") {
    GltfBuilder builder;
    builder.doc["nodes"] = {{{"children", {1}}, {"translation", {0, 1, 0}}}, {{"translation", {0, 2, 0}}}};
    // Inverse bind matrices = inverse of each joint's bind world transform: translations by -1, -3.
    const int ibm = builder.add({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -3, 0, 1,  // for joint 1 (listed first)
                                 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1, 0, 1},
                                "MAT4");
    builder.doc["skins"] = {{{"joints", {1, 0}}, {"inverseBindMatrices", ibm}}};
    builder.animate(0, "rotation", "LINEAR", {0.0f, 1.0f}, concat({quat_z(0), quat_z(90)}));
    const GltfAnimation gltf = builder.load();
    CHECK(gltf.joint_count(0) == 2);
    const std::vector<float> bind = gltf.bind_pose_joint_matrices(0);
    for (size_t i = 0; i < bind.size(); ++i) CHECK(near(bind[i], (i % 16) % 5 == 0 ? 1.0 : 0.0));
    // At t = 1 the root turns 90° about z around (0, 1, 0): the child joint's bind point
    // (0, 3, 0) moves to (-2, 1, 0); its joint matrix maps it there.
    const std::vector<float> posed = gltf.joint_matrices(0, 0, 1.0);
    const float* m = posed.data();  // joint 1
    const double x = m[4] * 3 + m[12], y = m[5] * 3 + m[13];
    CHECK(near(x, -2.0));
    CHECK(near(y, 1.0));
  }

  TEST_CASE("invalid documents are refused with a message, never a crash") {
    auto refused = [](GltfBuilder builder, const std::string& fragment) {
      std::string message;
      try {
        builder.load();
      } catch (const GltfError& e) {
        message = e.what();
      }
      INFO("message: " << message << " / expected: " << fragment);
      CHECK(message.find(fragment) != std::string::npos);
      CHECK(message.find('\n') == std::string::npos);
    };
    GltfBuilder base;
    base.doc["nodes"] = {json::object(), json::object()};

    GltfBuilder b = base;
    b.doc["nodes"][0]["children"] = {5};
    refused(b, "does not exist");
    b = base;
    b.doc["nodes"][0]["children"] = {1};
    b.doc["nodes"][1]["children"] = {0};
    refused(b, "cycle");
    b = base;
    b.doc["nodes"][0]["children"] = {1, 1};
    refused(b, "more than one parent");
    b = base;
    b.doc["skins"] = {{{"joints", {0, 7}}}};
    refused(b, "not a node");
    b = base;
    b.doc["skins"] = {{{"joints", {0, 1}}, {"inverseBindMatrices", b.add(std::vector<float>(16, 0.f), "MAT4")}}};
    refused(b, "1 inverse bind matrices for 2 joints");
    b = base;
    b.animate(0, "translation", "LINEAR", {0.0f, 1.0f, 0.5f}, std::vector<float>(9, 0.0f));
    refused(b, "input decreases at keyframe 2");
    b = base;
    b.animate(0, "translation", "LINEAR", {0.0f, 1.0f}, std::vector<float>(9, 0.0f));
    refused(b, "3 elements for 2 keyframes");
    b = base;
    b.animate(0, "translation", "CUBICSPLINE", {0.0f, 1.0f}, std::vector<float>(6, 0.0f));
    refused(b, "CUBICSPLINE needs 6");
    b = base;
    b.animate(0, "translation", "LINEAR", {0.0f, 1.0f}, {0, 0, 0, std::numeric_limits<float>::quiet_NaN(), 0, 0});
    refused(b, "element 1 has a non-finite value");
    b = base;
    b.animate(0, "rotation", "LINEAR", {0.0f, 1.0f}, std::vector<float>(8, 0.0f));
    refused(b, "zero-length rotation");
    b = base;
    b.animate(0, "translation", "BOUNCY", {0.0f, 1.0f}, std::vector<float>(6, 0.0f));
    refused(b, "unknown interpolation");
    b = base;
    b.animate(9, "translation", "LINEAR", {0.0f, 1.0f}, std::vector<float>(6, 0.0f));
    refused(b, "targets node 9");
    b = base;
    b.doc["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    b.animate(0, "translation", "LINEAR", {0.0f, 1.0f}, std::vector<float>(6, 0.0f));
    refused(b, "has a matrix");
    b = base;
    b.animate(0, "translation", "LINEAR", {0.0f, 1.0f}, std::vector<float>(6, 0.0f));
    b.accessors[1]["count"] = 1000;  // reads past its bufferView
    refused(b, "past the end");
    b = base;
    b.animate(0, "translation", "LINEAR", {0.0f, 1.0f}, std::vector<float>(6, 0.0f));
    b.doc["animations"][0]["channels"][0]["sampler"] = 4;
    refused(b, "sampler 4");
    b = base;
    b.animate(0, "translation", "LINEAR", {0.0f, 1.0f}, std::vector<float>(6, 0.0f));
    b.accessors[0]["type"] = "VEC2";
    refused(b, "input: accessor 0 is FLOAT VEC2; expected FLOAT SCALAR");
  }

  TEST_CASE("mesh primitives: positions and triangles are read and index-checked") {
    GltfBuilder builder;
    const int positions = builder.add({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}, "VEC3");
    builder.doc["meshes"] = {
        {{"primitives",
          {{{"attributes", {{"POSITION", positions}}}, {"mode", 5}}, {{"attributes", {{"POSITION", positions}}}}}}}};
    GltfAnimation gltf = builder.load();
    CHECK(gltf.mesh_count() == 1);
    CHECK(gltf.primitive_count(0) == 2);
    CHECK(gltf.primitive_positions(0, 0).size() == 12);
    CHECK(gltf.primitive_triangles(0, 0) == std::vector<uint32_t>{0, 1, 2, 2, 1, 3});  // strip, winding kept
    CHECK_THROWS_AS(gltf.primitive_triangles(0, 1), GltfError);                        // 4 vertices: not triangles
    CHECK_THROWS_AS(gltf.primitive_positions(0, 2), GltfError);
    CHECK_THROWS_AS(gltf.primitive_positions(1, 0), GltfError);
  }

  // The real characters: bind pose and every sampled frame. At the bind pose (static TRS),
  // jointWorld × inverseBind is the identity only when the skin was bound in the space the
  // joints' root lives in. Fox and SimpleSkin are. CesiumMan, RiggedFigure and RiggedSimple put
  // a Z-up to Y-up rotation on an ancestor of the skeleton that the inverse bind matrices do
  // not undo: every joint matrix at the bind pose is then the same rigid transform (the whole
  // mesh turned upright, as viewers show it), for CesiumMan and RiggedFigure exactly the
  // skinned node's global transform. So a runtime's rest pose (identity joint matrices) is the
  // mesh as stored, and an animated frame of those files includes that rotation.
  TEST_CASE(
      "real characters: bind pose is one common rigid transform (identity where bound at the root), "
      "finite matrices over every animation") {
    struct Model {
      std::string path;
      size_t animations;
      bool bind_is_identity;
      bool bind_is_skinned_node;  // joint matrices at bind = global transform of the skinned node
    };
    const Model models[] = {{"CesiumMan/CesiumMan.glb", 1, false, true},
                            {"Fox/Fox.glb", 3, true, true},
                            {"RiggedFigure/RiggedFigure.glb", 1, false, true},
                            {"RiggedSimple/RiggedSimple.glb", 1, false, false},
                            {"SimpleSkin/SimpleSkin.gltf", 1, true, true}};
    for (const Model& model : models) {
      CAPTURE(model.path);
      const std::filesystem::path path = skelform::test::data_file(model.path);
      if (path.empty()) {
        MESSAGE("skipped: " << model.path << " not found under " << skelform::test::data_dir());
        continue;
      }
      const GltfAnimation gltf = GltfAnimation::load_file(path.string());
      REQUIRE(gltf.skin_count() >= 1);
      CHECK(gltf.animations().size() == model.animations);
      const std::vector<float> bind = gltf.bind_pose_joint_matrices(0);
      const float* common = bind.data();
      double spread = 0, from_identity = 0, rigidity = 0;
      for (size_t i = 0; i < bind.size(); ++i) {
        spread = std::max(spread, double(std::fabs(bind[i] - common[i % 16])));
        from_identity = std::max(from_identity, std::fabs(bind[i] - ((i % 16) % 5 == 0 ? 1.0 : 0.0)));
      }
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          double d = 0;
          for (int r = 0; r < 3; ++r) d += double(common[4 * a + r]) * common[4 * b + r];
          rigidity = std::max(rigidity, std::fabs(d - (a == b ? 1.0 : 0.0)));
        }
      CHECK(spread < 1e-4);
      CHECK(rigidity < 1e-4);
      if (model.bind_is_identity)
        CHECK(from_identity < 1e-4);
      else
        CHECK(from_identity > 0.5);  // documents the rotated files above
      if (model.bind_is_skinned_node) {
        const std::vector<float> world = gltf.node_world_matrices(kStaticPose, 0.0);
        for (size_t n = 0; n < gltf.node_count(); ++n) {
          if (gltf.node_skin(n) != 0) continue;
          double worst = 0;
          for (size_t i = 0; i < 16; ++i) worst = std::max(worst, double(std::fabs(common[i] - world[16 * n + i])));
          CHECK(worst < 1e-4);
        }
      }
      for (size_t a = 0; a < gltf.animations().size(); ++a) {
        const auto& info = gltf.animations()[a];
        CHECK(info.duration() > 0);
        for (int step = 0; step <= 64; ++step) {
          const std::vector<float> m = gltf.joint_matrices(0, a, info.start + info.duration() * step / 64.0);
          bool finite = true;
          for (float v : m) finite = finite && std::isfinite(v);
          CHECK(finite);
        }
      }
      for (size_t mesh = 0; mesh < gltf.mesh_count(); ++mesh)
        for (size_t p = 0; p < gltf.primitive_count(mesh); ++p)
          CHECK(gltf.primitive_triangles(mesh, p).size() % 3 == 0);
    }
  }

}  // TEST_SUITE

// Blender exports the armature's current pose as the static node transforms, not its rest
// pose: in the Quaternius characters the static pose turns joints up to ~80 degrees away from
// the pose the inverse binds were taken in. The bind pose is then every joint at the skinned
// node's world transform (which places the mesh as stored), not the static pose.
TEST_CASE("gltf animation: the bind pose of a file whose static pose is posed is the skinned node's transform") {
  SKELFORM_REQUIRE_DATA(path, "quaternius/animals_pack/Wolf.glb");
  const GltfAnimation gltf = GltfAnimation::load_file(path.string());
  const std::vector<float> still = gltf.joint_matrices(0, kStaticPose, 0.0);
  const std::vector<float> bind = gltf.bind_pose_joint_matrices(0);
  REQUIRE(still.size() == bind.size());
  double spread_static = 0, spread_bind = 0;
  for (size_t i = 0; i < bind.size(); ++i) {
    spread_static = std::max(spread_static, double(std::fabs(still[i] - still[i % 16])));
    spread_bind = std::max(spread_bind, double(std::fabs(bind[i] - bind[i % 16])));
  }
  CHECK(spread_static > 1.0);  // the static pose is a posed skeleton (joint matrices differ)
  CHECK(spread_bind == 0.0);   // the bind pose: one transform for every joint
  const std::vector<float> world = gltf.node_world_matrices(kStaticPose, 0.0);
  for (size_t n = 0; n < gltf.node_count(); ++n) {
    if (gltf.node_skin(n) != 0) continue;
    for (size_t i = 0; i < 16; ++i) CHECK(bind[i] == world[16 * n + i]);
  }
  // Wolf's armature: a 100 × scale and the Y-up turn.
  const double scale = std::cbrt(std::fabs(double(bind[0]) * (double(bind[5]) * bind[10] - double(bind[9]) * bind[6]) -
                                           double(bind[4]) * (double(bind[1]) * bind[10] - double(bind[9]) * bind[2]) +
                                           double(bind[8]) * (double(bind[1]) * bind[6] - double(bind[5]) * bind[2])));
  CHECK(scale == doctest::Approx(100.0).epsilon(1e-5));
}
