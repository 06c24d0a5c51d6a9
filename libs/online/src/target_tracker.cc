#include "quadhand/online/target_tracker.h"

#include <algorithm>
#include <cmath>

namespace quadhand::online {

bool TargetTrackerOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  for (double v : {position_noise, yaw_noise, acceleration_noise, yaw_acceleration_noise, initial_speed, gate}) {
    if (!(std::isfinite(v) && v > 0.0)) return fail("target tracker: noises, prior and gate must be positive");
  }
  if (max_rejections < 1) return fail("target tracker: max_rejections must be >= 1");
  if (min_measurements < 2) return fail("target tracker: min_measurements must be >= 2 (a velocity needs two)");
  return true;
}

TargetTracker::TargetTracker(const TargetTrackerOptions& options) : options_(options) {}

TargetTracker::Axis TargetTracker::Predicted(const Axis& a, double dt, double q) {
  // x' = x + v dt; P' = F P F^T + Q, Q of white acceleration of density q.
  Axis p = a;
  p.x = a.x + a.v * dt;
  p.pxx = a.pxx + 2.0 * dt * a.pxv + dt * dt * a.pvv + q * dt * dt * dt / 3.0;
  p.pxv = a.pxv + dt * a.pvv + q * dt * dt / 2.0;
  p.pvv = a.pvv + q * dt;
  return p;
}

void TargetTracker::Restart(double t, const Vec3& position, double yaw) {
  const double speed_prior = options_.initial_speed * options_.initial_speed;
  for (int k = 0; k < 3; ++k) {
    axes_[k] = Axis{position[k], 0.0, options_.position_noise * options_.position_noise, 0.0, speed_prior};
  }
  axes_[3] = Axis{yaw, 0.0, options_.yaw_noise * options_.yaw_noise, 0.0, 1.0};
  time_ = t;
  track_length_ = 1;
  rejections_in_row_ = 0;
}

bool TargetTracker::Observe(double t, const Vec3& position, double yaw) {
  if (!std::isfinite(t) || !position.allFinite() || !std::isfinite(yaw)) {
    ++dropped_;
    return false;
  }
  if (track_length_ == 0) {
    Restart(t, position, yaw);
    ++measurements_;
    return true;
  }
  if (t <= time_) {
    ++dropped_;
    return false;
  }
  const double dt = t - time_;
  Axis predicted[4];
  double measured[4] = {position.x(), position.y(), position.z(), 0.0};
  const double noise[4] = {options_.position_noise, options_.position_noise, options_.position_noise,
                           options_.yaw_noise};
  const double q[4] = {options_.acceleration_noise, options_.acceleration_noise, options_.acceleration_noise,
                       options_.yaw_acceleration_noise};
  for (int k = 0; k < 4; ++k) predicted[k] = Predicted(axes_[k], dt, q[k]);
  // The yaw is unwrapped onto the prediction's turn.
  measured[3] = predicted[3].x + std::remainder(yaw - predicted[3].x, 2.0 * M_PI);
  // The gate: the innovation of every coordinate against its own spread.
  bool outlier = false;
  for (int k = 0; k < 4; ++k) {
    const double s = predicted[k].pxx + noise[k] * noise[k];
    if (std::abs(measured[k] - predicted[k].x) > options_.gate * std::sqrt(s)) outlier = true;
  }
  if (outlier && track_length_ >= options_.min_measurements) {
    ++rejected_;
    if (++rejections_in_row_ >= options_.max_rejections) {
      ++restarts_;
      Restart(t, position, yaw);
      ++measurements_;
      return true;
    }
    return false;
  }
  for (int k = 0; k < 4; ++k) {
    Axis& a = axes_[k];
    a = predicted[k];
    const double s = a.pxx + noise[k] * noise[k];
    const double gain_x = a.pxx / s, gain_v = a.pxv / s;
    const double innovation = measured[k] - a.x;
    a.x += gain_x * innovation;
    a.v += gain_v * innovation;
    const double pxx = (1.0 - gain_x) * a.pxx;
    const double pxv = (1.0 - gain_x) * a.pxv;
    const double pvv = a.pvv - gain_v * a.pxv;
    a.pxx = pxx;
    a.pxv = pxv;
    a.pvv = pvv;
  }
  time_ = t;
  ++measurements_;
  ++track_length_;
  rejections_in_row_ = 0;
  return true;
}

std::optional<TargetEstimate> TargetTracker::Estimate(double t) const {
  if (track_length_ < options_.min_measurements) return std::nullopt;
  // Before the newest measurement too: a vehicle's state is judged against
  // the target at the state's own time, and a measurement that came after
  // it must not move the target on (clamped, it put a cup at 0.3 m/s up to
  // a frame, 1 cm, ahead of where it was). The mean runs the model
  // backwards; the spread grows with the time either way.
  const double dt = t - time_;
  TargetEstimate estimate;
  estimate.time = t;
  const double q[4] = {options_.acceleration_noise, options_.acceleration_noise, options_.acceleration_noise,
                       options_.yaw_acceleration_noise};
  double sigma = 0.0;
  for (int k = 0; k < 3; ++k) {
    const Axis a = Predicted(axes_[k], std::abs(dt), q[k]);
    estimate.position[k] = axes_[k].x + axes_[k].v * dt;
    estimate.velocity[k] = a.v;
    sigma = std::max(sigma, std::sqrt(std::max(0.0, a.pxx)));
  }
  const Axis yaw = Predicted(axes_[3], std::abs(dt), q[3]);
  estimate.yaw = axes_[3].x + axes_[3].v * dt;
  estimate.yaw_rate = yaw.v;
  estimate.position_sigma = sigma;
  return estimate;
}

std::optional<planner::TargetMotion> TargetTracker::MotionFrom(double t) const {
  const std::optional<TargetEstimate> estimate = Estimate(t);
  if (!estimate) return std::nullopt;
  return planner::TargetMotion::Constant(estimate->position, estimate->velocity, Vec3::Zero(), estimate->yaw_rate);
}

}  // namespace quadhand::online
