// What quadhand-online streams, and how a new plan is spliced in.
//
// A Setpoint is the vehicle's reference at one instant in the planner's
// frames: world ENU, body FLU, Hopf yaw (traj/flatness.h), actuated joints in
// URDF order. The MAVLink bridge converts it to NED (mavlink_bridge.h).
//
// Splicing. A replan starts from the measured state, so at the splice the new
// plan is up to the tracking error away from the old one. Instead of jumping,
// the streamed setpoint moves from the old plan to the new one over a window
// of W seconds with the quintic smoothstep weight
//     w(s) = 10 s^3 - 15 s^4 + 6 s^5,   s = (t - t_splice) / W in [0, 1],
// whose first and second derivatives vanish at both ends:
//     x(t) = (1 - w) x_old(t) + w x_new(t)
// for position, velocity, acceleration, yaw rate, joint angles and rates
// (yaw along the shorter arc). Velocity and acceleration are blended as
// values, not differentiated through w: the blend releases the controller's
// pull towards the old plan gradually instead of commanding the correction
// manoeuvre as feed-forward. Between two setpoints dt apart the position moves
// by at most max(|v_old|, |v_new|) dt + max|w'| dt |x_new - x_old|, with
// max|w'| = 15 / (8 W): the step bound that BlendStepBound() returns.
#pragma once

#include "quadhand/core/types.h"
#include "quadhand/planner/whole_body_problem.h"

namespace quadhand::online {

struct Setpoint {
  Vec3 position = Vec3::Zero();      // m, ENU
  Vec3 velocity = Vec3::Zero();      // m/s
  Vec3 acceleration = Vec3::Zero();  // m/s^2
  double yaw = 0.0;                  // Hopf yaw, rad
  double yaw_rate = 0.0;             // rad/s
  VecX joints;                       // rad
  VecX joint_rates;                  // rad/s
};

// The setpoint of a state (its jerk dropped), and of a plan sample (its
// jerk, attitude and thrust dropped).
Setpoint FromState(const planner::BoundaryState& state);
Setpoint FromSample(const planner::WholeBodySample& sample);

// The same pose with every rate and acceleration zero: a hold.
Setpoint HoldAt(const Setpoint& setpoint);

// Quintic smoothstep on s clamped to [0, 1].
double SpliceWeight(double s);

// (1 - w) a + w b, field by field (yaw along the shorter arc from a's yaw).
Setpoint Blend(const Setpoint& a, const Setpoint& b, double w);

// Largest position change between two blended setpoints dt apart over a
// window of `window` s, given the largest speed of either plan and the
// largest distance between them over the window (see the header comment).
double BlendStepBound(double max_speed, double max_separation, double window, double dt);

}  // namespace quadhand::online
