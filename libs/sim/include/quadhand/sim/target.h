// A moving target the simulated vehicle sees (docs/sim.md, "A moving
// target"; docs/moving_targets.md): it moves from its pose at t = 0 by a
// traj::TargetMotion (the task's goal.tool.motion), plus, optionally, a
// random walk of its velocity (a belt that surges, a cup pushed by hand),
// and its pose is measured every 1/rate s of simulated time with Gaussian
// noise, seeded: what a camera or a motion-capture system would report, and
// what the autopilot sends as LANDING_TARGET.
#pragma once

#include <cstdint>
#include <random>
#include <string>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/traj/target_motion.h"

namespace quadhand::sim {

struct SimTargetOptions {
  double rate = 30.0;         // measurements per second of simulated time, in (0, 1000]
  double noise = 0.005;       // m, standard deviation per axis of a measured position
  double yaw_noise = 0.02;    // rad, of a measured heading
  // m/s per square root of a second: the velocity's random walk on top of
  // the motion (0: none).
  double random_walk = 0.0;
  uint64_t seed = 0;
  uint8_t target_num = 1;     // LANDING_TARGET's target_num
  // The simulated time at which the target is at its pose in the task (its
  // motion's t = 0): a conveyor's cup that passes the task's place while
  // the vehicle is on its way. Before it a constant motion is extrapolated
  // backwards; a path file's first pose is held.
  double pass_time = 0.0;

  bool IsValid(std::string* why) const;
};

// One measurement: the pose as measured (with noise) and the true one.
struct TargetSample {
  double time = 0.0;
  Vec3 measured_position = Vec3::Zero();
  double measured_yaw = 0.0;
  Vec3 true_position = Vec3::Zero();
  double true_yaw = 0.0;
};

class SimTarget {
 public:
  // The target's pose at t = 0 (the task's tool goal) and how it moves from
  // there.
  SimTarget(const Pose& pose, traj::TargetMotion motion, const SimTargetOptions& options);

  // The true pose at simulated time t (advancing the random walk up to t:
  // times must not decrease between calls). The heading is the target's
  // turn about world z since t = 0 (its pose in the task is heading 0).
  Vec3 Position(double t);
  double Yaw(double t) const { return motion_.Yaw(t - options_.pass_time); }
  // The true pose: the pose at t = 0 turned by Yaw(t), at Position(t).
  Pose PoseAt(double t);
  // The measurement due at or before t, if one is (then the next is due
  // 1/rate later).
  bool MeasurementDue(double t, TargetSample* sample);

  const SimTargetOptions& options() const { return options_; }

 private:
  void AdvanceWalk(double t);

  Pose pose_;
  traj::TargetMotion motion_;
  SimTargetOptions options_;
  std::mt19937_64 rng_;
  double next_measurement_ = 0.0;
  // The random walk: its time, velocity and the displacement it has added.
  double walk_time_ = 0.0;
  Vec3 walk_velocity_ = Vec3::Zero(), walk_offset_ = Vec3::Zero();
};

}  // namespace quadhand::sim
