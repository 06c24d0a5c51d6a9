// Multibody dynamics of the vehicle: mass properties against the URDF and
// hand computations, hover equilibrium, free fall, the arm's reaction wrench,
// conservation laws under RK4, servo limits.
#include <cmath>

#include <gtest/gtest.h>

#include "quadhand/robot/kinematics.h"
#include "quadhand/sim/dynamics.h"
#include "sim/sim_test_util.h"

namespace quadhand::sim {
namespace {

using testing::Config;
using testing::Joints;
using testing::Model;
using testing::Robot;

constexpr double kG = 9.81;
// robot.md: base 1.12, battery 0.25, link1 0.10, link2 0.08, link3 0.15 kg.
constexpr double kRobotMass = 1.70;

ControlInput Hold(const VehicleState& s) { return ControlInput{s.thrusts, s.joints, VecX::Zero(s.joints.size())}; }

// A configuration without thrust (min_thrust 0) and optionally without gravity.
SimConfig Unpowered(double gravity) {
  SimConfig c = Config();
  c.rotors.min_thrust = 0.0;
  c.gravity = gravity;
  return c;
}

TEST(VehicleModelTest, TotalMassIncludesArmBatteryAndPayload) {
  EXPECT_NEAR(Model(true, 0.0).TotalMass(), kRobotMass, 1e-12);
  EXPECT_NEAR(Model(false, 0.15).TotalMass(), kRobotMass + 0.15, 1e-12);
  EXPECT_NEAR(Model(true, 0.15).MassPropertiesAt(Joints(0.7, -0.4, 1.0)).mass, kRobotMass + 0.15, 1e-12);
}

TEST(VehicleModelTest, CogOfStaticPoseMatchesUrdfKinematics) {
  // With PCGC on, the vehicle is the URDF as written (battery on its mimic joint).
  const VehicleModel model = Model(true, 0.0);
  for (const VecX& q : {Joints(0, 0, 0), Joints(0.7, -0.4, 1.0), Joints(1.5, 1.2, -2.0)}) {
    robot::KinematicsState kin;
    robot::ComputeKinematics(Robot(), Pose::Identity(), q, &kin);
    Vec3 moment = Vec3::Zero();
    double mass = 0.0;
    for (int i = 0; i < Robot().num_links(); ++i) {
      const robot::Link& link = Robot().link(i);
      moment += link.mass * (kin.link_poses[i] * link.center_of_mass);
      mass += link.mass;
    }
    const MassProperties mp = model.MassPropertiesAt(q);
    EXPECT_NEAR((mp.com - moment / mass).norm(), 0.0, 1e-12) << q.transpose();
  }
}

TEST(VehicleModelTest, CogMatchesHandComputationWithPayload) {
  // Arm straight forward (robot.md): CoMs along x at battery -0.145, link1 0.14,
  // link2 0.32, link3 0.45, payload at the tool 0.51; z = -0.045 for all but the base.
  const MassProperties mp = Model(false, 0.15).MassPropertiesAt(Joints(0, 0, 0));
  const double mx = -0.25 * 0.145 + 0.10 * 0.14 + 0.08 * 0.32 + 0.15 * 0.45 + 0.15 * 0.51;
  EXPECT_NEAR(mp.com.x(), mx / 1.85, 1e-12);
  EXPECT_NEAR(mp.com.y(), 0.0, 1e-12);
  EXPECT_NEAR(mp.com.z(), -0.045 * 0.73 / 1.85, 1e-12);
}

TEST(VehicleModelTest, PcgcMovesCogBackTowardRotorCentreAsArmLowers) {
  const VehicleModel on = Model(true, 0.0), off = Model(false, 0.0);
  // Moments about the rotor centre along x, from robot.md: the arm gives
  // 0.04 * 0.33 + 0.0939 cos(q1); the battery -0.06 * 0.25 - 0.02125 cos(q1)
  // when it follows joint1 (PCGC) and -0.03625 when locked.
  double min_on = 1, max_on = -1, min_off = 1, max_off = -1;
  for (double q1 = 0.0; q1 <= 1.5701; q1 += 0.157) {
    const double c = std::cos(q1);
    const double x_on = on.MassPropertiesAt(Joints(q1, 0, 0)).com.x();
    const double x_off = off.MassPropertiesAt(Joints(q1, 0, 0)).com.x();
    EXPECT_NEAR(x_on, (0.0132 - 0.015 + (0.0939 - 0.02125) * c) / kRobotMass, 1e-12);
    EXPECT_NEAR(x_off, (0.0132 - 0.03625 + 0.0939 * c) / kRobotMass, 1e-12);
    min_on = std::min(min_on, x_on), max_on = std::max(max_on, x_on);
    min_off = std::min(min_off, x_off), max_off = std::max(max_off, x_off);
  }
  // Arm fully lowered: PCGC brings the CoG within 1.1 mm of the rotor centre,
  // without it the locked battery leaves it 13.6 mm behind.
  const double lowered_on = on.MassPropertiesAt(Joints(1.57, 0, 0)).com.x();
  const double lowered_off = off.MassPropertiesAt(Joints(1.57, 0, 0)).com.x();
  EXPECT_LT(std::abs(lowered_on), 0.0011);
  EXPECT_NEAR(lowered_off, -0.0136, 2e-4);
  // The CoG travels less over the joint1 range: 42.7 mm instead of 55.2 mm.
  EXPECT_NEAR(max_on - min_on, 0.07265 / kRobotMass, 1e-4);
  EXPECT_NEAR(max_off - min_off, 0.0939 / kRobotMass, 1e-4);
  // The battery hangs down with the arm: the CoG also drops.
  EXPECT_LT(on.MassPropertiesAt(Joints(1.57, 0, 0)).com.z(), off.MassPropertiesAt(Joints(1.57, 0, 0)).com.z() - 0.01);
}

TEST(DynamicsTest, HoverEquilibriumThrustEqualsTotalWeight) {
  for (bool pcgc : {true, false}) {
    for (double payload : {0.0, 0.15}) {
      const VehicleModel model = Model(pcgc, payload);
      for (const VecX& q : {Joints(0.2, 0, 0), Joints(0.9, -0.6, 1.0), Joints(1.5, 1.0, -0.5)}) {
        const VehicleState s = VehicleState::AtRest(model, Vec3(1, 2, 3), q);
        EXPECT_NEAR(s.thrusts.sum(), (kRobotMass + payload) * kG, 1e-9);
        DynamicsInfo info;
        const VecX dx = StateDerivative(model, PackState(s), Hold(s), &info);
        EXPECT_LT(info.acceleration.norm(), 1e-9) << "pcgc " << pcgc << " payload " << payload;
        EXPECT_LT(info.angular_acceleration.norm(), 1e-9);
        EXPECT_LT(dx.norm(), 1e-9);
        // The arm's static load on the base: its weight and the CoG torque.
        const MassProperties mp = model.MassPropertiesAt(q);
        EXPECT_NEAR(info.arm_wrench.force.z(), -(mp.mass - 1.12) * kG, 1e-9);
        EXPECT_NEAR(info.arm_wrench.torque.y(), mp.com.x() * mp.mass * kG, 1e-9);
      }
    }
  }
}

TEST(DynamicsTest, FreeFallWithZeroThrust) {
  const VehicleModel model = Model(Unpowered(kG));
  VehicleState s = VehicleState::AtRest(model, Vec3(0, 0, 10), Joints(0.8, 0.3, 0.5));
  s.thrusts.setZero();
  s.attitude = Quat(Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized()));
  ControlInput u = Hold(s);
  u.thrust_command.setZero();
  DynamicsInfo info;
  StateDerivative(model, PackState(s), u, &info);
  EXPECT_LT((info.acceleration - Vec3(0, 0, -kG)).norm(), 1e-12);
  EXPECT_LT(info.angular_acceleration.norm(), 1e-12);
  for (int k = 0; k < 1000; ++k) s = Rk4Step(model, s, u, 0.001);
  EXPECT_NEAR(s.position.z(), 10.0 - 0.5 * kG, 1e-9);
  EXPECT_LT(s.body_rate.norm(), 1e-12);
  EXPECT_NEAR(s.thrusts.norm(), 0.0, 1e-12);
}

TEST(DynamicsTest, FreeFallWithMovingArmKeepsCentreOfMassParabolaAndAngularMomentum) {
  // The servos move the arm; no external force but gravity acts on the whole:
  // the CoM falls on a parabola and the angular momentum about it is constant.
  for (bool pcgc : {true, false}) {
    SimConfig c = Unpowered(kG);
    c.pcgc = pcgc;
    c.payload.attached = true;
    const VehicleModel model = Model(c);
    VehicleState s = VehicleState::AtRest(model, Vec3(0, 0, 10), Joints(0.2, -0.5, 0.0));
    s.thrusts.setZero();
    s.velocity = Vec3(1.0, -0.5, 2.0);
    s.body_rate = Vec3(0.2, -0.3, 0.4);
    ControlInput u{Vec4::Zero(), Joints(1.4, 0.8, 2.0), VecX::Zero(3)};
    const VehicleMomentum m0 = ComputeMomentum(model, s);
    const double h = 0.001;
    for (int k = 1; k <= 800; ++k) {
      s = Rk4Step(model, s, u, h);
      const double t = k * h;
      if (k % 100 != 0) continue;
      const VehicleMomentum m = ComputeMomentum(model, s);
      const Vec3 expected = m0.center_of_mass + m0.com_velocity * t + 0.5 * t * t * Vec3(0, 0, -kG);
      EXPECT_LT((m.center_of_mass - expected).norm(), 1e-8) << "t " << t;
      EXPECT_LT((m.angular - m0.angular).norm(), 1e-8) << "t " << t;
    }
    EXPECT_GT(s.joints[0], 1.0);  // the arm did move
  }
}

TEST(DynamicsTest, ArmReactionTorqueMatchesHandComputation) {
  // Base held still, no gravity, arm straight forward at rest, joint1
  // accelerating by alpha (arm swinging down). The arm needs, about the base
  // origin, sum_i (m_i d_i (0.04 + d_i) + Iyy_i) alpha along +y (d_i: CoM
  // distance from joint1, 0.04 m: joint1's x); it pushes back on the base
  // with the opposite torque (nose up) and with sum m_i d_i alpha along +z.
  const double alpha = 3.0;
  const robot::RobotModel& robot = Robot();
  auto iyy = [&](const char* link) { return robot.link(robot.LinkIndex(link)).inertia(1, 1); };
  const double arm_inertia = 0.10 * 0.10 * 0.14 + 0.08 * 0.28 * 0.32 + 0.15 * 0.41 * 0.45 + iyy("link1") +
                             iyy("link2") + iyy("link3");
  const double arm_moment = 0.10 * 0.10 + 0.08 * 0.28 + 0.15 * 0.41;
  // With PCGC the battery (0.25 kg, CoM 0.085 m behind its joint at (-0.06, 0, -0.045))
  // turns the other way: it needs -(0.25 * 0.085 * 0.145 + Iyy) alpha about y and
  // pushes the base along +z too, by 0.25 * 0.085 alpha.
  const double battery_inertia = 0.25 * 0.085 * 0.145 + iyy("battery");
  const double battery_moment = 0.25 * 0.085;

  for (bool pcgc : {false, true}) {
    SimConfig c = Unpowered(0.0);
    c.pcgc = pcgc;
    const VehicleModel model = Model(c);
    VehicleState s = VehicleState::AtRest(model, Vec3::Zero(), Joints(0, 0, 0));
    const BaseWrench w = ArmWrenchOnBase(model, s, Joints(alpha, 0, 0), Vec3::Zero(), Vec3::Zero());
    const double torque_y = -(arm_inertia - (pcgc ? battery_inertia : 0.0)) * alpha;
    const double force_z = (arm_moment + (pcgc ? battery_moment : 0.0)) * alpha;
    EXPECT_NEAR(w.torque.y(), torque_y, 1e-12) << "pcgc " << pcgc;
    EXPECT_LT(w.torque.y(), 0.0);  // nose up
    EXPECT_NEAR(w.force.z(), force_z, 1e-12);
    EXPECT_NEAR(w.force.x(), 0.0, 1e-12);
    EXPECT_NEAR(w.torque.x(), 0.0, 1e-12);
    EXPECT_NEAR(w.torque.z(), 0.0, 1e-12);
  }
  EXPECT_NEAR(arm_inertia, 0.0370, 1e-4);  // the size: 0.111 N m for 3 rad/s^2
}

TEST(DynamicsTest, ForwardDynamicsArmWrenchIsConsistent) {
  // The arm wrench reported by the forward dynamics is the arm's inverse
  // dynamics at the base acceleration the forward dynamics found.
  const VehicleModel model = Model(true, 0.15);
  VehicleState s = VehicleState::AtRest(model, Vec3(0, 0, 1), Joints(0.6, -0.3, 0.9));
  s.attitude = Quat(Eigen::AngleAxisd(0.4, Vec3(0.3, -1, 0.2).normalized()));
  s.velocity = Vec3(0.5, -1, 0.2);
  s.body_rate = Vec3(0.3, 0.8, -0.5);
  s.joint_rates = Joints(1.0, -1.5, 2.0);
  const VecX qdd = Joints(5.0, -8.0, 12.0);
  DynamicsInfo info;
  BaseForwardDynamics(model, s, qdd, RotorWrench(model, Vec4(5, 4, 3, 6)), &info);
  const BaseWrench w = ArmWrenchOnBase(model, s, qdd, info.acceleration, info.angular_acceleration);
  EXPECT_LT((w.force - info.arm_wrench.force).norm(), 1e-10);
  EXPECT_LT((w.torque - info.arm_wrench.torque).norm(), 1e-10);
}

TEST(DynamicsTest, Rk4ConservesEnergyAndMomentumOfATumblingBody) {
  // No gravity, no thrust, joints frozen: a rigid body spinning freely.
  const VehicleModel model = Model(Unpowered(0.0));
  VehicleState s = VehicleState::AtRest(model, Vec3::Zero(), Joints(0.9, -0.7, 1.2));
  s.thrusts.setZero();
  s.body_rate = Vec3(1.0, 0.5, 2.0);
  s.velocity = Vec3(0.3, 0.1, -0.2);
  ControlInput u = Hold(s);
  u.thrust_command.setZero();
  const VehicleMomentum m0 = ComputeMomentum(model, s);
  for (int k = 0; k < 2000; ++k) s = Rk4Step(model, s, u, 0.001);
  const VehicleMomentum m1 = ComputeMomentum(model, s);
  EXPECT_NEAR(m1.kinetic_energy, m0.kinetic_energy, 1e-9 * m0.kinetic_energy);
  EXPECT_LT((m1.angular - m0.angular).norm(), 1e-9 * m0.angular.norm());
  EXPECT_LT((m1.linear - m0.linear).norm(), 1e-12);
  EXPECT_NEAR(s.attitude.norm(), 1.0, 1e-12);
}

TEST(DynamicsTest, Rk4ConservesEnergyInFreeFallAndIsFourthOrder) {
  const VehicleModel model = Model(Unpowered(kG));
  VehicleState s0 = VehicleState::AtRest(model, Vec3(0, 0, 5), Joints(0.5, 0.5, 0.0));
  s0.thrusts.setZero();
  s0.body_rate = Vec3(3.0, -2.0, 4.0);
  ControlInput u = Hold(s0);
  u.thrust_command.setZero();
  auto fly = [&](double h, double duration) {
    VehicleState s = s0;
    const int steps = static_cast<int>(std::lround(duration / h));
    for (int k = 0; k < steps; ++k) s = Rk4Step(model, s, u, h);
    return s;
  };
  const VehicleMomentum e0 = ComputeMomentum(model, s0);
  const VehicleMomentum e1 = ComputeMomentum(model, fly(0.002, 1.0));
  EXPECT_NEAR(e1.kinetic_energy + e1.potential_energy, e0.kinetic_energy + e0.potential_energy, 1e-7);
  // Global error ~ h^4: halving the step divides it by about 16.
  const VehicleState ref = fly(0.00025, 0.5);
  const double err_coarse = (fly(0.004, 0.5).attitude.coeffs() - ref.attitude.coeffs()).norm();
  const double err_fine = (fly(0.002, 0.5).attitude.coeffs() - ref.attitude.coeffs()).norm();
  EXPECT_GT(err_coarse / err_fine, 12.0) << err_coarse << " " << err_fine;
  EXPECT_LT(err_coarse / err_fine, 20.0);
}

TEST(DynamicsTest, ServoIsRateAndAccelerationLimited) {
  const VehicleModel model = Model(Unpowered(0.0));
  VehicleState s = VehicleState::AtRest(model, Vec3::Zero(), Joints(0.0, 0.0, 0.0));
  s.thrusts.setZero();
  ControlInput u{Vec4::Zero(), Joints(1.5, -1.4, 3.0), VecX::Zero(3)};
  double max_rate[3] = {0, 0, 0};
  for (int k = 0; k < 3000; ++k) {
    const VecX qdd = ServoAccelerations(model, s.joints, s.joint_rates, u.joint_setpoints, u.joint_rate_setpoints);
    for (int j = 0; j < 3; ++j) {
      EXPECT_LE(std::abs(qdd[j]), model.servo_max_acceleration()[j] + 1e-12);
      max_rate[j] = std::max(max_rate[j], std::abs(s.joint_rates[j]));
    }
    s = Rk4Step(model, s, u, 0.001);
  }
  EXPECT_LE(max_rate[0], 2.0 + 1e-6);  // URDF rate limits
  EXPECT_GT(max_rate[0], 1.99);
  EXPECT_LE(max_rate[2], 3.0 + 1e-6);
  EXPECT_NEAR(s.joints[0], 1.5, 1e-4);
  EXPECT_NEAR(s.joints[1], -1.4, 1e-4);
  EXPECT_NEAR(s.joints[2], 3.0, 1e-4);
  // Setpoints beyond the URDF limits are clamped into them.
  u.joint_setpoints = Joints(2.5, 0, 0);
  for (int k = 0; k < 2000; ++k) s = Rk4Step(model, s, u, 0.001);
  EXPECT_NEAR(s.joints[0], 1.57, 1e-4);
}

TEST(DynamicsTest, MotorLagIsFirstOrder) {
  const VehicleModel model = Model(Unpowered(0.0));
  VehicleState s = VehicleState::AtRest(model, Vec3::Zero(), Joints(0.0, 0.0, 0.0));
  s.thrusts.setZero();
  ControlInput u = Hold(s);
  u.thrust_command = Vec4(4, 4, 4, 20);  // the last one above max_thrust
  const double tau = model.config().rotors.time_constant;
  for (int k = 0; k < 30; ++k) s = Rk4Step(model, s, u, 0.001);  // t = tau
  EXPECT_NEAR(s.thrusts[0], 4.0 * (1.0 - std::exp(-0.03 / tau)), 1e-6);
  EXPECT_NEAR(s.thrusts[3], model.config().rotors.max_thrust * (1.0 - std::exp(-0.03 / tau)), 1e-6);
}

}  // namespace
}  // namespace quadhand::sim
