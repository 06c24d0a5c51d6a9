// The paper's figure-eight experiment (Sec. VII-B) as a plan: the base flies
// a 3.6 m x 2 m figure eight (a Gerono-like lemniscate x = A sin(phi),
// y = B sin(2 phi)) while the arm joints move sinusoidally within limits.
// The phase phi starts and ends at rest: its rate ramps up and down with a
// quintic smoothstep, so velocity, acceleration and jerk are continuous; the
// joints follow the same ramped time. Attitude columns come from
// traj::FlatForward, as the planner writes them.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/sim/plan_io.h"

namespace quadhand::sim {

// Most rows a figure-eight plan may have ((loops x period + ramp) / dt).
constexpr double kMaxFigureEightRows = 1e7;

struct FigureEightOptions {
  double length = 3.6;     // x extent, m
  double width = 2.0;      // y extent, m
  Vec3 center = Vec3(0.0, 0.0, 1.2);  // m
  double period = 10.0;    // one loop at full speed, s
  int loops = 3;
  double ramp = 2.0;       // ramp-up and ramp-down of the phase rate, s
  double yaw = 0.0;        // constant Hopf yaw, rad
  double dt = 0.01;        // row spacing, s
  double gravity = 9.81;
  // Joint motion: q_k = center_k + amplitude_k sin(2 pi tau / period_k + phase_k),
  // tau the ramped time (tau' = 0 at rest); one entry per actuated joint.
  std::vector<double> joint_center = {0.785, 0.0, 0.0};
  std::vector<double> joint_amplitude = {0.6, 0.8, 1.2};
  std::vector<double> joint_period = {4.0, 5.0, 3.0};
  std::vector<double> joint_phase = {-1.5707963267948966, 0.0, 0.0};

  bool IsValid(std::string* why) const;
};

// Fails if the options are invalid or the joint motion leaves the given
// joint limits or exceeds the rate limits (0 = none).
core::Result<Plan> MakeFigureEightPlan(const FigureEightOptions& options, const std::vector<std::string>& joint_names,
                                       const VecX& lower, const VecX& upper, const VecX& max_rate);

}  // namespace quadhand::sim
