// Parameters of the vehicle simulator, read from a YAML file
// (data/sim/quadhand_sim.yaml; every key and its default: docs/sim.md).
// Units: metres, kilograms, seconds, radians, newtons.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/sim/faults.h"
#include "quadhand/sim/sensor.h"

namespace quadhand::sim {

// Four rotors in an X around the base origin (the centre of the rotor plate),
// thrust along +z of the base. Rotor k sits at
// (+-w/(2 sqrt 2), +-w/(2 sqrt 2), height) for wheelbase w, in the order
// front-left, rear-left, rear-right, front-right; the yaw torque of rotor k is
// spin[k] * torque_coefficient * thrust[k] about +z (spin = -1, +1, -1, +1).
struct RotorConfig {
  double wheelbase = 0.33;            // motor-to-motor diagonal, m
  double height = 0.025;              // rotor plane above the base origin, m
  double min_thrust = 0.2;            // per rotor, N
  double max_thrust = 10.0;           // per rotor, N
  double time_constant = 0.03;        // first-order motor lag, s
  double torque_coefficient = 0.016;  // yaw torque per thrust, m
};

// A servo tracks a setpoint (q_sp, qd_sp) with a rate- and acceleration-
// limited law: qd_des = clamp(qd_sp + position_gain (q_sp - q), +-max_rate),
// qdd = clamp((qd_des - qd) / time_constant, +-max_acceleration). Setpoints
// are clamped into the URDF joint limits first.
struct ServoConfig {
  double position_gain = 25.0;   // 1/s
  double time_constant = 0.02;   // velocity loop, s
  std::vector<double> max_rate;  // rad/s per actuated joint; empty: the URDF's velocity limits
  std::vector<double> max_acceleration = {30.0, 30.0, 60.0};  // rad/s^2 per actuated joint
};

// A point mass rigidly attached to the end-effector link.
struct PayloadConfig {
  bool attached = false;
  double mass = 0.15;         // kg
  Vec3 offset = Vec3::Zero();  // in the link's frame, m
  std::string link = "tool";  // the URDF link carrying it (needed only when attached)
};

// Geometric tracking controller on SE(3) (Lee, Leok, McClamroch 2010) with
// integral terms. It knows neither the arm's motion nor the CoG offset.
// Position gains are accelerations per metre (or per m/s, per m s), attitude
// gains angular accelerations per radian (or per rad/s, per rad s): the
// commands are scaled by the controller's mass and inertia.
struct ControllerConfig {
  double mass = 0.0;              // kg; 0: the vehicle's total mass at start (payload included)
  Vec3 inertia = Vec3::Zero();    // diagonal, kg m^2; 0: the composite inertia (full tensor) at nominal_joints
  std::vector<double> nominal_joints;  // rad; empty: the middle of each joint's limits
  Vec3 position_gain = Vec3(8.0, 8.0, 8.0);
  Vec3 velocity_gain = Vec3(5.0, 5.0, 5.0);
  Vec3 position_integral_gain = Vec3(4.0, 4.0, 4.0);
  double position_integral_limit = 0.1;  // |integral| per axis, m s
  Vec3 attitude_gain = Vec3(180.0, 180.0, 60.0);
  Vec3 rate_gain = Vec3(24.0, 24.0, 12.0);
  Vec3 attitude_integral_gain = Vec3(300.0, 300.0, 20.0);
  double attitude_integral_limit = 0.1;  // |integral| per axis, rad s
};

// Zero-mean Gaussian noise on the measured state, per control step.
struct NoiseConfig {
  bool enabled = true;
  double position = 0.001;   // m
  double velocity = 0.005;   // m/s
  double attitude = 0.002;   // rad, a random rotation vector per axis
  double body_rate = 0.01;   // rad/s
};

// What the autopilot does once the offboard stream is lost (docs/sim.md,
// "Failsafe"), after PX4's COM_OBL_RC_ACT and COM_FAIL_ACT_T: it always
// holds first; `land` then lands after `delay`. Hold is the default because
// an aerial manipulator between obstacles has no free space below it that
// anyone checked: a blind descent there is what the failsafe must avoid.
struct FailsafeConfig {
  enum class Action { kHold, kLand };
  Action action = Action::kHold;
  double delay = 5.0;        // s of hold before landing (COM_FAIL_ACT_T)
  double land_speed = 0.7;   // m/s of descent (MPC_LAND_SPEED)
  double land_height = 0.0;  // world z of the base frame when landed: no ground contact is simulated
};

struct SimConfig {
  std::string robot_path;           // URDF, resolved against the YAML file's folder
  double step = 0.001;              // RK4 step = control period, s (<= 0.002: at least 500 Hz)
  double gravity = 9.81;            // m/s^2, along -z of the world
  // The mimic joint of the battery. When it was left at this default and the
  // robot has no such joint, the robot has no PCGC and none is simulated;
  // a joint named in the configuration must exist.
  std::string pcgc_joint = "battery_joint";
  bool pcgc_joint_given = false;
  bool pcgc = true;                 // false: that joint is locked at 0
  Vec3 linear_drag = Vec3::Zero();  // N/(m/s) along the base axes, on the base velocity
  RotorConfig rotors;
  ServoConfig servo;
  PayloadConfig payload;
  ControllerConfig controller;
  NoiseConfig noise;
  FaultConfig faults;  // faults.h; none by default
  FailsafeConfig failsafe;
  SensorConfig sensor;  // sensor.h: what quadhand-sim --sensor renders

  // Checks ranges; `why` (optional) names the first bad key.
  bool IsValid(std::string* why) const;
};

// Reads a configuration; missing keys keep their defaults, unknown keys are
// errors (a typo never passes silently). Errors name the file and the key.
core::Result<SimConfig> LoadSimConfig(const std::string& path);
// Same from a string; `base_dir` resolves `robot`, `source` names it in errors.
core::Result<SimConfig> ParseSimConfig(const std::string& yaml, const std::string& base_dir,
                                       const std::string& source);

}  // namespace quadhand::sim
