// Cost of the bake's skeleton stage (DESIGN.md bake steps 4-5) on hand_closed.obj (8K
// vertices, 16K triangles): the bilaplacian tangent flow (100 steps), the Voronoi skeletal
// mesh, and both together as the baker runs them. The figure to beat is the skeleton issue's
// budget, printed beside it as `budget_ms`: under 1 s on one core for the two together.
#include "skelform/bake/input.h"
#include "skelform/bake/skeleton.h"
#include "skelform/bake/tangent_flow.h"
#include "skelform/bake/weld.h"

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

using namespace skelform::bake;

namespace {

constexpr double kBudgetMilliseconds = 1000.0;

std::filesystem::path data_dir() {
  if (const char* env = std::getenv("SKELFORM_DATA_DIR")) return env;
  return SKELFORM_DATA_DIR;
}

// The welded hand, loaded once; empty when the shared data is absent.
const std::optional<TriangleMesh>& hand_mesh() {
  static const std::optional<TriangleMesh> mesh = []() -> std::optional<TriangleMesh> {
    const std::filesystem::path path = data_dir() / "hand" / "hand_closed.obj";
    if (!std::filesystem::exists(path)) return std::nullopt;
    return weld(load_mesh(path.string())).mesh;
  }();
  return mesh;
}

bool skip_without_data(benchmark::State& state) {
  if (hand_mesh()) return false;
  state.SkipWithError(
      ("hand/hand_closed.obj not found under " + data_dir().string() + " (set SKELFORM_DATA_DIR)").c_str());
  return true;
}

void report(benchmark::State& state) {
  state.counters["vertices"] = static_cast<double>(hand_mesh()->positions.size());
  state.counters["budget_ms"] = kBudgetMilliseconds;
}

void BM_TangentFlow100(benchmark::State& state) {
  if (skip_without_data(state)) return;
  for (auto _ : state) {
    TriangleMesh mesh = *hand_mesh();
    apply_tangent_flow(mesh);
    benchmark::DoNotOptimize(mesh.positions.data());
  }
  report(state);
}

void BM_SkeletonExtraction(benchmark::State& state) {
  if (skip_without_data(state)) return;
  TriangleMesh flowed = *hand_mesh();
  apply_tangent_flow(flowed);
  for (auto _ : state) {
    SkeletalMesh skeleton = extract_skeleton(flowed);
    benchmark::DoNotOptimize(skeleton.skeletal_positions.data());
  }
  report(state);
}

void BM_TangentFlowAndSkeleton(benchmark::State& state) {
  if (skip_without_data(state)) return;
  for (auto _ : state) {
    TriangleMesh mesh = *hand_mesh();
    apply_tangent_flow(mesh);
    SkeletalMesh skeleton = extract_skeleton(mesh);
    benchmark::DoNotOptimize(skeleton.skeletal_positions.data());
  }
  report(state);
}

}  // namespace

BENCHMARK(BM_TangentFlow100)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SkeletonExtraction)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TangentFlowAndSkeleton)->Unit(benchmark::kMillisecond);
