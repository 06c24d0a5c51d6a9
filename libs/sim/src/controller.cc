#include "quadhand/sim/controller.h"

#include <algorithm>

#include "quadhand/traj/flatness.h"

namespace quadhand::sim {
namespace {

Vec3 Vee(const Mat3& S) { return Vec3(S(2, 1), S(0, 2), S(1, 0)); }

Vec3 ClampAbs(const Vec3& v, double limit) { return v.cwiseMax(-limit).cwiseMin(limit); }

}  // namespace

GeometricController::GeometricController(const ControllerConfig& config, double mass, const Mat3& inertia,
                                         double gravity)
    : config_(config), mass_(mass), inertia_(inertia), gravity_(gravity) {}

void GeometricController::Reset() {
  position_integral_.setZero();
  attitude_integral_.setZero();
}

ControllerOutput GeometricController::Update(const Measurement& m, const Setpoint& sp, double dt) {
  ControllerOutput out;
  const Vec3 e_p = m.position - sp.position;
  const Vec3 e_v = m.velocity - sp.velocity;
  position_integral_ = ClampAbs(position_integral_ + e_p * dt, config_.position_integral_limit);
  const Vec3 a_cmd = sp.acceleration - config_.position_gain.cwiseProduct(e_p) -
                     config_.velocity_gain.cwiseProduct(e_v) -
                     config_.position_integral_gain.cwiseProduct(position_integral_);

  traj::FlatnessOptions flat_options;
  flat_options.gravity = gravity_;
  const traj::FlatState desired = traj::FlatForward(sp.velocity, a_cmd, sp.jerk, sp.yaw, sp.yaw_rate, flat_options);
  const Mat3 R = m.attitude.toRotationMatrix();
  const Mat3 R_d = desired.rotation();
  out.desired_attitude = desired.attitude();
  out.thrust = mass_ * (a_cmd + gravity_ * Vec3::UnitZ()).dot(R.col(2));

  const Vec3 e_R = 0.5 * Vee(R_d.transpose() * R - R.transpose() * R_d);
  const Vec3 e_w = m.body_rate - R.transpose() * R_d * desired.body_rate;
  attitude_integral_ = ClampAbs(attitude_integral_ + e_R * dt, config_.attitude_integral_limit);
  const Vec3 alpha = -config_.attitude_gain.cwiseProduct(e_R) - config_.rate_gain.cwiseProduct(e_w) -
                     config_.attitude_integral_gain.cwiseProduct(attitude_integral_);
  out.torque = inertia_ * alpha + m.body_rate.cross(inertia_ * m.body_rate);
  out.attitude_error = e_R;
  return out;
}

Eigen::Vector4d MixRotors(const Eigen::Matrix4d& allocation, double thrust, const Vec3& torque, double min_thrust,
                          double max_thrust) {
  const Eigen::Matrix4d inverse = allocation.inverse();
  const Eigen::Vector4d base = inverse * Eigen::Vector4d(thrust, torque.x(), torque.y(), 0.0);
  const Eigen::Vector4d yaw = inverse.col(3) * torque.z();
  // The largest share of the yaw torque that keeps every rotor within limits.
  double share = 1.0;
  for (int i = 0; i < 4; ++i) {
    if (base[i] < min_thrust || base[i] > max_thrust) {
      share = 0.0;
      break;
    }
    if (yaw[i] > 0.0) share = std::min(share, (max_thrust - base[i]) / yaw[i]);
    if (yaw[i] < 0.0) share = std::min(share, (min_thrust - base[i]) / yaw[i]);
  }
  share = std::max(share, 0.0);
  return (base + share * yaw).cwiseMax(min_thrust).cwiseMin(max_thrust);
}

}  // namespace quadhand::sim
