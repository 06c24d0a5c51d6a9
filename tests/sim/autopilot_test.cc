// The PX4-like autopilot of quadhand-sim --udp, without sockets: modes,
// commands and their acknowledgements, telemetry, following setpoints,
// offboard loss, joint setpoints, and the start pose readers.
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "quadhand/link/frames.h"
#include "quadhand/sim/autopilot.h"
#include "quadhand/traj/flatness.h"
#include "sim/sim_test_util.h"

namespace quadhand::sim {
namespace {

using testing::Joints;
using testing::Model;

template <typename M>
std::vector<M> All(const std::vector<link::Message>& messages) {
  std::vector<M> found;
  for (const link::Message& m : messages) {
    if (const M* x = std::get_if<M>(&m)) found.push_back(*x);
  }
  return found;
}

link::CommandLong Command(uint16_t id, float param1, float param2 = 0) {
  link::CommandLong c;
  c.command = id;
  c.param1 = param1;
  c.param2 = param2;
  c.target_system = 1;
  c.target_component = 1;
  return c;
}

link::CommandLong SetMode(uint32_t main_mode) {
  return Command(link::mav::kCmdDoSetMode, link::mav::kModeFlagCustomModeEnabled, static_cast<float>(main_mode));
}

link::CommandLong Arm(bool arm) { return Command(link::mav::kCmdComponentArmDisarm, arm ? 1.0f : 0.0f); }

// A position setpoint at an ENU point and ENU yaw, converted as quadhand-online does.
link::SetPositionTargetLocalNed PositionTarget(const Vec3& p_enu, double yaw_enu) {
  link::SetPositionTargetLocalNed sp;
  const Vec3 p = link::EnuToNed(p_enu);
  sp.x = static_cast<float>(p.x());
  sp.y = static_cast<float>(p.y());
  sp.z = static_cast<float>(p.z());
  sp.yaw = static_cast<float>(link::YawEnuToNed(yaw_enu));
  sp.target_system = 1;
  return sp;
}

class AutopilotTest : public ::testing::Test {
 protected:
  void SetUp() override { Start(StartPose{}); }

  void Start(const StartPose& start) {
    AutopilotOptions options;
    options.record_flown = true;
    auto autopilot = Autopilot::Create(Simulator(Model(true, 0.0), 7), start, options);
    ASSERT_TRUE(autopilot.ok()) << autopilot.status().message();
    autopilot_ = std::make_unique<Autopilot>(std::move(*autopilot));
  }

  // Handles a message from the ground (system 255, component 190); returns the replies.
  std::vector<link::Message> Send(const link::Message& m) {
    std::vector<link::Message> out;
    autopilot_->Handle(m, 255, 190, &out);
    return out;
  }

  link::CommandAck Ack(const link::Message& command) {
    const std::vector<link::CommandAck> acks = All<link::CommandAck>(Send(command));
    EXPECT_EQ(acks.size(), 1u);
    return acks.empty() ? link::CommandAck{} : acks.front();
  }

  // Advances to t; keeps what was sent.
  void AdvanceTo(double t) {
    ASSERT_TRUE(autopilot_->AdvanceTo(t, &sent_).ok());
  }

  // Streams `setpoint` (and the optional joint setpoint) every 20 ms until t.
  void Stream(const link::Message& setpoint, double t, const link::Message* joints = nullptr) {
    while (autopilot_->time() < t - 1e-9) {
      Send(setpoint);
      if (joints) Send(*joints);
      AdvanceTo(std::min(t, autopilot_->time() + 0.02));
    }
  }

  // Arms and switches to OFFBOARD after a second of `setpoint`.
  void GoOffboard(const link::Message& setpoint) {
    Stream(setpoint, autopilot_->time() + 1.0);
    ASSERT_EQ(Ack(Arm(true)).result, link::mav::kResultAccepted);
    ASSERT_EQ(Ack(SetMode(link::mav::kPx4MainModeOffboard)).result, link::mav::kResultAccepted);
    ASSERT_EQ(autopilot_->mode(), FlightMode::kOffboard);
  }

