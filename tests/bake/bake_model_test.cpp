// The whole bake of a deformable: stored arrays consistent, rest pose reproduced from them.
#include "baked_eval.h"
#include "skelform/bake/bake.h"
#include "skelform/bake/procedural.h"
#include "test_support.h"

#include <doctest/doctest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <map>

using namespace skelform::bake;

namespace {

InputMesh as_input(const TriangleMesh& mesh) {
  InputMesh input;
  input.positions = mesh.positions;
  input.triangles = mesh.triangles;
  InputPrimitive primitive;
  primitive.vertex_count = static_cast<uint32_t>(mesh.positions.size());
  primitive.triangle_count = static_cast<uint32_t>(mesh.triangles.size());
  input.primitives.push_back(primitive);
  return input;
}

// Max |evaluated - original| / diagonal over the dense vertices of one deformable, where the
// originals are the primitives' vertices in binding order.
double rest_error(const BakedDeformable& baked, const std::vector<Vec3>& originals) {
  const std::vector<glm::vec3> evaluated = skelform::test::evaluate_rest(baked);
  REQUIRE(evaluated.size() == originals.size());
  const double diagonal = bounds_of(originals).diagonal();
  double worst = 0;
  for (size_t i = 0; i < originals.size(); ++i)
    worst = std::max(worst, glm::length(Vec3(evaluated[i]) - originals[i]) / diagonal);
  return worst;
}

void check_consistent(const BakedDeformable& baked) {
  const size_t control = baked.control_positions.size();
  CHECK(baked.control_normals.size() == control);
  CHECK(baked.skeletal_positions.size() == control);
  CHECK(baked.medial_radius.size() == control);
  CHECK(baked.control_indices.size() % 3 == 0);
  for (uint32_t i : baked.control_indices) REQUIRE(i < control);
  REQUIRE(!baked.stencil_offsets.empty());
  const size_t refined = baked.stencil_offsets.size() - 1;
  CHECK(baked.stencil_offsets.back() == baked.stencil_indices.size());
  CHECK(baked.stencil_weights.size() == baked.stencil_indices.size());
  for (uint32_t i : baked.stencil_indices) REQUIRE(i < control);
  for (uint32_t i : baked.refined_indices) REQUIRE(i < refined);
  CHECK(baked.binding_triangle.size() == baked.dense_vertex_count);
  for (uint32_t t : baked.binding_triangle) REQUIRE(t < baked.refined_indices.size() / 3);
  // Paper eq. (1) at rest, in the stored floats: M = S + d·N.
  for (size_t v = 0; v < control; ++v) {
    const glm::vec3 rebuilt = baked.skeletal_positions[v] + baked.medial_radius[v] * baked.control_normals[v];
    CHECK(glm::length(rebuilt - baked.control_positions[v]) <=
          1e-5f * (1.0f + glm::length(baked.control_positions[v])));
    CHECK(baked.medial_radius[v] >= 0.0f);
  }
  for (size_t s = 0; s < baked.weight_sets.size(); ++s) CHECK(baked.weight_sets[s].size() == control);
}

}  // namespace

TEST_CASE("a decimated capsule bakes and its binding reproduces every vertex at rest") {
  const TriangleMesh dense = make_capsule(0.5, 3.0, 64, 120, 16);  // ~19K triangles
  const BakeResult result = bake_model(as_input(dense));           // default: BakeOptions::target_triangles
  REQUIRE(result.deformables.size() == 1);
  const BakedDeformable& baked = result.deformables[0];
  check_consistent(baked);
  CHECK(result.reports[0].decimated);
  CHECK(result.reports[0].control_triangles <= BakeOptions{}.target_triangles);
  CHECK(baked.subdivision_level >= 1);
  CHECK(rest_error(baked, dense.positions) <= 1e-5);
  // The tangent flow keeps the control vertices on the dense surface (reference_surface), so
  // the coarse control mesh's skeleton stays inside the real shape.
  CHECK(result.reports[0].skeleton_inside >= 0.995);
}

TEST_CASE("a flat mesh bakes with the zero-radius skeleton") {
  TriangleMesh strip;
  for (int i = 0; i < 6; ++i) {
    strip.positions.push_back({0.0, double(i), 0.0});
    strip.positions.push_back({1.0, double(i), 0.0});
  }
  for (uint32_t i = 0; i < 5; ++i) {
    strip.triangles.push_back({2 * i, 2 * i + 1, 2 * i + 3});
    strip.triangles.push_back({2 * i, 2 * i + 3, 2 * i + 2});
  }
  const BakeResult result = bake_model(as_input(strip));
  CHECK(result.reports[0].flat);
  check_consistent(result.deformables[0]);
  CHECK(rest_error(result.deformables[0], strip.positions) <= 1e-5);
}

TEST_CASE("every skinned model of the data set bakes and reproduces its rest pose") {
  for (const char* name : {"RiggedSimple/RiggedSimple.glb", "RiggedFigure/RiggedFigure.glb",
                           "SimpleSkin/SimpleSkin.gltf", "Fox/Fox.glb", "CesiumMan/CesiumMan.glb"}) {
    SKELFORM_REQUIRE_DATA(path, name);
    CAPTURE(std::string(name));
    const InputMesh input = load_mesh(path.string());
    const BakeResult result = bake_model(input);
    REQUIRE(result.deformables.size() == 1);
    const BakedDeformable& baked = result.deformables[0];
    check_consistent(baked);
    CHECK(baked.skin >= 0);
    const double error = rest_error(baked, input.positions);
    const DeformableReport& r = result.reports[0];
    MESSAGE(std::string(name) << ": " << r.dense_vertices << " vertices, control " << r.control_triangles
                              << " triangles, level " << r.subdivision_level << ", residual share " << r.residual_share
                              << ", rest error " << error << ", skeleton inside " << r.skeleton_inside);
    CHECK(error <= 1e-5);
    // The share of vertices skelform works for: none rigidly weighted (one joint holds 99.9 % of
    // the skin), every one whose dominant joint holds 95 % or less (each bound widened by 1e-5,
    // as the rule works in float and this count in double).
    size_t blended = 0, fully_blended = 0;
    for (size_t v = 0; v < input.positions.size(); ++v) {
      std::map<uint16_t, double> share;
      double total = 0.0;
      for (size_t set = 0; set < input.joint_sets.size(); ++set)
        for (size_t k = 0; k < 4; ++k)
          if (input.weight_sets[set][v][k] > 0.0f) {
            share[input.joint_sets[set][v][k]] += input.weight_sets[set][v][k];
            total += input.weight_sets[set][v][k];
          }
      double largest = 0.0;
      for (const auto& joint : share) largest = std::max(largest, joint.second);
      if (total > 0.0 && largest / total < 0.999 + 1e-5) ++blended;
      if (total > 0.0 && largest / total <= 0.95 - 1e-5) ++fully_blended;
    }
    const double n = double(input.positions.size());
    CHECK(r.skelform_share <= double(blended) / n + 1e-12);
    CHECK(r.skelform_share >= double(fully_blended) / n - 1e-12);
    CHECK(r.skelform_share > 0.0);
  }
}
