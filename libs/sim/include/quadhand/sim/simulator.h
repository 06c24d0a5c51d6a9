// The simulation loop: measure (with optional seeded noise) -> controller ->
// mixer -> RK4 step of the vehicle, at the configured step. Setpoints come
// from the caller, so the offline mode (TrackPlan, a plan file) and a future
// online mode (setpoints over UDP) share the same Step().
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/sim/controller.h"
#include "quadhand/sim/dynamics.h"
#include "quadhand/sim/plan_io.h"
#include "quadhand/sim/vehicle_model.h"

namespace quadhand::sim {

// Most seconds TrackPlan() simulates (settle plus the plan's span): an hour,
// far beyond any flight a plan describes, so that a bad input cannot run for days.
constexpr double kMaxSimulatedSeconds = 3600.0;

// The arm pose the controller's inertia is taken at: controller.nominal_joints,
// or the middle of each joint's limits.
VecX NominalJoints(const VehicleModel& model);

class Simulator {
 public:
  // The controller's mass and inertia are the configured ones, or (when 0)
  // the vehicle's total mass and its inertia tensor about the CoG at NominalJoints().
  Simulator(VehicleModel model, uint64_t seed);

  const VehicleModel& model() const { return model_; }
  const GeometricController& controller() const { return controller_; }

  // Attaches a payload of `mass` kg at `offset` (m, in the frame of the
  // configuration's payload.link, the tool) or, with mass 0, removes it: a
  // gripper closing on an object or letting it go. The vehicle's dynamics
  // change at once; the controller's mass changes by the payload's (known
  // from the task, as a hover-thrust estimate would learn it), its inertia
  // does not, and the payload's weight moment about the base (at the
  // measured attitude and joints) is fed forward to its torque from then
  // on. A payload of the configuration is not known to the controller.
  // With faults.payload_mass_factor the object's real mass is that times
  // `mass`; the controller still learns `mass` (what the task declared).
  // Fails on a bad mass or offset, or a robot without that link.
  core::Status SetPayload(double mass, const Vec3& offset);

  // Sets the state and time, clears the controller's integrators.
  void Reset(const VehicleState& state, double time = 0.0);

  // Advances by h seconds (0 < h <= the configured step; 0: one full step)
  // holding `setpoint`: the controller runs once at the start of the step.
  void Step(const Setpoint& setpoint, double h = 0.0);

  double time() const { return time_; }
  double step() const { return model_.config().step; }
  const VehicleState& state() const { return state_; }
  // The autopilot's state estimate: the true state with faults.estimate's
  // position error (and its drift's velocity) added. It is what the
  // controller flies on (with the noise) and what telemetry reports.
  VehicleState Estimate() const;
  // Its position alone (what the per-step loop needs, without copying the joints).
  Vec3 EstimatedPosition() const;
  // The air's velocity over the last step (faults.wind), world.
  const Vec3& wind() const { return input_.wind; }
  const ControlInput& last_input() const { return input_; }
  const ControllerOutput& last_output() const { return output_; }
  // The dynamics at the current state under the last input (accelerations,
  // arm wrench, rotor wrench).
  DynamicsInfo CurrentDynamics() const;

 private:
  Measurement Measure();

  VehicleModel model_;
  GeometricController controller_;
  // The link carrying a payload attached by SetPayload, whose moment is fed
  // forward; -1: none (nothing held, or only the configuration's payload).
  int known_load_link_ = -1;
  std::mt19937_64 rng_;
  // The faults' own draws (gusts), so that a configuration without faults
  // draws the same noise as before they existed.
  std::mt19937_64 fault_rng_;
  DrydenGusts gusts_;
  double declared_payload_ = 0.0;  // what the controller was told is held
  bool stalled_ = false;           // faults.servo's joint has stalled
  double stalled_position_ = 0.0;
  VehicleState state_;
  double time_ = 0.0;
  ControlInput input_;
  ControllerOutput output_;
};


// One recorded sample of a flight: the flown state in the plan's columns and diagnostics.
struct FlownSample {
  PlanRow flown;                        // t, base state (acceleration from the dynamics), Hopf yaw, joints
  Vec3 position_error = Vec3::Zero();   // flown - planned, W, m
  double yaw_error = 0.0;               // wrapped, rad
  Vec3 center_of_mass = Vec3::Zero();   // whole vehicle, base frame, m
  BaseWrench arm_wrench;                // arm (battery, payload) on the base, base frame
  double thrust = 0.0;                  // sum of rotor thrusts, N
};

// The simulator's state now as a recorded sample, with its errors from the
// planned position and yaw at this time.
FlownSample RecordFlown(const Simulator& simulator, const Vec3& planned_position, double planned_yaw);

struct TrackOptions {
  // Seconds of hovering at the plan's first setpoint (velocities zeroed)
  // before t0, not recorded, so integrators settle; meant for plans that start at rest.
  // At most kMaxSimulatedSeconds.
  double settle = 0.0;
};

struct TrackingErrorStats {
  double mean = 0.0, median = 0.0, p95 = 0.0, max = 0.0, rms = 0.0;  // of |position error|, m
};

struct TrackResult {
  std::vector<FlownSample> samples;  // one per plan row, at the row's time
  TrackingErrorStats error;
  double simulated_s = 0.0;          // including settling
};

// Flies `plan` from its first row's state (at rest in body rate; thrusts that
// hold the vehicle) and records one sample per plan row. Fails if the plan's
// joints do not match the model.
core::Result<TrackResult> TrackPlan(Simulator* simulator, const Plan& plan, const TrackOptions& options = {});

TrackingErrorStats ComputeErrorStats(const std::vector<FlownSample>& samples);

// The flown file: the plan columns (with `gripper` when the samples have
// it), then err_x,err_y,err_z,err_pos,err_yaw, cog_x,cog_y,cog_z,arm_fx,
// arm_fy,arm_fz,arm_tx,arm_ty,arm_tz,thrust.
std::string FlownCsv(const std::vector<FlownSample>& samples, const std::vector<std::string>& joint_names);

}  // namespace quadhand::sim