  std::unique_ptr<Autopilot> autopilot_;
  std::vector<link::Message> sent_;
};

TEST_F(AutopilotTest, HoversInPositionModeAndStreamsTelemetry) {
  StartPose start;
  start.position = Vec3(1, 2, 3);
  start.yaw = 0.3;
  Start(start);
  AdvanceTo(1.0);
  const auto heartbeats = All<link::Heartbeat>(sent_);
  ASSERT_EQ(heartbeats.size(), 2u);  // t = 0 and t = 1
  EXPECT_EQ(heartbeats[0].type, link::mav::kTypeQuadrotor);
  EXPECT_EQ(heartbeats[0].autopilot, link::mav::kAutopilotPx4);
  EXPECT_EQ(heartbeats[0].custom_mode, link::mav::Px4CustomMode(link::mav::kPx4MainModePosition));
  EXPECT_EQ(heartbeats[0].base_mode, link::mav::kModeFlagCustomModeEnabled);  // disarmed
  EXPECT_EQ(heartbeats[0].system_status, link::mav::kStateStandby);
  const auto positions = All<link::LocalPositionNed>(sent_);
  const auto attitudes = All<link::AttitudeQuaternion>(sent_);
  std::vector<link::DebugFloatArray> joints, goals;
  for (const link::DebugFloatArray& array : All<link::DebugFloatArray>(sent_)) {
    (array.name == kJointGoalsArrayName ? goals : joints).push_back(array);
  }
  EXPECT_EQ(positions.size(), 51u);  // 50 Hz over [0, 1]
  EXPECT_EQ(attitudes.size(), 51u);
  ASSERT_EQ(joints.size(), 51u);
  ASSERT_EQ(goals.size(), 51u);
  EXPECT_EQ(goals.back().array_id, kJointGoalsArrayId);
  EXPECT_EQ(goals.back().time_usec, joints.back().time_usec);
  EXPECT_EQ(positions[50].time_boot_ms, 1000u);
  // NED: north = ENU y, east = ENU x, down = -ENU z (within the few
  // centimetres the arm's CoG offset pushes the base before the integrators settle).
  EXPECT_NEAR(positions.back().x, 2.0, 0.05);
  EXPECT_NEAR(positions.back().y, 1.0, 0.05);
  EXPECT_NEAR(positions.back().z, -3.0, 0.05);
  // Yaw 0.3 from east counter-clockwise is pi/2 - 0.3 from north clockwise.
  const Quat q(attitudes.back().q1, attitudes.back().q2, attitudes.back().q3, attitudes.back().q4);
  const Vec3 forward = q * Vec3::UnitX();
  EXPECT_NEAR(std::atan2(forward.y(), forward.x()), M_PI_2 - 0.3, 0.01);
  EXPECT_EQ(joints.back().name, kJointsArrayName);
  EXPECT_EQ(joints.back().array_id, kJointsArrayId);
  const VecX& q_now = autopilot_->state().joints;
  for (int k = 0; k < q_now.size(); ++k) EXPECT_NEAR(joints.back().data[static_cast<size_t>(k)], q_now[k], 1e-6);
  EXPECT_EQ(autopilot_->flown().size(), 51u);
}

TEST_F(AutopilotTest, OffboardNeedsASecondOfSetpoints) {
  const link::Message hold = PositionTarget(Vec3(0, 0, 1), 0.0);
  EXPECT_EQ(Ack(SetMode(link::mav::kPx4MainModeOffboard)).result, link::mav::kResultTemporarilyRejected);
  Stream(hold, 0.5);
  EXPECT_EQ(Ack(SetMode(link::mav::kPx4MainModeOffboard)).result, link::mav::kResultTemporarilyRejected);
  EXPECT_EQ(autopilot_->mode(), FlightMode::kPosition);
  Stream(hold, 1.02);
  const link::CommandAck ack = Ack(SetMode(link::mav::kPx4MainModeOffboard));
  EXPECT_EQ(ack.result, link::mav::kResultAccepted);
  EXPECT_EQ(ack.command, link::mav::kCmdDoSetMode);
  EXPECT_EQ(ack.target_system, 255);
  EXPECT_EQ(ack.target_component, 190);
  EXPECT_EQ(autopilot_->mode(), FlightMode::kOffboard);
  sent_.clear();
  Stream(hold, 2.05);
  EXPECT_EQ(All<link::Heartbeat>(sent_).back().custom_mode, link::mav::Px4CustomMode(link::mav::kPx4MainModeOffboard));
  // Back to POSITION on request; a stream with a gap starts counting again.
  EXPECT_EQ(Ack(SetMode(link::mav::kPx4MainModePosition)).result, link::mav::kResultAccepted);
  EXPECT_EQ(autopilot_->mode(), FlightMode::kPosition);
  AdvanceTo(3.0);
  Stream(hold, 3.5);
  EXPECT_EQ(Ack(SetMode(link::mav::kPx4MainModeOffboard)).result, link::mav::kResultTemporarilyRejected);
  // Unknown main modes and a mode without the custom flag are denied.
  EXPECT_EQ(Ack(SetMode(2)).result, link::mav::kResultDenied);
  EXPECT_EQ(Ack(Command(link::mav::kCmdDoSetMode, 0, 6)).result, link::mav::kResultDenied);
}

TEST_F(AutopilotTest, ArmingAndDisarmingAreAcknowledged) {
  EXPECT_FALSE(autopilot_->armed());
  EXPECT_EQ(Ack(Arm(true)).result, link::mav::kResultAccepted);
  EXPECT_TRUE(autopilot_->armed());
  AdvanceTo(0.1);
  const auto heartbeats = All<link::Heartbeat>(sent_);
  ASSERT_FALSE(heartbeats.empty());
  EXPECT_EQ(heartbeats.back().base_mode, link::mav::kModeFlagCustomModeEnabled | link::mav::kModeFlagSafetyArmed);
  EXPECT_EQ(heartbeats.back().system_status, link::mav::kStateActive);
  EXPECT_EQ(Ack(Command(link::mav::kCmdComponentArmDisarm, 3)).result, link::mav::kResultDenied);
  EXPECT_EQ(Ack(Arm(false)).result, link::mav::kResultAccepted);
  EXPECT_FALSE(autopilot_->armed());
}

TEST_F(AutopilotTest, UnknownCommandsAreUnsupportedAndOtherSystemsIgnored) {
  const link::CommandAck ack = Ack(Command(511, 33, 20000));  // MAV_CMD_SET_MESSAGE_INTERVAL
  EXPECT_EQ(ack.command, 511);
  EXPECT_EQ(ack.result, link::mav::kResultUnsupported);
  link::CommandLong other = Arm(true);
  other.target_system = 2;
  EXPECT_TRUE(Send(other).empty());
  EXPECT_FALSE(autopilot_->armed());
}

TEST_F(AutopilotTest, FlysToATargetOneMetreAway) {
  GoOffboard(PositionTarget(Vec3(0, 0, 1), 0.0));
  // One metre north and facing north (ENU yaw pi/2, NED yaw 0).
  const link::SetPositionTargetLocalNed target = PositionTarget(Vec3(0, 1, 1), M_PI_2);
  EXPECT_FLOAT_EQ(target.x, 1.0f);
  EXPECT_FLOAT_EQ(target.yaw, 0.0f);
  Stream(target, autopilot_->time() + 6.0);
  EXPECT_EQ(autopilot_->mode(), FlightMode::kOffboard);
  EXPECT_LT((autopilot_->state().position - Vec3(0, 1, 1)).norm(), 0.03);
  EXPECT_LT(autopilot_->state().velocity.norm(), 0.05);
  EXPECT_NEAR(traj::HopfYawOf(autopilot_->state().attitude), M_PI_2, 0.03);
  // The telemetry says so in NED.
  const auto positions = All<link::LocalPositionNed>(sent_);
  EXPECT_NEAR(positions.back().x, 1.0, 0.03);
  EXPECT_NEAR(positions.back().y, 0.0, 0.03);
}

TEST_F(AutopilotTest, SetpointsAreIgnoredUntilArmed) {
  Stream(PositionTarget(Vec3(0, 0, 1), 0.0), 1.1);
  ASSERT_EQ(Ack(SetMode(link::mav::kPx4MainModeOffboard)).result, link::mav::kResultAccepted);
  Stream(PositionTarget(Vec3(1, 0, 1), 0.0), 3.0);  // offboard but disarmed: holds
  EXPECT_LT((autopilot_->state().position - Vec3(0, 0, 1)).norm(), 0.02);
  // A frame other than LOCAL_NED is refused.
  link::SetPositionTargetLocalNed body = PositionTarget(Vec3(1, 0, 1), 0.0);
  body.coordinate_frame = 8;
  const uint64_t rejected = autopilot_->setpoints_rejected();
  Send(body);
  EXPECT_EQ(autopilot_->setpoints_rejected(), rejected + 1);
}

TEST_F(AutopilotTest, OffboardLossHoldsPosition) {
  GoOffboard(PositionTarget(Vec3(0, 0, 1), 0.0));
  // Velocity control: 1 m/s east, position, acceleration and yaw ignored.
  link::SetPositionTargetLocalNed velocity;
  velocity.vy = 1.0f;  // NED y is east
  velocity.type_mask = typemask::kXIgnore | typemask::kYIgnore | typemask::kZIgnore | typemask::kAxIgnore |
                       typemask::kAyIgnore | typemask::kAzIgnore | typemask::kYawIgnore | typemask::kYawRateIgnore;
  velocity.target_system = 1;
  const double t_stop = autopilot_->time() + 3.0;
  Stream(velocity, t_stop);
  EXPECT_NEAR(autopilot_->state().velocity.x(), 1.0, 0.05);  // ENU x is east
  EXPECT_NEAR(autopilot_->state().velocity.y(), 0.0, 0.05);
  const Vec3 at_stop = autopilot_->state().position;
  sent_.clear();
  AdvanceTo(t_stop + 0.45);
  EXPECT_EQ(autopilot_->mode(), FlightMode::kOffboard);  // not yet 0.5 s
  AdvanceTo(t_stop + 0.55);
  EXPECT_EQ(autopilot_->mode(), FlightMode::kPosition);
  const auto texts = All<link::StatusText>(sent_);
  ASSERT_EQ(texts.size(), 1u);
  EXPECT_NE(texts[0].text.find("Offboard lost"), std::string::npos);
  // It holds where it was when the loss was detected: brakes, comes back, stays.
  const Vec3 hold = autopilot_->CurrentSetpoint().position;
  EXPECT_NEAR(hold.x(), at_stop.x() + 0.5, 0.1);  // it kept flying at 1 m/s for 0.5 s
  AdvanceTo(t_stop + 6.0);
  EXPECT_LT((autopilot_->state().position - hold).norm(), 0.03);
  EXPECT_LT(autopilot_->state().velocity.norm(), 0.05);
  EXPECT_EQ(All<link::Heartbeat>(sent_).back().custom_mode, link::mav::Px4CustomMode(link::mav::kPx4MainModePosition));
}

TEST_F(AutopilotTest, TheLandFailsafeHoldsForItsDelayThenLandsAndDisarms) {
  SimConfig config = testing::Config();
  config.failsafe.action = FailsafeConfig::Action::kLand;
  config.failsafe.delay = 2.0;
  config.failsafe.land_speed = 0.5;
  config.failsafe.land_height = 0.2;
  AutopilotOptions options;
  StartPose start;
  start.position = Vec3(0.5, 0, 1.2);
  auto created = Autopilot::Create(Simulator(Model(config), 7), start, options);
  ASSERT_TRUE(created.ok()) << created.status().message();
  autopilot_ = std::make_unique<Autopilot>(std::move(*created));
  GoOffboard(PositionTarget(start.position, 0.0));
  const double t_stop = autopilot_->time();
  sent_.clear();
  AdvanceTo(t_stop + 0.6);
  EXPECT_EQ(autopilot_->mode(), FlightMode::kPosition);  // the hold first
  AdvanceTo(t_stop + 2.4);
  EXPECT_EQ(autopilot_->mode(), FlightMode::kPosition);
  EXPECT_NEAR(autopilot_->state().position.z(), 1.2, 0.02);
  AdvanceTo(t_stop + 2.6);
  ASSERT_EQ(autopilot_->mode(), FlightMode::kLand);
  // Straight down at the land speed: a second in, about 0.5 m lower, same x, y.
  AdvanceTo(t_stop + 3.6);
  EXPECT_NEAR(autopilot_->state().position.z(), 1.2 - 0.5 * 1.0, 0.1);
  EXPECT_NEAR(autopilot_->state().position.x(), 0.5, 0.03);
  EXPECT_TRUE(autopilot_->armed());
  AdvanceTo(t_stop + 6.0);
  EXPECT_NEAR(autopilot_->state().position.z(), 0.2, 0.03);
  EXPECT_FALSE(autopilot_->armed());
  std::vector<std::string> texts;
  for (const link::StatusText& text : All<link::StatusText>(sent_)) texts.push_back(text.text);
  ASSERT_EQ(texts.size(), 3u);
  EXPECT_NE(texts[0].find("Offboard lost"), std::string::npos);
  EXPECT_EQ(texts[1], "Failsafe: landing");
  EXPECT_EQ(texts[2], "Landed");
  EXPECT_EQ(All<link::Heartbeat>(sent_).back().custom_mode,
            link::mav::Px4CustomMode(link::mav::kPx4MainModeAuto, link::mav::kPx4AutoSubModeLand));
}

TEST_F(AutopilotTest, AModeChangeDuringTheFailsafesHoldCancelsTheLand) {
  SimConfig config = testing::Config();
  config.failsafe.action = FailsafeConfig::Action::kLand;
  config.failsafe.delay = 3.0;
  auto created = Autopilot::Create(Simulator(Model(config), 7), StartPose{}, AutopilotOptions{});
  ASSERT_TRUE(created.ok()) << created.status().message();
  autopilot_ = std::make_unique<Autopilot>(std::move(*created));
  GoOffboard(PositionTarget(Vec3(0, 0, 1), 0.0));
  AdvanceTo(autopilot_->time() + 0.7);
  ASSERT_EQ(autopilot_->mode(), FlightMode::kPosition);
  // The planner is back: streams, and asks for OFFBOARD again within the delay.
  GoOffboard(PositionTarget(Vec3(0, 0, 1), 0.0));
  Stream(PositionTarget(Vec3(0, 0, 1), 0.0), autopilot_->time() + 2.0);
  EXPECT_EQ(autopilot_->mode(), FlightMode::kOffboard);
  EXPECT_TRUE(autopilot_->armed());
}

TEST_F(AutopilotTest, JointSetpointsMoveTheJoints) {
  const VecX start = autopilot_->state().joints;
  link::DebugFloatArray array;
  array.name = kJointSetpointArrayName;
  array.array_id = kJointSetpointArrayId;
  const VecX target = Joints(1.2, 0.5, -1.0);
  array.data = {1.2f, 0.5f, -1.0f, 0.0f, 0.0f, 0.0f};
  const link::Message joint_sp = array;
  const link::Message hold = PositionTarget(Vec3(0, 0, 1), 0.0);
  // Before offboard the arm holds its pose.
  Stream(hold, 1.05, &joint_sp);
  EXPECT_LT((autopilot_->state().joints - start).norm(), 1e-3);
  GoOffboard(hold);
  Stream(hold, autopilot_->time() + 2.0, &joint_sp);
  EXPECT_LT((autopilot_->state().joints - target).norm(), 0.01);
  std::vector<link::DebugFloatArray> telemetry, goals;
  for (const link::DebugFloatArray& a : All<link::DebugFloatArray>(sent_)) {
    (a.name == kJointGoalsArrayName ? goals : telemetry).push_back(a);
  }
  ASSERT_FALSE(telemetry.empty());
  ASSERT_FALSE(goals.empty());
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(telemetry.back().data[static_cast<size_t>(k)], target[k], 0.01);
  // Each servo's goal is the JOINT_SP it was sent.
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(goals.back().data[static_cast<size_t>(k)], target[k], 1e-6);
  // The base still holds its position while the arm moves (the controller
  // knows nothing about the arm: centimetres, not decimetres).
  EXPECT_LT((autopilot_->state().position - Vec3(0, 0, 1)).norm(), 0.05);
}

TEST(StartPoseTest, ParsesTheStartOption) {
  core::Result<StartPose> s = ParseStartPose("1,-2.5,3");
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->position, Vec3(1, -2.5, 3));
  EXPECT_EQ(s->yaw, 0.0);
  s = ParseStartPose("0,0,1,3.14");
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->yaw, 3.14);
  for (const char* bad : {"", "1,2", "1,2,3,4,5", "1,,3", "1,2,x", "1,2,3,", "nan,0,1", "1 2 3"}) {
    EXPECT_FALSE(ParseStartPose(bad).ok()) << bad;
  }
}

