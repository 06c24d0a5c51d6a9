// The gate a sensor frame passes before the rolling map takes it: each
// reason to drop one, counted, and a good frame after them still taken.
#include "quadhand/perception/sensor_frame.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace quadhand {
namespace {

using perception::FrameDrop;

perception::SensorFrame FrameAt(double t) {
  perception::SensorFrame frame;
  frame.t = t;
  frame.position = Vec3(1.0, 2.0, 3.0);
  const Quat q(Eigen::AngleAxisd(0.3, Vec3(1.0, 2.0, 3.0).normalized()));
  frame.attitude = Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
  return frame;
}

TEST(FrameGateTest, DropsEachKindOfBadFrameAndCountsItsReason) {
  perception::FrameGateOptions options;
  options.max_future = 0.05;
  options.max_age = 0.5;
  perception::FrameGate gate(options);
  const double nan = std::numeric_limits<double>::quiet_NaN();

  EXPECT_EQ(gate.Admit(FrameAt(1.0), 1.01), FrameDrop::kNone);
  EXPECT_DOUBLE_EQ(gate.last_taken(), 1.0);

  perception::SensorFrame f = FrameAt(1.1);
  f.position.z() = nan;
  EXPECT_EQ(gate.Admit(f, 1.1), FrameDrop::kMalformed);
  f = FrameAt(1.1);
  f.attitude[2] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(gate.Admit(f, 1.1), FrameDrop::kMalformed);
  f = FrameAt(nan);
  EXPECT_EQ(gate.Admit(f, 1.1), FrameDrop::kMalformed);
  f = FrameAt(1.1);
  f.attitude *= 1.01;  // |q| off by 1e-2
  EXPECT_EQ(gate.Admit(f, 1.1), FrameDrop::kBadPose);
  f.attitude = Eigen::Vector4d::Zero();
  EXPECT_EQ(gate.Admit(f, 1.1), FrameDrop::kBadPose);
  EXPECT_EQ(gate.Admit(FrameAt(1.2), 1.1), FrameDrop::kFromTheFuture);
  EXPECT_EQ(gate.Admit(FrameAt(1.0), 1.1), FrameDrop::kOutOfOrder);  // a duplicate
  EXPECT_EQ(gate.Admit(FrameAt(0.9), 1.1), FrameDrop::kOutOfOrder);
  EXPECT_EQ(gate.Admit(FrameAt(1.05), 1.6), FrameDrop::kStale);
  // Within the sync allowance ahead, and a hair off unit length: taken.
  f = FrameAt(1.64);
  f.attitude *= 1.0 + 5e-4;
  EXPECT_EQ(gate.Admit(f, 1.6), FrameDrop::kNone);

  const perception::FrameCounts& c = gate.counts();
  EXPECT_EQ(c.taken, 2);
  EXPECT_EQ(c.malformed, 3);
  EXPECT_EQ(c.bad_pose, 2);
  EXPECT_EQ(c.from_the_future, 1);
  EXPECT_EQ(c.out_of_order, 2);
  EXPECT_EQ(c.stale, 1);
  EXPECT_EQ(c.dropped(), 9);
  EXPECT_DOUBLE_EQ(gate.last_taken(), 1.64);
  // The pose taken is normalised.
  const Pose pose = perception::SensorPose(f);
  EXPECT_NEAR((pose.linear() * pose.linear().transpose() - Mat3::Identity()).norm(), 0.0, 1e-12);
  EXPECT_NEAR((pose.translation() - f.position).norm(), 0.0, 1e-15);
}

TEST(FrameGateTest, SetSensorPoseAndSensorPoseRoundTrip) {
  const Pose pose = MakePose(Vec3(-1.5, 2.0, 0.25), Quat(Eigen::AngleAxisd(2.5, Vec3(0.3, 0.4, -1.0).normalized()))
                                                        .toRotationMatrix());
  perception::SensorFrame frame;
  perception::SetSensorPose(pose, &frame);
  EXPECT_EQ(perception::CheckPose(frame.position, frame.attitude, 1e-12), FrameDrop::kNone);
  const Pose back = perception::SensorPose(frame);
  EXPECT_NEAR((back.matrix() - pose.matrix()).norm(), 0.0, 1e-12);
}

TEST(FrameGateTest, OptionsAreValidated) {
  perception::FrameGateOptions options;
  std::string why;
  EXPECT_TRUE(options.IsValid(&why)) << why;
  options.max_age = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(options.IsValid(&why)) << why;
  options.max_age = 0.0;
  EXPECT_FALSE(options.IsValid(&why));
  options = {};
  options.max_future = std::nan("");
  EXPECT_FALSE(options.IsValid(&why));
  options = {};
  options.quaternion_tolerance = 0.0;
  EXPECT_FALSE(options.IsValid(&why));
}

}  // namespace
}  // namespace quadhand
