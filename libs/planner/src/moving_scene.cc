#include "quadhand/planner/moving_scene.h"

namespace quadhand::planner {

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

BoundaryState StateAtZero(const BoundaryState& at_t, const TargetMotion& motion, double t) {
  BoundaryState back = at_t;
  back.position = motion.Displacement(t).inverse() * at_t.position;
  back.yaw = at_t.yaw - motion.Yaw(t);
  back.velocity.setZero();
  back.acceleration.setZero();
  back.jerk.setZero();
  back.yaw_rate = 0.0;
  back.joint_rates = VecX::Zero(at_t.joints.size());
  return back;
}

InsertionGoal MovedInsertion(const InsertionGoal& at_zero, const TargetMotion& motion, double t) {
  InsertionGoal moved = at_zero;
  const Pose displacement = motion.Displacement(t);
  moved.tool_position = displacement * at_zero.tool_position;
  moved.tool_orientation = Quat(displacement.linear() * at_zero.tool_orientation.toRotationMatrix());
  moved.direction = displacement.linear() * at_zero.direction;
  return moved;
}

robot::KinematicsState InTargetFrameAtZero(const robot::KinematicsState& kinematics, const TargetMotion& motion,
                                           double t) {
  robot::KinematicsState back = kinematics;
  const Pose inverse = motion.Displacement(t).inverse();
  for (Pose& pose : back.link_poses) pose = inverse * pose;
  for (Vec3& axis : back.joint_axes) axis = inverse.linear() * axis;
  for (Vec3& origin : back.joint_origins) origin = inverse * origin;
  return back;
}

}  // namespace quadhand::planner