link::CommandLong Gripper(int action) { return Command(link::mav::kCmdDoGripper, 1.0f, static_cast<float>(action)); }

TEST_F(AutopilotTest, TheGripperPicksUpEachLoadWhereTheToolIsAndLetsItGo) {
  AutopilotOptions options;
  // The first load 0.3 m below the start (the tool is not there: it is taken
  // where the vehicle's own tool is), the second one kilogram.
  options.gripper_loads = {{0.2, Vec3(0.0, 0.0, 0.7), false}, {1.0, Vec3(0.5, 0.0, 1.0), false}};
  auto created = Autopilot::Create(Simulator(Model(true, 0.0), 7), StartPose{}, options);
  ASSERT_TRUE(created.ok()) << created.status().message();
  autopilot_ = std::make_unique<Autopilot>(std::move(*created));
  const double empty = autopilot_->simulator().model().TotalMass();
  EXPECT_FALSE(autopilot_->gripper_closed());
  AdvanceTo(1.0);

  EXPECT_EQ(Ack(Gripper(link::mav::kGripperActionGrab)).result, link::mav::kResultAccepted);
  EXPECT_TRUE(autopilot_->gripper_closed());
  EXPECT_EQ(autopilot_->gripper_grabs(), 1);
  const VehicleModel& held = autopilot_->simulator().model();
  EXPECT_NEAR(held.TotalMass(), empty + 0.2, 1e-9);
  EXPECT_DOUBLE_EQ(held.payload_mass(), 0.2);
  // The load's point, in the tool's frame at the grab.
  const VehicleState& s = autopilot_->state();
  const int tool = held.robot().LinkIndex("tool");
  const Pose X_WT = MakePose(s.position, s.attitude.toRotationMatrix()) * held.LinkPosesInBase(s.joints)[tool];
  EXPECT_TRUE((X_WT * held.config().payload.offset).isApprox(Vec3(0.0, 0.0, 0.7), 1e-9));
  // A second grab while closed changes nothing.
  EXPECT_EQ(Ack(Gripper(link::mav::kGripperActionGrab)).result, link::mav::kResultAccepted);
  EXPECT_EQ(autopilot_->gripper_grabs(), 1);
  // Carrying it, the vehicle still holds its position.
  AdvanceTo(4.0);
  EXPECT_LT((autopilot_->state().position - StartPose{}.position).norm(), 0.05);

  EXPECT_EQ(Ack(Gripper(link::mav::kGripperActionRelease)).result, link::mav::kResultAccepted);
  EXPECT_FALSE(autopilot_->gripper_closed());
  EXPECT_NEAR(autopilot_->simulator().model().TotalMass(), empty, 1e-9);
  EXPECT_EQ(Ack(Gripper(link::mav::kGripperActionGrab)).result, link::mav::kResultAccepted);
  EXPECT_NEAR(autopilot_->simulator().model().TotalMass(), empty + 1.0, 1e-9);
  EXPECT_EQ(Ack(Gripper(link::mav::kGripperActionRelease)).result, link::mav::kResultAccepted);
  // A grab beyond the loads closes on nothing; an unknown action is denied.
  EXPECT_EQ(Ack(Gripper(link::mav::kGripperActionGrab)).result, link::mav::kResultAccepted);
  EXPECT_NEAR(autopilot_->simulator().model().TotalMass(), empty, 1e-9);
  EXPECT_EQ(Ack(Gripper(7)).result, link::mav::kResultDenied);
}

