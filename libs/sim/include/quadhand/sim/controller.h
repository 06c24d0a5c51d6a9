// Geometric tracking controller on SE(3) (Lee, Leok, McClamroch, CDC 2010)
// with integral terms, and the rotor mixer. Like a real autopilot it knows
// only the vehicle's mass and a nominal inertia: neither the arm's motion nor
// the CoG offset it causes, so the arm's disturbance shows up as tracking error.
//
//   a_cmd  = a_d - Kp e_p - Kv e_v - Ki int(e_p)            e_p = p - p_d, e_v = v - v_d
//   thrust = m (a_cmd + g e3) . R e3                        (N)
//   R_d, omega_d = traj::FlatForward(v_d, a_cmd, j_d, yaw_d, yaw_rate_d)
//                  (the planner's flatness map, so "yaw" means the same Hopf yaw)
//   e_R = vee(R_d^T R - R^T R_d) / 2,  e_w = omega - R^T R_d omega_d
//   tau = J (-KR e_R - Kw e_w - KI int(e_R)) + omega x J omega   (N m, base frame)
#pragma once

#include "quadhand/core/types.h"
#include "quadhand/sim/config.h"

namespace quadhand::sim {

// What the vehicle should do now; world frame W, FLU body.
struct Setpoint {
  Vec3 position = Vec3::Zero();      // m
  Vec3 velocity = Vec3::Zero();      // m/s
  Vec3 acceleration = Vec3::Zero();  // m/s^2
  Vec3 jerk = Vec3::Zero();          // m/s^3 (body-rate feed-forward; may be zero)
  double yaw = 0.0;                  // Hopf yaw (traj/flatness.h), rad
  double yaw_rate = 0.0;             // rad/s
  VecX joints;                       // servo setpoints, rad
  VecX joint_rates;                  // rad/s
};

// The controller's view of the vehicle (possibly noisy).
struct Measurement {
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();  // W
  Quat attitude = Quat::Identity();
  Vec3 body_rate = Vec3::Zero();  // B
};

struct ControllerOutput {
  double thrust = 0.0;           // collective, N
  Vec3 torque = Vec3::Zero();    // about the base origin, B, N m
  Quat desired_attitude = Quat::Identity();
  Vec3 attitude_error = Vec3::Zero();  // e_R
};

class GeometricController {
 public:
  // `mass` (kg) and `inertia` (kg m^2, base axes) are what the controller
  // believes; gains come from `config` (its mass/inertia fields are ignored here).
  GeometricController(const ControllerConfig& config, double mass, const Mat3& inertia, double gravity);

  // One control period of length dt (s): integrates the error terms.
  ControllerOutput Update(const Measurement& measured, const Setpoint& setpoint, double dt);
  void Reset();

  double mass() const { return mass_; }
  // What it believes the mass is from now on (a payload picked up or put
  // down); the integrators keep their state. mass > 0.
  void set_mass(double mass) { mass_ = mass; }
  const Mat3& inertia() const { return inertia_; }

 private:
  ControllerConfig config_;
  double mass_;
  Mat3 inertia_;
  double gravity_;
  Vec3 position_integral_ = Vec3::Zero();
  Vec3 attitude_integral_ = Vec3::Zero();
};

// Rotor thrusts for a collective thrust and torques, within [min, max] per
// rotor. Yaw has the lowest priority: the largest share (0 to 1) of the yaw
// torque that keeps every rotor within limits is applied; if thrust and roll
// and pitch torques alone leave the limits, no yaw torque, and each thrust is clamped.
Eigen::Vector4d MixRotors(const Eigen::Matrix4d& allocation, double thrust, const Vec3& torque, double min_thrust,
                          double max_thrust);

}  // namespace quadhand::sim
