// What a plan writes: the plan file's table (io/plan_file.h) sampled from the
// trajectory, and the report (docs/plan.md "Report fields"): outcome,
// timings, the terminal state, the post-check with every check, the
// attempts, the final cost terms, the front-end path and the configuration,
// as JSON text. quadhand-plan and the Python module write both with these.
#pragma once

#include <string>

#include "quadhand/io/plan_file.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::planner {

// Samples `trajectory` every `dt` seconds (dt > 0), the last row exactly at
// the duration, into the plan file's columns for the robot's joints.
io::PlanTable SamplePlanTable(const WholeBodyTrajectory& trajectory, const robot::RobotModel& robot, double dt);

// For a task with a mission (contracts.md 0.3): appends the columns `step`
// (the index of the step flown at each row's time) and `gripper` (1 while
// an object is held: from the start of its grasp to the start of its
// release; else 0). `step_end_times` holds each step's end, s, increasing
// (the last is the plan's duration). Nothing for a task without one.
void AppendMissionColumns(const std::vector<MissionStep>& mission, const std::vector<double>& step_end_times,
                          io::PlanTable* table);

// For a task whose target moves (contracts.md 0.3): appends the columns
// target_x, target_y, target_z, target_qw, target_qx, target_qy, target_qz,
// the target's pose at each row's time (the tool goal's pose moved by the
// target's displacement). Nothing for a target that stands still.
void AppendTargetColumns(const Task& task, io::PlanTable* table);

// Each step's end time in a plan of `task` (PlanResult::steps; a step that
// was not planned ends where the plan does). Empty for a task without a
// mission.
std::vector<double> MissionStepEndTimes(const Task& task, const PlanResult& result);

// What the report records besides the result itself.
struct PlanReportInfo {
  std::string task;            // the task file, or a description of where the task came from
  std::string solver;          // as given (e.g. "lbfgs", "nlopt:LD_MMA")
  std::string representation;  // "mrc_sdf", "esdf", "sfc"
  unsigned seed = 0;
  double representation_build_ms = 0;  // building the scene's representation (once per scene)
  double total_ms = 0;                 // wall time of the whole run that made the plan
  // The configuration planned with (every key), and where it came from (a
  // file, or "defaults"); none recorded when null.
  const PlannerConfig* config = nullptr;
  std::string config_source = "defaults";
  // The scene as loaded: reading, moving, cropping and filtering its scans
  // (ms), the points planned against and the points post-checked against
  // (more when a voxel filter reduced the former); not recorded when negative.
  double scene_load_ms = -1.0;
  // Loading the robot's meshes and link SDFs (PlanningContext::
  // robot_load_seconds), and of it the SDFs (also in
  // representation_build_ms for MRC-SDF); not recorded when negative.
  double robot_load_ms = -1.0;
  double sdf_load_ms = -1.0;
  // Building the front end's map, and the bytes its grid holds (-1: not given).
  double front_end_build_ms = -1.0;
  long front_end_grid_bytes = -1;
  long scene_points = -1;
  long checked_points = -1;
  // The robot's self-collision pairs (checked and excluded, with why); none
  // recorded when null.
  const env::SelfCollisionModel* self_collision = nullptr;
  double front_end_inflation = -1.0;  // m; not recorded when negative
  // The task's mission, for the report's `steps` (contracts.md 0.3); none
  // recorded when null or empty. `step_end_times`: MissionStepEndTimes.
  const std::vector<MissionStep>* mission = nullptr;
  std::vector<double> step_end_times = {};
};

// The report as pretty-printed JSON text (two-space indent, newline at the end).
std::string PlanReportJson(const PlanResult& result, const robot::RobotModel& robot, const PlanReportInfo& info);

}  // namespace quadhand::planner
