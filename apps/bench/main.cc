// quadhand-bench: the seeded trials of the window-and-cup benchmark
// (shared/spec/benchmark.md), one JSON line per trial. Trial k uses seed k,
// so any trial can be re-run alone (--first k --trials 1). docs/benchmark.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include "app_options.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/core/file_util.h"
#include "quadhand/core/log.h"
#include "quadhand/core/text.h"
#include "quadhand/opt/solver_registry.h"
#include "quadhand/planner/bench_config.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/mission_plan.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/planner/task.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/solvers/builtin_solvers.h"

namespace {

using namespace quadhand;
using Clock = std::chrono::steady_clock;

int Fail(const std::string& message) {
  core::PrintError("quadhand-bench", message);
  return 2;
}

// Trial k's start: uniform in the box, yaw and joint ranges, redrawn (same
// generator) while the robot is within the safety distance of the scene.
bool DrawStart(unsigned seed, const planner::BenchConfig& config, const robot::RobotModel& robot,
               const env::ExactMeshModel& exact, double safety, planner::BoundaryState* start) {
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
    if (env::WholeBodyClearance(kinematics, exact, safety + 0.01, {}, nullptr) >= safety + 0.005) return true;
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

// Per (representation, solver) tallies for the summary lines, and per
// target speed when the target moves.
struct Tally {
  int trials = 0, successes = 0, certified = 0;
  std::vector<double> solve_ms, front_ms, clearances, tool_errors;
};

// Trial k's motion of a moving target (BenchTarget): its speed bin, a
// heading drawn with seed k, and the sign of the motion.
struct TrialTarget {
  double speed = 0.0, heading = 0.0;
  Vec3 velocity = Vec3::Zero();
};

TrialTarget DrawTarget(unsigned seed, const planner::BenchTarget& target) {
  // Its own generator (the start keeps the draws it had without a target).
  std::mt19937_64 rng(0x9e3779b97f4a7c15ull ^ seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  TrialTarget trial;
  trial.speed = target.speeds[seed % target.speeds.size()];
  trial.heading = target.heading_min + unit(rng) * (target.heading_max - target.heading_min);
  if (unit(rng) < 0.5) trial.heading += M_PI;
  trial.velocity = trial.speed * Vec3(std::cos(trial.heading), std::sin(trial.heading), 0.0);
  return trial;
}

// "K/N" -> shard K of N (0 <= K < N).
bool ParseShard(const std::string& text, int* index, int* count) {
  const size_t slash = text.find('/');
  if (slash == std::string::npos) return false;
  try {
    size_t used_k = 0, used_n = 0;
    *index = std::stoi(text.substr(0, slash), &used_k);
    *count = std::stoi(text.substr(slash + 1), &used_n);
    if (used_k != slash || used_n != text.size() - slash - 1) return false;
  } catch (const std::exception&) {
    return false;
  }
  return *count >= 1 && *index >= 0 && *index < *count;
}

int main(int argc, char** argv) {
  CLI::App app{"quadhand-bench: seeded trials of the window-and-cup benchmark, one JSON line per\n"
               "(trial, representation, solver); trial k uses seed k. See docs/benchmark.md."};
  std::string config_path = core::FindBundledFile("data/bench/window_cup.yaml", QUADHAND_SOURCE_DIR), out_path, shard_text = "0/1";
  std::vector<std::string> representations = {"mrc_sdf"}, solver_names = {"lbfgs"};
  int trials = 100, first = 0;
  app.add_option("--config", config_path, "Benchmark config (YAML): the task and how trials draw their starts")
      ->capture_default_str();
  std::string planner_config_path;
  app.add_option("--planner-config", planner_config_path,
                 "Planner configuration (YAML, docs/configuration.md); keys left out keep their defaults");
  app.add_option("--trials", trials, "Number of trials")->capture_default_str()->check(CLI::Range(1, 1000000));
  app.add_option("--first", first, "Index (= seed) of the first trial")->capture_default_str();
  app.add_option("--solvers,--solver", solver_names,
                 "Optimiser back-ends, comma separated: lbfgs, ceres, ipopt, nlopt[:ALGORITHM] (docs/solvers.md)")
      ->delimiter(',')->capture_default_str();
  app.add_option("--representations,--representation", representations,
                 "Collision representations, comma separated: mrc_sdf, esdf, sfc")->delimiter(',')->capture_default_str();
  app.add_option("--shard", shard_text, "K/N: run only the trials k with k % N == K (for running on many machines)")
      ->capture_default_str();
  app.add_option("--out", out_path, "Results, one JSON line per (trial, representation, solver)")->required();
  std::vector<std::string> package_path;
  quadhand::apps::AddPackagePathOption(&app, &package_path);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }
  int shard = 0, shards = 1;
  if (!ParseShard(shard_text, &shard, &shards)) return Fail("--shard '" + shard_text + "': expected K/N with 0 <= K < N");
  if (first < 0) return Fail("--first must be >= 0");
  if (static_cast<long long>(first) + trials > std::numeric_limits<int>::max()) {
    return Fail("--first + --trials must stay below 2^31 (trial indices are seeds)");
  }
  // The output is checked before any trial runs, not after the last.
  if (core::Status s = core::CheckOutputPathAndFolder(out_path); !s.ok()) return Fail("--out: " + s.message());
  for (const std::string& input : {config_path, planner_config_path}) {
    if (!input.empty() && core::SameFile(out_path, input)) {
      return Fail("--out " + out_path + ": is an input of this run; refusing to overwrite it");
    }
  }
  if (std::error_code error; !std::filesystem::is_directory(core::DirectoryOf(out_path), error)) {
    return Fail("--out " + out_path + ": its folder does not exist");
  }
  if (core::Status s = solvers::RegisterBuiltinSolvers(); !s.ok()) return Fail(s.message());
  std::vector<std::unique_ptr<opt::Solver>> solver_list;
  for (const std::string& name : solver_names) {
    auto solver = opt::CreateSolver(name);
    if (!solver.ok()) return Fail("--solvers: " + solver.status().message());
    if (!(*solver)->available()) return Fail("--solvers: '" + name + "' was built without its library");
    solver_list.push_back(std::move(*solver));
  }
  for (const std::string& name : representations) {
    if (core::Status s = planner::CheckRepresentationName(name); !s.ok()) return Fail("--representations: " + s.message());
  }
  auto config = planner::LoadBenchConfig(config_path);
  if (!config.ok()) return Fail(config.status().message());
  auto planner_config = planner::LoadPlannerConfigOrDefaults(planner_config_path);
  if (!planner_config.ok()) return Fail(planner_config.status().message());
  planner::PlanningContextOptions context_options = planner::ContextOptions(*planner_config, representations);
  context_options.front_end_also_contain = {config->box_min, config->box_max};
  if (config->target) {
    // A trial's target is within pass_time x its speed of its place in the
    // task at any arrival up to twice pass_time: the front end's map covers
    // that, in every heading drawn.
    auto task = planner::LoadTask(config->task_path);
    if (!task.ok()) return Fail(task.status().message());
    if (task->tool) {
      const double reach = config->target->pass_time *
                           *std::max_element(config->target->speeds.begin(), config->target->speeds.end());
      for (int corner = 0; corner < 4; ++corner) {
        const double heading = corner % 2 == 0 ? config->target->heading_min : config->target->heading_max;
        const double sign = corner < 2 ? 1.0 : -1.0;
        context_options.front_end_also_contain.push_back(task->tool->position +
                                                         sign * reach * Vec3(std::cos(heading), std::sin(heading), 0.0));
      }
    }
  }
  if (core::SameFile(out_path, config->task_path)) {
    return Fail("--out " + out_path + ": is an input of this run; refusing to overwrite it");
  }
  robot::PrependRosPackagePath(package_path);
  auto context = planner::PlanningContext::Load(config->task_path, context_options);
  if (!context.ok()) return Fail(context.status().message());
  if (config->target && (*context)->moving_scene() == nullptr) {
    return Fail(config_path + ": target: the task's goal.tool has no motion (" + config->task_path +
                "): a trial moves the target the task says moves, with its moving_points");
  }
  const planner::Task* task = &(*context)->task();
  const robot::RobotModel* robot = &(*context)->robot();
  const env::ExactMeshModel* exact = &(*context)->exact();
  // Every trial's start is drawn before anything is printed, so that a start
  // box with no free start is refused in the one line of bad input.
  const int mine = (trials + shards - 1 - ((shard - first % shards + shards) % shards)) / shards;
  std::map<int, planner::BoundaryState> starts;
  for (int k = first; k < first + trials; ++k) {
    if (k % shards != shard) continue;
    planner::BoundaryState start = task->start;
    if (!DrawStart(static_cast<unsigned>(k), *config, *robot, *exact, task->safety_distance, &start)) {
      return Fail(config_path + ": start_box: trial " + std::to_string(k) +
                  ": no start clear of the scene by the safety distance in 1000 draws");
    }
    start.joint_rates = VecX::Zero(robot->num_actuated());
    starts.emplace(k, std::move(start));
  }
  std::fprintf(stderr, "loaded %s and built %zu representation(s)\n", config->task_path.c_str(),
               representations.size());
  for (const std::string& repair : robot::TakeMeshRepairReports()) {
    std::fprintf(stderr, "quadhand-bench: %s\n", repair.c_str());
  }
  for (const std::string& caution : planner::TaskCautions(*task)) {
    std::fprintf(stderr, "quadhand-bench: caution: %s\n", caution.c_str());
  }
  const planner::PlannerOptions options = planner_config->planner;

  std::ostringstream lines;
  std::map<std::string, Tally> tallies;
  // A mission's phases depend on the task, not on the start: each
  // representation's are built by its first trial and kept.
  std::vector<planner::MissionPhaseCache> phases((*context)->representations().size());
  int done = 0;
  for (const auto& [k, start] : starts) {
    planner::Task trial = *task;
    trial.start = start;
    // A moving target: this trial's motion, passing the task's place for it
    // at pass_time, with the moving points placed alike.
    std::optional<TrialTarget> target;
    std::unique_ptr<planner::MovingSceneModels> moving;
    if (config->target) {
      target = DrawTarget(static_cast<unsigned>(k), *config->target);
      const Pose placement = MakePose(-target->velocity * config->target->pass_time, Mat3::Identity());
      trial.tool->position = placement * task->tool->position;
      trial.tool->moving->motion =
          planner::TargetMotion::Constant(trial.tool->position, target->velocity, Vec3::Zero(), 0.0);
      auto built = (*context)->MovingSceneFor(trial.tool->moving->motion, placement);
      if (!built.ok()) return Fail(built.status().message());
      moving = std::move(*built);
    }
    for (size_t ri = 0; ri < (*context)->representations().size(); ++ri) {
      const planner::Representation& model = (*context)->representations()[ri];
      for (size_t si = 0; si < solver_list.size(); ++si) {
        const auto plan_start = std::chrono::steady_clock::now();
        core::Result<planner::PlanResult> result = core::Status::Internal("not planned");
        if (moving) {
          planner::PlanningScene scene = (*context)->Scene(ri);
          scene.moving = &moving->scene;
          result = planner::Plan(scene, trial, options, *solver_list[si]);
        } else {
          result = planner::PlanTask(**context, trial, ri, options, *solver_list[si], &phases[ri]);
        }
        const double plan_ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - plan_start).count();
        nlohmann::json line;
        line["trial"] = k;
        line["seed"] = k;
        line["representation"] = model.name;
        line["solver"] = solver_names[si];
        line["start"] = {{"position", {trial.start.position.x(), trial.start.position.y(), trial.start.position.z()}},
                         {"yaw", trial.start.yaw},
                         {"joints", std::vector<double>(trial.start.joints.data(),
                                                        trial.start.joints.data() + trial.start.joints.size())}};
        std::string tally_name = model.name + " + " + solver_names[si];
        if (target) {
          line["target"] = {{"speed_mps", target->speed},
                            {"heading_rad", target->heading},
                            {"velocity", {target->velocity.x(), target->velocity.y(), target->velocity.z()}}};
          tally_name += core::Format(" @ target %.2f m/s", target->speed);
        }
        Tally& tally = tallies[tally_name];
        ++tally.trials;
        if (!result.ok()) {
          line["success"] = false;
          line["status"] = "invalid_input";
          line["failure"] = result.status().message();
        } else {
          line["success"] = result->success;
          line["status"] = planner::PlanStatusName(result->status);
          line["failure"] = result->success ? "" : result->message;
          line["solve_ms"] = result->solve_ms;
          line["front_end_ms"] = result->front_end_ms;
          line["post_check_ms"] = result->post_check_ms;
          line["representation_build_ms"] = model.build_ms + result->per_plan_collision_ms;
          line["iterations"] = result->iterations;
          line["cost_evaluations"] = result->evaluations;
          line["attempts"] = result->attempts.size();
          // Why each re-solve was needed: the attempts that failed their post-check.
          nlohmann::json failed_checks = nlohmann::json::array();
          for (const planner::PlanAttempt& attempt : result->attempts) {
            if (!attempt.post_check_failure.empty()) failed_checks.push_back(attempt.post_check_failure);
          }
          line["attempt_failures"] = failed_checks;
          line["initial_guess"] = result->initial_guess;
          line["min_clearance_m"] = result->post_check.min_clearance_model;
          line["min_clearance_exact_m"] = result->post_check.min_clearance_exact;
          line["certified"] = result->post_check.certified;
          line["certified_clearance_m"] = result->post_check.certified_clearance;
          line["certificate_samples"] = result->post_check.certificate_samples;
          line["duration_s"] = result->trajectory ? result->trajectory->duration() : 0.0;
          // The whole plan after loading: every stage, a mission's phases included.
          line["plan_ms"] = plan_ms;
          if (!trial.mission.empty()) {
            line["mission_phase_build_ms"] = result->mission_phase_ms;
            nlohmann::json steps = nlohmann::json::array();
            for (const planner::StepResult& step : result->steps) {
              steps.push_back({{"kind", planner::StepKindName(step.kind)}, {"planned", step.planned},
                               {"certified", step.certified}});
            }
            line["steps"] = steps;
          }
          if (result->moving_target && result->trajectory && result->insertion.tool_link >= 0) {
            // How far the tool is from the target where it is at the grasp.
            const planner::WholeBodySample last = result->trajectory->Sample(result->trajectory->duration());
            const Vec3 tool = robot::LinkPose(*robot, last.BasePose(), last.joints, result->insertion.tool_link)
                                  .translation();
            const double error = (tool - result->insertion.tool_position).norm();
            line["tool_to_target_m"] = error;
            line["arrival_s"] = result->trajectory->duration();
            if (result->success) tally.tool_errors.push_back(error);
          }
          tally.front_ms.push_back(result->front_end_ms);
          if (result->success && result->post_check.certified) ++tally.certified;
          if (result->success) {
            ++tally.successes;
            tally.solve_ms.push_back(result->solve_ms);
            tally.clearances.push_back(result->post_check.min_clearance_exact);
          }
        }
        lines << line.dump() << '\n';
        std::fprintf(stderr, "[%d/%d] trial %d %s + %s: %s%s%s\n", done + 1, mine, k, model.name.c_str(),
                     solver_names[si].c_str(), line["success"].get<bool>() ? "success" : "FAILED",
                     line["success"].get<bool>() ? "" : ": ", line["failure"].get<std::string>().c_str());
      }
    }
    ++done;
  }
  if (core::Status s = core::WriteFileAtomically(out_path, lines.str()); !s.ok()) return Fail(s.message());
  for (const auto& [name, t] : tallies) {
    std::printf("%s: %d/%d successful (%.1f %%); solve ms over successes: median %.1f, p95 %.1f; front end median "
                "%.2f ms; min exact clearance over successes: min %.4f, median %.4f m\n",
                name.c_str(), t.successes, t.trials, 100.0 * t.successes / std::max(1, t.trials),
                Percentile(t.solve_ms, 0.5), Percentile(t.solve_ms, 0.95), Percentile(t.front_ms, 0.5),
                t.clearances.empty() ? NAN : *std::min_element(t.clearances.begin(), t.clearances.end()),
                Percentile(t.clearances, 0.5));
    if (!t.tool_errors.empty() || config->target) {
      std::printf("  certified %d/%d (%.1f %%); tool to target at the grasp over successes: median %.2f mm, max "
                  "%.2f mm\n",
                  t.certified, t.trials, 100.0 * t.certified / std::max(1, t.trials),
                  1e3 * Percentile(t.tool_errors, 0.5),
                  t.tool_errors.empty() ? NAN : 1e3 * *std::max_element(t.tool_errors.begin(), t.tool_errors.end()));
    }
  }
  return 0;
}
