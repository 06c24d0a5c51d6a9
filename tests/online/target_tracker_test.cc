// The moving target as the online mode sees it (online/target_tracker.h,
// TargetFromLandingTarget): the filter against a known motion measured with
// noise, reordered and outlying measurements, and the LANDING_TARGET
// conversion from MAVLink's frames.
#include "quadhand/online/target_tracker.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "quadhand/link/frames.h"
#include "quadhand/online/mavlink_bridge.h"
#include "quadhand/sim/autopilot.h"
#include "online/online_test_util.h"

namespace quadhand::online {
namespace {

// A cup on a belt: 0.3 m/s along a heading, turning slowly, measured at
// `rate` Hz with `noise` m of Gaussian noise per axis.
struct Belt {
  Vec3 start = Vec3(-3.2, -0.6, 0.86);
  Vec3 velocity = Vec3(0.06, 0.294, 0.0);
  double yaw0 = 0.3, yaw_rate = 0.1;
  Vec3 Position(double t) const { return start + velocity * t; }
  double Yaw(double t) const { return yaw0 + yaw_rate * t; }
};

TEST(TargetTrackerTest, LearnsAConstantMotionFromNoisyMeasurementsAndPredictsIt) {
  const Belt belt;
  // Over 20 seeded runs of 2 s at 30 Hz with 5 mm of noise: the velocity's
  // and the 1 s prediction's root-mean-square errors (the filter's own
  // spread of the velocity is about 0.02 m/s per axis then).
  double velocity_sq = 0.0, ahead_sq = 0.0, yaw_rate_sq = 0.0;
  const int runs = 20;
  for (int seed = 1; seed <= runs; ++seed) {
    TargetTracker tracker;
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.005), yaw_noise(0.0, 0.02);
    EXPECT_FALSE(tracker.Estimate(0.0).has_value());
    for (int k = 0; k <= 60; ++k) {
      const double t = k / 30.0;
      EXPECT_TRUE(tracker.Observe(t, belt.Position(t) + Vec3(noise(rng), noise(rng), noise(rng)),
                                  link::WrapAngle(belt.Yaw(t) + yaw_noise(rng))));
    }
    const auto now = tracker.Estimate(2.0);
    ASSERT_TRUE(now.has_value());
    EXPECT_LT((now->position - belt.Position(2.0)).norm(), 0.01);
    EXPECT_LT(now->position_sigma, 0.005);
    velocity_sq += (now->velocity - belt.velocity).squaredNorm();
    yaw_rate_sq += std::pow(now->yaw_rate - belt.yaw_rate, 2);
    const auto ahead = tracker.Estimate(3.0);
    ASSERT_TRUE(ahead.has_value());
    EXPECT_GT(ahead->position_sigma, now->position_sigma);
    ahead_sq += (ahead->position - belt.Position(3.0)).squaredNorm();
    // The same as the planner's motion, its clock starting now.
    const auto motion = tracker.MotionFrom(2.0);
    ASSERT_TRUE(motion.has_value());
    EXPECT_TRUE((motion->Displacement(1.0) * now->position).isApprox(ahead->position, 1e-9));
  }
  EXPECT_LT(std::sqrt(velocity_sq / runs), 0.045);
  EXPECT_LT(std::sqrt(ahead_sq / runs), 0.05);
  EXPECT_LT(std::sqrt(yaw_rate_sq / runs), 0.05);
}

// A vehicle's state is judged against the target at the state's own time,
// which can be before the newest measurement: the estimate then is where
// the target was, not where it was last measured.
TEST(TargetTrackerTest, EstimatesBeforeTheNewestMeasurementWhereTheTargetWas) {
  const Belt belt;
  TargetTracker tracker;
  for (int k = 0; k <= 60; ++k) tracker.Observe(k / 30.0, belt.Position(k / 30.0), belt.Yaw(k / 30.0));
  const double newest = 2.0, before = newest - 0.03;
  const auto estimate = tracker.Estimate(before);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_DOUBLE_EQ(estimate->time, before);
  EXPECT_LT((estimate->position - belt.Position(before)).norm(), 0.001);
  EXPECT_GT((belt.Position(newest) - belt.Position(before)).norm(), 0.005);  // the belt moves that much between
  EXPECT_LT(std::abs(estimate->yaw - belt.Yaw(before)), 1e-3);
  // The spread grows either way from the newest measurement.
  EXPECT_GT(estimate->position_sigma, tracker.Estimate(newest)->position_sigma);
}

TEST(TargetTrackerTest, DropsReorderedAndRejectsOutlyingMeasurementsThenRestartsOnAMovedTarget) {
  const Belt belt;
  TargetTracker tracker;
  for (int k = 0; k <= 30; ++k) tracker.Observe(k / 30.0, belt.Position(k / 30.0), belt.Yaw(k / 30.0));
  EXPECT_EQ(tracker.measurements(), 31);
  // Older than the newest: a reordered link.
  EXPECT_FALSE(tracker.Observe(0.5, belt.Position(0.5), belt.Yaw(0.5)));
  EXPECT_EQ(tracker.dropped(), 1);
  // A single wild measurement (30 cm off) is rejected, the estimate kept.
  EXPECT_FALSE(tracker.Observe(1.05, belt.Position(1.05) + Vec3(0.3, 0, 0), belt.Yaw(1.05)));
  EXPECT_EQ(tracker.rejected(), 1);
  EXPECT_TRUE(tracker.Observe(1.1, belt.Position(1.1), belt.Yaw(1.1)));
  EXPECT_LT((tracker.Estimate(1.1)->position - belt.Position(1.1)).norm(), 0.002);
  // The target is picked up and put down 1 m away: after max_rejections the
  // filter starts again there, and learns the motion afresh.
  const Vec3 moved(1.0, 0.0, 0.0);
  int used = 0;
  for (int k = 0; k < 20; ++k) {
    const double t = 1.2 + k / 30.0;
    used += tracker.Observe(t, belt.Position(t) + moved, belt.Yaw(t)) ? 1 : 0;
  }
  EXPECT_EQ(tracker.restarts(), 1);
  EXPECT_GE(used, 14);
  const auto estimate = tracker.Estimate(1.2 + 19 / 30.0);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_LT((estimate->position - belt.Position(1.2 + 19 / 30.0) - moved).norm(), 0.01);
  // Not a number: not used.
  EXPECT_FALSE(tracker.Observe(5.0, Vec3(NAN, 0, 0), 0.0));
}

TEST(TargetTrackerTest, RejectsBadOptions) {
  TargetTrackerOptions options;
  std::string why;
  EXPECT_TRUE(options.IsValid(&why));
  options.position_noise = 0.0;
  EXPECT_FALSE(options.IsValid(&why));
  options = {};
  options.min_measurements = 1;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("min_measurements"), std::string::npos);
}

