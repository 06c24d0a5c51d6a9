#include "quadhand/planner/moving_scene.h"

#include <algorithm>

namespace quadhand::planner {

SceneAtTimeModel::SceneAtTimeModel(const env::CollisionModel& still, const env::CollisionModel& moving,
                                   const TargetMotion& motion, double t)
    : still_(still),
      moving_(moving),
      displacement_(motion.Displacement(t)),
      back_(displacement_.inverse()),
      still_slots_(env::SlotsOfLinks(still.links())),
      moving_slots_(env::SlotsOfLinks(moving.links())) {
  links_ = still.links();
  links_.insert(links_.end(), moving.links().begin(), moving.links().end());
  std::sort(links_.begin(), links_.end());
  links_.erase(std::unique(links_.begin(), links_.end()), links_.end());
}

env::DistanceQuality SceneAtTimeModel::distance_quality() const {
  // The weaker of the two (the enum runs from exact to a lower bound).
  return std::max(still_.distance_quality(), moving_.distance_quality());
}

double SceneAtTimeModel::LinkPenalty(int link, const Pose& X_WL, const env::PenaltyParameters& parameters,
                                     const env::QueryContext& context, env::LinkWrench* wrench) const {
  double penalty = 0.0;
  if (Has(still_slots_, link)) penalty += still_.LinkPenalty(link, X_WL, parameters, context, wrench);
  if (Has(moving_slots_, link)) {
    env::LinkWrench at_zero;
    const double moving = moving_.LinkPenalty(link, back_ * X_WL, parameters, context,
                                              wrench != nullptr ? &at_zero : nullptr);
    penalty += moving;
    if (wrench != nullptr && moving > 0.0) {
      wrench->force += displacement_.linear() * at_zero.force;
      wrench->torque += displacement_.linear() * at_zero.torque;
    }
  }
  return penalty;
}

double SceneAtTimeModel::LinkClearance(int link, const Pose& X_WL, double search_radius,
                                       const env::QueryContext& context) const {
  double clearance = search_radius;
  if (Has(still_slots_, link)) clearance = std::min(clearance, still_.LinkClearance(link, X_WL, search_radius, context));
  if (Has(moving_slots_, link)) {
    clearance = std::min(clearance, moving_.LinkClearance(link, back_ * X_WL, search_radius, context));
  }
  return clearance;
}

BoundaryState MovedState(const BoundaryState& at_zero, const TargetMotion& motion, double t) {
  BoundaryState moved = at_zero;
  Vec3 d[5];
  motion.PointDerivatives(at_zero.position, t, d);
  moved.position = d[0];
  moved.velocity = d[1];
  moved.acceleration = d[2];
  moved.jerk = d[3];
  moved.yaw = at_zero.yaw + motion.Yaw(t);
  moved.yaw_rate = motion.YawRate(t);
  moved.joint_rates = VecX::Zero(at_zero.joints.size());
  return moved;
}

BoundaryState MovedRestState(const BoundaryState& state, const Pose& move, double turn) {
  BoundaryState moved = state;
  moved.position = move * state.position;
  moved.yaw = state.yaw + turn;
  moved.velocity.setZero();
  moved.acceleration.setZero();
  moved.jerk.setZero();
  moved.yaw_rate = 0.0;
  moved.joint_rates = VecX::Zero(state.joints.size());
  return moved;
}

BoundaryState StateAtZero(const BoundaryState& at_t, const TargetMotion& motion, double t) {
  return MovedRestState(at_t, motion.Displacement(t).inverse(), -motion.Yaw(t));
}

InsertionGoal MovedInsertion(const InsertionGoal& insertion, const Pose& move) {
  InsertionGoal moved = insertion;
  moved.tool_position = move * insertion.tool_position;
  moved.tool_orientation = Quat(move.linear() * insertion.tool_orientation.toRotationMatrix());
  moved.direction = move.linear() * insertion.direction;
  return moved;
}

InsertionGoal MovedInsertion(const InsertionGoal& at_zero, const TargetMotion& motion, double t) {
  return MovedInsertion(at_zero, motion.Displacement(t));
}

robot::KinematicsState InTargetFrameAtZero(const robot::KinematicsState& kinematics, const TargetMotion& motion,
                                           double t) {
  return InTargetFrameAtZero(kinematics, motion.Displacement(t));
}

robot::KinematicsState InTargetFrameAtZero(const robot::KinematicsState& kinematics, const Pose& displacement) {
  robot::KinematicsState back = kinematics;
  const Pose inverse = displacement.inverse();
  for (Pose& pose : back.link_poses) pose = inverse * pose;
  for (Vec3& axis : back.joint_axes) axis = inverse.linear() * axis;
  for (Vec3& origin : back.joint_origins) origin = inverse * origin;
  return back;
}

double StillAndMovingClearance(const robot::KinematicsState& kinematics, const env::CollisionModel& still,
                               const env::CollisionModel* moving, const Pose& displacement, double reach, int* link) {
  int still_link = -1;
  double clearance = env::WholeBodyClearance(kinematics, still, reach, {}, &still_link);
  if (link != nullptr) *link = still_link;
  if (moving == nullptr) return clearance;
  int moving_link = -1;
  const double near_target =
      env::WholeBodyClearance(InTargetFrameAtZero(kinematics, displacement), *moving, reach, {}, &moving_link);
  if (near_target < clearance) {
    clearance = near_target;
    if (link != nullptr) *link = moving_link;
  }
  return clearance;
}

}  // namespace quadhand::planner
