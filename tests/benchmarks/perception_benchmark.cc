// The rolling map's costs (docs/perception.md, "The rolling map"): one
// frame of 30,000 returns into the map (the target: <= 5 ms), at two
// resolutions, and moving the window. Two frames: a synthetic worst case (a
// depth camera's 87 x 58 degrees, every return at its own depth in 1-6 m:
// one ray per return), and a depth frame the simulator's camera renders of
// a forest (returns on trunk surfaces, 30,000 of them taken evenly), from
// an origin that moves 2 cm per frame as a flight's does. The second
// argument is the threads that walk the rays (RollingMapOptions::ray_threads),
// the third RollingMapOptions::stop_ray_after_crossed (0: whole rays).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "quadhand/explore/guide.h"
#include "quadhand/perception/rolling_map.h"
#include "quadhand/sim/sensor.h"

namespace {

using quadhand::Vec3;
using quadhand::perception::RollingMap;
using quadhand::perception::RollingMapOptions;

// 30,000 returns: directions spread over the camera's view along +x, each
// at a depth drawn in [1, 6] m (posts at random ranges), seeded.
std::vector<Vec3> Frame(const Vec3& origin, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> azimuth(-43.5, 43.5), elevation(-29.0, 29.0), depth(1.0, 6.0);
  std::vector<Vec3> points;
  points.reserve(30000);
  constexpr double kDegree = M_PI / 180.0;
  for (int n = 0; n < 30000; ++n) {
    const double a = azimuth(*rng) * kDegree, e = elevation(*rng) * kDegree, d = depth(*rng);
    points.push_back(origin + d * Vec3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)));
  }
  return points;
}

void BM_InsertFrame(benchmark::State& state) {
  RollingMapOptions options;
  options.resolution = state.range(0) / 100.0;
  options.ray_threads = static_cast<int>(state.range(1));
  options.stop_ray_after_crossed = static_cast<int>(state.range(2));
  auto map = RollingMap::Create(options);
  std::mt19937_64 rng(1);
  Vec3 origin(0.0, 0.0, 1.2);
  std::vector<std::vector<Vec3>> frames;
  for (int k = 0; k < 16; ++k) frames.push_back(Frame(origin + Vec3(0.02 * k, 0.0, 0.0), &rng));
  int k = 0;
  for (auto _ : state) {
    const Vec3 at = origin + Vec3(0.02 * (k % 16), 0.0, 0.0);
    benchmark::DoNotOptimize((*map)->Insert(frames[k % 16], at));
    ++k;
  }
  state.counters["known_voxels"] = static_cast<double>((*map)->num_known_voxels());
  state.counters["memory_MB"] = static_cast<double>((*map)->memory_bytes()) / 1e6;
}
BENCHMARK(BM_InsertFrame)->ArgsProduct({{10, 5}, {1, 2, 4, 8}, {0, 8}})->Unit(benchmark::kMillisecond)->UseRealTime();

// Trunks (radius 0.1-0.25 m, 4 m tall, points every 5 cm) at 0.15 per m^2
// over 20 x 8 m ahead of the camera; its depth frame from (0, 0, 1.2)
// looking along +x, 30,000 returns taken evenly, in the world frame.
std::vector<Vec3> ForestWorld() {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> x(1.0, 21.0), y(-4.0, 4.0), radius(0.1, 0.25);
  std::vector<Vec3> world;
  for (int tree = 0; tree < 24; ++tree) {
    const double cx = x(rng), cy = y(rng), r = radius(rng);
    const int around = static_cast<int>(std::ceil(2.0 * M_PI * r / 0.05));
    for (double z = 0.0; z <= 4.0; z += 0.05) {
      for (int k = 0; k < around; ++k) {
        const double a = 2.0 * M_PI * k / around;
        world.emplace_back(cx + r * std::cos(a), cy + r * std::sin(a), z);
      }
    }
  }
  return world;
}
std::vector<Vec3> RenderedForestFrame() {
  const std::vector<Vec3> world = ForestWorld();
  quadhand::sim::SensorConfig config;
  config.kind = quadhand::sim::SensorKind::kDepth;
  auto renderer = quadhand::sim::SensorRenderer::Create(world, config, 1);
  const quadhand::Pose camera = quadhand::MakePose(Vec3(0.0, 0.0, 1.2), quadhand::sim::DefaultMount(config.kind).linear());
  const std::vector<Vec3> seen = (*renderer)->Render(camera);
  std::vector<Vec3> frame;
  const size_t stride = std::max<size_t>(1, seen.size() / 30000);
  for (size_t i = 0; i < seen.size() && frame.size() < 30000; i += stride) frame.push_back(camera * seen[i]);
  return frame;
}

void BM_InsertRenderedFrame(benchmark::State& state) {
  RollingMapOptions options;
  options.resolution = state.range(0) / 100.0;
  options.ray_threads = static_cast<int>(state.range(1));
  options.stop_ray_after_crossed = static_cast<int>(state.range(2));
  auto map = RollingMap::Create(options);
  const std::vector<Vec3> frame = RenderedForestFrame();
  int k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize((*map)->Insert(frame, Vec3(0.02 * (k % 16), 0.0, 1.2)));
    ++k;
  }
  state.counters["returns"] = static_cast<double>(frame.size());
  state.counters["known_voxels"] = static_cast<double>((*map)->num_known_voxels());
}
BENCHMARK(BM_InsertRenderedFrame)->ArgsProduct({{10, 5}, {1, 2, 4, 8}, {0, 8}})->Unit(benchmark::kMillisecond)->UseRealTime();

