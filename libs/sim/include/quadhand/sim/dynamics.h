// Dynamics of the vehicle: a floating base carrying the arm, the battery and
// the payload as one multibody tree. The joints are driven by servos, so their
// accelerations are prescribed (servo model below); the base's 6-DoF motion
// then follows from the coupled Newton-Euler equations of the whole tree:
//
//   Ic(q) a_B = F_rotors + F_drag - p(q, qd, qdd, v_B, R_WB)
//
// with Ic the composite spatial inertia of every body about the base frame,
// a_B the base's spatial acceleration and p the recursive Newton-Euler bias
// (gravity, velocity products and the joints' accelerations). The wrench the
// arm exerts on the base (the paper's f_d, tau_d: everything hanging off the
// base, battery and payload included, gravity load included) is reported.
// Rotor thrusts follow their commands with a first-order lag.
//
// Conventions: world W is ENU with gravity along -z; the base frame B is FLU.
// Position and velocity of the base origin in W; attitude R_WB (Hamilton
// quaternion); body rate omega in B; joints in URDF order of the actuated joints.
#pragma once

#include "quadhand/core/types.h"
#include "quadhand/sim/vehicle_model.h"

namespace quadhand::sim {

struct VehicleState {
  Vec3 position = Vec3::Zero();     // p_WB, m
  Quat attitude = Quat::Identity(); // R_WB
  Vec3 velocity = Vec3::Zero();     // of the base origin, in W, m/s
  Vec3 body_rate = Vec3::Zero();    // omega in B, rad/s
  VecX joints;                      // actuated joint positions, rad
  VecX joint_rates;                 // rad/s
  Vec4 thrusts = Vec4::Zero();      // rotor thrusts, N (motor states)

  // At rest at `position` with level attitude and the given joints; thrusts that
  // hold the vehicle there (weight and CoG torque) as far as the rotor limits allow.
  static VehicleState AtRest(const VehicleModel& model, const Vec3& position, const VecX& joints);
};

// What the dynamics holds constant over one integration step.
struct ControlInput {
  Vec4 thrust_command = Vec4::Zero();  // N per rotor (clamped into the rotor limits)
  VecX joint_setpoints;                // rad
  VecX joint_rate_setpoints;           // rad/s (feed-forward)
  // The air's velocity (world), steady wind plus gusts (faults.wind): not
  // a command, but, like one, held over the step.
  Vec3 wind = Vec3::Zero();
};



// A wrench on the base: force in B and torque about the base origin in B.
struct BaseWrench {
  Vec3 force = Vec3::Zero();
  Vec3 torque = Vec3::Zero();
};

// By-products of one evaluation of the dynamics.
struct DynamicsInfo {
  Vec3 acceleration = Vec3::Zero();          // of the base origin, in W, m/s^2
  Vec3 angular_acceleration = Vec3::Zero();  // in B, rad/s^2
  VecX joint_accelerations;                  // rad/s^2
  BaseWrench rotor_wrench;                   // thrusts and yaw torques
  BaseWrench arm_wrench;                     // what the arm (battery, payload) exerts on the base
};

// The wind's drag on the vehicle at `state` (faults.wind): quadratic,
// 0.5 rho CdA |v_rel| v_rel with v_rel the air's velocity less the body's,
// on the base (base_drag_area, at its origin) and on every arm link (its
// drag area at its frame's origin, moving with the base's velocity and
// rotation: the arm's own joint rates are left out). The arm's share acts
// on the base through the stiff servos: a wrench about the base origin, in B.
BaseWrench WindWrench(const VehicleModel& model, const VehicleState& state, const Vec3& wind);

// Servo model (ServoConfig): joint accelerations from the state and setpoints.
VecX ServoAccelerations(const VehicleModel& model, const VecX& q, const VecX& qd, const VecX& q_setpoint,
                        const VecX& qd_setpoint);

// Collective thrust and torques of the rotors at `thrusts` (not clamped).
BaseWrench RotorWrench(const VehicleModel& model, const Vec4& thrusts);

// Base motion for a prescribed joint motion (q, qd, qdd) under the external
// wrench `external` on the base (rotors, drag) and gravity. Fills the base
// accelerations and the arm wrench of `info` (not joint accelerations or rotor wrench).
void BaseForwardDynamics(const VehicleModel& model, const VehicleState& state, const VecX& qdd,
                         const BaseWrench& external, DynamicsInfo* info);

// The wrench the arm (every body but the base) exerts on the base when the
// base moves with angular acceleration `angular_acceleration` (B) and its
// origin with `acceleration` (classical, in W), the joints with qdd; gravity
// is the model's. For hand checks and diagnostics.
BaseWrench ArmWrenchOnBase(const VehicleModel& model, const VehicleState& state, const VecX& qdd,
                           const Vec3& acceleration, const Vec3& angular_acceleration);

// The state derivative as a flat vector (layout of PackState), filling `info` if given.
VecX StateDerivative(const VehicleModel& model, const VecX& x, const ControlInput& u, DynamicsInfo* info = nullptr);

// Flat layout [p(3), q_wxyz(4), v(3), omega(3), joints(n), joint_rates(n), thrusts(4)].
VecX PackState(const VehicleState& state);
VehicleState UnpackState(const VecX& x, int num_actuated);

// One classical Runge-Kutta step of length h with `u` held; renormalises the attitude.
VehicleState Rk4Step(const VehicleModel& model, const VehicleState& state, const ControlInput& u, double h);

// Whole-vehicle quantities at a state, in W.
struct VehicleMomentum {
  Vec3 center_of_mass = Vec3::Zero();  // p_WC, m
  Vec3 com_velocity = Vec3::Zero();    // m/s
  Vec3 linear = Vec3::Zero();          // kg m/s
  Vec3 angular = Vec3::Zero();         // about the centre of mass, kg m^2/s
  double kinetic_energy = 0.0;         // J
  double potential_energy = 0.0;       // J, zero at z = 0
};
VehicleMomentum ComputeMomentum(const VehicleModel& model, const VehicleState& state);

}  // namespace quadhand::sim
