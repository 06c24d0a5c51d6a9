// Faults the simulator injects: the `faults:` key of its configuration
// (docs/sim.md, "Faults"). Each is off by default; the random ones draw from
// the simulator's seed. They act on the vehicle's physics (wind, a weak
// motor, a slow or stalled servo, a payload heavier than declared) or on its
// state estimate (a position jump or drift, which the autopilot then flies
// on; a frozen or NaN telemetry stream, which only the link sees). The
// simulator's own record keeps the true states, so a flight is always
// judged on what the vehicle really did.
#pragma once

#include <random>
#include <string>

#include "quadhand/core/types.h"

namespace quadhand::sim {

// Steady wind plus Dryden turbulence (MIL-F-8785C, low altitude), acting by
// quadratic drag on the base and on each arm link.
struct WindFault {
  Vec3 steady = Vec3::Zero();   // m/s, world (ENU)
  double gust_intensity = 0.0;  // sigma of the horizontal gust components, m/s (0: no gusts)
  double altitude = 2.0;        // m above ground: the scale lengths and the vertical intensity
  double min_airspeed = 1.0;    // m/s: the filters' speed floor (a hovering vehicle has none)
  double base_drag_area = 0.03;       // Cd A of the base (airframe, battery, rotors), m^2
  double arm_drag_coefficient = 1.0;  // Cd of each arm link, on its collision box's mean face area
  double air_density = 1.225;         // kg/m^3
  bool active() const { return steady.squaredNorm() > 0.0 || gust_intensity > 0.0; }
};

// One rotor delivering a fraction of the thrust its motor is commanded
// (and so of its maximum); the controller and the mixer do not know.
struct MotorFault {
  int rotor = -1;  // 0..3 in the mixer's order (front-left, rear-left, rear-right, front-right); -1: none
  double thrust_factor = 1.0;
};

// Slower servos (extra velocity-loop lag, every joint) and one that stalls:
// from `stall_time` on, joint `stall_joint` stays where it is.
struct ServoFault {
  double extra_lag = 0.0;  // s
  int stall_joint = -1;    // actuated joint index; -1: none
  double stall_time = 0.0;  // s of simulated time
};

// Faults of the state estimate. A jump and a drift move the estimate the
// autopilot flies on (and reports): the vehicle really moves by minus
// them. A freeze repeats the last telemetry sample, time stamp included,
// and NaN fills the telemetry's fields: the link sees them, the
// autopilot's own estimator does not (it would reject them).
struct EstimateFault {
  double jump_time = -1.0;     // s; < 0: none
  Vec3 jump = Vec3::Zero();    // m, world, added to the estimate from jump_time on
  Vec3 drift = Vec3::Zero();   // m/s, world, the estimate's error growing from t = 0
  double freeze_time = -1.0, freeze_duration = 0.0;  // s
  double nan_time = -1.0, nan_duration = 0.0;        // s
  bool FrozenAt(double t) const { return freeze_time >= 0.0 && t >= freeze_time && t < freeze_time + freeze_duration; }
  bool NanAt(double t) const { return nan_time >= 0.0 && t >= nan_time && t < nan_time + nan_duration; }
  // What the estimate's position is off by at time t.
  Vec3 PositionErrorAt(double t) const {
    return drift * std::max(0.0, t) + (jump_time >= 0.0 && t >= jump_time ? jump : Vec3::Zero());
  }
};

struct FaultConfig {
  WindFault wind;
  MotorFault motor;
  ServoFault servo;
  // The mass a grasped object really has, over what the gripper command
  // declares (the task's mass, which the controller is told).
  double payload_mass_factor = 1.0;
  EstimateFault estimate;

  // Checks ranges against `num_actuated` joints; `why` names the key.
  bool IsValid(int num_actuated, std::string* why) const;
};

// Dryden gusts (MIL-F-8785C, low altitude), world frame: a longitudinal
// component along the steady wind (world x without one) with the
// first-order form, a lateral and a vertical one with the second-order form
// (1 + sqrt(3) T s) / (1 + T s)^2, T = L / V. The scale lengths follow the
// altitude h (in feet in the standard): L_w = h, L_u = L_v = h / (0.177 +
// 0.000823 h)^1.2; the vertical intensity is the horizontal one times
// (0.177 + 0.000823 h)^0.4. Each filter's gain makes its stationary
// standard deviation exactly its intensity. V is the airspeed, at least
// min_airspeed. Integrated by Euler-Maruyama (the filters' time constants
// are tenths of a second or more, the step a millisecond), from the
// stationary distribution at the first step's airspeed.
class DrydenGusts {
 public:
  DrydenGusts() = default;
  explicit DrydenGusts(const WindFault& wind);
  // Advances by dt at airspeed `airspeed` and returns the gust velocity.
  Vec3 Step(double dt, double airspeed, std::mt19937_64* rng);
  Vec3 current() const { return current_; }
  double vertical_intensity() const { return sigma_w_; }
  double longitudinal_scale() const { return length_uv_; }
  double vertical_scale() const { return length_w_; }

 private:
  WindFault wind_;
  double sigma_uv_ = 0.0, sigma_w_ = 0.0, length_uv_ = 1.0, length_w_ = 1.0;
  Vec3 along_ = Vec3::UnitX(), across_ = Vec3::UnitY();
  bool started_ = false;       // the states are drawn at the first step
  double u_ = 0.0;             // longitudinal state
  double v1_ = 0.0, v2_ = 0.0;  // lateral filter states
  double w1_ = 0.0, w2_ = 0.0;  // vertical filter states
  Vec3 current_ = Vec3::Zero();
};

}  // namespace quadhand::sim