// A flight's frame with and without a prior map (RollingMap::SetPrior; the
// argument: 1 with the whole forest as the prior): the window moved to the
// origin, then the rendered frame, one thread.
void BM_FlightFrameWithPrior(benchmark::State& state) {
  RollingMapOptions options;
  auto map = RollingMap::Create(options);
  const std::vector<Vec3> frame = RenderedForestFrame();
  (*map)->MoveWindow(Vec3(0.0, 0.0, 1.2));
  if (state.range(0) != 0) (void)(*map)->SetPrior(ForestWorld());
  int k = 0;
  for (auto _ : state) {
    const Vec3 at(0.02 * (k % 16), 0.0, 1.2);
    (*map)->MoveWindow(at);
    benchmark::DoNotOptimize((*map)->Insert(frame, at));
    ++k;
  }
  state.counters["prior_points"] = static_cast<double>((*map)->prior_points());
  state.counters["memory_MB"] = static_cast<double>((*map)->memory_bytes()) / 1e6;
}
BENCHMARK(BM_FlightFrameWithPrior)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// The local planner's scene at every replan (explore/local_planner.h): the
// boundary in its default box (12 x 12 x 4 m) about the vehicle, after a
// few rendered frames from nearby.
void BM_ObstacleBoundary(benchmark::State& state) {
  RollingMapOptions options;
  options.resolution = state.range(0) / 100.0;
  auto map = RollingMap::Create(options);
  const std::vector<Vec3> frame = RenderedForestFrame();
  for (int k = 0; k < 4; ++k) (void)(*map)->Insert(frame, Vec3(0.1 * k, 0.0, 1.2));
  const Vec3 start(0.3, 0.0, 1.2), half(6.0, 6.0, 2.0);
  size_t centres = 0;
  for (auto _ : state) {
    const std::vector<Vec3> boundary = (*map)->ObstacleBoundary(start - half, start + half);
    centres = boundary.size();
    benchmark::DoNotOptimize(boundary.data());
  }
  state.counters["boundary_voxels"] = static_cast<double>(centres);
}
BENCHMARK(BM_ObstacleBoundary)->Arg(10)->Arg(5)->Unit(benchmark::kMillisecond);

// The local planner's targets at every snapshot: the free voxels of its
// box joined to the start (RollingMap::ConnectedFree).
void BM_ConnectedFree(benchmark::State& state) {
  RollingMapOptions options;
  auto map = RollingMap::Create(options);
  const std::vector<Vec3> frame = RenderedForestFrame();
  for (int k = 0; k < 4; ++k) (void)(*map)->Insert(frame, Vec3(0.1 * k, 0.0, 1.2));
  const Vec3 start(0.3, 0.0, 1.2), half(6.0, 6.0, 2.0);
  (*map)->MarkFree(start, 0.5);
  size_t joined = 0;
  for (auto _ : state) {
    const quadhand::perception::FreeRegion region = (*map)->ConnectedFree(start - half, start + half, start);
    joined = static_cast<size_t>(std::count(region.in.begin(), region.in.end(), 1));
    benchmark::DoNotOptimize(region.in.data());
  }
  state.counters["joined_voxels"] = static_cast<double>(joined);
}
BENCHMARK(BM_ConnectedFree)->Unit(benchmark::kMillisecond);

// The local planner's guide at every snapshot (explore/guide.h): the way
// to a goal 20 m ahead through the whole window, round what the frames saw.
void BM_Guide(benchmark::State& state) {
  RollingMapOptions options;
  auto map = RollingMap::Create(options);
  const std::vector<Vec3> frame = RenderedForestFrame();
  for (int k = 0; k < 4; ++k) (void)(*map)->Insert(frame, Vec3(0.1 * k, 0.0, 1.2));
  const double cell = state.range(0) / 100.0;
  int blocked = 0;
  for (auto _ : state) {
    const quadhand::explore::Guide guide = quadhand::explore::Guide::Compute(**map, Vec3(20.0, 0.0, 1.2), cell, 1.0);
    blocked = guide.blocked_cells();
    benchmark::DoNotOptimize(guide.CostAt(Vec3(0.3, 0.0, 1.2)));
  }
  state.counters["blocked_cells"] = blocked;
}
BENCHMARK(BM_Guide)->Arg(40)->Arg(25)->Unit(benchmark::kMillisecond);

void BM_MoveWindow(benchmark::State& state) {
  RollingMapOptions options;
  auto map = RollingMap::Create(options);
  std::mt19937_64 rng(2);
  for (int k = 0; k < 30; ++k) (void)(*map)->Insert(Frame(Vec3(0.3 * k, 0.0, 1.2), &rng), Vec3(0.3 * k, 0.0, 1.2));
  double x = 0.0;
  for (auto _ : state) {
    (*map)->MoveWindow(Vec3(x, 0.0, 1.2));
    x += 0.01;
  }
  state.counters["known_voxels"] = static_cast<double>((*map)->num_known_voxels());
}
BENCHMARK(BM_MoveWindow)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
