#include "quadhand/sim/target.h"

#include <cmath>

namespace quadhand::sim {
namespace {

// The walk advances in steps of at most this much simulated time.
constexpr double kWalkStep = 0.01;

}  // namespace

bool SimTargetOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!(rate > 0.0 && rate <= 1000.0)) return fail("target rate must be in (0, 1000] Hz");
  if (!(noise >= 0.0 && noise <= 1.0)) return fail("target noise must be in [0, 1] m");
  if (!(yaw_noise >= 0.0 && yaw_noise <= 1.0)) return fail("target yaw noise must be in [0, 1] rad");
  if (!(random_walk >= 0.0 && random_walk <= 10.0)) return fail("target random walk must be in [0, 10] m/s/sqrt(s)");
  if (!(pass_time >= 0.0 && pass_time <= 3600.0)) return fail("target pass time must be in [0, 3600] s");
  return true;
}

SimTarget::SimTarget(const Pose& pose, traj::TargetMotion motion, const SimTargetOptions& options)
    : pose_(pose), motion_(std::move(motion)), options_(options), rng_(options.seed) {}

void SimTarget::AdvanceWalk(double t) {
  if (options_.random_walk <= 0.0) return;
  std::normal_distribution<double> unit(0.0, 1.0);
  while (walk_time_ < t) {
    const double h = std::min(kWalkStep, t - walk_time_);
    walk_offset_ += walk_velocity_ * h;
    walk_velocity_ += options_.random_walk * std::sqrt(h) * Vec3(unit(rng_), unit(rng_), 0.0);
    walk_time_ += h;
  }
}

Vec3 SimTarget::Position(double t) {
  AdvanceWalk(t);
  return motion_.Displacement(t - options_.pass_time) * pose_.translation() + walk_offset_;
}

Pose SimTarget::PoseAt(double t) {
  return MakePose(Position(t), Eigen::AngleAxisd(Yaw(t), Vec3::UnitZ()).toRotationMatrix() * pose_.linear());
}

bool SimTarget::MeasurementDue(double t, TargetSample* sample) {
  if (t + 1e-9 < next_measurement_) return false;
  std::normal_distribution<double> unit(0.0, 1.0);
  sample->time = t;
  sample->true_position = Position(t);
  sample->true_yaw = Yaw(t);
  sample->measured_position =
      sample->true_position + options_.noise * Vec3(unit(rng_), unit(rng_), unit(rng_));
  sample->measured_yaw = sample->true_yaw + options_.yaw_noise * unit(rng_);
  next_measurement_ += 1.0 / options_.rate;
  if (next_measurement_ <= t) next_measurement_ = t + 1.0 / options_.rate;
  return true;
}

}  // namespace quadhand::sim