TEST_F(AutopilotTest, ALoadHeldAtTheStartIsCarriedFromTheFirstInstant) {
  AutopilotOptions options;
  options.gripper_loads = {{0.15, Vec3(0.12, 0.0, 0.0), true}};
  StartPose start;
  start.position = Vec3(1.0, 2.0, 1.5);
  auto created = Autopilot::Create(Simulator(Model(true, 0.0), 7), start, options);
  ASSERT_TRUE(created.ok()) << created.status().message();
  autopilot_ = std::make_unique<Autopilot>(std::move(*created));
  EXPECT_TRUE(autopilot_->gripper_closed());
  EXPECT_DOUBLE_EQ(autopilot_->simulator().model().payload_mass(), 0.15);
  EXPECT_TRUE(autopilot_->simulator().model().config().payload.offset.isApprox(Vec3(0.12, 0.0, 0.0)));
  AdvanceTo(3.0);
  EXPECT_LT((autopilot_->state().position - start.position).norm(), 0.05);
  options.gripper_loads = {{0.1, Vec3::Zero(), false}, {0.1, Vec3::Zero(), true}};
  EXPECT_FALSE(Autopilot::Create(Simulator(Model(true, 0.0), 7), start, options).ok());
}

TEST(StartPoseTest, ReadsTheGripperLoadsOfAMission) {
  const std::string path = ::testing::TempDir() + "/autopilot_mission.yaml";
  std::ofstream(path) << "start: {position: [0, 0, 1], yaw: 0, joints: [0, 0, 0]}\n"
                         "mission:\n"
                         "  - grasp: {object: {shape: {sphere: {radius: 0.02}}, pose: {position: [0.1, 0, 0]}, mass: 0.05}}\n"
                         "  - reach: {position: [1, 0, 1], yaw: 0, joints: [0, 0, 0]}\n"
                         "  - release: {}\n"
                         "  - grasp: {object: {shape: {box: {size: [0.1, 0.1, 0.1]}}, pose: {position: [1, 0, 0.5]}}}\n";
  auto loads = LoadTaskGripperLoads(path);
  ASSERT_TRUE(loads.ok()) << loads.status().message();
  ASSERT_EQ(loads->size(), 2u);
  EXPECT_TRUE((*loads)[0].held_at_start);
  EXPECT_DOUBLE_EQ((*loads)[0].mass, 0.05);
  EXPECT_EQ((*loads)[0].position, Vec3(0.1, 0, 0));
  EXPECT_FALSE((*loads)[1].held_at_start);
  EXPECT_DOUBLE_EQ((*loads)[1].mass, 0.0);
  EXPECT_EQ((*loads)[1].position, Vec3(1, 0, 0.5));
  auto none = LoadTaskGripperLoads(testing::kRoot + "/data/tasks/window_cup.yaml");
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  std::ofstream(path, std::ios::trunc) << "mission:\n  - grasp: {object: {pose: {position: [1, 2]}}}\n";
  const auto bad = LoadTaskGripperLoads(path);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("mission[0].grasp.object.pose.position"), std::string::npos)
      << bad.status().message();
}

