// Differential flatness of a quadrotor without drag, with the attitude
// parametrised by the Hopf fibration (Watterson & Kumar; Wang et al.).
//
// Frames and units: world W is ENU (z up), gravity g along -z; the body frame
// B is FLU. Inputs are the flat-output derivatives in W (m/s, m/s^2, m/s^3),
// yaw psi (rad) and yaw rate (rad/s).
//
//   thrust f  = |a + g e3|                    (collective thrust per unit mass, m/s^2)
//   z         = (a + g e3) / f                (body z axis in W)
//   q         = q_tilt(z) * q_z(psi)          (Hamilton, body-to-world, [w, x, y, z])
//   q_tilt    = [1 + c, -b, a, 0] / sqrt(2 (1 + c)),  z = (a, b, c)
//   z_dot     = (I - z z^T) j / f
//   omega     = body rate in B (rad/s):
//     omega_x = sin(psi) a' - cos(psi) b' - (a sin(psi) - b cos(psi)) c' / (1 + c)
//     omega_y = cos(psi) a' + sin(psi) b' - (a cos(psi) + b sin(psi)) c' / (1 + c)
//     omega_z = (b a' - a b') / (1 + c) + psi_dot          (a', b', c') = z_dot
//   ||omega_xy||^2 = omega_x^2 + omega_y^2 = ||z_dot||^2 (exact; the paper's
//   "= ||z_dot||" drops the square).
// "psi" is the Hopf yaw: the heading of the rotation that follows the minimal
// tilt, not an Euler angle; it equals the Euler yaw when the tilt is zero.
//
// Singular cases (reported in FlatState::status; outputs stay finite):
//  * kFreeFall, f < options.min_thrust: the body axis is undefined. z := e3,
//    z_dot := 0, q := q_z(psi), omega := (0, 0, psi_dot), ||omega_xy||^2 := 0.
//    In the backward pass only the thrust gradient (through (a + g e3) / f,
//    zero if f == 0) and the psi / psi_dot paths carry gradient.
//  * kNearInverted, 1 + c < options.inverted_tolerance (z points almost
//    straight down): the Hopf chart is singular. q and omega are evaluated at
//    the nearest axis with 1 + c = inverted_tolerance (same azimuth; +x if
//    z = -e3 exactly). f, z, z_dot and ||omega_xy||^2 are exact. In the backward
//    pass the gradients from q and omega through z and z_dot are dropped
//    (set to zero); those from f and ||omega_xy||^2 are exact.
// In every case the psi and psi_dot gradients are exact derivatives of the
// returned (possibly fallback) outputs.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace quadhand::traj {

struct FlatnessOptions {
  double gravity = 9.81;             // m/s^2, along -z of W
  double min_thrust = 1e-3;          // m/s^2: below this, free fall
  double inverted_tolerance = 1e-4;  // on 1 + z_c: below this, near inverted
};

enum class FlatnessStatus { kOk, kFreeFall, kNearInverted };

// Name of a status, e.g. "near inverted".
const char* FlatnessStatusName(FlatnessStatus status);

struct FlatState {
  FlatnessStatus status = FlatnessStatus::kOk;
  double thrust = 0.0;                     // f, m/s^2
  Eigen::Vector3d z_body = Eigen::Vector3d::UnitZ();  // body z axis in W
  Eigen::Vector3d z_body_dot = Eigen::Vector3d::Zero();
  Eigen::Vector4d quat = Eigen::Vector4d(1.0, 0.0, 0.0, 0.0);  // [w, x, y, z], body-to-world
  Eigen::Vector3d body_rate = Eigen::Vector3d::Zero();         // omega in B, rad/s
  double body_rate_xy_sq = 0.0;            // omega_x^2 + omega_y^2, rad^2/s^2

  // The attitude as an Eigen quaternion / rotation matrix R_WB.
  Eigen::Quaterniond attitude() const { return {quat[0], quat[1], quat[2], quat[3]}; }
  Eigen::Matrix3d rotation() const { return attitude().toRotationMatrix(); }
};

// Gradients of a scalar cost with respect to the outputs of FlatForward().
struct FlatStateGrad {
  double thrust = 0.0;
  Eigen::Vector4d quat = Eigen::Vector4d::Zero();  // d/d[w, x, y, z]
  Eigen::Vector3d body_rate = Eigen::Vector3d::Zero();
  double body_rate_xy_sq = 0.0;
};

// Gradients of the same cost with respect to the flat inputs.
struct FlatInputGrad {
  Eigen::Vector3d vel = Eigen::Vector3d::Zero();  // always zero without drag
  Eigen::Vector3d acc = Eigen::Vector3d::Zero();
  Eigen::Vector3d jerk = Eigen::Vector3d::Zero();
  double yaw = 0.0;
  double yaw_rate = 0.0;
};

// Forward map. `vel` does not enter the drag-free model; it is part of the
// interface so a drag model can be added without changing callers.
FlatState FlatForward(const Eigen::Vector3d& vel, const Eigen::Vector3d& acc,
                      const Eigen::Vector3d& jerk, double yaw, double yaw_rate,
                      const FlatnessOptions& options = {});

// Backward pass: given the inputs, the state FlatForward() returned for them
// (with the same options) and the output gradients, returns the input
// gradients. Stateless and thread-safe; always finite for finite arguments.
FlatInputGrad FlatBackward(const Eigen::Vector3d& vel, const Eigen::Vector3d& acc,
                           const Eigen::Vector3d& jerk, double yaw, double yaw_rate,
                           const FlatState& state, const FlatStateGrad& grad,
                           const FlatnessOptions& options = {});

// Inverses for measured attitudes (simulators, online state estimates): the
// Hopf yaw of an attitude (body FLU -> world ENU), in (-pi, pi], and the yaw
// rate that goes with a body rate (rad/s, body frame), so that FlatForward of
// a trajectory with that yaw reproduces the attitude's heading.
double HopfYawOf(const Eigen::Quaterniond& attitude);
double HopfYawRateOf(const Eigen::Quaterniond& attitude, const Eigen::Vector3d& body_rate);

}  // namespace quadhand::traj