TEST(TargetFromLandingTargetTest, ReadsTheLocalFramePoseInEnu) {
  // A target at (east 1, north 2, up 0.8) heading north-east (45 degrees from east).
  const double yaw_enu = M_PI / 4;
  const Quat q_enu(Eigen::AngleAxisd(yaw_enu, Vec3::UnitZ()));
  const Quat q_ned = link::AttitudeEnuFluToNedFrd(q_enu);
  const Vec3 ned = link::EnuToNed(Vec3(1.0, 2.0, 0.8));
  link::LandingTarget message;
  message.time_usec = 2500000;
  message.target_num = 3;
  message.frame = link::mav::kFrameLocalNed;
  message.x = static_cast<float>(ned.x());
  message.y = static_cast<float>(ned.y());
  message.z = static_cast<float>(ned.z());
  message.q = {static_cast<float>(q_ned.w()), static_cast<float>(q_ned.x()), static_cast<float>(q_ned.y()),
               static_cast<float>(q_ned.z())};
  message.position_valid = 1;
  const auto measurement = TargetFromLandingTarget(message);
  ASSERT_TRUE(measurement.has_value());
  EXPECT_DOUBLE_EQ(measurement->vehicle_time, 2.5);
  EXPECT_TRUE(measurement->position.isApprox(Vec3(1.0, 2.0, 0.8), 1e-6));
  EXPECT_NEAR(measurement->yaw, yaw_enu, 1e-6);
  EXPECT_EQ(measurement->target_num, 3);

  link::LandingTarget invalid = message;
  invalid.position_valid = 0;  // the camera angles only
  EXPECT_FALSE(TargetFromLandingTarget(invalid).has_value());
  invalid = message;
  invalid.frame = 8;  // MAV_FRAME_BODY_NED
  EXPECT_FALSE(TargetFromLandingTarget(invalid).has_value());
  invalid = message;
  invalid.q = {0.5f, 0.0f, 0.0f, 0.0f};
  EXPECT_FALSE(TargetFromLandingTarget(invalid).has_value());
  invalid = message;
  invalid.x = NAN;
  EXPECT_FALSE(TargetFromLandingTarget(invalid).has_value());
}

