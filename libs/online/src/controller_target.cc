// OnlineController's moving target (controller.h, OnlineOptions'
// target_* fields; docs/moving_targets.md, "Online"): its measurements, the
// prediction each plan is made against, the replans the prediction calls
// for, and the follow after the arrival.
#include <algorithm>
#include <cmath>
#include <limits>

#include "quadhand/core/text.h"
#include "quadhand/online/controller.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/robot/kinematics.h"

namespace quadhand::online {
namespace {

using core::Format;

// The follow after the arrival is checked every this many seconds.
constexpr double kFollowCheckStep = 0.02;

Mat3 TurnAboutZ(double yaw) { return Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix(); }

}  // namespace

void OnlineController::OnTarget(double t, const Vec3& position, double yaw, double age) {
  if (tracker_ == nullptr) return;  // the task's goal stands still
  if (!position.allFinite() || !std::isfinite(yaw) || !std::isfinite(t)) {
    ++stats_.target_dropped_malformed;
    return;
  }
  if (!(age <= options_.max_target_age) || t <= target_time_) {
    ++stats_.target_dropped_stale;
    return;
  }
  const int rejected_before = tracker_->rejected();
  if (tracker_->Observe(t, position, yaw)) {
    ++stats_.target_measurements;
    target_time_ = t;
  } else if (tracker_->rejected() > rejected_before) {
    ++stats_.target_rejected;
  } else {
    ++stats_.target_dropped_stale;
  }
  stats_.target_restarts = tracker_->restarts();
}

Pose OnlineController::TargetPoseOf(const TargetEstimate& estimate) const {
  // The measured heading is the target's turn about z from its pose in the task.
  return MakePose(estimate.position, TurnAboutZ(estimate.yaw) * task_target_.linear());
}

std::optional<Pose> OnlineController::TargetPoseAt(double t) const {
  if (tracker_ == nullptr) return std::nullopt;
  const std::optional<TargetEstimate> estimate = tracker_->Estimate(t);
  if (!estimate) return std::nullopt;
  return TargetPoseOf(*estimate);
}

Pose OnlineController::PlannedTarget(const ActivePlan& plan, double plan_time) {
  return plan.target->motion.Displacement(plan_time) * plan.plan->target_at_zero;
}

Vec3 OnlineController::MeasuredTool() const {
  return robot::LinkPose(setup_.scene.robot, MakePose(position_, attitude_.toRotationMatrix()), joints_, tool_link_)
      .translation();
}

bool OnlineController::PredictTarget(double t, std::optional<planner::TargetMotion>* motion, Pose* placement) const {
  const std::optional<Pose> pose = TargetPoseAt(t);
  std::optional<planner::TargetMotion> from = tracker_->MotionFrom(t);
  if (!pose || !from) return false;
  *motion = std::move(from);
  *placement = *pose * task_target_.inverse();
  return true;
}

Setpoint OnlineController::SampleActive(const ActivePlan& plan, double t) {
  const planner::WholeBodyTrajectory& trajectory = *plan.plan->trajectory;
  const double plan_time = t - plan.start;
  if (!plan.target || plan_time <= trajectory.duration()) return FromSample(trajectory.Sample(plan_time));
  // Past the arrival: the end state moved on with the target as predicted.
  return FromState(planner::MovedState(plan.plan->terminal_at_zero, plan.target->motion, plan_time));
}

double OnlineController::ArrivalShift() const {
  const planner::PlanResult& plan = *to_.plan;
  const double arrival = to_.start + plan.trajectory->duration();
  const std::optional<Pose> predicted = TargetPoseAt(arrival);
  if (!predicted || !to_.target) return 0.0;
  const Pose planned = PlannedTarget(to_, plan.trajectory->duration());
  // A turn of the target swings the base about the grasp by the arm's reach.
  const double reach = (plan.terminal.position - planned.translation()).norm();
  const Mat3 turn = predicted->linear() * planned.linear().transpose();
  return (predicted->translation() - planned.translation()).norm() + reach * std::abs(std::atan2(turn(1, 0), turn(0, 0)));
}

double OnlineController::ToolTargetError() const {
  const std::optional<Pose> target = TargetPoseAt(position_time_);
  if (!target || tool_link_ < 0 || !HaveState()) return std::numeric_limits<double>::quiet_NaN();
  return (MeasuredTool() - target->translation()).norm();
}

MeasuredState OnlineController::FollowState(const ActivePlan& plan, double plan_time) const {
  return LevelStateOf(SampleActive(plan, plan.start + plan_time));
}

MeasuredState OnlineController::LevelStateOf(const Setpoint& s) const {
  MeasuredState state = measured();
  state.position = s.position;
  state.attitude = Quat(TurnAboutZ(s.yaw));
  state.joints = s.joints;
  return state;
}

double OnlineController::ClearFollowDuration(double longest) const {
  if (!to_.target) return 0.0;
  const double end = to_.plan->trajectory->duration();
  // The moving points go with the robot; only the still scene can come nearer.
  for (double tau = 0.0; tau <= longest + 1e-9; tau += kFollowCheckStep) {
    int link = -1;
    if (ConfigurationMargin(nullptr, FollowState(to_, end + tau), &link) < 0.0) return std::max(0.0, tau - kFollowCheckStep);
  }
  return longest;
}

void OnlineController::CheckTarget(double t) {
  // Offboard and armed, nothing to plan against: the vehicle holds, and
  // would hold for ever.
  if (phase_ == Phase::kWaitingForPlan && !first_plan_ && !TargetPoseAt(t) &&
      t - confirmed_time_ > options_.connect_timeout) {
    Fail(Phase::kHoldingAfterFailure,
         Format("no estimate of the target %.1f s after the vehicle was ready (%ld measurements used)",
                options_.connect_timeout, stats_.target_measurements),
         HoldCause::kTargetLost);
    return;
  }
  if (phase_ == Phase::kFlying && t - target_time_ > options_.target_timeout) {
    Fail(Phase::kHoldingAfterFailure,
         Format("no measurement of the target for %.2f s (limit %.2f s)", t - target_time_, options_.target_timeout),
         HoldCause::kTargetLost);
    return;
  }
  if (phase_ == Phase::kArrived && !arrival_done_ && to_.plan) {
    const double arrival = to_.start + to_.plan->trajectory->duration();
    if (position_time_ >= arrival) {
      const double error = ToolTargetError();
      if (std::isnan(stats_.arrival_target_error)) {
        stats_.arrival_target_error = error;
        stats_.max_follow_target_error = error;
      }
      stats_.max_follow_target_error = std::max(stats_.max_follow_target_error, error);
    }
    return;
  }
  if (phase_ != Phase::kFlying || !to_.target || t - last_target_trigger_ < options_.target_replan_interval) return;
  const double shift = ArrivalShift();
  // A prediction far ahead is uncertain and a later replan corrects it:
  // the threshold grows with the time left to the arrival.
  const double left = std::max(0.0, to_.start + to_.plan->trajectory->duration() - t);
  if (shift > options_.target_replan_threshold + options_.target_replan_slope * left) ReplanTail(t, shift);
}

void OnlineController::CarryWithTarget(double t, double tau, const Vec3& plan_velocity, double rate,
                                       double rate_change, Setpoint* retreat) const {
  const std::optional<TargetEstimate> now = tracker_ != nullptr ? tracker_->Estimate(t) : std::nullopt;
  if (!now || !to_.target) return;
  const planner::TargetMotion& planned = to_.target->motion;
  // Relative to the target the plan runs backwards at `rate`, and the
  // target carries the whole: the world velocity is the target's at the
  // point plus the relative one turned with it (the tracker's motion has no
  // acceleration; the turn's own terms are left out).
  const Pose carry = TargetPoseOf(*now) * PlannedTarget(to_, tau).inverse();
  const Mat3& turn = carry.linear();
  const Vec3 planned_point_velocity = planned.PointVelocity(retreat->position, tau);
  const Vec3 position = carry * retreat->position;
  retreat->velocity = now->velocity + now->yaw_rate * Vec3::UnitZ().cross(position - now->position) +
                      turn * (plan_velocity - planned_point_velocity) * rate;
  retreat->acceleration = turn * (retreat->acceleration - planned_point_velocity * rate_change);
  retreat->position = position;
  retreat->yaw += std::atan2(turn(1, 0), turn(0, 0));
  retreat->yaw_rate = now->yaw_rate + retreat->yaw_rate - planned.YawRate(tau) * rate;
}

bool OnlineController::RetreatWithTargetIsClear(double t) {
  auto margin_at = [&](double tau) {
    int link = -1;
    return ConfigurationMargin(nullptr, LevelStateOf(RetreatReference(t + tau)), &link);
  };
  for (double tau = 0.0; tau <= retreat_duration_ + 1e-9; tau += kFollowCheckStep) {
    if (margin_at(tau) < 0.0) return false;
  }
  // The follow after it stops short of what would come too near.
  retreat_hold_ = options_.abort_hold;
  for (double tau = kFollowCheckStep; tau <= options_.abort_hold + 1e-9; tau += kFollowCheckStep) {
    if (margin_at(retreat_duration_ + tau) < 0.0) {
      retreat_hold_ = tau - kFollowCheckStep;
      break;
    }
  }
  return true;
}

}  // namespace quadhand::online
