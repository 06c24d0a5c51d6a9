// The moving target as quadhand-online sees it (docs/moving_targets.md,
// "Online"): noisy, time-stamped measurements of its position and heading
// (LANDING_TARGET over MAVLink), filtered by a constant-velocity Kalman
// filter per axis and for the yaw, and predicted forward as the constant
// motion the planner plans against (planner::TargetMotion).
//
// Model: each coordinate is a position with a velocity driven by white
// acceleration of spectral density `acceleration_noise` (m^2/s^3; rad^2/s^3
// for the yaw); each measurement has independent noise of standard deviation
// `position_noise` (m) and `yaw_noise` (rad). A measurement older than the
// newest one taken is dropped (a reordered link); one farther from the
// prediction than `gate` standard deviations of the innovation is rejected
// as an outlier, and after `max_rejections` rejections in a row the filter
// starts again from the next measurement (the target was moved, or the
// estimate lost it).
#pragma once

#include <optional>
#include <string>

#include "quadhand/core/types.h"
#include "quadhand/planner/target_motion.h"

namespace quadhand::online {

struct TargetTrackerOptions {
  double position_noise = 0.005;      // m, one standard deviation per axis
  double yaw_noise = 0.02;            // rad
  // m^2/s^3: a belt or a turntable changes speed slowly (an acceleration of
  // about 0.1 m/s^2 over a second); a target that changes faster is
  // followed with a lag unless this is raised.
  double acceleration_noise = 0.01;
  double yaw_acceleration_noise = 0.01;  // rad^2/s^3
  double initial_speed = 1.0;         // m/s, the velocity's prior standard deviation
  double gate = 5.0;                  // standard deviations of the innovation
  int max_rejections = 5;
  // Measurements needed before Estimate() gives one (two fix a velocity).
  int min_measurements = 3;

  bool IsValid(std::string* why) const;
};

struct TargetEstimate {
  double time = 0.0;  // the time it is for
  Vec3 position = Vec3::Zero(), velocity = Vec3::Zero();
  double yaw = 0.0, yaw_rate = 0.0;
  // One standard deviation of the position (the largest axis'), m.
  double position_sigma = 0.0;
};

class TargetTracker {
 public:
  explicit TargetTracker(const TargetTrackerOptions& options = {});

  // One measurement of the target's position (world ENU) and yaw (about
  // world z) at time t. Returns false when it was not used (older than the
  // newest, not finite, or rejected by the gate).
  bool Observe(double t, const Vec3& position, double yaw);

  // The estimate predicted to time t, before the newest measurement's time
  // too (the constant-velocity model run backwards; the spread grows with
  // |t - that time|); none before min_measurements were taken.
  std::optional<TargetEstimate> Estimate(double t) const;

  // The estimate at t as a constant motion whose clock starts at t (its
  // origin is the estimated position, turning about it at the yaw rate).
  std::optional<planner::TargetMotion> MotionFrom(double t) const;

  int measurements() const { return measurements_; }  // used, in all
  int dropped() const { return dropped_; }     // older than the newest
  int rejected() const { return rejected_; }   // by the gate
  int restarts() const { return restarts_; }   // after max_rejections in a row

 private:
  // One coordinate: position and rate, and their covariance.
  struct Axis {
    double x = 0.0, v = 0.0;
    double pxx = 0.0, pxv = 0.0, pvv = 0.0;
  };
  static Axis Predicted(const Axis& axis, double dt, double q);
  void Restart(double t, const Vec3& position, double yaw);

  TargetTrackerOptions options_;
  Axis axes_[4];  // x, y, z, yaw (unwrapped)
  double time_ = 0.0;
  int measurements_ = 0, dropped_ = 0, rejected_ = 0, restarts_ = 0, rejections_in_row_ = 0;
  int track_length_ = 0;  // measurements since the last (re)start
};

}  // namespace quadhand::online