TEST(StartPoseTest, ReadsTheStartOfATask) {
  core::Result<StartPose> s = LoadTaskStartPose(testing::kRoot + "/data/tasks/window_cup.yaml");
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->position, Vec3(0.5, 0.2, 1.2));
  EXPECT_NEAR(s->yaw, M_PI, 1e-6);
  ASSERT_EQ(s->joints.size(), 3);
  EXPECT_EQ(s->joints, Joints(0.3, -0.2, 0.0));
  const std::string path = ::testing::TempDir() + "/autopilot_bad_task.yaml";
  for (const std::string& text : {std::string("goal: {}\n"), std::string("start: {position: [1, 2], yaw: 0, joints: []}\n"),
                                  std::string("start: {position: [1, 2, 3], joints: [0, 0, 0]}\n"),
                                  std::string("start: {position: [1, 2, 3], yaw: 0, joints: [a]}\n"),
                                  std::string("start: [\n")}) {
    std::ofstream(path) << text;
    const core::Result<StartPose> bad = LoadTaskStartPose(path);
    ASSERT_FALSE(bad.ok()) << text;
    EXPECT_NE(bad.status().message().find(path), std::string::npos) << bad.status().message();
  }
  EXPECT_EQ(LoadTaskStartPose(path + ".none").status().code(), core::StatusCode::kNotFound);
  // A task's joints must fit the robot.
  StartPose wrong;
  wrong.joints = Joints(0, 0, 0).head(2);
  EXPECT_FALSE(Autopilot::Create(Simulator(Model(true, 0.0), 1), wrong, {}).ok());
}

