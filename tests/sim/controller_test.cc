// The geometric controller, the mixer and the simulation loop.
#include <cmath>

#include <gtest/gtest.h>

#include "quadhand/sim/controller.h"
#include "quadhand/sim/simulator.h"
#include "quadhand/traj/flatness.h"
#include "sim/sim_test_util.h"

namespace quadhand::sim {
namespace {

using testing::Config;
using testing::Joints;
using testing::Model;

Setpoint HoverAt(const Vec3& p, double yaw, const VecX& q) {
  Setpoint sp;
  sp.position = p;
  sp.yaw = yaw;
  sp.joints = q;
  sp.joint_rates = VecX::Zero(q.size());
  return sp;
}

TEST(MixerTest, ReproducesFeasibleWrench) {
  const VehicleModel model = Model(true, 0.0);
  const Vec4 t = MixRotors(model.allocation(), 18.0, Vec3(0.2, -0.3, 0.05), 0.2, 10.0);
  const BaseWrench w = RotorWrench(model, t);
  EXPECT_NEAR(w.force.z(), 18.0, 1e-12);
  EXPECT_LT((w.torque - Vec3(0.2, -0.3, 0.05)).norm(), 1e-12);
}

TEST(MixerTest, YawHasLowestPriority) {
  const VehicleModel model = Model(true, 0.0);
  // Far more yaw torque than four rotors can give: roll, pitch and thrust stay
  // exact, the yaw torque is as large as the limits allow (not dropped).
  const Vec4 t = MixRotors(model.allocation(), 18.0, Vec3(0.1, -0.2, 5.0), 0.2, 10.0);
  const BaseWrench w = RotorWrench(model, t);
  EXPECT_NEAR(w.force.z(), 18.0, 1e-9);
  EXPECT_NEAR(w.torque.x(), 0.1, 1e-9);
  EXPECT_NEAR(w.torque.y(), -0.2, 1e-9);
  EXPECT_GT(w.torque.z(), 0.05);
  EXPECT_LE(t.maxCoeff(), 10.0 + 1e-12);
  EXPECT_GE(t.minCoeff(), 0.2 - 1e-12);
}

TEST(HopfYawTest, InvertsTheFlatnessMap) {
  for (const Vec3& acc : {Vec3(0, 0, 0), Vec3(2, -1, 0.5), Vec3(-3, 2, -4), Vec3(0.1, 4, 1)}) {
    for (double yaw : {0.0, 1.0, -2.5, 3.0}) {
      const traj::FlatState st = traj::FlatForward(Vec3::Zero(), acc, Vec3(1, -2, 0.5), yaw, 0.7);
      EXPECT_NEAR(traj::HopfYawOf(st.attitude()), yaw, 1e-12) << acc.transpose();
      EXPECT_NEAR(traj::HopfYawRateOf(st.attitude(), st.body_rate), 0.7, 1e-12);
    }
  }
}

TEST(ControllerTest, HoverHoldsPositionAndThrustEqualsWeight) {
  for (double payload : {0.0, 0.15}) {
    const VehicleModel model = Model(true, payload);
    const VecX q = Joints(0.6, 0.4, 0.0);
    Simulator sim(model, 1);
    sim.Reset(VehicleState::AtRest(model, Vec3(0, 0, 1), q));
    const Setpoint sp = HoverAt(Vec3(0, 0, 1), 0.0, q);
    // The controller does not know the CoG offset: its integrators take a few seconds.
    for (int k = 0; k < 8000; ++k) sim.Step(sp);
    EXPECT_LT((sim.state().position - sp.position).norm(), 0.002) << payload;
    EXPECT_NEAR(sim.state().thrusts.sum(), model.TotalMass() * 9.81, 1e-3);
    EXPECT_LT(sim.state().body_rate.norm(), 1e-3);
  }
}

TEST(ControllerTest, ConvergesFromAnOffset) {
  const VehicleModel model = Model(false, 0.15);
  const VecX q = Joints(0.8, 0.3, 0.0);
  const Setpoint sp = HoverAt(Vec3(1, -1, 2), 0.5, q);
  Simulator sim(model, 7);
  VehicleState start = VehicleState::AtRest(model, sp.position + Vec3(0.5, -0.3, 0.2), q);
  start.attitude = Quat(Eigen::AngleAxisd(-0.2, Vec3::UnitZ()));
  sim.Reset(start);
  double max_error = 0.0;
  for (int k = 0; k < 8000; ++k) {
    sim.Step(sp);
    max_error = std::max(max_error, (sim.state().position - sp.position).norm());
  }
  EXPECT_LT((sim.state().position - sp.position).norm(), 0.01);
  EXPECT_NEAR(traj::HopfYawOf(sim.state().attitude), 0.5, 0.01);
  EXPECT_LT(max_error, 1.0);  // no wild excursion on the way
}

TEST(ControllerTest, ArmMotionShowsUpAsTrackingError) {
  // Hovering while joint1 swings: the controller does not know the arm, so the
  // vehicle moves; a static arm leaves it still.
  const VehicleModel model = Model(true, 0.0);
  auto flight_error = [&](double amplitude) {
    Simulator sim(model, 1);
    const VecX q0 = Joints(0.8, 0.0, 0.0);
    sim.Reset(VehicleState::AtRest(model, Vec3(0, 0, 1), q0));
    for (int k = 0; k < 10000; ++k) sim.Step(HoverAt(Vec3(0, 0, 1), 0.0, q0));  // integrators settle
    double worst = 0.0;
    for (int k = 0; k < 3000; ++k) {
      const double t = k * 0.001;
      Setpoint sp = HoverAt(Vec3(0, 0, 1), 0.0, Joints(0.8 + amplitude * std::sin(3 * t), 0, 0));
      sp.joint_rates[0] = 3 * amplitude * std::cos(3 * t);
      sim.Step(sp);
      worst = std::max(worst, (sim.state().position - sp.position).norm());
    }
    return worst;
  };
  EXPECT_LT(flight_error(0.0), 1e-3);
  EXPECT_GT(flight_error(0.6), 0.005);
}

TEST(SimulatorTest, NoiseIsSeeded) {
  SimConfig c = Config();
  c.noise.enabled = true;
  const VehicleModel model = Model(c);
  const VecX q = Joints(0.5, 0.0, 0.0);
  auto fly = [&](uint64_t seed) {
    Simulator sim(model, seed);
    sim.Reset(VehicleState::AtRest(model, Vec3(0, 0, 1), q));
    for (int k = 0; k < 500; ++k) sim.Step(HoverAt(Vec3(0, 0, 1), 0.0, q));
    return sim.state().position;
  };
  EXPECT_EQ(fly(3), fly(3));
  EXPECT_NE(fly(3), fly(4));
}

TEST(SimulatorTest, PartialStepsLandOnTheRequestedTime) {
  const VehicleModel model = Model(true, 0.0);
  Simulator sim(model, 1);
  const VecX q = Joints(0.5, 0.0, 0.0);
  sim.Reset(VehicleState::AtRest(model, Vec3(0, 0, 1), q), 0.25);
  sim.Step(HoverAt(Vec3(0, 0, 1), 0, q), 0.0004);
  EXPECT_NEAR(sim.time(), 0.2504, 1e-15);
  sim.Step(HoverAt(Vec3(0, 0, 1), 0, q));
  EXPECT_NEAR(sim.time(), 0.2514, 1e-15);
}

}  // namespace
}  // namespace quadhand::sim
