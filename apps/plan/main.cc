// quadhand-plan: a task (YAML) on a point-cloud scene (PCD) -> a verified
// whole-body trajectory (CSV), a report (JSON) and optionally a 3-D page.
// Contract: shared/spec/contracts.md; options: docs/plan.md.
// Exit codes: 0 success, 1 planning ran but no plan passed the post-check
// (the report says why), 2 bad input (one line on stderr).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "app_options.h"
#include "quadhand/core/file_util.h"
#include "quadhand/core/log.h"
#include "quadhand/core/text.h"
#include "quadhand/opt/solver_registry.h"
#include "quadhand/planner/plan_output.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/mission_plan.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/planner/task.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/solvers/builtin_solvers.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/viz/html_view.h"

namespace {

using namespace quadhand;
using Clock = std::chrono::steady_clock;

constexpr int kExitNoPlan = 1;
constexpr int kExitBadInput = 2;

int Fail(const std::string& message) {
  core::PrintError("quadhand-plan", message);
  return kExitBadInput;
}

double Ms(Clock::time_point since) { return std::chrono::duration<double, std::milli>(Clock::now() - since).count(); }

// The 3-D page: the cloud, the base and tool paths, the link meshes along the plan.
core::Result<std::string> HtmlPage(const planner::PlanResult& result, const robot::RobotModel& robot,
                                   const std::vector<Vec3>& points, const std::string& task_path,
                                   const planner::Task& task, const planner::MovingScene* moving,
                                   const std::vector<Vec3>& moving_points) {
  const std::string& tool_link = task.tool_link;
  viz::HtmlViewData data;
  data.title = "QuadHand plan: " + task_path;
  data.points = points;
  const std::vector<int> links = robot.CollisionLinks();
  for (int link : links) {
    auto mesh = robot::LinkCollisionMesh(robot, link);
    if (!mesh.ok()) return mesh.status();
    data.links.push_back({robot.link(link).name, std::move(*mesh)});
  }
  // A mission's objects: each grasped one drawn where it lies, then with
  // the tool while held (its leg's robot carries it as its last link), then
  // where it was let go.
  struct DrawnObject {
    long grasp_step;
    Pose pose;  // where it is now, as the samples advance
  };
  std::vector<DrawnObject> objects;
  for (size_t i = 0; i < task.mission.size(); ++i) {
    if (task.mission[i].kind != planner::StepKind::kGrasp) continue;
    for (const planner::MissionLeg& leg : result.mission_legs) {
      if (leg.held_grasp_step != static_cast<long>(i) || leg.object_link < 0) continue;
      auto mesh = robot::LinkCollisionMesh(*leg.robot, leg.object_link);
      if (!mesh.ok()) return mesh.status();
      data.links.push_back({planner::StepName(task.mission, i) + " object", std::move(*mesh)});
      objects.push_back({static_cast<long>(i), task.mission[i].object.pose});
      break;
    }
  }
  const planner::WholeBodyTrajectory& trajectory = *result.trajectory;
  const int tool = robot.LinkIndex(tool_link);
  robot::KinematicsState kinematics, held;
  const int steps = std::max(2, static_cast<int>(std::ceil(trajectory.duration() / 0.02)));
  for (int k = 0; k <= steps; ++k) {
    const double t = trajectory.duration() * k / steps;
    const planner::WholeBodySample s = trajectory.Sample(t);
    robot::ComputeKinematics(robot, s.BasePose(), s.joints, &kinematics);
    data.times.push_back(t);
    std::vector<Pose> poses;
    for (int link : links) poses.push_back(kinematics.link_poses[link]);
    for (DrawnObject& object : objects) {
      for (const planner::MissionLeg& leg : result.mission_legs) {
        if (leg.held_grasp_step != object.grasp_step || t < leg.start_s || t > leg.end_s) continue;
        robot::ComputeKinematics(*leg.robot, s.BasePose(), s.joints, &held);
        object.pose = held.link_poses[leg.object_link];
        break;
      }
      poses.push_back(object.pose);
    }
    data.link_poses.push_back(std::move(poses));
    if (moving != nullptr) data.moving_displacements.push_back(moving->motion->Displacement(t));
    data.base_path.push_back(s.position);
    if (tool >= 0) data.tool_path.push_back(kinematics.link_poses[tool].translation());
  }
  if (moving != nullptr) data.moving_points = moving_points;
  if (result.insertion.enabled) {
    data.has_insertion = true;
    data.insertion_end = result.insertion.tool_position;
    data.insertion_start = result.insertion.tool_position - result.insertion.length * result.insertion.direction;
  }
  char summary[512];
  std::snprintf(summary, sizeof(summary),
                "%s\nduration %.2f s, optimisation %.1f ms\nmin clearance %s%.4f m (exact link meshes)\n%s",
                result.success ? "SUCCESS: passed the post-check" : "FAILED the post-check", trajectory.duration(),
                result.solve_ms, result.post_check.min_clearance_exact_is_bound ? ">= " : "",
                result.post_check.min_clearance_exact, result.message.c_str());
  data.summary = summary;
  for (size_t i = 0; i < result.steps.size() && i < task.mission.size(); ++i) {
    const planner::StepResult& step = result.steps[i];
    data.summary += "\n" + planner::StepName(task.mission, i) +
                    (step.planned ? core::Format(": %.2f to %.2f s%s", step.start_s, step.end_s,
                                                 step.certified ? "" : ", NOT certified")
                                  : std::string(": not planned"));
  }
  return viz::RenderHtmlView(data);
}

}  // namespace

