// The simulator's faults (faults.h, docs/sim.md "Faults"): the Dryden gusts'
// intensities and correlation against the standard's figures, the wind's
// drag against its formula, a weak motor, a slow and a stalled servo, a
// payload heavier than declared, the estimate's jump, drift, freeze and
// NaN, and the configuration's keys.
#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "quadhand/link/frames.h"
#include "quadhand/sim/autopilot.h"
#include "quadhand/sim/faults.h"
#include "quadhand/sim/simulator.h"
#include "sim/sim_test_util.h"

namespace quadhand::sim {
namespace {

using testing::Config;
using testing::Joints;
using testing::Model;

Setpoint HoverAt(const Vec3& p, const VecX& q) {
  Setpoint sp;
  sp.position = p;
  sp.joints = q;
  sp.joint_rates = VecX::Zero(q.size());
  return sp;
}

// Over many independent gust fields, each from its stationary start: the
// sample standard deviation of every component is its intensity (the
// vertical one from the standard's altitude ratio), and the longitudinal
// component's correlation over one time constant L_u / V is e^-1.
TEST(DrydenGustsTest, HasTheStandardsIntensitiesAndCorrelation) {
  WindFault wind;
  wind.gust_intensity = 1.5;
  wind.altitude = 2.0;
  const double speed = 5.0, dt = 0.005;
  const double h_ft = 2.0 / 0.3048, scale = 0.177 + 0.000823 * h_ft;
  const double expected_w = 1.5 * std::pow(scale, 0.4), length_u = 2.0 / std::pow(scale, 1.2);
  const double lag = length_u / speed;
  std::mt19937_64 rng(3);
  constexpr int kFields = 3000;
  double sum_sq[3] = {0, 0, 0}, cross = 0.0, later_sq = 0.0;
  for (int f = 0; f < kFields; ++f) {
    DrydenGusts gusts(wind);
    const Vec3 first = gusts.Step(dt, speed, &rng);
    for (int i = 0; i < 3; ++i) sum_sq[i] += first[i] * first[i];
    Vec3 later = first;
    for (double t = dt; t < lag - 0.5 * dt; t += dt) later = gusts.Step(dt, speed, &rng);
    cross += first.x() * later.x();
    later_sq += later.x() * later.x();
  }
  EXPECT_NEAR(std::sqrt(sum_sq[0] / kFields), 1.5, 0.06 * 1.5);
  EXPECT_NEAR(std::sqrt(sum_sq[1] / kFields), 1.5, 0.06 * 1.5);
  EXPECT_NEAR(std::sqrt(sum_sq[2] / kFields), expected_w, 0.06 * expected_w);
  EXPECT_NEAR(std::sqrt(later_sq / kFields), 1.5, 0.06 * 1.5);  // still stationary
  EXPECT_NEAR(cross / std::sqrt(sum_sq[0] * later_sq), std::exp(-1.0), 0.05);
  DrydenGusts gusts(wind);
  EXPECT_NEAR(gusts.longitudinal_scale(), length_u, 1e-12);
  EXPECT_NEAR(gusts.vertical_scale(), 2.0, 1e-12);
  EXPECT_NEAR(gusts.vertical_intensity(), expected_w, 1e-12);
}

TEST(DrydenGustsTest, NoIntensityNoGust) {
  DrydenGusts gusts(WindFault{});
  std::mt19937_64 rng(1);
  EXPECT_EQ(gusts.Step(0.001, 3.0, &rng), Vec3::Zero());
}

// Quadratic drag on the base and on every arm link, at the links' places.
TEST(WindTest, TheDragIsTheQuadraticLawOnTheBaseAndTheArm) {
  SimConfig config = Config();
  config.faults.wind.steady = Vec3(3.0, 0.0, 0.0);
  config.faults.wind.arm_drag_coefficient = 0.0;
  const VehicleModel base_only = Model(config);
  const VehicleState still = VehicleState::AtRest(base_only, Vec3(0, 0, 1), Joints(0.6, 0.4, 0.0));
  const BaseWrench base = WindWrench(base_only, still, Vec3(3.0, 0.0, 0.0));
  EXPECT_NEAR(base.force.x(), 0.5 * 1.225 * 0.03 * 9.0, 1e-12);
  EXPECT_NEAR(base.force.tail<2>().norm(), 0.0, 1e-12);
  EXPECT_NEAR(base.torque.norm(), 0.0, 1e-12);

  config.faults.wind.arm_drag_coefficient = 1.0;
  const VehicleModel with_arm = Model(config);
  double area = 0.0;
  Vec3 torque = Vec3::Zero();
  const std::vector<Pose> poses = with_arm.LinkPosesInBase(still.joints);
  for (size_t link = 1; link < with_arm.drag_areas().size(); ++link) {
    area += with_arm.drag_areas()[link];
    torque += poses[link].translation().cross(Vec3(0.5 * 1.225 * with_arm.drag_areas()[link] * 9.0, 0.0, 0.0));
  }
  EXPECT_GT(area, 0.005);  // the arm's links have a frontal area
  const BaseWrench all = WindWrench(with_arm, still, Vec3(3.0, 0.0, 0.0));
  EXPECT_NEAR(all.force.x(), 0.5 * 1.225 * (0.03 + area) * 9.0, 1e-12);
  EXPECT_LT((all.torque - torque).norm(), 1e-12);
  // Moving with the air: no drag.
  VehicleState moving = still;
  moving.velocity = Vec3(3.0, 0.0, 0.0);
  EXPECT_LT(WindWrench(with_arm, moving, Vec3(3.0, 0.0, 0.0)).force.norm(), 1e-12);
}

// A 3 m/s wind tilts the hovering vehicle into it; the integrators bring
// it back to its setpoint.
TEST(WindTest, SteadyWindIsHeldAgainst) {
  SimConfig config = Config();
  config.faults.wind.steady = Vec3(3.0, 0.0, 0.0);
  const VehicleModel model = Model(config);
  const VecX q = Joints(0.6, 0.4, 0.0);
  Simulator sim(model, 1);
  sim.Reset(VehicleState::AtRest(model, Vec3(0, 0, 1), q));
  const Setpoint sp = HoverAt(Vec3(0, 0, 1), q);
  double pushed = 0.0;
  for (int k = 0; k < 10000; ++k) {
    sim.Step(sp);
    pushed = std::max(pushed, sim.state().position.x() - sp.position.x());
  }
  EXPECT_GT(pushed, 0.002);
  EXPECT_LT(pushed, 0.05);
  EXPECT_LT((sim.state().position - sp.position).norm(), 0.003);
  // Leaning into the wind: the thrust axis has a -x part.
  EXPECT_LT((sim.state().attitude * Vec3::UnitZ()).x(), -0.005);
  EXPECT_EQ(sim.wind(), Vec3(3.0, 0.0, 0.0));
}

TEST(MotorFaultTest, AWeakMotorDeliversItsFractionAndTheVehicleStillHovers) {
  auto hover = [](const SimConfig& config) {
    const VehicleModel model = Model(config);
    const VecX q = Joints(0.6, 0.4, 0.0);
    Simulator sim(model, 1);
    sim.Reset(VehicleState::AtRest(model, Vec3(0, 0, 1), q));
    for (int k = 0; k < 8000; ++k) sim.Step(HoverAt(Vec3(0, 0, 1), q));
    return sim;
  };
  SimConfig config = Config();
  config.faults.motor.rotor = 2;
  config.faults.motor.thrust_factor = 0.8;
  const Simulator weak = hover(config), healthy = hover(Config());
  const Vec4& t = weak.state().thrusts;
  EXPECT_NEAR(weak.CurrentDynamics().rotor_wrench.force.z(), t[0] + t[1] + 0.8 * t[2] + t[3], 1e-9);
  // It is commanded more, to make up for it (the delivered share as before).
  EXPECT_NEAR(0.8 * t[2], healthy.state().thrusts[2], 0.05);
  EXPECT_LT((weak.state().position - Vec3(0, 0, 1)).norm(), 0.01);
}

TEST(ServoFaultTest, ASlowServoLagsAndAStalledOneHolds) {
  const VecX from = Joints(0.2, 0.4, 0.0), to = Joints(0.8, 0.4, 0.0);
  auto joint_after = [&](const SimConfig& config, double seconds) {
    const VehicleModel model = Model(config);
    Simulator sim(model, 1);
    sim.Reset(VehicleState::AtRest(model, Vec3(0, 0, 1), from));
    const int steps = static_cast<int>(std::lround(seconds / sim.step()));
    for (int k = 0; k < steps; ++k) sim.Step(HoverAt(Vec3(0, 0, 1), to));
    return sim.state().joints[0];
  };
  SimConfig slow = Config();
  slow.faults.servo.extra_lag = 0.3;
  EXPECT_LT(joint_after(slow, 0.2), joint_after(Config(), 0.2) - 0.05);
  SimConfig stalled = Config();
  stalled.faults.servo.stall_joint = 0;
  stalled.faults.servo.stall_time = 0.05;
  const double at_stall = joint_after(stalled, 0.05);
  EXPECT_GT(at_stall, 0.2);
  EXPECT_NEAR(joint_after(stalled, 1.0), at_stall, 1e-12);
  EXPECT_GT(joint_after(Config(), 1.0), 0.79);
}

// A jammed joint is part of a rigid arm: the base hovering under it holds
// its position as well as under an arm commanded to stay where it is, while
// the plan commands the joint elsewhere.
TEST(ServoFaultTest, AStalledJointPushesNothingOntoTheBase) {
  const VecX from = Joints(0.2, 0.4, 0.0), to = Joints(1.2, 0.4, 0.0);
  auto base_offset = [&](const SimConfig& config, const VecX& commanded) {
    const VehicleModel model = Model(config);
    Simulator sim(model, 1);
    sim.Reset(VehicleState::AtRest(model, Vec3(0, 0, 1), from));
    double worst = 0.0;
    const int steps = static_cast<int>(std::lround(2.0 / sim.step()));
    for (int k = 0; k < steps; ++k) {
      sim.Step(HoverAt(Vec3(0, 0, 1), commanded));
      worst = std::max(worst, (sim.state().position - Vec3(0, 0, 1)).norm());
    }
    return worst;
  };
  SimConfig stalled = Config();
  stalled.faults.servo.stall_joint = 0;
  stalled.faults.servo.stall_time = 0.0;
  const double still = base_offset(Config(), from);
  EXPECT_LT(base_offset(stalled, to), still + 1e-3);
}

TEST(PayloadFaultTest, TheObjectIsHeavierThanTheControllerIsTold) {
  SimConfig config = Config();
  config.faults.payload_mass_factor = 1.5;
  config.faults.wind.steady = Vec3(1.0, 0.0, 0.0);
  Simulator sim(Model(config), 1);
  const double controller_before = sim.controller().mass();
  const std::vector<double> drag_areas = sim.model().drag_areas();
  ASSERT_TRUE(sim.SetPayload(0.2, Vec3(0.05, 0, 0)).ok());
  EXPECT_EQ(sim.model().drag_areas(), drag_areas);  // the same vehicle, its meshes not read again
  EXPECT_NEAR(sim.model().payload_mass(), 0.3, 1e-12);
  EXPECT_NEAR(sim.controller().mass(), controller_before + 0.2, 1e-12);
  ASSERT_TRUE(sim.SetPayload(0.0, Vec3::Zero()).ok());
  EXPECT_NEAR(sim.model().payload_mass(), 0.0, 1e-12);
  EXPECT_NEAR(sim.controller().mass(), controller_before, 1e-12);
}

// A jump of the estimate is flown: the vehicle ends off its setpoint by
// minus the jump, where the estimate says it is on it.
TEST(EstimateFaultTest, AJumpIsFlownByTheAutopilot) {
  SimConfig config = Config();
  config.faults.estimate.jump_time = 0.5;
  config.faults.estimate.jump = Vec3(0.02, -0.01, 0.0);
  const VehicleModel model = Model(config);
  const VecX q = Joints(0.6, 0.4, 0.0);
  Simulator sim(model, 1);
  sim.Reset(VehicleState::AtRest(model, Vec3(0, 0, 1), q));
  for (int k = 0; k < 6000; ++k) sim.Step(HoverAt(Vec3(0, 0, 1), q));
  EXPECT_LT((sim.state().position - Vec3(-0.02, 0.01, 1.0)).norm(), 0.002);
  EXPECT_LT((sim.Estimate().position - Vec3(0, 0, 1)).norm(), 0.002);
}

class EstimateTelemetryTest : public ::testing::Test {
 protected:
  std::vector<link::LocalPositionNed> Fly(const SimConfig& config, double until) {
    AutopilotOptions options;
    auto autopilot = Autopilot::Create(Simulator(Model(config), 7), StartPose{}, options);
    EXPECT_TRUE(autopilot.ok());
    std::vector<link::Message> out;
    EXPECT_TRUE(autopilot->AdvanceTo(until, &out).ok());
    std::vector<link::LocalPositionNed> positions;
    for (const link::Message& m : out) {
      if (const auto* p = std::get_if<link::LocalPositionNed>(&m)) positions.push_back(*p);
    }
    return positions;
  }
};

TEST_F(EstimateTelemetryTest, AFrozenEstimateRepeatsItsStampAndNanFillsTheFields) {
  SimConfig frozen = Config();
  frozen.faults.estimate.freeze_time = 0.5;
  frozen.faults.estimate.freeze_duration = 0.3;
  int repeated = 0;
  uint32_t last = 0;
  for (const link::LocalPositionNed& p : Fly(frozen, 1.2)) {
    if (p.time_boot_ms == last) ++repeated;
    if (p.time_boot_ms != last) {
      EXPECT_GT(p.time_boot_ms, last);
    }
    last = p.time_boot_ms;
  }
  EXPECT_GE(repeated, 5);     // the 0.3 s freeze at the telemetry's rate
  EXPECT_GE(last, 1100u);      // and the stamps move on after it
  SimConfig nan = Config();
  nan.faults.estimate.nan_time = 0.5;
  nan.faults.estimate.nan_duration = 0.2;
  int nans = 0;
  for (const link::LocalPositionNed& p : Fly(nan, 1.0)) {
    const bool is_nan = std::isnan(p.x) && std::isnan(p.vz);
    nans += is_nan;
    EXPECT_EQ(is_nan, p.time_boot_ms >= 500 && p.time_boot_ms < 700) << p.time_boot_ms;
  }
  EXPECT_GE(nans, 3);
}

TEST(FaultConfigTest, TheKeysAreReadAndBadValuesNamed) {
  const std::string robot = "robot: " + testing::kRoot + "/meshes/quadhand/quadhand.urdf\n";
  auto parsed = ParseSimConfig(robot +
                                   "faults:\n"
                                   "  wind: {steady: [2, 1, 0], gust_intensity: 1.5, altitude: 3}\n"
                                   "  motor: {rotor: 1, thrust_factor: 0.7}\n"
                                   "  servo: {extra_lag: 0.05, stall_joint: 2, stall_time: 4}\n"
                                   "  payload_mass_factor: 1.3\n"
                                   "  estimate:\n"
                                   "    jump: {time: 3, offset: [0.02, 0, 0]}\n"
                                   "    drift: [0.001, 0, 0]\n"
                                   "    freeze: {time: 5, duration: 1}\n"
                                   "    nan: {time: 6, duration: 0.1}\n",
                               ".", "f.yaml");
  ASSERT_TRUE(parsed.ok()) << parsed.status().message();
  const FaultConfig& f = parsed->faults;
  EXPECT_EQ(f.wind.steady, Vec3(2, 1, 0));
  EXPECT_EQ(f.wind.gust_intensity, 1.5);
  EXPECT_EQ(f.motor.rotor, 1);
  EXPECT_EQ(f.servo.stall_joint, 2);
  EXPECT_EQ(f.payload_mass_factor, 1.3);
  EXPECT_EQ(f.estimate.jump, Vec3(0.02, 0, 0));
  EXPECT_EQ(f.estimate.freeze_duration, 1.0);
  EXPECT_EQ(f.estimate.nan_time, 6.0);
  EXPECT_EQ(parsed->failsafe.action, FailsafeConfig::Action::kHold);  // the default
  auto land = ParseSimConfig(robot + "failsafe: {action: land, delay: 2, land_speed: 0.5, land_height: 0.1}\n", ".",
                             "f.yaml");
  ASSERT_TRUE(land.ok()) << land.status().message();
  EXPECT_EQ(land->failsafe.action, FailsafeConfig::Action::kLand);
  EXPECT_EQ(land->failsafe.delay, 2.0);
  EXPECT_EQ(land->failsafe.land_speed, 0.5);
  EXPECT_EQ(land->failsafe.land_height, 0.1);
  const std::pair<std::string, std::string> bad[] = {
      {"faults: {wind: {gusts: 1}}", "f.yaml: faults.wind.gusts: unknown key"},
      {"faults: {wind: {steady: [40, 0, 0]}}", "faults.wind.steady must be at most 30 m/s"},
      {"faults: {motor: {thrust_factor: 0.5}}", "f.yaml: faults.motor.rotor: missing"},
      {"faults: {motor: {rotor: 4}}", "faults.motor.rotor must be 0, 1, 2 or 3"},
      {"faults: {motor: {rotor: 1.5}}", "f.yaml: faults.motor.rotor: expected a whole number"},
      {"faults: {servo: {extra_lag: -1}}", "faults.servo.extra_lag must be in [0, 5] s"},
      {"faults: {payload_mass_factor: .nan}", "f.yaml: faults.payload_mass_factor: must be finite"},
      {"faults: {estimate: {freeze: {time: 1}}}", "f.yaml: faults.estimate.freeze.duration: missing"},
      {"faults: {estimate: {jump: {time: 1}}}", "f.yaml: faults.estimate.jump.offset: missing"},
      {"failsafe: {action: fly}", "f.yaml: failsafe.action: must be hold or land, not 'fly'"},
      {"failsafe: {land_speed: 0}", "failsafe.land_speed must be in (0, 5] m/s"},
      {"failsafe: {delay: -1}", "failsafe.delay must be in [0, 3600] s"},
      {"failsafe: {hold: 1}", "f.yaml: failsafe.hold: unknown key"},
  };
  for (const auto& [text, fragment] : bad) {
    auto r = ParseSimConfig(robot + text + "\n", ".", "f.yaml");
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_NE(r.status().message().find(fragment), std::string::npos) << r.status().message();
  }
  // The stalled joint is checked against the robot.
  SimConfig config = Config();
  config.faults.servo.stall_joint = 3;
  auto model = VehicleModel::Create(testing::Robot(), config);
  ASSERT_FALSE(model.ok());
  EXPECT_NE(model.status().message().find("faults.servo.stall_joint must be an actuated joint index (0..2)"),
            std::string::npos)
      << model.status().message();
}

}  // namespace
}  // namespace quadhand::sim
