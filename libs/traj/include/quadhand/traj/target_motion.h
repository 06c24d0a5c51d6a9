// A moving target's rigid motion (the task's goal.tool.motion, contracts.md
// version 0.3, docs/moving_targets.md), below the planner so that the
// simulator moves its targets with it too. The target translates and turns
// about the world z axis through itself, either at a constant velocity,
// acceleration and yaw rate, or along a sampled path read from a file. A
// hovering robot can follow a turn about z by its yaw alone, so a
// whole-body state that grasps the target at one time grasps it at any
// other once moved by the same displacement (planner::MovedState): the
// terminal state is a function of the arrival time.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::traj {

// One row of a sampled target path: the target's world pose at time t.
struct TargetPathSample {
  double t = 0.0;
  Vec3 position = Vec3::Zero();
  double yaw = 0.0;  // about world z, unwrapped along the path (rad)
};

class TargetMotion {
 public:
  // Constant motion of the target that is at `origin` at t = 0: velocity
  // and acceleration (world) and a yaw rate about world z through it.
  static TargetMotion Constant(const Vec3& origin, const Vec3& velocity, const Vec3& acceleration,
                               double yaw_rate);
  // A sampled path, linear in position and yaw between its rows; before
  // the first row the target stands at it, after the last it stays there.
  // Rows must have strictly increasing t (the parser checks).
  static TargetMotion Sampled(std::vector<TargetPathSample> path);

  // The same motion on a clock that starts `offset` seconds later: its
  // time t is this motion's t + offset, and its Displacement(t) is still
  // this one's from this motion's t = 0 (a mission's leg that starts at
  // `offset` sees the target where the mission's clock has it).
  TargetMotion Shifted(double offset) const;
  double time_offset() const { return offset_; }

  // The rigid displacement from t = 0 to t: where a point fixed to the
  // target at x (t = 0) is at t is Displacement(t) * x.
  Pose Displacement(double t) const;
  // The target's turn from t = 0 to t about world z (rad).
  double Yaw(double t) const;
  double YawRate(double t) const;
  // The target's own position at t (the axis of its turn).
  Vec3 Center(double t) const;
  // The velocity at time t of the target-fixed point that is at `x` then.
  Vec3 PointVelocity(const Vec3& x, double t) const;
  // The position at t of the target-fixed point at `x0` at t = 0 and its
  // first four time derivatives (out[0] .. out[4]). For a sampled path the
  // derivatives are those of the row interval holding t (one-sided at the
  // rows).
  void PointDerivatives(const Vec3& x0, double t, Vec3 out[5]) const;
  // The highest speed any point within `radius` of the target's centre
  // reaches over [0, horizon] (m/s): what the certificate adds for the
  // moving points.
  double MaxSpeed(double radius, double horizon) const;
  // The fastest turn over [0, horizon] (rad/s, absolute).
  double MaxYawRate(double horizon) const;

  bool sampled() const { return !path_.empty(); }

 private:
  // The segment of a sampled path holding t: index of its first row, and
  // t clamped into the path.
  int Segment(double t) const;
  // A sampled path's position and yaw at t, linear between its rows.
  TargetPathSample Interpolated(double t) const;
  // The public functions at this motion's own time (no offset).
  Vec3 CenterAt(double t) const;
  double YawAt(double t) const;
  double YawRateAt(double t) const;
  Pose DisplacementAt(double t) const;
  Vec3 PointVelocityAt(const Vec3& x, double t) const;

  // Constant motion.
  Vec3 origin_ = Vec3::Zero(), velocity_ = Vec3::Zero(), acceleration_ = Vec3::Zero();
  double yaw_rate_ = 0.0;
  // Sampled path (non-empty: sampled).
  std::vector<TargetPathSample> path_;
  double offset_ = 0.0;  // Shifted()
};

// Reads a target path file (contracts.md: columns t,x,y,z,qw,qx,qy,qz found
// by name in the header, one row per sample). Errors start with `source`
// and name the line: a missing column, a value that is not a finite number,
// time not strictly increasing, a quaternion not of unit length (1e-3), an
// orientation that tilts away from the first row's (more than 0.1 degree:
// only turns about world z can be followed by a hovering robot), fewer than
// 2 rows, or more than a turn between two rows.
core::Result<std::vector<TargetPathSample>> ParseTargetPath(const std::string& text, const std::string& source);

}  // namespace quadhand::traj
