#include "quadhand/online/setpoint.h"

#include <algorithm>
#include <cmath>

namespace quadhand::online {

Setpoint FromState(const planner::BoundaryState& state) {
  Setpoint s;
  s.position = state.position;
  s.velocity = state.velocity;
  s.acceleration = state.acceleration;
  s.yaw = state.yaw;
  s.yaw_rate = state.yaw_rate;
  s.joints = state.joints;
  s.joint_rates = state.joint_rates;
  return s;
}

Setpoint FromSample(const planner::WholeBodySample& sample) { return FromState(sample.State()); }

Setpoint HoldAt(const Setpoint& setpoint) {
  Setpoint hold = setpoint;
  hold.velocity.setZero();
  hold.acceleration.setZero();
  hold.yaw_rate = 0.0;
  hold.joint_rates = VecX::Zero(setpoint.joints.size());
  return hold;
}

double SpliceWeight(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * s * (10.0 + s * (-15.0 + 6.0 * s));
}

Setpoint Blend(const Setpoint& a, const Setpoint& b, double w) {
  Setpoint s;
  const double u = 1.0 - w;
  s.position = u * a.position + w * b.position;
  s.velocity = u * a.velocity + w * b.velocity;
  s.acceleration = u * a.acceleration + w * b.acceleration;
  s.yaw = a.yaw + w * std::remainder(b.yaw - a.yaw, 2.0 * M_PI);
  s.yaw_rate = u * a.yaw_rate + w * b.yaw_rate;
  s.joints = u * a.joints + w * b.joints;
  s.joint_rates = u * a.joint_rates + w * b.joint_rates;
  return s;
}

double BlendStepBound(double max_speed, double max_separation, double window, double dt) {
  return max_speed * dt + 15.0 / (8.0 * window) * dt * max_separation;
}

}  // namespace quadhand::online
