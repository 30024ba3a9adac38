// The skeleton issue's targets on real third-party models (DESIGN.md "Metrics", skeleton
// inside; paper section 2 and Fig. 5). Pipeline as the baker runs it: load → weld →
// bilaplacian tangent flow (100 steps) → Voronoi skeletal mesh. Every measure is taken
// against the welded input mesh, before the flow moved anything.
#include "test_support.h"

#include "skelform/bake/input.h"
#include "skelform/bake/metrics.h"
#include "skelform/bake/skeleton.h"
#include "skelform/bake/tangent_flow.h"
#include "skelform/bake/weld.h"

#include <algorithm>
#include <string>
#include <vector>

using namespace skelform::bake;

namespace {

struct SkeletonQuality {
  double inside = 0.0;                // fraction of skeletal vertices with winding number > 0.5
  double medial_median = 0.0;         // median over vertices of dist(S, input surface) / d
  double medial_radius_median = 0.0;  // median d / bounding-box diagonal
  size_t vertices = 0;
  size_t without_candidates = 0;
};

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

SkeletonQuality measure_skeleton(const TriangleMesh& input, bool with_tangent_flow) {
  TriangleMesh control = input;
  if (with_tangent_flow) apply_tangent_flow(control, TangentFlowOptions{100, 0.1});
  const SkeletalMesh skeleton = extract_skeleton(control);

  SkeletonQuality quality;
  quality.vertices = skeleton.skeletal_positions.size();
  quality.without_candidates = skeleton.vertices_without_candidates;
  quality.inside = inside_fraction(input, skeleton.skeletal_positions);
  // A skeletal vertex on the medial axis is as far from the surface as its ball's radius d:
  // the ratio is 1 there, and small for a skeleton that hugs the surface.
  const std::vector<double> distances = surface_distances(input, skeleton.skeletal_positions);
  std::vector<double> medial_ratio, relative_radius;
  const double diagonal = bounds_of(input.positions).diagonal();
  for (size_t v = 0; v < distances.size(); ++v) {
    relative_radius.push_back(skeleton.medial_radius[v] / diagonal);
    if (skeleton.medial_radius[v] > 0.0) medial_ratio.push_back(distances[v] / skeleton.medial_radius[v]);
  }
  quality.medial_median = median(medial_ratio);
  quality.medial_radius_median = median(relative_radius);
  return quality;
}

TriangleMesh load_welded(const std::string& path) { return weld(load_mesh(path)).mesh; }

void check_dense_model(const std::string& relative) {
  SKELFORM_REQUIRE_DATA(path, relative);
  const TriangleMesh input = load_welded(path.string());
  const SkeletonQuality quality = measure_skeleton(input, true);
  MESSAGE(relative << ": " << quality.vertices << " vertices, inside " << quality.inside * 100.0
                   << " %, median dist(S, surface)/d " << quality.medial_median << ", median d/diagonal "
                   << quality.medial_radius_median << ", without candidates " << quality.without_candidates);
  CHECK(quality.inside >= 0.995);
  CHECK(quality.medial_median >= 0.9);
}

void check_flow_improves(const std::string& relative) {
  SKELFORM_REQUIRE_DATA(path, relative);
  const TriangleMesh input = load_welded(path.string());
  const SkeletonQuality without_flow = measure_skeleton(input, false);
  const SkeletonQuality with_flow = measure_skeleton(input, true);
  MESSAGE(relative << " (" << input.positions.size() << " vertices): inside " << without_flow.inside * 100.0
                   << " % without the tangent flow, " << with_flow.inside * 100.0 << " % with it; median dist/d "
                   << without_flow.medial_median << " -> " << with_flow.medial_median);
  CHECK(with_flow.inside > without_flow.inside);
}

}  // namespace

TEST_CASE("skeleton models: spot is >= 99.5 % inside and medial") { check_dense_model("spot/spot.obj"); }

TEST_CASE("skeleton models: hand_closed is >= 99.5 % inside and medial") { check_dense_model("hand/hand_closed.obj"); }

TEST_CASE("skeleton models: CesiumMan (welded) is >= 99.5 % inside and medial") {
  check_dense_model("CesiumMan/CesiumMan.glb");
}

TEST_CASE("skeleton models: the tangent flow brings more of a low-poly skeleton inside (paper Fig. 5)") {
  check_flow_improves("RiggedFigure/RiggedFigure.glb");
  check_flow_improves("Fox/Fox.glb");
}
