// quadhand-bench: the seeded trials of the window-and-cup benchmark
// (shared/spec/benchmark.md), one JSON line per trial. Trial k uses seed k,
// so any trial can be re-run alone (--first k --trials 1). docs/benchmark.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "quadhand/core/file_util.h"
#include "quadhand/core/log.h"
#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/opt/solver_registry.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/representation.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/scene/point_cloud.h"
#include "quadhand/solvers/builtin_solvers.h"

namespace {

using namespace quadhand;
using Clock = std::chrono::steady_clock;

int Fail(const std::string& message) {
  std::fprintf(stderr, "quadhand-bench: error: %s\n", message.c_str());
  return 2;
}

struct BenchConfig {
  std::string task_path;
  Vec3 box_min, box_max;
  double yaw_min = -M_PI, yaw_max = M_PI;
};

core::Result<BenchConfig> LoadConfig(const std::string& path) {
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return text.status();
  BenchConfig config;
  try {
    const YAML::Node root = YAML::Load(*text);
    config.task_path = core::ResolvePath(core::DirectoryOf(path), root["task"].as<std::string>());
    for (int i = 0; i < 3; ++i) {
      config.box_min[i] = root["start_box"]["min"][i].as<double>();
      config.box_max[i] = root["start_box"]["max"][i].as<double>();
    }
    if (root["yaw"]) {
      config.yaw_min = root["yaw"][0].as<double>();
      config.yaw_max = root["yaw"][1].as<double>();
    }
  } catch (const YAML::Exception& e) {
    return core::Status::InvalidArgument(path + ": malformed benchmark config: " + e.msg);
  }
  if (!((config.box_min.array() <= config.box_max.array()).all() && config.box_min.allFinite() &&
        config.box_max.allFinite() && config.yaw_min <= config.yaw_max)) {
    return core::Status::InvalidArgument(path + ": start_box min must not exceed max");
  }
  return config;
}

// Trial k's start: uniform in the box, yaw and joint ranges, redrawn (same
// generator) while the robot is within the safety distance of the scene.
bool DrawStart(unsigned seed, const BenchConfig& config, const robot::RobotModel& robot,
               const planner::ExactClearance& exact, double safety, planner::BoundaryState* start) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const VecX lower = robot.LowerLimits(), upper = robot.UpperLimits();
  robot::KinematicsState kinematics;
  for (int attempt = 0; attempt < 1000; ++attempt) {
    for (int i = 0; i < 3; ++i) start->position[i] = config.box_min[i] + unit(rng) * (config.box_max[i] - config.box_min[i]);
    start->yaw = config.yaw_min + unit(rng) * (config.yaw_max - config.yaw_min);
    start->joints.resize(robot.num_actuated());
    for (int q = 0; q < robot.num_actuated(); ++q) start->joints[q] = lower[q] + unit(rng) * (upper[q] - lower[q]);
    start->velocity.setZero();
    start->acceleration.setZero();
    const Pose base = MakePose(start->position, Eigen::AngleAxisd(start->yaw, Vec3::UnitZ()).toRotationMatrix());
    robot::ComputeKinematics(robot, base, start->joints, &kinematics);
    if (exact.WholeBody(kinematics, safety + 0.01, nullptr) >= safety + 0.005) return true;
  }
  return false;
}

