// Eigen aliases and small SE(3) helpers used across QuadHand.
// Conventions (see docs/conventions.md): world frame ENU, metres, radians;
// quaternions are Hamilton, body-to-world; a pose X_WB maps B coordinates to W.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace quadhand {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using VecX = Eigen::VectorXd;
using MatX = Eigen::MatrixXd;
using Quat = Eigen::Quaterniond;
using Pose = Eigen::Isometry3d;

// Skew-symmetric matrix [v]x such that [v]x w = v x w.
inline Mat3 Skew(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// Pose from a translation and a rotation.
inline Pose MakePose(const Vec3& translation, const Mat3& rotation) {
  Pose pose = Pose::Identity();
  pose.linear() = rotation;
  pose.translation() = translation;
  return pose;
}

// A finite pose whose linear part is a rotation (orthonormal to 1e-6,
// not a reflection).
inline bool IsRigidMotion(const Pose& pose) {
  const Mat3& R = pose.linear();
  return pose.matrix().allFinite() && (R.transpose() * R - Mat3::Identity()).norm() < 1e-6 && R.determinant() > 0.0;
}

// Rotation matrix exp([w]x) of a rotation vector (axis * angle).
inline Mat3 ExpSO3(const Vec3& rotation_vector) {
  const double angle = rotation_vector.norm();
  if (angle < 1e-12) return Mat3::Identity() + Skew(rotation_vector);
  return Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix();
}

}  // namespace quadhand
