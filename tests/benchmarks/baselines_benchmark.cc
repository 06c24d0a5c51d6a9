// The baseline representations on the window-and-cup scene
// (data/scenes/window_cup.pcd; shared/spec/benchmark.md):
//   - ESDF build at 0.02 m (OctoMap insertion, DynamicEDT3D update, dense copy),
//   - corridor generation along the front-end path from the task start
//     (0.5, 0.2, 1.2) through both windows to (-2.995, 0, 1.388), the point
//     0.10 m above the base goal where the insertion starts,
//   - one LinkPenalty (with wrench) per model, at the terminal state (the
//     open fingers around the cup: many samples within the threshold) and at
//     the start (nothing near).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <benchmark/benchmark.h>

#include "quadhand/env/esdf_model.h"
#include "quadhand/env/sfc_model.h"
#include "quadhand/planner/front_end.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/scene/point_cloud.h"

namespace quadhand {
namespace {

const std::string kRoot = QUADHAND_SOURCE_DIR;
const Vec3 kStart(0.5, 0.2, 1.2);
const Vec3 kPathGoal(-2.995, 0.0, 1.388);

struct Scene {
  robot::RobotModel robot;
  std::vector<Vec3> points;
  std::vector<int> links;
  std::vector<geometry::TriangleMesh> meshes;
  std::vector<Vec3> path;  // front-end shortcut path
  Pose start_base, goal_base;
  VecX start_joints, goal_joints;
};

const Scene& WindowCup() {
  static const Scene scene = [] {
    auto robot = robot::RobotModel::LoadFromUrdfFile(kRoot + "/meshes/quadhand/quadhand.urdf");
    auto cloud = scene::LoadPcd(kRoot + "/data/scenes/window_cup.pcd");
    if (!robot.ok() || !cloud.ok()) {
      std::fprintf(stderr, "cannot load the robot or the scene\n");
      std::exit(2);
    }
    Scene s{std::move(*robot), std::move(cloud->points), {}, {}, {}, {}, {}, {}, {}};
    for (int link : s.robot.CollisionLinks()) {
      s.links.push_back(link);
      s.meshes.push_back(*robot::LinkCollisionMesh(s.robot, link));
    }
    auto path = planner::FindBasePath(s.points, kStart, kPathGoal, planner::FrontEndOptions());
    if (!path.ok()) {
      std::fprintf(stderr, "front end: %s\n", path.status().message().c_str());
      std::exit(2);
    }
    s.path = path->shortcut;
    // Terminal state: yaw pi, joints (0.6, pi/2 - 0.6, 0), tool at (-3.2, 0, 0.86).
    const Mat3 yaw_pi = Eigen::AngleAxisd(M_PI, Vec3::UnitZ()).toRotationMatrix();
    s.goal_joints = Vec3(0.6, M_PI / 2 - 0.6, 0.0);
    const Vec3 tool_offset =
        robot::LinkPose(s.robot, MakePose(Vec3::Zero(), yaw_pi), s.goal_joints, s.robot.LinkIndex("tool"))
            .translation();
    s.goal_base = MakePose(Vec3(-3.2, 0.0, 0.86) - tool_offset, yaw_pi);
    s.start_base = MakePose(kStart, yaw_pi);
    s.start_joints = Vec3(0.3, -0.2, 0.0);
    return s;
  }();
  return scene;
}

void BM_EsdfBuild(benchmark::State& state) {
  const Scene& s = WindowCup();
  env::EsdfOptions options;
  options.resolution = 0.02;
  options.max_distance = 0.01 * static_cast<double>(state.range(0));
  double octomap = 0, edt = 0, grid = 0;
  long voxels = 0, cells = 0;
  for (auto _ : state) {
    auto model = env::EsdfModel::Create(s.links, s.meshes, s.points, options);
    if (!model.ok()) return state.SkipWithError(model.status().message().c_str());
    octomap += (*model)->octomap_seconds();
    edt += (*model)->edt_seconds();
    grid += (*model)->grid_seconds();
    voxels = (*model)->num_occupied_voxels();
    cells = static_cast<long>((*model)->dims().x()) * (*model)->dims().y() * (*model)->dims().z();
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["octomap_ms"] = 1e3 * octomap / n;
  state.counters["edt_update_ms"] = 1e3 * edt / n;
  state.counters["dense_copy_ms"] = 1e3 * grid / n;
  state.counters["occupied_voxels"] = static_cast<double>(voxels);
  state.counters["field_cells"] = static_cast<double>(cells);
}

void BM_CorridorGeneration(benchmark::State& state) {
  const Scene& s = WindowCup();
  double corridor = 0;
  long faces = 0, polytopes = 0;
  for (auto _ : state) {
    auto model = env::SfcModel::Create(s.links, s.meshes, s.points, s.path);
    if (!model.ok()) return state.SkipWithError(model.status().message().c_str());
    corridor += (*model)->corridor_seconds();
    polytopes = (*model)->num_polytopes();
    faces = 0;
    for (const env::Polytope& p : (*model)->polytopes()) faces += p.num_faces();
  }
  state.counters["corridor_ms"] = 1e3 * corridor / static_cast<double>(state.iterations());
  state.counters["polytopes"] = static_cast<double>(polytopes);
  state.counters["faces"] = static_cast<double>(faces);
  state.counters["path_length_m"] = planner::PathLength(s.path);
}

const env::EsdfModel& Esdf() {
  static const auto model = env::EsdfModel::Create(WindowCup().links, WindowCup().meshes, WindowCup().points);
  return **model;
}

const env::SfcModel& Sfc() {
  static const auto model = env::SfcModel::Create(WindowCup().links, WindowCup().meshes, WindowCup().points,
                                                  WindowCup().path);
  return **model;
}

// state.range(0): 0 = terminal state (fingers around the cup), 1 = start.
void LinkPenalty(benchmark::State& state, const env::CollisionModel& model, const char* link_name,
                 const env::LinkSurfaceSamples& (*samples_of)(int)) {
  const Scene& s = WindowCup();
  const bool at_goal = state.range(0) == 0;
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(s.robot, at_goal ? s.goal_base : s.start_base, at_goal ? s.goal_joints : s.start_joints,
                           &kinematics);
  const int link = s.robot.LinkIndex(link_name);
  // The corridor model: the polytope of the last path segment at the goal, of the first at the start.
  const env::QueryContext context{at_goal ? static_cast<int>(s.path.size()) - 2 : 0, 0.0};
  const env::PenaltyParameters parameters{0.03, 0.01};
  double cost = 0;
  for (auto _ : state) {
    env::LinkWrench wrench;
    cost = model.LinkPenalty(link, kinematics.link_poses[link], parameters, context, &wrench);
    benchmark::DoNotOptimize(wrench);
  }
  state.counters["penalty"] = cost;
  state.counters["clearance"] = model.LinkClearance(link, kinematics.link_poses[link], 0.2, context);
  state.counters["samples"] = static_cast<double>(samples_of(link).points.size());
  state.SetLabel(at_goal ? "terminal state" : "start");
}

const env::LinkSurfaceSamples& EsdfSamples(int link) { return Esdf().samples_of_link(link); }
const env::LinkSurfaceSamples& SfcSamples(int link) { return Sfc().samples_of_link(link); }

void BM_EsdfLinkPenalty(benchmark::State& state) { LinkPenalty(state, Esdf(), "link3", &EsdfSamples); }
void BM_SfcLinkPenalty(benchmark::State& state) { LinkPenalty(state, Sfc(), "link3", &SfcSamples); }

}  // namespace
}  // namespace quadhand

// Argument: the EDT's max_distance in cm (20 is EsdfOptions' default).
BENCHMARK(quadhand::BM_EsdfBuild)->Arg(20)->Arg(50)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(quadhand::BM_CorridorGeneration)->Unit(benchmark::kMillisecond);
BENCHMARK(quadhand::BM_EsdfLinkPenalty)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
BENCHMARK(quadhand::BM_SfcLinkPenalty)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