int main(int argc, char** argv) {
  const auto start_time = Clock::now();
  CLI::App app{
      "quadhand-plan: plan a whole-body trajectory for a task (YAML) on a point-cloud scene (PCD).\n"
      "Writes the plan (CSV), a report (JSON) and optionally a 3-D page (HTML); see docs/plan.md.\n"
      "Exit codes: 0 a plan passed the post-check, 1 no plan passed it (the report says why),\n"
      "2 bad input."};
  std::string task_path, out_path, report_path, html_path, solver_name = "lbfgs", representation = "mrc_sdf";
  double dt = 0.01;
  unsigned seed = 0;
  bool verbose = false, keep_failed_plan = false;
  // Required unless --print-config: checked after parsing.
  CLI::Option* task_option = app.add_option("task", task_path, "Task file (YAML, docs/task_format.md); required");
  CLI::Option* out_option = app.add_option(
      "--out", out_path, "Plan file to write (CSV), written only when the plan passed the post-check; required");
  CLI::Option* report_option =
      app.add_option("--report", report_path, "Report file to write (JSON), always written when planning ran; required");
  app.add_option("--html", html_path, "Also write a self-contained 3-D page of the plan");
  app.add_option("--solver", solver_name, "Optimiser back-end: lbfgs, ceres, ceres:BFGS, ipopt, nlopt, nlopt:ALGORITHM (docs/solvers.md)")->capture_default_str();
  app.add_option("--representation", representation, "Collision representation: mrc_sdf, esdf or sfc")->capture_default_str();
  app.add_option("--dt", dt, "Time step of the plan file and of the post-check, seconds")->capture_default_str();
  app.add_option("--seed", seed, "Seed of every random choice (recorded in the report)")->capture_default_str();
  std::string config_path;
  app.add_option("--planner-config", config_path,
                 "Planner configuration (YAML): every tunable of the planner, cost, solver, post-check, front end\n"
                 "and representations; keys left out keep their defaults (docs/configuration.md,\n"
                 "data/config/default.yaml). Recorded in the report");
  bool print_config = false;
  app.add_flag("--print-config", print_config,
               "Print the configuration planning would use (the defaults, or --planner-config's with the\n"
               "defaults filled in) as YAML, and exit");
  std::vector<std::string> package_path;
  quadhand::apps::AddPackagePathOption(&app, &package_path);
  int threads = -1;
  app.add_option("--threads", threads,
                 "Workers for the cost's and the post-check's samples (0: one per core; default: the\n"
                 "configuration's cost.threads and post_check.threads, 0). The result does not depend on it")
      ->check(CLI::Range(0, 256));
  app.add_flag("-v,--verbose", verbose, "Print solver progress");
  app.add_flag("--keep-failed-plan", keep_failed_plan,
               "Write the plan file even when the plan failed the post-check (for inspection only)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }
  robot::PrependRosPackagePath(package_path);
  auto loaded_config = planner::LoadPlannerConfigOrDefaults(config_path);
  if (!loaded_config.ok()) return Fail(loaded_config.status().message());
  planner::PlannerConfig& config = *loaded_config;
  if (threads >= 0) planner::SetWorkerThreads(threads, &config);
  if (print_config) {
    std::printf("%s", planner::PlannerConfigYaml(config).c_str());
    return 0;
  }
  for (const CLI::Option* option : {task_option, out_option, report_option}) {
    if (option->count() == 0) return Fail(option->get_name() + " is required");
  }
  // The outputs are checked before anything is read or printed: each a file
  // that may be replaced, no two the same, none an input given here (the
  // task's own inputs are protected once it is read, below).
  std::vector<std::pair<std::string, std::string>> outputs_given = {{"--out", out_path}, {"--report", report_path}};
  if (app.count("--html") > 0) outputs_given.emplace_back("--html", html_path);
  for (size_t i = 0; i < outputs_given.size(); ++i) {
    const auto& [option, path] = outputs_given[i];
    if (core::Status s = core::CheckOutputPathAndFolder(path); !s.ok()) return Fail(option + ": " + s.message());
    for (size_t j = 0; j < i; ++j) {
      if (core::SameFile(path, outputs_given[j].second)) {
        return Fail(option + " and " + outputs_given[j].first + " name the same file: " + path);
      }
    }
    for (const std::string& input : {task_path, config_path}) {
      if (!input.empty() && core::SameFile(path, input)) {
        return Fail(option + " " + path + ": is an input of this run; refusing to overwrite it");
      }
    }
  }
  core::SetLogLevel(verbose ? core::LogLevel::kVerbose : core::LogLevel::kInfo);
  if (!(std::isfinite(dt) && dt >= 1e-4 && dt <= 1.0)) return Fail("--dt must be in [0.0001, 1] seconds");
  if (core::Status s = solvers::RegisterBuiltinSolvers(); !s.ok()) return Fail(s.message());
  auto solver = opt::CreateSolver(solver_name);
  if (!solver.ok()) return Fail("--solver: " + solver.status().message());
  if (!(*solver)->available()) return Fail("--solver '" + solver_name + "' was built without its library");

  auto context = planner::PlanningContext::Load(task_path, planner::ContextOptions(config, {representation}));
  if (!context.ok()) return Fail(context.status().message());
  const planner::Task& task = (*context)->task();
  const robot::RobotModel& robot = (*context)->robot();
  std::vector<std::string> inputs = {task_path, config_path, task.robot_path, task.srdf_path};
  for (const scene::ScanSource& scan : task.scans) inputs.push_back(scan.path);
  for (const auto& [option, path] : outputs_given) {
    for (const std::string& input : inputs) {
      if (!input.empty() && core::SameFile(path, input)) {
        return Fail(option + " " + path + ": is an input of this run (" + task_path + "); refusing to overwrite it");
      }
    }
  }
  const double representation_ms = (*context)->representations().front().build_ms;

  const planner::PlannerOptions options = planner::RunPlannerOptions(config, dt, seed, verbose);
  auto result = planner::PlanTask(**context, 0, options, **solver);
  if (!result.ok()) return Fail(result.status().message());
  // Printed once the input is known to be good, so that bad input gives its
  // error line alone.
  if ((*context)->dropped_non_finite_points() > 0) {
    core::LogInfo("%s: dropped %ld non-finite points", task.scene_path.c_str(),
                  (*context)->dropped_non_finite_points());
  }
  for (const std::string& repair : robot::TakeMeshRepairReports()) core::LogInfo("quadhand-plan: %s", repair.c_str());
  for (const std::string& caution : planner::TaskCautions(task)) core::LogInfo("quadhand-plan: caution: %s", caution.c_str());
  core::LogInfo("quadhand-plan: %s, %zu scene points (%zu post-checked) loaded in %.0f ms, robot %s",
                task_path.c_str(), (*context)->points().size(), (*context)->checked_points().size(),
                (*context)->scene_load_seconds() * 1e3, robot.name().c_str());

  const double total_ms = Ms(start_time);
  core::AtomicFileSet outputs;
  for (const std::string& input : inputs) {
    if (!input.empty()) outputs.Protect(input);
  }
  planner::PlanReportInfo info{task_path,         solver_name, representation,
                               seed,              representation_ms, total_ms,
                               &config, config_path.empty() ? "defaults" : config_path};
  info.scene_load_ms = (*context)->scene_load_seconds() * 1e3;
  info.robot_load_ms = (*context)->robot_load_seconds() * 1e3;
  info.sdf_load_ms = (*context)->sdf_load_seconds() * 1e3;
  info.front_end_build_ms = (*context)->front_end().build_seconds() * 1e3;
  info.front_end_grid_bytes = static_cast<long>((*context)->front_end().grid_bytes());
  info.scene_points = static_cast<long>((*context)->points().size());
  info.checked_points = static_cast<long>((*context)->checked_points().size());
  info.self_collision = &(*context)->self_collision();
  info.front_end_inflation = (*context)->front_end_inflation();
  info.mission = &(*context)->task().mission;
  info.step_end_times = planner::MissionStepEndTimes((*context)->task(), *result);
  if (core::Status s = outputs.Stage(report_path, planner::PlanReportJson(*result, robot, info)); !s.ok()) {
    return Fail(s.message());
  }
  if (result->trajectory && (result->success || keep_failed_plan)) {
    io::PlanTable table = planner::SamplePlanTable(*result->trajectory, robot, dt);
    planner::AppendMissionColumns((*context)->task().mission, info.step_end_times, &table);
    planner::AppendTargetColumns((*context)->task(), &table);
    if (core::Status s = outputs.Stage(out_path, io::PlanTableCsv(table)); !s.ok()) return Fail(s.message());
  }
  if (!html_path.empty() && result->trajectory) {
    auto page = HtmlPage(*result, robot, (*context)->points(), task_path, (*context)->task(),
                         (*context)->moving_scene(), (*context)->moving_points());
    if (!page.ok()) return Fail(html_path + ": " + page.status().message());
    if (core::Status s = outputs.Stage(html_path, *page); !s.ok()) return Fail(s.message());
  }
  if (core::Status s = outputs.Commit(); !s.ok()) return Fail(s.message());

  std::printf("%s: %s in %.1f ms of optimisation (%d iterations, %d evaluations, %zu attempt(s)), "
              "duration %.2f s, min clearance %.4f m (exact %s%.4f m%s)\n",
              result->success ? "success" : "FAILED", result->message.c_str(), result->solve_ms, result->iterations,
              result->evaluations, result->attempts.size(), result->trajectory ? result->trajectory->duration() : 0.0,
              result->post_check.min_clearance_model, result->post_check.min_clearance_exact_is_bound ? ">= " : "",
              result->post_check.min_clearance_exact,
              result->post_check.min_clearance_exact_is_bound ? ": nothing nearer than the search reach" : "");
  if (result->trajectory && (result->success || keep_failed_plan)) std::printf("plan:   %s\n", out_path.c_str());
  std::printf("report: %s\n", report_path.c_str());
  if (!html_path.empty() && result->trajectory) std::printf("page:   %s\n", html_path.c_str());
  return result->success ? 0 : kExitNoPlan;
}
