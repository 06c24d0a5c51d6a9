#include "quadhand/planner/plan_status.h"

namespace quadhand::planner {

const char* PlanStatusName(PlanStatus status) {
  switch (status) {
    case PlanStatus::kSuccess: return "success";
    case PlanStatus::kPostCheckFailed: return "post_check_failed";
    case PlanStatus::kSolverFailed: return "solver_failed";
    case PlanStatus::kTerminalStateFailed: return "terminal_state_failed";
    case PlanStatus::kFrontEndFailed: return "front_end_failed";
    case PlanStatus::kRepresentationFailed: return "representation_failed";
    case PlanStatus::kInsertionInProgress: return "insertion_in_progress";
    case PlanStatus::kStartInCollision: return "start_in_collision";
    case PlanStatus::kInvalidInput: return "invalid_input";
    case PlanStatus::kMissionStepInvalid: return "mission_step_invalid";
    case PlanStatus::kTargetUnreachable: return "target_unreachable";
  }
  return "unknown";
}

const char* CheckKindName(CheckKind kind) {
  switch (kind) {
    case CheckKind::kClearance: return "clearance";
    case CheckKind::kSelfClearance: return "self_clearance";
    case CheckKind::kVelocity: return "velocity";
    case CheckKind::kAcceleration: return "acceleration";
    case CheckKind::kYawRate: return "yaw_rate";
    case CheckKind::kBodyRateXY: return "body_rate_xy";
    case CheckKind::kJointRate: return "joint_rate";
    case CheckKind::kJointLimits: return "joint_limits";
    case CheckKind::kStartState: return "start_state";
    case CheckKind::kEndState: return "end_state";
    case CheckKind::kInsertion: return "insertion";
    case CheckKind::kSampling: return "sampling";
    case CheckKind::kHeldObjectClearance: return "held_object_clearance";
    case CheckKind::kVia: return "via";
    case CheckKind::kRelativeSpeed: return "relative_speed";
    case CheckKind::kFollowTarget: return "follow_target";
  }
  return "unknown";
}

}  // namespace quadhand::planner
