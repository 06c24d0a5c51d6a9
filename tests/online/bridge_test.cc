// The splice weight and blend, the MAVLink bridge's conversions and message
// contents, and the flight log's columns.
#include <gtest/gtest.h>

#include <algorithm>
#include <sstream>

#include "online/online_test_util.h"
#include "quadhand/link/frames.h"
#include "quadhand/sim/plan_io.h"

namespace quadhand::online {
namespace {

using testing::MakeController;
using testing::WindowCup;

Setpoint MakeSetpoint(const Vec3& p, const Vec3& v, double yaw) {
  Setpoint s;
  s.position = p;
  s.velocity = v;
  s.acceleration = Vec3(0.1, -0.2, 0.3);
  s.yaw = yaw;
  s.yaw_rate = 0.4;
  s.joints = Vec3(0.3, -0.2, 0.1);
  s.joint_rates = Vec3(0.01, 0.02, -0.03);
  return s;
}

TEST(SpliceTest, WeightIsSmoothAtBothEnds) {
  EXPECT_EQ(SpliceWeight(0.0), 0.0);
  EXPECT_EQ(SpliceWeight(1.0), 1.0);
  EXPECT_EQ(SpliceWeight(-3.0), 0.0);
  EXPECT_EQ(SpliceWeight(7.0), 1.0);
  EXPECT_NEAR(SpliceWeight(0.5), 0.5, 1e-15);
  const double h = 1e-4;
  for (double s : {0.0, 1.0}) {  // first and second derivatives vanish
    const double left = SpliceWeight(s - h), mid = SpliceWeight(s), right = SpliceWeight(s + h);
    EXPECT_NEAR((right - left) / (2 * h), 0.0, 1e-6);
    EXPECT_NEAR((right - 2 * mid + left) / (h * h), 0.0, 1e-2);
  }
  // The largest slope, 15/8 at s = 1/2, is what BlendStepBound assumes.
  double steepest = 0.0;
  for (double s = 0.0; s <= 1.0; s += 1e-3) steepest = std::max(steepest, (SpliceWeight(s + h) - SpliceWeight(s)) / h);
  EXPECT_NEAR(steepest, 15.0 / 8.0, 1e-3);
}

TEST(SpliceTest, BlendGoesTheShortWayRoundAndKeepsTheStepBound) {
  const Setpoint a = MakeSetpoint(Vec3(0, 0, 1), Vec3(1, 0, 0), M_PI - 0.1);
  const Setpoint b = MakeSetpoint(Vec3(0.2, 0.1, 1), Vec3(1, 0.2, 0), -M_PI + 0.1);
  EXPECT_NEAR(std::remainder(Blend(a, b, 0.5).yaw - M_PI, 2 * M_PI), 0.0, 1e-12);  // through pi, not zero
  EXPECT_LT((Blend(a, b, 0.0).position - a.position).norm(), 1e-15);
  EXPECT_LT((Blend(a, b, 1.0).joints - b.joints).norm(), 1e-15);
  // Two straight plans at 1 m/s, 0.2236 m apart, blended over 0.5 s and sampled at 50 Hz.
  const double window = 0.5, dt = 0.02;
  double worst = 0.0;
  Vec3 previous = a.position;
  for (double t = dt; t <= window + 1e-9; t += dt) {
    Setpoint pa = a, pb = b;
    pa.position += t * a.velocity;
    pb.position += t * b.velocity;
    const Vec3 p = Blend(pa, pb, SpliceWeight(t / window)).position;
    worst = std::max(worst, (p - previous).norm());
    previous = p;
  }
  const double bound = BlendStepBound(b.velocity.norm(), (b.position - a.position).norm() + window * 0.2, window, dt);
  EXPECT_LE(worst, bound);
  EXPECT_GT(worst, 0.5 * bound);  // the bound is not loose by orders of magnitude
}

TEST(BridgeTest, SetpointMessagesCarryNedValuesAndTheJointLayout) {
  const Setpoint s = MakeSetpoint(Vec3(1.0, 2.0, 3.0), Vec3(0.5, -0.5, 0.25), 0.3);
  ControllerOutput out;
  out.setpoint = s;
  out.send_heartbeat = true;
  out.commands = {{Command::kSetOffboardMode, 2}, {Command::kArm, 0}};
  const LinkTargets targets;
  const std::vector<link::Message> messages = MessagesFor(out, 12.345, targets);
  ASSERT_EQ(messages.size(), 5u);
  const auto& heartbeat = std::get<link::Heartbeat>(messages[0]);
  EXPECT_EQ(heartbeat.type, link::mav::kTypeOnboardController);
  const auto& target = std::get<link::SetPositionTargetLocalNed>(messages[1]);
  EXPECT_EQ(target.type_mask, 0);
  EXPECT_EQ(target.coordinate_frame, link::mav::kFrameLocalNed);
  EXPECT_EQ(target.time_boot_ms, 12345u);
  EXPECT_FLOAT_EQ(target.x, 2.0f);  // north = ENU y
  EXPECT_FLOAT_EQ(target.y, 1.0f);  // east = ENU x
  EXPECT_FLOAT_EQ(target.z, -3.0f);
  EXPECT_FLOAT_EQ(target.vx, -0.5f);
  EXPECT_FLOAT_EQ(target.vz, -0.25f);
  EXPECT_FLOAT_EQ(target.afz, -0.3f);
  EXPECT_NEAR(target.yaw, M_PI / 2 - 0.3, 1e-6);
  EXPECT_FLOAT_EQ(target.yaw_rate, -0.4f);
  const auto& joints = std::get<link::DebugFloatArray>(messages[2]);
  EXPECT_EQ(joints.name, "JOINT_SP");
  ASSERT_EQ(joints.data.size(), 6u);
  EXPECT_FLOAT_EQ(joints.data[1], -0.2f);
  EXPECT_FLOAT_EQ(joints.data[5], -0.03f);
  const auto& mode = std::get<link::CommandLong>(messages[3]);
  EXPECT_EQ(mode.command, link::mav::kCmdDoSetMode);
  EXPECT_EQ(mode.param1, 1.0f);
  EXPECT_EQ(mode.param2, 6.0f);
  EXPECT_EQ(mode.confirmation, 2);
  const auto& arm = std::get<link::CommandLong>(messages[4]);
  EXPECT_EQ(arm.command, link::mav::kCmdComponentArmDisarm);
  EXPECT_EQ(arm.param1, 1.0f);
  EXPECT_EQ(arm.target_system, 1);
}

TEST(BridgeTest, TheAutopilotsModeIsReadFromItsHeartbeatAndEachChangeIsAnEvent) {
  auto controller = MakeController();
  const LinkTargets targets;
  auto heartbeat = [&](uint32_t custom_mode, bool armed) {
    link::Heartbeat h;
    h.type = link::mav::kTypeQuadrotor;
    h.autopilot = link::mav::kAutopilotPx4;
    h.base_mode = link::mav::kModeFlagCustomModeEnabled | (armed ? link::mav::kModeFlagSafetyArmed : 0);
    h.custom_mode = custom_mode;
    return h;
  };
  EXPECT_EQ(controller->autopilot_mode(), AutopilotMode::kUnknown);
  DeliverToController(heartbeat(link::mav::Px4CustomMode(link::mav::kPx4MainModePosition), false), 1, 0.0, targets,
                      controller.get());
  EXPECT_EQ(controller->autopilot_mode(), AutopilotMode::kPosition);
  DeliverToController(heartbeat(link::mav::Px4CustomMode(link::mav::kPx4MainModeOffboard), true), 1, 1.0, targets,
                      controller.get());
  EXPECT_EQ(controller->autopilot_mode(), AutopilotMode::kOffboard);
  DeliverToController(
      heartbeat(link::mav::Px4CustomMode(link::mav::kPx4MainModeAuto, link::mav::kPx4AutoSubModeLand), true), 1, 2.0,
      targets, controller.get());
  EXPECT_EQ(controller->autopilot_mode(), AutopilotMode::kLand);
  DeliverToController(heartbeat(link::mav::Px4CustomMode(link::mav::kPx4MainModeAuto, 3), true), 1, 3.0, targets,
                      controller.get());
  EXPECT_EQ(controller->autopilot_mode(), AutopilotMode::kHold);
  const std::vector<std::string> events = controller->Tick(3.0).events;
  std::string all;
  for (const std::string& e : events) all += e + "\n";
  // The first mode seen is no change; the three after it are.
  EXPECT_NE(all.find("the autopilot is now in OFFBOARD"), std::string::npos) << all;
  EXPECT_NE(all.find("the autopilot is now in LAND: it is landing"), std::string::npos) << all;
  EXPECT_NE(all.find("the autopilot is now in HOLD"), std::string::npos) << all;
  EXPECT_EQ(all.find("now in POSITION"), std::string::npos) << all;
}

TEST(BridgeTest, TelemetryReachesTheControllerInEnu) {
  auto controller = MakeController();
  const LinkTargets targets;
  link::LocalPositionNed position;
  position.x = 0.2f;  // north
  position.y = 0.5f;  // east
  position.z = -1.2f;
  position.vx = 1.0f;
  link::AttitudeQuaternion attitude;
  const Quat q_enu(Eigen::AngleAxisd(3.0, Vec3::UnitZ()) * Eigen::AngleAxisd(0.1, Vec3::UnitX()));
  const Quat q_ned = link::AttitudeEnuFluToNedFrd(q_enu);
  attitude.q1 = static_cast<float>(q_ned.w());
  attitude.q2 = static_cast<float>(q_ned.x());
  attitude.q3 = static_cast<float>(q_ned.y());
  attitude.q4 = static_cast<float>(q_ned.z());
  attitude.yawspeed = 0.5f;  // about down
  link::DebugFloatArray joints;
  joints.name = "JOINTS";
  joints.data = {0.3f, -0.2f, 0.0f, 0.1f, 0.0f, 0.0f};
  EXPECT_TRUE(DeliverToController(position, 1, 0.5, targets, controller.get()));
  EXPECT_TRUE(DeliverToController(attitude, 1, 0.5, targets, controller.get()));
  EXPECT_TRUE(DeliverToController(joints, 1, 0.5, targets, controller.get()));
  EXPECT_FALSE(DeliverToController(position, 7, 0.5, targets, controller.get()));  // another system
  link::DebugFloatArray other;
  other.name = "OTHER";
  other.data = {1.0f, 2.0f};
  EXPECT_FALSE(DeliverToController(other, 1, 0.5, targets, controller.get()));
  ASSERT_TRUE(controller->has_measured_state());
  const MeasuredState m = controller->measured();
  EXPECT_LT((m.position - Vec3(0.5, 0.2, 1.2)).norm(), 1e-6);
  EXPECT_LT((m.velocity - Vec3(0.0, 1.0, 0.0)).norm(), 1e-6);
  EXPECT_LT(m.attitude.angularDistance(q_enu), 1e-6);
  EXPECT_NEAR(m.body_rate.z(), -0.5, 1e-6);
  EXPECT_NEAR(m.joints[0], 0.3, 1e-6);
  EXPECT_NEAR(m.joint_rates[0], 0.1, 1e-6);
  // The servos' goals (optional): one angle per actuated joint.
  EXPECT_EQ(controller->joint_goals().size(), 0);
  link::DebugFloatArray goals;
  goals.name = "JOINT_GOAL";
  goals.data = {0.4f, -0.1f, 0.2f};
  EXPECT_TRUE(DeliverToController(goals, 1, 0.5, targets, controller.get()));
  ASSERT_EQ(controller->joint_goals().size(), 3);
  EXPECT_NEAR(controller->joint_goals()[0], 0.4, 1e-6);
  EXPECT_NEAR(controller->joint_goals()[2], 0.2, 1e-6);

  // A PX4 heartbeat in OFFBOARD, armed, and acknowledgements.
  link::Heartbeat heartbeat;
  heartbeat.base_mode = link::mav::kModeFlagCustomModeEnabled | link::mav::kModeFlagSafetyArmed;
  heartbeat.custom_mode = link::mav::Px4CustomMode(link::mav::kPx4MainModeOffboard);
  EXPECT_TRUE(DeliverToController(heartbeat, 1, 0.6, targets, controller.get()));
  link::CommandAck ack;
  ack.command = 999;
  EXPECT_FALSE(DeliverToController(ack, 1, 0.6, targets, controller.get()));
}

TEST(FlightLogTest, WritesThePlanColumnsThenTheSetpoints) {
  FlightLog log;
  MeasuredState m;
  m.joints = Vec3(0.1, 0.2, 0.3);
  m.joint_rates = Vec3::Zero();
  m.attitude = Quat(Eigen::AngleAxisd(0.4, Vec3::UnitZ()));
  for (int k = 0; k < 5; ++k) {
    m.time = 0.02 * k;
    m.position = Vec3(0.01 * k, 0.0, 1.0);
    m.velocity = Vec3(0.5 * k, 0.0, 0.0);
    std::optional<Setpoint> sp;
    if (k >= 2) sp = MakeSetpoint(Vec3(0.01 * k, 0.03, 1.0), Vec3::Zero(), 0.4);
    log.Record(m, sp, k >= 2 ? Phase::kFlying : Phase::kWaitingForVehicle, std::nullopt, Vec3(0.004, -0.005, 0.0));
  }
  const std::vector<std::string> names = WindowCup().robot().ActuatedJointNames();
  const std::string csv = log.Csv(names);
  // The measured part is a plan file.
  auto plan = sim::ParsePlanCsv(csv, names, "log.csv");
  ASSERT_TRUE(plan.ok()) << plan.status().message();
  ASSERT_EQ(plan->rows.size(), 5u);
  EXPECT_NEAR(plan->rows[3].acceleration.x(), 0.5 / 0.02, 1e-9);
  EXPECT_NEAR(plan->rows[3].yaw, 0.4, 1e-9);
  EXPECT_NE(csv.find(",sp_px,sp_py,sp_pz,"), std::string::npos);
  EXPECT_NE(csv.find(",sp_joint1_rate,"), std::string::npos);
  // The shift added when the setpoint was sent follows the setpoint.
  EXPECT_NE(csv.find(",sp_joint3_rate,sp_shift_x,sp_shift_y,sp_shift_z,err_pos,phase\n"), std::string::npos);
  EXPECT_NE(csv.find(",0.03,1,0,0,0,0.1,-0.2,0.3,0.4,0.4,0.3,-0.2,0.1,0.01,0.02,-0.03,0.004,-0.005,0,0.03,flying\n"),
            std::string::npos)
      << csv;
  EXPECT_NE(csv.find(",,waiting_for_vehicle\n"), std::string::npos);
  // Every line has as many fields as the header.
  std::istringstream lines(csv);
  std::string line;
  std::getline(lines, line);
  const auto count = [](const std::string& s) { return std::count(s.begin(), s.end(), ','); };
  const long fields = count(line);
  while (std::getline(lines, line)) EXPECT_EQ(count(line), fields) << line;
}

}  // namespace
}  // namespace quadhand::online