double Percentile(std::vector<double> values, double p) {
  if (values.empty()) return NAN;
  std::sort(values.begin(), values.end());
  const double index = p * (values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(index)), hi = std::min(values.size() - 1, lo + 1);
  return values[lo] + (index - lo) * (values[hi] - values[lo]);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"quadhand-bench: seeded trials of the window-and-cup benchmark, one JSON line per trial"};
  std::string config_path = "data/bench/window_cup.yaml", out_path, solver_name = "lbfgs", representation = "mrc_sdf";
  int trials = 100, first = 0;
  app.add_option("--config", config_path, "Benchmark config (YAML)")->capture_default_str();
  app.add_option("--trials", trials, "Number of trials")->capture_default_str()->check(CLI::Range(1, 1000000));
  app.add_option("--first", first, "Index (= seed) of the first trial")->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--solver", solver_name, "Optimiser back-end: lbfgs, ceres, ipopt, nlopt[:ALGORITHM] (docs/solvers.md)")->capture_default_str();
  app.add_option("--representation", representation, "Collision representation: mrc_sdf, esdf or sfc")->capture_default_str();
  app.add_option("--out", out_path, "Results, one JSON line per trial")->required();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }
  if (core::Status s = solvers::RegisterBuiltinSolvers(); !s.ok()) return Fail(s.message());
  auto solver = opt::CreateSolver(solver_name);
  if (!solver.ok()) return Fail("--solver: " + solver.status().message());
  auto config = LoadConfig(config_path);
  if (!config.ok()) return Fail(config.status().message());
  auto task = planner::LoadTask(config->task_path);
  if (!task.ok()) return Fail(task.status().message());
  auto robot = robot::RobotModel::LoadFromUrdfFile(task->robot_path);
  if (!robot.ok()) return Fail(robot.status().message());
  if (core::Status s = planner::ApplyRobot(*robot, &*task); !s.ok()) return Fail(s.message());
  auto cloud = scene::LoadPcd(task->scene_path);
  if (!cloud.ok()) return Fail(cloud.status().message());
  auto model = planner::MakeRepresentation(representation, *robot, task->sdf_dir, cloud->points);
  if (!model.ok()) return Fail(model.status().message());
  const double build_ms = model->build_ms;
  auto exact = planner::ExactClearance::Create(*robot, cloud->points);
  if (!exact.ok()) return Fail(exact.status().message());
  std::vector<Vec3> contain = {config->box_min, config->box_max};
  if (task->terminal) contain.push_back(task->terminal->position);
  auto front_end = planner::FrontEndMap::Build(cloud->points, planner::FrontEndOptions{}, contain);
  if (!front_end.ok()) return Fail(front_end.status().message());
  const planner::PlanningScene scene{*robot, *model->scene_model, **exact, *front_end, model->per_plan};
  const planner::PlannerOptions options = planner::DefaultPlannerOptions();

  std::ostringstream lines;
  std::vector<double> solve_ms, front_ms, clearances;
  int successes = 0;
  for (int k = first; k < first + trials; ++k) {
    planner::Task trial = *task;
    if (!DrawStart(static_cast<unsigned>(k), *config, *robot, **exact, task->safety_distance, &trial.start)) {
      return Fail("trial " + std::to_string(k) + ": no collision-free start found in 1000 draws");
    }
    trial.start.joint_rates = VecX::Zero(robot->num_actuated());
    auto result = planner::Plan(scene, trial, options, **solver);
    nlohmann::json line;
    line["trial"] = k;
    line["seed"] = k;
    line["representation"] = representation;
    line["solver"] = solver_name;
    line["start"] = {{"position", {trial.start.position.x(), trial.start.position.y(), trial.start.position.z()}},
                     {"yaw", trial.start.yaw},
                     {"joints", std::vector<double>(trial.start.joints.data(), trial.start.joints.data() + trial.start.joints.size())}};
    if (!result.ok()) {
      line["success"] = false;
      line["status"] = "invalid_input";
      line["failure"] = result.status().message();
    } else {
      line["success"] = result->success;
      line["status"] = result->status;
      line["failure"] = result->success ? "" : result->message;
      line["solve_ms"] = result->solve_ms;
      line["front_end_ms"] = result->front_end_ms;
      line["representation_build_ms"] = build_ms + result->per_plan_collision_ms;
      line["iterations"] = result->iterations;
      line["cost_evaluations"] = result->evaluations;
      line["attempts"] = result->attempts.size();
      line["min_clearance_m"] = result->post_check.min_clearance_model;
      line["min_clearance_exact_m"] = result->post_check.min_clearance_exact;
      line["duration_s"] = result->trajectory ? result->trajectory->duration() : 0.0;
      front_ms.push_back(result->front_end_ms);
      if (result->success) {
        ++successes;
        solve_ms.push_back(result->solve_ms);
        clearances.push_back(result->post_check.min_clearance_exact);
      }
    }
    lines << line.dump() << '\n';
    std::fprintf(stderr, "trial %d: %s%s%s\n", k, line["success"].get<bool>() ? "success" : "FAILED",
                 line["success"].get<bool>() ? "" : ": ", line["failure"].get<std::string>().c_str());
  }
  if (core::Status s = core::WriteFileAtomically(out_path, lines.str()); !s.ok()) return Fail(s.message());
  std::printf("%d/%d successful (%.1f %%); solve ms over successes: median %.1f, p95 %.1f; front end median %.2f ms; "
              "min exact clearance over successes: min %.4f, median %.4f m\n",
              successes, trials, 100.0 * successes / trials, Percentile(solve_ms, 0.5), Percentile(solve_ms, 0.95),
              Percentile(front_ms, 0.5), clearances.empty() ? NAN : *std::min_element(clearances.begin(), clearances.end()),
              Percentile(clearances, 0.5));
  return 0;
}
