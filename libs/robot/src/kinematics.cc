#include "quadhand/robot/kinematics.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace quadhand::robot {
namespace {

// Joint position from q: the joint's own coordinate, or its mimic source's
// mapped through the (composed) multiplier and offset; 0 for fixed joints.
double JointPosition(const Joint& joint, const VecX& q) {
  if (joint.q_index < 0) return 0.0;
  return joint.mimic_multiplier * q[joint.q_index] + joint.mimic_offset;
}

// Rotation by `angle` about the unit `axis` (Rodrigues).
Mat3 AxisRotation(const Vec3& axis, double angle) {
  const double c = std::cos(angle);
  const double s = std::sin(angle);
  Mat3 R = (1.0 - c) * axis * axis.transpose();
  R.diagonal().array() += c;
  R += s * Skew(axis);
  return R;
}

// Pose of the child link in the world from its parent's X_WP, written into
// *X_WC in place (no temporaries of the state's size); also returns the joint
// frame's rotation R_WJ, which gives the joint's world axis.
void ChildPose(const Joint& joint, const Pose& X_WP, double position, Mat3* R_WJ, Pose* X_WC) {
  *R_WJ = X_WP.linear() * joint.origin.linear();
  const Vec3 p_WJ = X_WP.translation() + X_WP.linear() * joint.origin.translation();
  switch (joint.type) {
    case JointType::kRevolute:
    case JointType::kContinuous:
      X_WC->linear() = *R_WJ * AxisRotation(joint.axis, position);
      X_WC->translation() = p_WJ;
      return;
    case JointType::kPrismatic:
      X_WC->linear() = *R_WJ;
      X_WC->translation() = p_WJ + *R_WJ * (joint.axis * position);
      return;
    case JointType::kFixed:
      break;
  }
  X_WC->linear() = *R_WJ;
  X_WC->translation() = p_WJ;
}

template <typename Vector>
void ResizeIfNeeded(Vector* vector, int size) {
  // resize() with an unchanged size keeps the storage, so the steady state
  // (the optimiser's inner loop) never allocates.
  if (static_cast<int>(vector->size()) != size) vector->resize(static_cast<size_t>(size));
}

void ResizeJacobian(Jacobian* J, int rows, int cols) {
  if (J->rows() != rows || J->cols() != cols) J->resize(rows, cols);
  J->setZero();
}

}  // namespace

void ComputeKinematics(const RobotModel& model, const Pose& X_WB, const VecX& q,
                       KinematicsState* state) {
  assert(state != nullptr);
  assert(q.size() == model.num_actuated());
  ResizeIfNeeded(&state->link_poses, model.num_links());
  ResizeIfNeeded(&state->joint_axes, model.num_joints());
  ResizeIfNeeded(&state->joint_origins, model.num_joints());
  ResizeIfNeeded(&state->joint_positions, model.num_joints());
  state->link_poses[0] = X_WB;
  // Topological order: a joint's parent link pose is always ready.
  for (int j = 0; j < model.num_joints(); ++j) {
    const Joint& joint = model.joint(j);
    const double position = JointPosition(joint, q);
    Pose& X_WC = state->link_poses[joint.child_link];
    Mat3 R_WJ;
    ChildPose(joint, state->link_poses[joint.parent_link], position, &R_WJ, &X_WC);
    state->joint_axes[j] = R_WJ * joint.axis;
    state->joint_origins[j] = X_WC.translation();
    state->joint_positions[j] = position;
  }
}

Pose LinkPose(const RobotModel& model, const Pose& X_WB, const VecX& q, int link) {
  assert(q.size() == model.num_actuated());
  Pose X_WL = X_WB;
  Mat3 R_WJ;
  for (int j : model.JointsToLink(link)) {
    const Joint& joint = model.joint(j);
    Pose X_WC = Pose::Identity();
    ChildPose(joint, X_WL, JointPosition(joint, q), &R_WJ, &X_WC);
    X_WL = X_WC;
  }
  return X_WL;
}

void PointJacobian(const RobotModel& model, const KinematicsState& state, int link,
                   const Vec3& p_W, Jacobian* J) {
  assert(J != nullptr);
  ResizeJacobian(J, 3, 6 + model.num_actuated());
  J->block<3, 3>(0, 0).setIdentity();
  // p = p_WB + R r: the perturbation R -> exp([dphi]x) R moves p by dphi x (p - p_WB).
  J->block<3, 3>(0, 3) = -Skew(p_W - state.link_poses[0].translation());
  for (int j : model.JointsToLink(link)) {
    const Joint& joint = model.joint(j);
    if (joint.q_index < 0) continue;
    // A mimic joint moves with d(position)/dq = multiplier of its source's coordinate.
    const Vec3& axis = state.joint_axes[j];
    const Vec3 column = joint.type == JointType::kPrismatic
                            ? Vec3(axis)
                            : Vec3(axis.cross(p_W - state.joint_origins[j]));
    J->col(6 + joint.q_index) += joint.mimic_multiplier * column;
  }
}

void LinkJacobian(const RobotModel& model, const KinematicsState& state, int link, Jacobian* J) {
  assert(J != nullptr);
  ResizeJacobian(J, 6, 6 + model.num_actuated());
  const Vec3& p_W = state.link_poses[link].translation();
  J->block<3, 3>(0, 0).setIdentity();
  J->block<3, 3>(0, 3) = -Skew(p_W - state.link_poses[0].translation());
  J->block<3, 3>(3, 3).setIdentity();
  for (int j : model.JointsToLink(link)) {
    const Joint& joint = model.joint(j);
    if (joint.q_index < 0) continue;
    const Vec3& axis = state.joint_axes[j];
    const int col = 6 + joint.q_index;
    if (joint.type == JointType::kPrismatic) {
      J->block<3, 1>(0, col) += joint.mimic_multiplier * axis;
    } else {
      J->block<3, 1>(0, col) += joint.mimic_multiplier * axis.cross(p_W - state.joint_origins[j]);
      J->block<3, 1>(3, col) += joint.mimic_multiplier * axis;
    }
  }
}

std::vector<double> LinkOriginReach(const RobotModel& model) {
  std::vector<double> reach(model.num_links(), 0.0);
  const VecX lower = model.LowerLimits(), upper = model.UpperLimits();
  for (int j = 0; j < model.num_joints(); ++j) {  // parents come first (topological order)
    const Joint& joint = model.joint(j);
    double travel = 0.0;
    if (joint.type == JointType::kPrismatic && joint.q_index >= 0) {
      // A mimic joint moves by multiplier x its source's position + offset.
      travel = std::max(std::abs(lower[joint.q_index]), std::abs(upper[joint.q_index]));
      if (joint.is_mimic) travel = std::abs(joint.mimic_multiplier) * travel + std::abs(joint.mimic_offset);
    }
    reach[joint.child_link] = reach[joint.parent_link] + joint.origin.translation().norm() + travel;
  }
  return reach;
}

}  // namespace quadhand::robot
