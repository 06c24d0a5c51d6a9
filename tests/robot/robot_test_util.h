// Shared helpers of the robot tests: fixture paths, state perturbation and
// central-difference Jacobians to check the analytic ones against.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "quadhand/core/types.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::robot::testing {

inline constexpr double kPi = 3.14159265358979323846;

inline std::string SourcePath(const std::string& relative) {
  return std::string(QUADHAND_SOURCE_DIR) + "/" + relative;
}
inline std::string FixturePath(const std::string& relative) {
  return SourcePath("tests/robot/fixtures/" + relative);
}
inline std::string Arm2Path() { return FixturePath("qh_fixture_pkg/urdf/arm2.urdf"); }

// The state perturbed by dx, laid out like a Jacobian's columns: base
// translation, base rotation as exp([dphi]x) R, then actuated joints.
struct State {
  Pose X_WB = Pose::Identity();
  VecX q;

  State Perturbed(const VecX& dx) const {
    State out = *this;
    out.X_WB.translation() += dx.head<3>();
    out.X_WB.linear() = ExpSO3(dx.segment<3>(3)) * X_WB.linear();
    out.q += dx.tail(q.size());
    return out;
  }
};

// Rotation vector of R (log map).
inline Vec3 LogSO3(const Mat3& R) {
  const Eigen::AngleAxisd angle_axis(R);
  return angle_axis.angle() * angle_axis.axis();
}

// Step of the central differences. Truncation error ~ h^2 |f'''| / 6 ~ 1e-13,
// rounding ~ eps |f| / h ~ 1e-9 for positions of order 1 m.
inline constexpr double kFiniteDifferenceStep = 1e-6;
// Per column: max |J_numeric - J_analytic| <= tol * max(1, max |J_numeric|).
inline constexpr double kJacobianRelativeTolerance = 1e-6;

// Central-difference Jacobian of the world position of the point p_L fixed to `link`.
inline Jacobian NumericPointJacobian(const RobotModel& model, const State& state, int link,
                                     const Vec3& p_L) {
  const int n = 6 + model.num_actuated();
  const double h = kFiniteDifferenceStep;
  Jacobian J(3, n);
  for (int k = 0; k < n; ++k) {
    VecX dx = VecX::Zero(n);
    dx[k] = h;
    const State plus = state.Perturbed(dx);
    const State minus = state.Perturbed(-dx);
    const Vec3 p_plus = LinkPose(model, plus.X_WB, plus.q, link) * p_L;
    const Vec3 p_minus = LinkPose(model, minus.X_WB, minus.q, link) * p_L;
    J.col(k) = (p_plus - p_minus) / (2.0 * h);
  }
  return J;
}

// Central-difference Jacobian of the link pose: origin velocity, then angular
// velocity from log(R(+h) R(-h)^T) / 2h, both world frame.
inline Jacobian NumericLinkJacobian(const RobotModel& model, const State& state, int link) {
  const int n = 6 + model.num_actuated();
  const double h = kFiniteDifferenceStep;
  Jacobian J(6, n);
  for (int k = 0; k < n; ++k) {
    VecX dx = VecX::Zero(n);
    dx[k] = h;
    const State plus = state.Perturbed(dx);
    const State minus = state.Perturbed(-dx);
    const Pose X_plus = LinkPose(model, plus.X_WB, plus.q, link);
    const Pose X_minus = LinkPose(model, minus.X_WB, minus.q, link);
    J.block(0, k, 3, 1) = (X_plus.translation() - X_minus.translation()) / (2.0 * h);
    J.block(3, k, 3, 1) =
        LogSO3(X_plus.linear() * X_minus.linear().transpose()) / (2.0 * h);
  }
  return J;
}

// Largest per-column error relative to max(1, column magnitude); the
// comparison used by every Jacobian test.
inline double JacobianError(const Jacobian& numeric, const Jacobian& analytic) {
  double worst = 0.0;
  for (int k = 0; k < numeric.cols(); ++k) {
    const double scale = std::max(1.0, numeric.col(k).cwiseAbs().maxCoeff());
    const double error = (numeric.col(k) - analytic.col(k)).cwiseAbs().maxCoeff() / scale;
    worst = std::max(worst, error);
  }
  return worst;
}

inline Pose RandomPose(std::mt19937* rng, double position_range) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Quat rotation(uniform(*rng), uniform(*rng), uniform(*rng), uniform(*rng));
  if (rotation.norm() < 1e-3) rotation = Quat::Identity();
  Vec3 position(uniform(*rng), uniform(*rng), uniform(*rng));
  return MakePose(position_range * position, rotation.normalized().toRotationMatrix());
}

// Uniform within the joint limits; [-pi, pi] where a joint has none.
inline VecX RandomConfiguration(const RobotModel& model, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  VecX q(model.num_actuated());
  const VecX lower = model.LowerLimits();
  const VecX upper = model.UpperLimits();
  for (int k = 0; k < q.size(); ++k) {
    const double lo = std::isfinite(lower[k]) ? lower[k] : -kPi;
    const double hi = std::isfinite(upper[k]) ? upper[k] : kPi;
    q[k] = lo + (hi - lo) * uniform(*rng);
  }
  return q;
}

}  // namespace quadhand::robot::testing
