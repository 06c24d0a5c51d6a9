// Forward kinematics of a floating-base robot and analytic Jacobians.
//
// The state is the root (base) pose X_WB and the actuated joint positions q.
// A Jacobian here has 6 + num_actuated columns:
//   columns 0-2: base translation, world frame;
//   columns 3-5: base rotation as a world-frame rotation vector dphi, i.e. the
//                perturbation R_WB -> exp([dphi]x) R_WB (p_WB unchanged);
//   columns 6+k: actuated joint k (mimic joints contribute through their source).
#pragma once

#include <vector>

#include "quadhand/robot/robot_model.h"

namespace quadhand::robot {

// Everything forward kinematics computes, reusable by Jacobian queries.
struct KinematicsState {
  std::vector<Pose> link_poses;         // X_WL for every link
  std::vector<Vec3> joint_axes;         // unit axis of every joint, world frame
  std::vector<Vec3> joint_origins;      // origin of every joint (= child link) frame, world frame
  std::vector<double> joint_positions;  // position of every joint (0 for fixed)
};

// Fills `state` for the base pose X_WB and actuated positions q (size num_actuated).
void ComputeKinematics(const RobotModel& model, const Pose& X_WB, const VecX& q,
                       KinematicsState* state);

// Convenience: pose of one link.
Pose LinkPose(const RobotModel& model, const Pose& X_WB, const VecX& q, int link);

// Per link: an upper bound of the distance from the root link's origin to
// the link's origin over every joint value within the limits (the sum of the
// joint offsets along the chain, plus each prismatic joint's largest travel;
// rotations do not move a child origin away from its joint). Infinite below
// a prismatic joint without limits. From the URDF alone: the arm's reach,
// with no constant of any particular robot.
std::vector<double> LinkOriginReach(const RobotModel& model);

using Jacobian = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic>;

// 3 x (6 + n) Jacobian of the world position of a point rigidly attached to
// `link`, given by its current world position p_W.
void PointJacobian(const RobotModel& model, const KinematicsState& state, int link,
                   const Vec3& p_W, Jacobian* J);

// 6 x (6 + n) Jacobian of the pose of `link`: rows 0-2 the velocity of the
// link origin, rows 3-5 the angular velocity, both in the world frame.
void LinkJacobian(const RobotModel& model, const KinematicsState& state, int link, Jacobian* J);

}  // namespace quadhand::robot
