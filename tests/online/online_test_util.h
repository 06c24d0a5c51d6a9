// Closed-loop harnesses of the online controller tests: the controller flies
// the simulated vehicle in-process, faster than real time, on a simulated
// clock. After every Tick the test waits for the planning worker, so a plan
// or replan is ready at the next tick whatever the machine's load: the runs
// are deterministic (the plans arrive "instantly" in simulated time and are
// spliced at their splice times).
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>

#include <gtest/gtest.h>

#include "quadhand/core/text.h"
#include "quadhand/online/controller.h"
#include "quadhand/online/flight_log.h"
#include "quadhand/online/mavlink_bridge.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/sim/autopilot.h"
#include "quadhand/sim/config.h"
#include "quadhand/sim/simulator.h"
#include "quadhand/solvers/lbfgs_solver.h"
#include "support/window_cup_scene.h"

namespace quadhand::online::testing {

using quadhand::testing::WindowCup;

inline sim::SimConfig SimConfig() {
  auto config = sim::LoadSimConfig(std::string(QUADHAND_SOURCE_DIR) + "/data/sim/quadhand_sim.yaml");
  EXPECT_TRUE(config.ok()) << config.status().message();
  return config.ok() ? *config : sim::SimConfig{};
}

// The bundled vehicle, with `faults` (none by default).
inline sim::VehicleModel VehicleModel(const sim::FaultConfig& faults = {}) {
  sim::SimConfig config = SimConfig();
  config.faults = faults;
  auto model = sim::VehicleModel::Create(WindowCup().robot(), config);
  EXPECT_TRUE(model.ok()) << model.status().message();
  return *model;
}

inline const solvers::LbfgsSolver& Solver() {
  static const solvers::LbfgsSolver solver;
  return solver;
}

// The planner on the default task; solves limited by iterations only (not
// wall time), so that results do not depend on the machine's load.
inline PlanningSetup Setup() {
  PlanningSetup setup{WindowCup().Scene(), &WindowCup().task, planner::DefaultPlannerOptions(),
                      planner::DefaultReplanOptions(), &Solver()};
  setup.plan_options.solver.max_time_seconds = 60.0;
  setup.replan_options.solver.max_time_seconds = 60.0;
  return setup;
}

inline std::unique_ptr<OnlineController> MakeController(const OnlineOptions& options = {}) {
  auto controller = OnlineController::Create(Setup(), options);
  EXPECT_TRUE(controller.ok()) << controller.status().message();
  return std::move(*controller);
}

// A vehicle without a link answers the controller's TIMESYNC request at
// once, its clock the test's: no latency.
inline void AnswerTimesync(OnlineController* controller, const ControllerOutput& out, double t) {
  if (out.timesync_request) controller->OnTimesync(t, std::max<int64_t>(1, std::llround(t * 1e9)), *out.timesync_request);
}

inline sim::Setpoint ToSim(const Setpoint& s) {
  sim::Setpoint out;
  out.position = s.position;
  out.velocity = s.velocity;
  out.acceleration = s.acceleration;
  out.yaw = s.yaw;
  out.yaw_rate = s.yaw_rate;
  out.joints = s.joints;
  out.joint_rates = s.joint_rates;
  return out;
}

// The vehicle without a link: the simulator, a vehicle that accepts every
// command at once, 50 Hz telemetry, 1 Hz heartbeats. Hooks let a test push,
// move or silence the vehicle.
class DirectFlight {
 public:
  // From `start`'s start state (the default task's when null; its robot's
  // joints must be the bundled robot's).
  explicit DirectFlight(OnlineController* controller, const sim::FaultConfig& faults = {},
                        const planner::Task* start = nullptr)
      : controller_(controller), sim_(VehicleModel(faults), 11) {
    const planner::Task& task = start != nullptr ? *start : WindowCup().task;
    sim::VehicleState state = sim::VehicleState::AtRest(sim_.model(), task.start.position, task.start.joints);
    state.attitude = Quat(Eigen::AngleAxisd(task.start.yaw, Vec3::UnitZ()));
    sim_.Reset(state, 0.0);
    hold_ = sim::Setpoint{};
    hold_.position = state.position;
    hold_.yaw = task.start.yaw;
    hold_.joints = state.joints;
    hold_.joint_rates = VecX::Zero(state.joints.size());
    current_ = hold_;
  }

  // Runs 50 Hz periods until `until` (s) or the controller finishes; `hook`
  // runs before each period with the time (and may change the simulator).
  void Run(double until, const std::function<void(double, sim::Simulator*)>& hook = nullptr) {
    while (t_ < until - 1e-9 && !controller_->finished()) {
      if (hook) hook(t_, &sim_);
      const sim::VehicleState& s = sim_.state();
      if (!silent_) {
        controller_->OnPosition(t_, s.position, s.velocity);
        controller_->OnAttitude(t_, s.attitude, s.body_rate);
        controller_->OnJoints(t_, s.joints, s.joint_rates);
        if (report_goals_) controller_->OnJointGoals(t_, current_.joints);  // the servos' goals: the setpoint flown
        if (period_ % 50 == 0) controller_->OnHeartbeat(t_, armed_, offboard_);
      }
      const ControllerOutput out = controller_->Tick(t_);
      for (const std::string& e : out.events) events_.push_back(core::Format("[%6.2f s] ", t_) + e);
      controller_->WaitUntilIdle();
      if (!silent_ && !uplink_lost_) AnswerTimesync(controller_, out, t_);
      for (const CommandRequest& c : out.commands) {
        if (c.command == Command::kSetOffboardMode) offboard_ = true;
        else armed_ = true;
        controller_->OnCommandAck(t_, c.command, AckResult::kAccepted);
      }
      if (out.setpoint && !uplink_lost_) {
        if (!first_setpoint_time_) first_setpoint_time_ = t_;
        if (offboard_ && armed_) current_ = ToSim(*out.setpoint);
        last_stream_time_ = t_;
      } else if (offboard_ && t_ - last_stream_time_ > 0.5) {
        current_ = hold_;  // offboard loss: the vehicle holds
      }
      if (!silent_) log_.Record(controller_->measured(), out.setpoint, out.phase);
      const double end = t_ + 0.02;
      while (sim_.time() < end - 1e-9) sim_.Step(current_, std::min(sim_.step(), end - sim_.time()));
      t_ = end;
      ++period_;
    }
  }

  double time() const { return t_; }
  // The controller's events, each with its time: for a failure's message.
  std::string Events() const {
    std::string all;
    for (const std::string& e : events_) all += e + "\n";
    return all;
  }
  void set_silent(bool silent) { silent_ = silent; }
  // Nothing the controller sends reaches the vehicle (setpoints, TIMESYNC
  // requests); its states still come.
  void set_uplink_lost(bool lost) { uplink_lost_ = lost; }
  // Whether the vehicle reports its servos' goals (JOINT_GOAL).
  void set_report_goals(bool report) { report_goals_ = report; }
  const sim::Simulator& simulator() const { return sim_; }
  const FlightLog& log() const { return log_; }
  std::optional<double> first_setpoint_time() const { return first_setpoint_time_; }

 private:
  OnlineController* controller_;
  sim::Simulator sim_;
  std::vector<std::string> events_;
  sim::Setpoint hold_, current_;
  bool armed_ = false, offboard_ = false, silent_ = false, uplink_lost_ = false, report_goals_ = true;
  double t_ = 0.0, last_stream_time_ = -1e9;
  long period_ = 0;
  std::optional<double> first_setpoint_time_;
  FlightLog log_;
};

}  // namespace quadhand::online::testing
