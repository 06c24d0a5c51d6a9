// The simulated vehicle: the URDF's rigid bodies (masses, centres of mass,
// inertias), the PCGC battery on its mimic joint (or locked at zero), an
// optional payload at the tool frame, four rotors, servo limits and drag.
// Immutable after Create(); the dynamics (dynamics.h) read it.
//
// Frames: the base frame B is the URDF root link's frame (FLU, origin at the
// centre of the rotor plate); link frames as in the URDF. Spatial vectors are
// [angular; linear] (Featherstone), expressed in the body's own frame.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/sim/config.h"

namespace quadhand::sim {

using Vec4 = Eigen::Vector4d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

// Mass, centre of mass and inertia of a set of bodies, in some frame F:
// `com` is p_FC, `inertia` is about the centre of mass with F's axes.
struct MassProperties {
  double mass = 0.0;
  Vec3 com = Vec3::Zero();
  Mat3 inertia = Mat3::Zero();
};

// 6x6 spatial inertia [[Ic + m [c]x [c]x^T, m [c]x], [m [c]x^T, m 1]] of a
// body with mass m, centre of mass c and inertia Ic about it (its own frame).
Mat6 SpatialInertia(const MassProperties& body);

// Where a joint is for the dynamics: its position comes from an actuated
// coordinate (itself or its mimic source) or it is locked (fixed joints, and
// the PCGC joint when PCGC is off).
struct JointCoupling {
  int q_index = -1;          // actuated coordinate, -1 when locked
  double multiplier = 1.0;   // position = multiplier * q[q_index] + offset
  double offset = 0.0;
};

class VehicleModel {
 public:
  // Fails (InvalidArgument) when the configuration does not fit the robot:
  // a PCGC joint that is not a mimic joint, no `tool` link, servo limit lists
  // of the wrong length, or an invalid configuration.
  static core::Result<VehicleModel> Create(const robot::RobotModel& robot, const SimConfig& config);
  // The same vehicle with another payload (Simulator::SetPayload: a gripper
  // closing or opening), without reading the robot's meshes again.
  core::Result<VehicleModel> WithPayload(const PayloadConfig& payload) const;

  const robot::RobotModel& robot() const { return robot_; }
  const SimConfig& config() const { return config_; }
  int num_actuated() const { return robot_.num_actuated(); }
  // PCGC acts: switched on, and the robot has its joint.
  bool pcgc() const { return config_.pcgc && has_pcgc_joint_; }
  double payload_mass() const { return config_.payload.attached ? config_.payload.mass : 0.0; }
  double gravity() const { return config_.gravity; }

  // Per robot link: mass properties in the link frame (payload included) and
  // the spatial inertia; per robot joint: its coupling.
  const MassProperties& body(int link) const { return bodies_[link]; }
  const Mat6& spatial_inertia(int link) const { return spatial_inertias_[link]; }
  const JointCoupling& coupling(int joint) const { return couplings_[joint]; }

  // Every robot joint's position from the actuated q (and rates, accelerations
  // from qd, qdd the same way), honouring mimic joints and the PCGC lock.
  std::vector<double> JointValues(const VecX& q_actuated, bool with_offset = true) const;

  // Pose of every link in the base frame at actuated positions q.
  std::vector<Pose> LinkPosesInBase(const VecX& q) const;
  // Whole vehicle (base, arm, battery, payload) in the base frame at q.
  MassProperties MassPropertiesAt(const VecX& q) const;
  double TotalMass() const { return total_mass_; }

  // Rotors: position in B (thrust along +z of B) and yaw-torque sign, in the
  // order front-left, rear-left, rear-right, front-right.
  const std::array<Vec3, 4>& rotor_positions() const { return rotor_positions_; }
  const Vec4& rotor_spin() const { return rotor_spin_; }
  // 4x4 map from rotor thrusts to [collective thrust; torque about the base origin in B].
  const Eigen::Matrix4d& allocation() const { return allocation_; }

  // Servo limits per actuated joint and the URDF position limits.
  const VecX& servo_max_rate() const { return servo_max_rate_; }
  const VecX& servo_max_acceleration() const { return servo_max_acceleration_; }
  const VecX& joint_lower() const { return joint_lower_; }
  const VecX& joint_upper() const { return joint_upper_; }
  // Cd A of each link for the wind's drag (faults.wind), m^2; the base's
  // (link 0) is 0 here: faults.wind.base_drag_area.
  const std::vector<double>& drag_areas() const { return drag_areas_; }

 private:
  VehicleModel(const robot::RobotModel& robot, const SimConfig& config) : robot_(robot), config_(config) {}
  // `drag_areas`: this robot's, already computed (null: computed here).
  static core::Result<VehicleModel> Create(const robot::RobotModel& robot, const SimConfig& config,
                                           const std::vector<double>* drag_areas);

  robot::RobotModel robot_;
  SimConfig config_;
  bool has_pcgc_joint_ = false;
  std::vector<MassProperties> bodies_;
  std::vector<Mat6> spatial_inertias_;
  std::vector<JointCoupling> couplings_;
  double total_mass_ = 0.0;
  std::array<Vec3, 4> rotor_positions_;
  Vec4 rotor_spin_ = Vec4(-1.0, 1.0, -1.0, 1.0);
  Eigen::Matrix4d allocation_ = Eigen::Matrix4d::Zero();
  VecX servo_max_rate_, servo_max_acceleration_, joint_lower_, joint_upper_;
  std::vector<double> drag_areas_;
};

}  // namespace quadhand::sim
