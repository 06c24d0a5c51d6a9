// quadhand-flightcheck: an independent verdict on a flight. Reads a flown
// record (any file in the plan file's columns: quadhand-sim --log,
// quadhand-online --log, or a real vehicle's log converted to them) and
// measures, at every row, the exact clearance of the robot's link meshes
// against the task's scene at the recorded pose, attitude and joints (the
// post-check's model), the longest time between two rows, and the tool's
// and the base's final errors. It shares nothing with the programs that
// flew: the fault campaign judges every flight with it. docs/reliability.md.
//
// Exit codes: 0 the flight kept the safety distance (less --tolerance);
// 6 it did not, or a gap between rows exceeded --max-gap; 2 bad input.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "app_options.h"
#include "quadhand/core/log.h"
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
  // A mission's flight changes its scene and its robot at every grasp and
  // release, at times only the plan knows: judging it against the task's
  // scene alone would call a flight safe that was not checked.
  if (!planner::PlansAsGoal(ctx.task())) {
    return Fail(task_path + ": a mission of " + std::to_string(ctx.task().mission.size()) +
                " steps: its flight is judged by quadhand-online, leg by leg with the held object (docs/online.md, "
                "Missions); quadhand-flightcheck judges goals");
  }
  const robot::RobotModel& robot = ctx.robot();
  auto flown = sim::LoadPlanCsv(flown_path, robot.ActuatedJointNames());
  if (!flown.ok()) return Fail(flown.status().message());

  robot::KinematicsState kinematics;
  double least = 1e300, least_time = std::nan(""), gap = 0.0, gap_time = std::nan(""), last_time = 0.0;
  std::string closest;
  long judged = 0;
  const sim::PlanRow* last = nullptr;
  for (const sim::PlanRow& row : flown->rows) {
    if (row.t < from || row.t > until) continue;
    if (judged > 0 && row.t - last_time > gap) {
      gap = row.t - last_time;
      gap_time = row.t;
    }
    last_time = row.t;
    ++judged;
    last = &row;
    robot::ComputeKinematics(robot, MakePose(row.position, row.attitude.toRotationMatrix()), row.joints, &kinematics);
    int link = -1;
    const double d = env::WholeBodyClearance(kinematics, ctx.exact(), 1.0, {}, &link);
    if (d < least) {
      least = d;
      least_time = row.t;
      closest = link >= 0 ? robot.link(link).name : "";
    }
  }
  if (judged == 0) return Fail(flown_path + ": no row between --from and --until");

  double tool_error = std::nan(""), base_error = std::nan("");
  robot::ComputeKinematics(robot, MakePose(last->position, last->attitude.toRotationMatrix()), last->joints,
                           &kinematics);
  const int tool = robot.LinkIndex(ctx.task().tool_link);
  if (ctx.task().tool && tool >= 0) {
    tool_error = (kinematics.link_poses[tool].translation() - ctx.task().tool->position).norm();
  }
  if (ctx.task().terminal) base_error = (last->position - ctx.task().terminal->position).norm();

  const double required = planner::AcceptedClearance(ctx.task(), tolerance);
  const bool kept = least >= required;
  const bool seen = max_gap <= 0.0 || gap <= max_gap;
  const int code = kept && seen ? kExitKept : kExitLost;
  if (json) {
    std::printf("{\"kept\": %s, \"seen\": %s, \"min_clearance\": %.6f, \"link\": \"%s\", \"t\": %.4f, "
                "\"required\": %.6f, \"rows\": %ld, \"max_gap\": %.4f, \"max_gap_t\": %.4f, \"tool_error\": %.6f, "
                "\"base_error\": %.6f}\n",
                kept ? "true" : "false", seen ? "true" : "false", least, closest.c_str(), least_time, required, judged,
                gap, std::isnan(gap_time) ? 0.0 : gap_time, std::isnan(tool_error) ? -1.0 : tool_error,
                std::isnan(base_error) ? -1.0 : base_error);
  } else {
    std::printf("%s: min exact clearance %.4f m (link %s, t = %.2f s); required %.4f m (safety distance %.4f m "
                "less %.4f m)\n",
                kept ? (seen ? "kept its clearance" : "NOT VERIFIED") : "CLEARANCE LOST", least, closest.c_str(),
                least_time, required, ctx.task().safety_distance, tolerance);
    std::printf("  %ld rows judged, longest gap %.3f s%s; final tool error %.4f m, base %.4f m from the goal\n", judged,
                gap, seen ? "" : " (over --max-gap)", tool_error, base_error);
  }
  return code;
}
