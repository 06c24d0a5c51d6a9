// The task file of quadhand-plan (docs/task_format.md; contract in
// shared/spec/contracts.md): robot, SDFs, scene, start state, goal (a full
// terminal state and/or a tool pose with an insertion) or mission (steps),
// limits, safety distance.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/planner/mission.h"
#include "quadhand/planner/whole_body_problem.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/scene/scans.h"

namespace quadhand::planner {

// A point the base passes on its way to the goal: within `tolerance` of
// `position`, at a time the optimiser chooses (a mission's `via` before a
// reach; the task file's `goal:` has none).
struct ViaPoint {
  Vec3 position = Vec3::Zero();
  double tolerance = 0.05;  // m
};

struct Task {
  std::string file;        // the task file itself, for messages
  std::string robot_path;  // resolved against the task file's folder
  std::string sdf_dir;
  std::string scene_path;  // the first scan's file, for messages
  // scene: one path (a scan in the world frame) or a list of scans with
  // their sensor poses, crop boxes and voxel filters.
  std::vector<scene::ScanSource> scans;
  BoundaryState start;                   // joints sized by the file
  std::optional<BoundaryState> terminal;  // goal.position/yaw/joints, at rest
  std::optional<ToolGoal> tool;           // goal.tool
  // mission: (mission.h), instead of goal:. A mission of one reach also
  // sets `terminal` and `tool` from it: it plans as that goal.
  std::vector<MissionStep> mission;
  // Passed in order before the goal (Plan(); set by PlanTask() for a leg
  // through a mission's vias).
  std::vector<ViaPoint> vias;
  Limits limits;                          // joint entries filled by ApplyRobot()
  double safety_distance = 0.03;
  // The end-effector frame: a link of the URDF (task key tool_link, default
  // "tool"; ApplyRobot checks it).
  std::string tool_link = "tool";
  bool tool_link_given = false;  // the task named it
  // Distance every checked pair of robot links keeps (env/self_collision.h),
  // metres, and the SRDF whose <disable_collisions> pairs are not checked
  // (empty: none; then pairs close at the zero configuration are dropped).
  double self_safety_distance = 0.01;
  std::string srdf_path;
};

// A goal, or a mission of one reach: planned as that goal (Plan()). Any
// other mission, one hold or via included, is planned step by step
// (PlanTask(), mission_plan.h).
inline bool PlansAsGoal(const Task& task) {
  return task.mission.empty() || (task.mission.size() == 1 && task.mission[0].kind == StepKind::kReach);
}

// The tool goal whose target moves: the goal's, or a longer mission's one
// moving reach (LoadTask allows one). Null when nothing moves.
inline const ToolGoal* MovingToolGoal(const Task& task) {
  if (task.tool) return task.tool->moving ? &*task.tool : nullptr;
  for (const MissionStep& step : task.mission) {
    if (step.reach_tool && step.reach_tool->moving) return &*step.reach_tool;
  }
  return nullptr;
}

// Parses and checks a task file on its own: every error names the file and
// the key ("task.yaml: start.joints: expected a list of numbers").
core::Result<Task> LoadTask(const std::string& path);

// The points of a world a simulated sensor sees (quadhand-sim --world,
// quadhand-explore): a PCD or PLY cloud, or a task file's (.yaml, .yml)
// scene - its scans placed and cropped as planning does, before any voxel
// filter (a sensor sees the raw scene, not its centroids). Errors name the
// file.
core::Result<std::vector<Vec3>> LoadWorldPoints(const std::string& path);
// The same for a task already loaded: its scene's points (none without one).
core::Result<std::vector<Vec3>> ScenePoints(const Task& task);

// What the caller gives itself instead of the task's keys: with robot_given
// the keys robot and sdf_dir may be left out, with scene_given the key scene.
struct TaskSources {
  bool robot_given = false;
  bool scene_given = false;
};

// The same with keys the caller gives itself (quadhand-online --perception:
// no scene).
core::Result<Task> LoadTask(const std::string& path, const TaskSources& sources);

// The same from YAML (or JSON) text: errors name `name`, and relative paths
// in the task resolve against `base_dir`.
core::Result<Task> ParseTaskText(const std::string& text, const std::string& name, const std::string& base_dir,
                                 const TaskSources& sources);

// Cautions about a valid task that may not plan as its author meant, one
// line each, naming the file; empty when there are none. Today: a scan whose
// voxel leaf is coarser than the safety distance (its reduced points may
// leave gaps a link fits through in the optimiser's scene, and the exact
// post-check, which sees every unfiltered point, then rejects the plans; a
// leaf in millimetres by mistake collapses a room to a few points). The
// applications print them after loading.
std::vector<std::string> TaskCautions(const Task& task);

// How far clearances to the scene are searched (the post-check, the
// end-state checks, the terminal-state search, replanning): the safety
// distance plus 5 cm, enough to show the margin a plan keeps while the
// queries stay local. A clearance found at this reach means nothing was
// nearer: it is a lower bound, and reports say so.
inline double ClearanceSearchReach(const Task& task) { return task.safety_distance + 0.05; }
// The same for the clearance between the robot's own links: the self safety
// distance plus 2 cm.
inline double SelfClearanceSearchReach(const Task& task) { return task.self_safety_distance + 0.02; }

// The least clearance every check accepts (the post-check, the end-state
// checks, the terminal-state search, replanning, the flight judges): the
// safety distance less a tolerance (PostCheckOptions::clearance_tolerance,
// or a flight's), and the same between the robot's own links.
inline double AcceptedClearance(const Task& task, double tolerance) { return task.safety_distance - tolerance; }
inline double AcceptedSelfClearance(const Task& task, double tolerance) {
  return task.self_safety_distance - tolerance;
}

// Checks the task against the robot (joint counts, start and terminal joints
// within limits), fills the joint limits from the URDF and checks tool_link:
// an error when the task named a link the robot lacks, or has a tool goal
// and the robot has no link of that name (a robot without one may still fly
// joint-space goals).
core::Status ApplyRobot(const robot::RobotModel& robot, Task* task);

}  // namespace quadhand::planner
