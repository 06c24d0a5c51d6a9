// Private helpers of libs/sim: a joint's transform and motion subspace.
#pragma once

#include <cmath>

#include "quadhand/core/types.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::sim::internal {

// X_PC: the child link's pose in the parent link at joint position `position`.
inline Pose JointTransform(const robot::Joint& joint, double position) {
  Pose X = joint.origin;
  switch (joint.type) {
    case robot::JointType::kRevolute:
    case robot::JointType::kContinuous:
      X.linear() = joint.origin.linear() * Eigen::AngleAxisd(position, joint.axis).toRotationMatrix();
      break;
    case robot::JointType::kPrismatic:
      X.translation() += joint.origin.linear() * (joint.axis * position);
      break;
    case robot::JointType::kFixed:
      break;
  }
  return X;
}

// Motion subspace S (6-vector, [angular; linear], child frame) of a joint.
inline Eigen::Matrix<double, 6, 1> MotionSubspace(const robot::Joint& joint) {
  Eigen::Matrix<double, 6, 1> S = Eigen::Matrix<double, 6, 1>::Zero();
  switch (joint.type) {
    case robot::JointType::kRevolute:
    case robot::JointType::kContinuous:
      S.head<3>() = joint.axis;
      break;
    case robot::JointType::kPrismatic:
      S.tail<3>() = joint.axis;
      break;
    case robot::JointType::kFixed:
      break;
  }
  return S;
}

}  // namespace quadhand::sim::internal
