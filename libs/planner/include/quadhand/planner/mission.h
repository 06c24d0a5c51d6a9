// A mission: the task file's `mission:` list (contracts.md version 0.3,
// docs/missions.md), steps flown in order in one plan. A `reach` flies to a
// whole-body state and/or a tool pose; a `move` draws a straight tool line
// with the tool's orientation held (lift, pull, retreat, drag, push); a
// `via` passes near a point; a `grasp` closes the gripper on an object,
// which from then on moves with the tool link; a `release` opens it and
// leaves the object where it is; a `hold` hovers.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/types.h"
#include "quadhand/planner/target_motion.h"
#include "quadhand/planner/whole_body_problem.h"

namespace quadhand::planner {

// The tool goal of a `goal:` or a `reach` step. With `moving`, the pose
// and the insertion are the target's at t = 0 (the plan's start), and move
// with it (target_motion.h).
struct ToolGoal {
  Vec3 position = Vec3::Zero();
  Quat orientation = Quat::Identity();
  bool has_insertion = false;
  Vec3 insertion_direction = -Vec3::UnitZ();  // unit
  double insertion_length = 0.0;              // metres
  std::optional<MovingTarget> moving;         // goal.tool.motion
};

// The straight approach a tool goal asks for, of the robot link
// `tool_link`: enabled when the goal has an insertion.
InsertionGoal InsertionOf(const ToolGoal& tool, int tool_link);

enum class StepKind { kReach, kMove, kVia, kGrasp, kRelease, kHold };

// "reach", "move", ... as in the task file.
const char* StepKindName(StepKind kind);

// The shape of a grasped object, in its own frame (a cylinder's axis is z,
// every primitive is centred on the frame's origin, as in URDF).
struct ObjectShape {
  enum class Kind { kBox, kCylinder, kSphere, kMesh };
  Kind kind = Kind::kBox;
  Vec3 box_size = Vec3::Zero();  // box: edge lengths
  double radius = 0.0;           // cylinder, sphere
  double length = 0.0;           // cylinder
  std::string mesh_path;         // mesh: resolved against the task file's folder; must bound a volume

  // The radius of a sphere about the frame's origin that holds the shape;
  // for a mesh, 0 (its vertices are read with the robot).
  double BoundingRadius() const;
};

struct MissionObject {
  ObjectShape shape;
  // The object's pose at the grasp, world frame; for a grasp that opens the
  // mission (an object held at the start), relative to the tool link.
  Pose pose = Pose::Identity();
  double mass = 0.0;  // kg
};

struct MissionStep {
  StepKind kind = StepKind::kReach;

  // reach: a terminal whole-body state (at rest) and/or a tool pose.
  std::optional<BoundaryState> reach_state;
  std::optional<ToolGoal> reach_tool;

  // move: the tool's straight line. Without a direction (only right after a
  // grasp or a release), the tool leaves along the insertion of the reach
  // before the grasp or release, reversed.
  std::optional<Vec3> move_direction;  // unit
  double move_length = 0.0;             // m, > 0
  std::optional<double> move_max_speed;  // m/s

  // via: the base passes within `via_tolerance` of `via_position`.
  Vec3 via_position = Vec3::Zero();
  double via_tolerance = 0.05;

  // grasp
  MissionObject object;
  double scene_margin = 0.01;  // scene points this close to the object leave the scene, m
  double close_time = 0.5;     // s at rest while the gripper closes
  bool held_at_start = false;  // the mission's first step: the object is in the gripper already

  // release
  double open_time = 0.5;  // s at rest while the gripper opens

  // hold
  double hold_duration = 0.0;  // s
};

// A grasp closes on an object the tool touches: its surface no farther from
// the tool point than this, metres (docs/missions.md).
constexpr double kGraspReach = 0.05;

// The distance from `x` (world) to the object's surface at its pose, 0
// inside it (geometry/primitives.h); for a mesh, the distance to its
// frame's origin (its vertices are read with the robot).
double DistanceToObjectSurface(const MissionObject& object, const Vec3& x);

// Whether the gripper acts at this step: a grasp (but not of an object
// already held at the start) closes it, a release opens it.
inline bool GripperActsAt(const MissionStep& step) {
  return (step.kind == StepKind::kGrasp && !step.held_at_start) || step.kind == StepKind::kRelease;
}

// "mission[2] (grasp)": how messages name a step.
std::string StepName(const std::vector<MissionStep>& mission, size_t index);

}  // namespace quadhand::planner
