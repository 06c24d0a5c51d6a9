// Typed outcomes of planning: how a plan ended, and which post-check a
// trajectory failed. Code branches on these values; their names (the strings
// of reports, logs and the Python module) are for people and files only.
#pragma once

namespace quadhand::planner {

// How Plan() or Replan() ended. Only kSuccess hands out a trajectory to fly.
enum class PlanStatus {
  kSuccess,               // the trajectory passed the post-check
  kPostCheckFailed,       // optimised, but a post-check failed after every attempt
  kSolverFailed,          // the solver returned no usable trajectory
  kTerminalStateFailed,   // no terminal state reaches the tool goal
  kFrontEndFailed,        // no collision-free path from the start to the goal
  kRepresentationFailed,  // the per-plan collision representation could not be built
  kInsertionInProgress,   // replan refused: the straight insertion has begun
  kStartInCollision,      // replan refused: the measured start is too deep inside the scene
  kInvalidInput,          // the request itself was rejected (recorded by callers, never set by Plan())
  // A mission step cannot start or end where the steps before it leave the
  // robot (its start or end state too close to the scene, say): set by
  // PlanTask(), never by Plan().
  kMissionStepInvalid,
  // A moving target that no plan can meet within the limits: wherever the
  // vehicle could be by then at v_max in a straight line, the target has
  // left the space the planner searches (PlanResult::target_out_of_reach_m).
  kTargetUnreachable,
};

// "success", "post_check_failed", ... (as in reports).
const char* PlanStatusName(PlanStatus status);

// The kinds of check of the post-check (post_check.h).
enum class CheckKind {
  kClearance,     // exact link meshes vs the scene's points
  kSelfClearance, // the robot's checked link pairs apart (env/self_collision.h)
  kVelocity,
  kAcceleration,
  kYawRate,
  kBodyRateXY,
  kJointRate,     // one check per actuated joint (CheckResult::joint)
  kJointLimits,
  kStartState,
  kEndState,
  kInsertion,
  kSampling,      // the trajectory needs more samples than are ever checked (a failure, never run)
  // An object held in a mission (planner/mission.h) vs the scene's points:
  // the safety distance, or >= 0 on the lines next to its grasp and release
  // (contracts.md 0.3). Set by PlanTask(), never by PostCheck().
  kHeldObjectClearance,
  // The base passes within each via's tolerance of its point, in order
  // (Task::vias): the worst via, by its distance over its tolerance.
  kVia,
  // A moving target's tool speed relative to the target at the arrival,
  // against goal.tool.max_relative_speed (docs/moving_targets.md).
  kRelativeSpeed,
  // A mission's grasp of a moving target: the tool stays where it met the
  // target, in the target's frame, while the gripper closes (set by
  // PlanTask(), never by PostCheck()).
  kFollowTarget,
};

// "clearance", "velocity", ..., "joint_rate".
const char* CheckKindName(CheckKind kind);

}  // namespace quadhand::planner
