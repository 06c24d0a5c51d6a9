// Front end on the window-and-cup scene (data/scenes/window_cup.pcd): building
// the map (distance grid + point index) once per scene, and one query (A* +
// shortcut) from the task start (0.5, 0.2, 1.2) and from a far corner of the
// start box to the base goal.
#include <string>

#include <benchmark/benchmark.h>

#include "quadhand/planner/front_end.h"
#include "quadhand/scene/point_cloud.h"

namespace {

using quadhand::Vec3;
using quadhand::planner::FrontEndMap;
using quadhand::planner::FrontEndOptions;

const Vec3 kGoal(-2.995, 0.0, 1.29);

const std::vector<Vec3>& Cloud() {
  static const std::vector<Vec3> points = [] {
    auto cloud = quadhand::scene::LoadPcd(std::string(QUADHAND_SOURCE_DIR) + "/data/scenes/window_cup.pcd");
    return cloud.ok() ? cloud->points : std::vector<Vec3>{};
  }();
  return points;
}

void BM_BuildMap(benchmark::State& state) {
  if (Cloud().empty()) return state.SkipWithError("cannot load data/scenes/window_cup.pcd");
  for (auto _ : state) {
    auto map = FrontEndMap::Build(Cloud(), FrontEndOptions(), {Vec3(0, -1, 0.8), Vec3(1, 1, 1.8), kGoal});
    if (!map.ok()) return state.SkipWithError(map.status().message().c_str());
    benchmark::DoNotOptimize(map->num_blocked());
  }
  state.counters["points"] = static_cast<double>(Cloud().size());
}

void BM_Query(benchmark::State& state, Vec3 start) {
  if (Cloud().empty()) return state.SkipWithError("cannot load data/scenes/window_cup.pcd");
  auto map = FrontEndMap::Build(Cloud(), FrontEndOptions(), {Vec3(0, -1, 0.8), Vec3(1, 1, 1.8), kGoal});
  if (!map.ok()) return state.SkipWithError(map.status().message().c_str());
  long expansions = 0, corners = 0;
  double search = 0.0, shortcut = 0.0;
  for (auto _ : state) {
    auto path = map->FindPath(start, kGoal);
    if (!path.ok()) return state.SkipWithError(path.status().message().c_str());
    expansions = path->expansions;
    corners = static_cast<long>(path->shortcut.size());
    search += path->search_seconds;
    shortcut += path->shortcut_seconds;
  }
  state.counters["expansions"] = static_cast<double>(expansions);
  state.counters["corners"] = static_cast<double>(corners);
  state.counters["astar_ms"] = 1e3 * search / static_cast<double>(state.iterations());
  state.counters["shortcut_ms"] = 1e3 * shortcut / static_cast<double>(state.iterations());
}

}  // namespace

BENCHMARK(BM_BuildMap)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Query, task_start, Vec3(0.5, 0.2, 1.2))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Query, corner_start, Vec3(1.0, -1.0, 1.8))->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