// The moving target (sim/target.h): its measurements come at its rate,
// scattered by its noise about where its motion (and random walk) puts it,
// as LANDING_TARGET in the local NED frame; a task's target is read with
// its motion.
TEST(SimTargetTest, MeasuresTheMovingTargetAtItsRateWithItsNoise) {
  SimTargetOptions options;
  options.rate = 50.0;
  options.noise = 0.01;
  options.seed = 5;
  const Vec3 start(1.0, 2.0, 0.8), velocity(0.2, -0.1, 0.0);
  SimTarget target(MakePose(start, Mat3::Identity()), traj::TargetMotion::Constant(start, velocity, Vec3::Zero(), 0.0),
                   options);
  int count = 0;
  Vec3 mean = Vec3::Zero();
  double squares = 0.0;
  for (int k = 0; k <= 2000; ++k) {  // 20 s in 10 ms steps
    TargetSample sample;
    if (!target.MeasurementDue(0.01 * k, &sample)) continue;
    ++count;
    EXPECT_TRUE(sample.true_position.isApprox(start + velocity * sample.time, 1e-12));
    const Vec3 error = sample.measured_position - sample.true_position;
    mean += error;
    squares += error.squaredNorm();
  }
  EXPECT_EQ(count, 1001);  // 50 Hz for 20 s, the first at t = 0
  mean /= count;
  EXPECT_LT(mean.norm(), 0.002);
  EXPECT_NEAR(std::sqrt(squares / (3.0 * count)), 0.01, 0.001);

  // A random walk takes it off its motion, by about walk * t^1.5 / sqrt(3).
  options.random_walk = 0.05;
  SimTarget walking(MakePose(start, Mat3::Identity()), traj::TargetMotion::Constant(start, velocity, Vec3::Zero(), 0.0),
                    options);
  const double off = (walking.Position(20.0) - (start + velocity * 20.0)).norm();
  EXPECT_GT(off, 0.05);
  EXPECT_LT(off, 5.0);
}

