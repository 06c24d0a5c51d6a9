// quadhand-flightcheck: an independent verdict on a flight. Reads a flown
// record (any file in the plan file's columns: quadhand-sim --log,
// quadhand-online --log, or a real vehicle's log converted to them) and
// measures, at every row, the exact clearance of the robot's link meshes
// against the task's scene at the recorded pose, attitude and joints (the
// post-check's model), the longest time between two rows, and the tool's
// and the base's final errors. It shares nothing with the programs that
// flew: the fault campaign judges every flight with it. docs/reliability.md.
// A mission's record has a gripper column: at each change the scene and the
// robot change as the planner's phases do (the object held where the flown
// tool closed on it, left where it opened), and the held object is judged
// too: never into the scene.
//
// Exit codes: 0 the flight kept the safety distance (less --tolerance);
// 6 it did not, or a gap between rows exceeded --max-gap; 2 bad input.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "app_options.h"
#include "quadhand/core/log.h"
#include "quadhand/core/text.h"
#include "quadhand/planner/flight_verdict.h"
#include "quadhand/planner/mission_plan.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/sim/plan_io.h"

namespace {

using namespace quadhand;

constexpr int kExitKept = 0;
constexpr int kExitBadInput = 2;
constexpr int kExitLost = 6;

int Fail(const std::string& message) {
  core::PrintError("quadhand-flightcheck", message);
  return kExitBadInput;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "quadhand-flightcheck: judge a flown record against the task's scene with the exact link meshes.\n"
      "  quadhand-flightcheck TASK.yaml FLOWN.csv [--tolerance M] [--from S] [--until S] [--max-gap S] [--json]\n"
      "FLOWN.csv: rows in the plan file's columns (shared/spec/contracts.md; extra columns are ignored).\n"
      "Exit codes: 0 the safety distance (less --tolerance) was kept at every row; 6 it was not, or two rows\n"
      "were more than --max-gap apart; 2 bad input."};
  std::string task_path, flown_path;
  double tolerance = 0.002, from = -1e300, until = 1e300, max_gap = 0.0;
  bool json = false;
  app.add_option("task", task_path, "Task file (YAML): robot, scene and safety distance")->required();
  app.add_option("flown", flown_path, "The flown record (CSV, plan file columns)")->required();
  app.add_option("--tolerance", tolerance, "Metres below the safety distance still accepted, in [0, 0.05]")
      ->capture_default_str();
  app.add_option("--from", from, "Judge rows from this time on (s of the record)");
  app.add_option("--until", until, "Judge rows up to this time (s of the record)");
  app.add_option("--max-gap", max_gap, "Longest time between two judged rows (s; 0: not checked)")
      ->capture_default_str();
  app.add_flag("--json", json, "Print one JSON line instead of words");
  std::vector<std::string> package_path;
  apps::AddPackagePathOption(&app, &package_path);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }
  if (!(std::isfinite(tolerance) && tolerance >= 0.0 && tolerance <= 0.05)) {
    return Fail("--tolerance must be in [0, 0.05] m");
  }
  if (!(std::isfinite(max_gap) && max_gap >= 0.0)) return Fail("--max-gap must be >= 0 s");
  if (std::isnan(from) || std::isnan(until) || from > until) return Fail("--from must not be after --until");

  robot::PrependRosPackagePath(package_path);
  auto config = planner::LoadPlannerConfigOrDefaults("");
  if (!config.ok()) return Fail(config.status().message());
  // The exact model only: no representation (and so no link SDFs) is needed.
  auto context = planner::PlanningContext::Load(task_path, planner::ContextOptions(*config, {}));
  if (!context.ok()) return Fail(context.status().message());
  const planner::PlanningContext& ctx = **context;
  const robot::RobotModel& robot = ctx.robot();
  auto flown = sim::LoadPlanCsv(flown_path, robot.ActuatedJointNames());
  if (!flown.ok()) return Fail(flown.status().message());
  // A mission's flight changes its scene and its robot at every grasp and
  // release: they are replayed at the gripper events of the record, with
  // the tool where it was then (planner::FlightJudge).
  auto judge = planner::FlightJudge::Create(ctx, config->planner.mission);
  if (!judge.ok()) return Fail(judge.status().message());
  if ((*judge)->replays_mission()) {
    bool acts = false;
    for (const planner::MissionStep& step : ctx.task().mission) {
      acts = acts || step.kind == planner::StepKind::kRelease ||
             (step.kind == planner::StepKind::kGrasp && !step.held_at_start);
    }
    if (acts && flown->rows.front().gripper < 0) {
      return Fail(flown_path + ": no 'gripper' column, and the mission of " + task_path +
                  " grasps or releases: the record must say when (quadhand-sim --log writes it)");
    }
  }
  // A moving target is judged where the record has it (its target_*
  // columns: the simulator's true pose, a plan's prediction, an online
  // flight's estimate), else where the task's motion puts it at the row's
  // time. An online flight log's rows before its tracker's first estimate
  // have no target: they are judged with the target at its pose in the task,
  // as quadhand-online's own judge has it (no plan is flown before then).
  const planner::MovingScene* moving = ctx.moving_scene();
  const bool record_has_target = flown->has_target_columns;
  long rows_without_target = 0;
  if (record_has_target) {
    for (const sim::PlanRow& row : flown->rows) rows_without_target += row.target ? 0 : 1;
  }
  Pose task_target = Pose::Identity();
  if (const planner::ToolGoal* target = planner::MovingToolGoal(ctx.task())) {
    task_target = MakePose(target->position, target->orientation.toRotationMatrix());
  }
  // The moving target's displacement from its pose in the task at a row
  // (nothing moves without one).
  auto displacement_at = [&](const sim::PlanRow& row) {
    if (moving == nullptr) return Pose(Pose::Identity());
    if (row.target) return Pose(*row.target * task_target.inverse());
    return record_has_target ? Pose::Identity() : moving->motion->Displacement(row.t);
  };
  robot::KinematicsState kinematics;
  double gap = 0.0, gap_time = std::nan(""), last_time = 0.0;
  long judged = 0;
  const sim::PlanRow* last = nullptr;
  for (const sim::PlanRow& row : flown->rows) {
    planner::FlownState state;
    state.t = row.t;
    state.base = MakePose(row.position, row.attitude.toRotationMatrix());
    state.joints = row.joints;
    state.gripper = row.gripper;
    state.target = displacement_at(row);
    const bool in_window = row.t >= from && row.t <= until;
    if (core::Status added = (*judge)->Add(state, in_window); !added.ok()) {
      return Fail(flown_path + core::Format(": t = %.3f s: ", row.t) + added.message());
    }
    if (!in_window) continue;
    if (judged > 0 && row.t - last_time > gap) {
      gap = row.t - last_time;
      gap_time = row.t;
    }
    last_time = row.t;
    ++judged;
    last = &row;
  }
  const double least = (*judge)->least(), least_time = (*judge)->least_t();
  const std::string& closest = (*judge)->closest_link();
  const double least_object = (*judge)->least_held(), least_object_time = (*judge)->least_held_t();
  const int gripper_events = (*judge)->gripper_events();
  if (judged == 0) return Fail(flown_path + ": no row between --from and --until");

  double tool_error = std::nan(""), base_error = std::nan("");
  robot::ComputeKinematics(robot, MakePose(last->position, last->attitude.toRotationMatrix()), last->joints,
                           &kinematics);
  const int tool = robot.LinkIndex(ctx.task().tool_link);
  if (ctx.task().tool && tool >= 0) {
    // A moving target is judged where it is at the last row's time.
    const Vec3 goal = displacement_at(*last) * ctx.task().tool->position;
    tool_error = (kinematics.link_poses[tool].translation() - goal).norm();
  }
  if (ctx.task().terminal) base_error = (last->position - ctx.task().terminal->position).norm();

  const double required = planner::AcceptedClearance(ctx.task(), tolerance);
  // A held object may come to its support at a grasp or release (contracts
  // 0.3), but never into the scene; how far it had to stay elsewhere depends
  // on the plan's steps, which quadhand-online judges (docs/online.md).
  const bool held = std::isfinite(least_object);
  const bool kept = least >= required && (!held || least_object >= -tolerance);
  const bool seen = max_gap <= 0.0 || gap <= max_gap;
  const int code = kept && seen ? kExitKept : kExitLost;
  if (json) {
    std::printf("{\"kept\": %s, \"seen\": %s, \"min_clearance\": %.6f, \"link\": \"%s\", \"t\": %.4f, "
                "\"required\": %.6f, \"rows\": %ld, \"max_gap\": %.4f, \"max_gap_t\": %.4f, \"tool_error\": %.6f, "
                "\"base_error\": %.6f, \"gripper_events\": %d, \"held_object_min_clearance\": %s, "
                "\"held_object_t\": %.4f, \"moving_target\": %s, \"rows_without_target\": %ld}\n",
                kept ? "true" : "false", seen ? "true" : "false", least, closest.c_str(), least_time, required, judged,
                gap, std::isnan(gap_time) ? 0.0 : gap_time, std::isnan(tool_error) ? -1.0 : tool_error,
                std::isnan(base_error) ? -1.0 : base_error, gripper_events,
                held ? core::Format("%.6f", least_object).c_str() : "null",
                std::isnan(least_object_time) ? 0.0 : least_object_time,
                moving == nullptr ? "null" : record_has_target ? "\"record\"" : "\"task\"", rows_without_target);
  } else {
    std::printf("%s: min exact clearance %.4f m (link %s, t = %.2f s); required %.4f m (safety distance %.4f m "
                "less %.4f m)\n",
                kept ? (seen ? "kept its clearance" : "NOT VERIFIED") : "CLEARANCE LOST", least, closest.c_str(),
                least_time, required, ctx.task().safety_distance, tolerance);
    std::printf("  %ld rows judged, longest gap %.3f s%s; final tool error %.4f m, base %.4f m from the goal\n", judged,
                gap, seen ? "" : " (over --max-gap)", tool_error, base_error);
    if (moving != nullptr) {
      std::printf("  moving target: judged where %s%s\n",
                  record_has_target ? "the record has it (its target_* columns)"
                                    : "the task's motion puts it (the record has no target_* columns)",
                  rows_without_target > 0
                      ? core::Format("; %ld rows without one (before an online flight's first estimate) at its pose "
                                     "in the task",
                                     rows_without_target)
                            .c_str()
                      : "");
    }
    if ((*judge)->replays_mission()) {
      std::printf("  mission: %d gripper events; held object: %s\n", gripper_events,
                  held ? core::Format("min exact clearance %.4f m (t = %.2f s; it must stay out of the scene, "
                                      ">= %.4f m)",
                                      least_object, least_object_time, -tolerance)
                             .c_str()
                       : "none held");
    }
  }
  return code;
}