// The simulator's moving target (sim/target.h) through the link: its
// LANDING_TARGET messages, read as the online mode reads them and filtered,
// follow the target it moves (0.3 m/s, measured at 30 Hz with 5 mm of
// noise) - the whole path a measurement takes, without sockets.
TEST(TargetTrackerTest, FollowsTheSimulatorsTargetThroughItsLandingTargetMessages) {
  sim::SimTargetOptions target_options;
  target_options.rate = 30.0;
  target_options.noise = 0.005;
  target_options.seed = 11;
  const Vec3 cup(-3.2, 0.0, 0.86), velocity(0.0, 0.3, 0.0);
  sim::AutopilotOptions options;
  options.target.emplace(MakePose(cup, Mat3::Identity()), traj::TargetMotion::Constant(cup, velocity, Vec3::Zero(), 0.1),
                         target_options);
  auto autopilot = sim::Autopilot::Create(sim::Simulator(testing::VehicleModel(), 3), sim::StartPose{}, options);
  ASSERT_TRUE(autopilot.ok()) << autopilot.status().message();
  TargetTracker tracker;
  int received = 0;
  double largest_error = 0.0;
  for (int step = 1; step <= 150; ++step) {  // 3 s in 20 ms steps
    std::vector<link::Message> out;
    ASSERT_TRUE(autopilot->AdvanceTo(0.02 * step, &out).ok());
    for (const link::Message& message : out) {
      const auto* landing = std::get_if<link::LandingTarget>(&message);
      if (landing == nullptr) continue;
      const auto measurement = TargetFromLandingTarget(*landing);
      ASSERT_TRUE(measurement.has_value());
      ++received;
      const Vec3 truth = cup + velocity * measurement->vehicle_time;
      largest_error = std::max(largest_error, (measurement->position - truth).norm());
      EXPECT_NEAR(measurement->yaw, 0.1 * measurement->vehicle_time, 0.1);
      tracker.Observe(measurement->vehicle_time, measurement->position, measurement->yaw);
    }
  }
  EXPECT_NEAR(received, 90, 1);  // 30 Hz for 3 s, the first at t = 0
  EXPECT_GT(largest_error, 0.001);  // the noise is there...
  EXPECT_LT(largest_error, 0.04);   // ...at 5 mm a axis (under 4.5 sigma of the 3-D norm)
  const auto estimate = tracker.Estimate(3.0);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_LT((estimate->velocity - velocity).norm(), 0.05);
  EXPECT_LT((estimate->position - (cup + velocity * 3.0)).norm(), 0.01);
  EXPECT_NEAR(estimate->yaw_rate, 0.1, 0.05);
}

}  // namespace
}  // namespace quadhand::online