TEST(SimTargetTest, ReadsATasksMovingTarget) {
  auto constant = LoadTaskTarget(std::string(QUADHAND_SOURCE_DIR) + "/data/tasks/moving_cup.yaml");
  ASSERT_TRUE(constant.ok()) << constant.status().message();
  EXPECT_TRUE(constant->pose.translation().isApprox(Vec3(-3.2, 0.0, 0.86)));
  EXPECT_TRUE((constant->motion.Displacement(2.0) * constant->pose.translation()).isApprox(Vec3(-3.2, 0.3, 0.86)));

  const std::string dir = ::testing::TempDir();
  std::ofstream(dir + "/belt.csv") << "t,x,y,z,qw,qx,qy,qz\n0,0,0,1,1,0,0,0\n2,1,0,1,1,0,0,0\n";
  std::ofstream(dir + "/path_task.yaml")
      << "goal:\n  tool:\n    position: [0, 0, 1]\n    orientation: [1, 0, 0, 0]\n    motion: {file: belt.csv}\n";
  auto sampled = LoadTaskTarget(dir + "/path_task.yaml");
  ASSERT_TRUE(sampled.ok()) << sampled.status().message();
  EXPECT_TRUE((sampled->motion.Displacement(1.0) * sampled->pose.translation()).isApprox(Vec3(0.5, 0, 1)));

  std::ofstream(dir + "/still_task.yaml") << "goal:\n  tool:\n    position: [0, 0, 1]\n";
  auto still = LoadTaskTarget(dir + "/still_task.yaml");
  ASSERT_FALSE(still.ok());
  EXPECT_NE(still.status().message().find("still_task.yaml: goal.tool.motion: missing"), std::string::npos);
  std::ofstream(dir + "/bad_task.yaml")
      << "goal:\n  tool:\n    position: [0, 0, 1]\n    orientation: [1, 0, 0, 0]\n    motion: {velocity: [1, 2]}\n";
  auto bad = LoadTaskTarget(dir + "/bad_task.yaml");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("bad_task.yaml: goal.tool.motion.velocity: expected a list of 3 numbers"),
            std::string::npos);
}

}  // namespace
}  // namespace quadhand::sim
