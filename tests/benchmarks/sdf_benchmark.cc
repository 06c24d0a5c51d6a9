// Link SDF micro-benchmarks: value + gradient queries, and generating every
// link of the reference robot at the default resolution.
#include <benchmark/benchmark.h>

#include <random>

#include "quadhand/geometry/mesh_to_sdf.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand {
namespace {

const std::string kUrdf = std::string(QUADHAND_SOURCE_DIR) + "/meshes/quadhand/quadhand.urdf";

const robot::RobotModel& Robot() {
  static const robot::RobotModel model = *robot::RobotModel::LoadFromUrdfFile(kUrdf);
  return model;
}

// The default-resolution grid of `link`, generated once per process.
const geometry::SdfGrid& LinkGrid(const std::string& link) {
  static std::map<std::string, geometry::SdfGrid> grids;
  auto it = grids.find(link);
  if (it == grids.end()) {
    const auto mesh = robot::LinkCollisionMesh(Robot(), Robot().LinkIndex(link));
    it = grids.emplace(link, *geometry::GenerateSdf(*mesh, link, kUrdf, {})).first;
  }
  return it->second;
}

// Query points: uniformly within the part of the grid where the collision
// cost is active (up to 0.08 m from the link's bounding box).
std::vector<Vec3> QueryPoints(const geometry::SdfGrid& grid, int count, unsigned seed) {
  std::mt19937 rng(seed);
  const Vec3 lo = grid.info().origin, hi = grid.info().GridMax();
  std::vector<Vec3> points(count);
  for (Vec3& p : points) {
    for (int i = 0; i < 3; ++i) p[i] = std::uniform_real_distribution<double>(lo[i], hi[i])(rng);
  }
  return points;
}

void BM_SdfValueAndGradient(benchmark::State& state, const std::string& link) {
  const geometry::SdfGrid& grid = LinkGrid(link);
  const std::vector<Vec3> points = QueryPoints(grid, 1 << 16, 1);
  size_t i = 0;
  double sum = 0;
  for (auto _ : state) {
    double d;
    Vec3 g;
    grid.Evaluate(points[i++ & 0xffff], &d, &g);
    sum += d + g.x();
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations());
  state.counters["grid_MB"] = grid.MemoryBytes() / 1e6;
}
BENCHMARK_CAPTURE(BM_SdfValueAndGradient, base_link, std::string("base_link"));
BENCHMARK_CAPTURE(BM_SdfValueAndGradient, link3, std::string("link3"));

// Spatially coherent queries (a point moving along a line), as the
// optimiser's samples of one obstacle point against one link are.
void BM_SdfValueAndGradientCoherent(benchmark::State& state) {
  const geometry::SdfGrid& grid = LinkGrid("base_link");
  const Vec3 lo = grid.info().origin, hi = grid.info().GridMax();
  size_t i = 0;
  double sum = 0;
  for (auto _ : state) {
    const double s = static_cast<double>(i++ & 0xffff) / 65536.0;
    double d;
    Vec3 g;
    grid.Evaluate(lo + s * (hi - lo), &d, &g);
    sum += d + g.x();
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SdfValueAndGradientCoherent);

void BM_GenerateAllLinks(benchmark::State& state) {
  const robot::RobotModel& model = Robot();
  std::vector<geometry::TriangleMesh> meshes;
  for (int link : model.CollisionLinks()) meshes.push_back(*robot::LinkCollisionMesh(model, link));
  geometry::SdfGenerationOptions options;
  options.num_threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    size_t bytes = 0;
    for (size_t i = 0; i < meshes.size(); ++i) {
      bytes += geometry::GenerateSdf(meshes[i], "link", kUrdf, options)->MemoryBytes();
    }
    state.counters["total_MB"] = bytes / 1e6;
  }
  state.counters["threads"] = options.num_threads;
}
BENCHMARK(BM_GenerateAllLinks)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace quadhand

BENCHMARK_MAIN();
