// Cost of the whole-body objective on the window-and-cup scene
// (shared/spec/benchmark.md): one evaluation with gradient, split by layer;
// MRC-SDF point-link queries per second; growth with cloud size and pieces.
// Needs the default link SDFs (data/sdf/quadhand, made by scripts/quickstart.sh).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <random>

#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/planner/whole_body_problem.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/scene/point_cloud.h"
#include "quadhand/solvers/lbfgs_solver.h"

namespace quadhand {
namespace {

const std::string kRoot = QUADHAND_SOURCE_DIR;

struct Scene {
  robot::RobotModel robot;
  std::vector<Vec3> points;
  std::vector<int> links;
  std::vector<geometry::SdfGrid> grids;
  planner::BoundaryState start, goal;
  planner::Limits limits;
  planner::InsertionGoal insertion;
};

const Scene& WindowCup() {
  static const Scene scene = [] {
    auto robot = robot::RobotModel::LoadFromUrdfFile(kRoot + "/meshes/quadhand/quadhand.urdf");
    auto cloud = scene::LoadPcd(kRoot + "/data/scenes/window_cup.pcd");
    if (!robot.ok() || !cloud.ok()) {
      std::fprintf(stderr, "cannot load the robot or the scene\n");
      std::exit(2);
    }
    Scene s{std::move(*robot), std::move(cloud->points), {}, {}, {}, {}, {}, {}};
    for (int link : s.robot.CollisionLinks()) {
      auto grid = geometry::SdfGrid::Load(kRoot + "/data/sdf/quadhand/" + s.robot.link(link).name + ".qhsdf");
      if (!grid.ok()) {
        std::fprintf(stderr, "%s\nrun scripts/quickstart.sh first (it generates the link SDFs)\n",
                     grid.status().message().c_str());
        std::exit(2);
      }
      s.links.push_back(link);
      s.grids.push_back(std::move(*grid));
    }
    // Terminal state of the benchmark: hover, yaw pi, joints (0.6, pi/2 - 0.6, 0),
    // tool at (-3.2, 0, 0.86); the base position follows from kinematics.
    s.goal.yaw = M_PI;
    s.goal.joints = Vec3(0.6, M_PI / 2 - 0.6, 0.0);
    const Pose hover = MakePose(Vec3::Zero(), Eigen::AngleAxisd(M_PI, Vec3::UnitZ()).toRotationMatrix());
    const int tool = s.robot.LinkIndex("tool");
    const Vec3 tool_offset = robot::LinkPose(s.robot, hover, s.goal.joints, tool).translation();
    s.goal.position = Vec3(-3.2, 0.0, 0.86) - tool_offset;
    s.start.position = Vec3(0.5, 0.2, 1.2);
    s.start.yaw = M_PI;
    s.start.joints = Vec3(0.3, -0.2, 0.0);
    s.limits.joint_rate_max = s.robot.VelocityLimits();
    s.limits.joint_lower = s.robot.LowerLimits();
    s.limits.joint_upper = s.robot.UpperLimits();
    s.insertion.enabled = true;
    s.insertion.tool_link = tool;
    s.insertion.tool_position = Vec3(-3.2, 0.0, 0.86);
    s.insertion.tool_orientation = Quat(robot::LinkPose(s.robot, hover, s.goal.joints, tool).linear());
    s.insertion.direction = -Vec3::UnitZ();
    s.insertion.length = 0.10;
    return s;
  }();
  return scene;
}

// A path through both windows; `pieces` waypoints resampled along it by arc length.
MatX PathWaypoints(const Scene& s, int pieces) {
  std::vector<Vec3> corners = {s.start.position, Vec3(-0.6, 0.0, 0.95), Vec3(-1.4, 0.0, 1.0), Vec3(-1.9, 0.0, 1.55),
                               Vec3(-2.5, 0.0, 1.55), s.goal.position + Vec3(0, 0, 0.10), s.goal.position};
  std::vector<double> cumulative = {0.0};
  for (size_t i = 1; i < corners.size(); ++i) cumulative.push_back(cumulative.back() + (corners[i] - corners[i - 1]).norm());
  MatX waypoints(3, pieces - 1);
  for (int i = 1; i < pieces; ++i) {
    const double target = cumulative.back() * i / pieces;
    size_t k = 1;
    while (k + 1 < cumulative.size() && cumulative[k] < target) ++k;
    const double f = (target - cumulative[k - 1]) / (cumulative[k] - cumulative[k - 1]);
    waypoints.col(i - 1) = corners[k - 1] + f * (corners[k] - corners[k - 1]);
  }
  return waypoints;
}

struct Problem {
  std::unique_ptr<env::MrcSdfModel> model;
  std::unique_ptr<planner::WholeBodyProblem> problem;
  VecX x;
};

Problem MakeProblem(const std::vector<Vec3>& points, int pieces) {
  const Scene& s = WindowCup();
  Problem p;
  p.model = std::move(*env::MrcSdfModel::Create(s.links, s.grids, points));
  p.problem = std::move(*planner::WholeBodyProblem::Create(s.robot, *p.model, s.start, s.goal, s.limits, s.insertion,
                                                           planner::WholeBodyCostOptions{}, pieces));
  MatX aux(4, pieces - 1);
  for (int i = 0; i < pieces - 1; ++i) {
    const double f = (i + 1.0) / pieces;
    aux(0, i) = M_PI;
    aux.block(1, i, 3, 1) = (1 - f) * s.start.joints + f * s.goal.joints;
  }
  p.x = p.problem->Pack(PathWaypoints(s, pieces), aux, VecX::Constant(pieces, 5.0 / pieces));
  return p;
}

void BM_ObjectiveWithGradient(benchmark::State& state) {
  const Problem p = MakeProblem(WindowCup().points, static_cast<int>(state.range(0)));
  double cost;
  VecX grad;
  for (auto _ : state) {
    p.problem->Evaluate(p.x, &cost, &grad);
    benchmark::DoNotOptimize(grad.data());
  }
  const auto terms = *p.problem->Breakdown(p.x);
  state.counters["collision_term"] = terms.Term("collision");
  state.counters["samples"] = state.range(0) * (p.problem->options().samples_per_piece + 1);
}
BENCHMARK(BM_ObjectiveWithGradient)->Arg(5)->Arg(10)->Arg(20)->Arg(40)->Unit(benchmark::kMicrosecond);

void BM_ObjectiveValueOnly(benchmark::State& state) {
  const Problem p = MakeProblem(WindowCup().points, 10);
  double cost;
  for (auto _ : state) {
    p.problem->Evaluate(p.x, &cost, nullptr);
    benchmark::DoNotOptimize(cost);
  }
}
BENCHMARK(BM_ObjectiveValueOnly)->Unit(benchmark::kMicrosecond);

// The same evaluation with no obstacle near the robot: what everything but
// the collision queries costs (MINCO, flatness, kinematics, other penalties).
void BM_ObjectiveWithoutObstacles(benchmark::State& state) {
  const Problem p = MakeProblem({Vec3(100, 100, 100)}, 10);
  double cost;
  VecX grad;
  for (auto _ : state) {
    p.problem->Evaluate(p.x, &cost, &grad);
    benchmark::DoNotOptimize(grad.data());
  }
}
BENCHMARK(BM_ObjectiveWithoutObstacles)->Unit(benchmark::kMicrosecond);

// Scene resampled to `count` points (jittered copies or a subset) to show how
// the cost grows with cloud density.
std::vector<Vec3> Resampled(int count) {
  const std::vector<Vec3>& points = WindowCup().points;
  std::mt19937 rng(1);
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  std::normal_distribution<double> jitter(0.0, 0.003);
  std::vector<Vec3> out(count);
  for (Vec3& p : out) p = points[pick(rng)] + Vec3(jitter(rng), jitter(rng), jitter(rng));
  return out;
}

void BM_ObjectiveVsCloudSize(benchmark::State& state) {
  const Problem p = MakeProblem(Resampled(static_cast<int>(state.range(0))), 10);
  double cost;
  VecX grad;
  for (auto _ : state) {
    p.problem->Evaluate(p.x, &cost, &grad);
    benchmark::DoNotOptimize(grad.data());
  }
  state.counters["points"] = state.range(0);
}
BENCHMARK(BM_ObjectiveVsCloudSize)->Arg(10000)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMicrosecond);

// MRC-SDF point-link queries per second: every link at poses along the path,
// counting the points that reach an SDF lookup.
void BM_MrcSdfPointLinkQueries(benchmark::State& state) {
  const Scene& s = WindowCup();
  const Problem p = MakeProblem(s.points, 10);
  const auto trajectory = *p.problem->Trajectory(p.x);
  std::vector<robot::KinematicsState> states(200);
  for (size_t i = 0; i < states.size(); ++i) {
    const auto sample = trajectory.Sample(trajectory.duration() * i / (states.size() - 1));
    robot::ComputeKinematics(s.robot, sample.BasePose(), sample.joints, &states[i]);
  }
  // Count lookups once (a clearance search with the penalty's reach visits the same points).
  long lookups_per_pass = 0;
  for (const auto& k : states) {
    for (int link : s.links) {
      const Pose& X = k.link_poses[link];
      const auto& info = p.model->grid_of_link(link).info();
      const Vec3 lo = info.geometry_min - Vec3::Constant(0.04), hi = info.geometry_max + Vec3::Constant(0.04);
      const Vec3 c = X * (0.5 * (lo + hi)), h = X.linear().cwiseAbs() * (0.5 * (hi - lo));
      p.model->points().VisitBox(c - h, c + h, [&](const Vec3& x) {
        const Vec3 xl = X.linear().transpose() * (x - X.translation());
        lookups_per_pass += (xl.array() >= lo.array()).all() && (xl.array() <= hi.array()).all();
      });
    }
  }
  env::PenaltyParameters parameters{0.04, 0.01};
  for (auto _ : state) {
    double total = 0;
    for (const auto& k : states) {
      for (int link : s.links) {
        env::LinkWrench wrench;
        total += p.model->LinkPenalty(link, k.link_poses[link], parameters, {}, &wrench);
      }
    }
    benchmark::DoNotOptimize(total);
  }
  state.SetItemsProcessed(state.iterations() * lookups_per_pass);
  state.counters["lookups_per_pass"] = lookups_per_pass;
}
BENCHMARK(BM_MrcSdfPointLinkQueries)->Unit(benchmark::kMicrosecond);

// A full L-BFGS solve from the hand-made path through both windows (no front
// end yet): the optimiser's own cost, for the 50 ms design target.
void BM_SolveFromHandMadePath(benchmark::State& state) {
  Problem p = MakeProblem(WindowCup().points, 10);
  solvers::LbfgsSolver solver;
  opt::SolverOptions options;
  options.relative_cost_tolerance = 1e-5;
  options.max_iterations = 500;
  opt::SolveResult result;
  for (auto _ : state) {
    result = solver.Solve(*p.problem, p.x, options);
    benchmark::DoNotOptimize(result.cost);
  }
  const auto terms = *p.problem->Breakdown(result.x);
  state.counters["iterations"] = result.iterations;
  state.counters["evaluations"] = result.evaluations;
  state.counters["collision_term"] = terms.Term("collision");
  state.counters["insertion_term"] = terms.Term("insertion");
  state.counters["duration_s"] = terms.time;
  state.SetLabel(result.StatusName());
}
BENCHMARK(BM_SolveFromHandMadePath)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace quadhand

BENCHMARK_MAIN();
