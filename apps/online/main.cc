// quadhand-online: flies a task on a vehicle over MAVLink (UDP). Reads the
// vehicle's state, plans from it to the task's goal (planner library), streams
// position and joint setpoints at --rate after PX4's offboard handshake, and
// replans (warm-started) when the tracking error exceeds a threshold.
// The logic is online::OnlineController (libs/online); this file owns the
// socket, the clock and the output. docs/online.md.
//
// Exit codes: 0 the plan was flown to its end; 1 planning failed (the vehicle
// was left holding at the last safe setpoint); 2 bad input; 3 the vehicle
// went silent (or never answered); 4 the vehicle refused or left OFFBOARD or
// arming; 5 interrupted (SIGINT/SIGTERM, --max-duration) before the end;
// 6 the flown path, judged on the vehicle's own time-stamped states against
// the exact meshes, did not keep the safety distance (less
// --clearance-tolerance), or was not seen densely enough to be judged.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "app_options.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/core/file_util.h"
#include "quadhand/core/log.h"
#include "quadhand/core/text.h"
#include "quadhand/link/connection.h"
#include "quadhand/link/frames.h"
#include "quadhand/link/sensor_stream.h"
#include "quadhand/link/udp.h"
#include "quadhand/explore/local_planner.h"
#include "quadhand/online/controller.h"
#include "quadhand/online/flight_log.h"
#include "quadhand/online/mavlink_bridge.h"
#include "quadhand/opt/solver_registry.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/mission_plan.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/planner/task.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/solvers/builtin_solvers.h"

namespace {

using namespace quadhand;
using Clock = std::chrono::steady_clock;

constexpr int kExitSuccess = 0;
constexpr int kExitPlanFailed = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitVehicleLost = 3;
constexpr int kExitRefused = 4;
constexpr int kExitInterrupted = 5;
constexpr int kExitClearanceLost = 6;
constexpr int kExitAborted = 7;

std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }

int Fail(const std::string& message) {
  core::PrintError("quadhand-online", message);
  return kExitBadInput;
}

double Quantile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double x = p * static_cast<double>(v.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(x));
  const size_t j = std::min(i + 1, v.size() - 1);
  return v[i] + (x - static_cast<double>(i)) * (v[j] - v[i]);
}

// The setpoint as it goes on the wire (NED), for --dry-run.
void PrintWireSetpoint(double t, const online::Setpoint& s) {
  const link::SetPositionTargetLocalNed m = online::ToPositionTarget(s, t, online::LinkTargets{});
  std::printf("  t=%6.3f  NED p=(%7.3f %7.3f %7.3f) v=(%6.3f %6.3f %6.3f) a=(%6.3f %6.3f %6.3f) yaw=%6.3f "
              "yaw_rate=%6.3f  JOINT_SP q=(",
              t, m.x, m.y, m.z, m.vx, m.vy, m.vz, m.afx, m.afy, m.afz, m.yaw, m.yaw_rate);
  for (int k = 0; k < s.joints.size(); ++k) std::printf("%s%.3f", k ? " " : "", s.joints[k]);
  std::printf(") qd=(");
  for (int k = 0; k < s.joint_rates.size(); ++k) std::printf("%s%.3f", k ? " " : "", s.joint_rates[k]);
  std::printf(")\n");
}

// The --log file as the flight goes (core::GrowingFile): the header, then
// every second the rows recorded since (all but the newest, which a state at
// the same time may still replace); at the end the rest, renamed to LOG.
class GrowingLog {
 public:
  GrowingLog(std::string path, std::vector<std::string> joints) : file_(std::move(path)), joints_(std::move(joints)) {}
  void Flush(const online::FlightLog& log) {
    if (log.samples().size() >= 2) Write(log, log.samples().size() - 1);
  }
  core::Status Finish(const online::FlightLog& log) {
    Write(log, log.samples().size());
    return file_.Finish();
  }

 private:
  void Write(const online::FlightLog& log, size_t end) {
    std::string text = header_written_ ? std::string() : log.CsvHeader(joints_);
    header_written_ = true;
    if (end > written_) text += log.CsvRows(joints_, written_, end);
    written_ = std::max(written_, end);
    file_.Append(text);
  }

  core::GrowingFile file_;
  std::vector<std::string> joints_;
  bool header_written_ = false;
  size_t written_ = 0;
};

int DryRun(const planner::PlanningContext& context, const online::PlanningSetup& setup, double rate,
           double hold_time) {
  const auto begin = Clock::now();
  auto result =
      planner::PlanTask(context, context.task(), 0, setup.plan_options, *setup.solver, setup.mission_phases);
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - begin).count();
  if (!result.ok()) return Fail(result.status().message());
  if (!result->success) {
    std::printf("FAILED: %s (%s) after %.1f ms: nothing would be streamed\n", planner::PlanStatusName(result->status),
                result->message.c_str(), ms);
    return kExitPlanFailed;
  }
  const planner::WholeBodyTrajectory& trajectory = *result->trajectory;
  const double period = 1.0 / rate;
  const long count = static_cast<long>(std::floor(trajectory.duration() / period + 1e-9)) + 1;
  double max_speed = 0.0;
  for (long k = 0; k < count; ++k) max_speed = std::max(max_speed, trajectory.Sample(k * period).velocity.norm());
  std::printf("dry run: plan from the task's start state, %.2f s long, planned in %.1f ms (min clearance %.4f m)\n",
              trajectory.duration(), ms, result->post_check.min_clearance_exact);
  std::printf("would stream %ld SET_POSITION_TARGET_LOCAL_NED + JOINT_SP pairs at %.1f Hz (type_mask 0, "
              "MAV_FRAME_LOCAL_NED) after >= %.1f s of hold, OFFBOARD and arming; peak speed %.2f m/s\n",
              count, rate, hold_time, max_speed);
  if (context.moving_scene() != nullptr) {
    std::printf("the target moves: this plan meets it as the task's goal.tool.motion moves it; in flight every plan is "
                "made against its measurements (LANDING_TARGET) instead\n");
  }
  const std::vector<planner::MissionStep>& mission = context.task().mission;
  for (size_t i = 0; !planner::PlansAsGoal(context.task()) && i < mission.size() && i < result->steps.size(); ++i) {
    const planner::MissionStep& step = mission[i];
    if (!planner::GripperActsAt(step)) continue;
    std::printf("would command the gripper (MAV_CMD_DO_GRIPPER, %s) from plan time %.2f s, once the tool is within "
                "--gripper-tolerance of its pose: %s\n",
                step.kind == planner::StepKind::kGrasp ? "grab" : "release", result->steps[i].start_s,
                planner::StepName(mission, i).c_str());
  }
  std::printf("first setpoints (plan time):\n");
  for (long k = 0; k < std::min<long>(count, 5); ++k) {
    PrintWireSetpoint(k * period, online::FromSample(trajectory.Sample(k * period)));
  }
  std::printf("last setpoint:\n");
  PrintWireSetpoint(trajectory.duration(), online::FromSample(trajectory.Sample(trajectory.duration())));
  return kExitSuccess;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "quadhand-online: fly a task (YAML) on a vehicle over MAVLink 2 / UDP (docs/online.md).\n"
      "Reads HEARTBEAT, LOCAL_POSITION_NED, ATTITUDE_QUATERNION and DEBUG_FLOAT_ARRAY 'JOINTS'; plans from the\n"
      "measured state to the task's goal; streams a hold for --hold-time s, requests OFFBOARD and arming, then\n"
      "streams SET_POSITION_TARGET_LOCAL_NED and DEBUG_FLOAT_ARRAY 'JOINT_SP' at --rate, replanning when the\n"
      "tracking error exceeds --replan-threshold.\n"
      "Exit codes: 0 flown to the end of the plan; 1 planning failed (vehicle left holding); 2 bad input;\n"
      "3 vehicle silent for --vehicle-timeout; 4 vehicle refused or left OFFBOARD/arming; 5 interrupted;\n"
      "6 the flown path (the vehicle's time-stamped states) did not keep the safety distance, or was not seen."};
  std::string task_path, vehicle_url, bind_url = "udp://0.0.0.0:0", key_path, log_path;
  double rate = 50.0, max_duration = 0.0;
  int target_system = 1, target_component = 1, system_id = 1, component_id = 191;
  bool require_signing = false, dry_run = false, quiet = false, no_replan = false, no_timesync = false;
  // The controller's options are bound to the command line directly; their
  // defaults are the command line's.
  online::OnlineOptions options;
  app.add_option("task", task_path, "Task file (YAML, docs/task_format.md)")->required();
  app.add_option("--vehicle", vehicle_url, "The vehicle's MAVLink address, udp://HOST:PORT (required unless --dry-run)");
  app.add_option("--bind", bind_url, "Local address to receive on, udp://ADDR:PORT (port 0: any free port)")
      ->capture_default_str();
  app.add_option("--rate", rate, "Setpoint rate, Hz (1 to 500)")->capture_default_str();
  std::string planner_config_path;
  app.add_option("--planner-config", planner_config_path,
                 "Planner configuration (YAML, docs/configuration.md): the planner, replanner, front end and\n"
                 "representation options; keys left out keep their defaults");
  int threads = -1;
  app.add_option("--threads", threads,
                 "Workers for the cost's and the post-check's samples (0: one per core; default: the\n"
                 "configuration's cost.threads and post_check.threads, 0). On a computer busy with other work,\n"
                 "fewer than its cores plan faster (docs/benchmark.md); the plans do not depend on it")
      ->check(CLI::Range(0, 256));
  app.add_option("--signing-key", key_path, "MAVLink 2 signing key file (64 hex digits or 32 raw bytes): signs what is "
                                            "sent, verifies what is received");
  app.add_flag("--require-signing", require_signing,
               "Drop unsigned, wrongly signed and replayed frames (needs --signing-key)");
  app.add_option("--log", log_path, "Write the flight (CSV): measured states in the plan file's columns, then the "
                                    "setpoints sent (docs/online.md); written as it flies to LOG.partial (every\n"
                                    "second), renamed to LOG at the end");
  app.add_flag("--dry-run", dry_run,
               "No vehicle: plan from the task's start state and print what would be streamed (exit 0 or 1)");
  app.add_option("--vehicle-timeout", options.vehicle_timeout,
                 "Seconds without LOCAL_POSITION_NED before streaming stops and the program exits with 3")
      ->capture_default_str();
  app.add_option("--ack-timeout", options.ack_timeout,
                 "Seconds to wait for each COMMAND_ACK (OFFBOARD, arming, the gripper) before sending the command "
                 "again; in (0, 10]")
      ->capture_default_str();
  app.add_option("--command-attempts", options.max_command_attempts,
                 "Sends of each command before giving up (the handshake: REFUSED, exit 4; a mission's gripper: holding); "
                 "a lossy uplink may need more; in [1, 100]")
      ->capture_default_str();
  app.add_option("--outage-timeout", options.outage_timeout,
                 "While flying a goal or holding a mission for the link, seconds of silence waited for as an outage "
                 "(holding; the vehicle re-engaged after its failsafe) before exit 3, and the longest a mission's "
                 "link hold waits to resume; in [--vehicle-timeout, 600]")
      ->capture_default_str();
  app.add_option("--resume-tolerance", options.resume_tolerance,
                 "A mission's link hold resumes along its plan once the vehicle's base and tool are within this "
                 "(m) of the plan's stop, at rest; in (0, 0.1]")
      ->capture_default_str();
  app.add_option("--replan-threshold", options.replan_threshold, "3-D tracking error (m) that triggers a warm-started replan")
      ->capture_default_str();
  app.add_option("--replan-period", options.replan_period,
                 "Seconds between replans while on track (continuous replanning; 0: only above the threshold)")
      ->capture_default_str();
  app.add_option("--periodic-max-velocity-error", options.periodic_max_velocity_error,
                 "Periodic replans wait while the vehicle's velocity is further than this (m/s) from its reference's "
                 "(a push being damped: not on track)")
      ->capture_default_str();
  app.add_flag("--no-replan", no_replan, "Never replan (fly the first plan only)");
  app.add_option("--hold-time", options.hold_time, "Seconds of hold setpoints before OFFBOARD is requested (>= 1, PX4's rule)")
      ->capture_default_str();
  app.add_option("--arrival-hold", options.arrival_hold, "Least seconds of holding at the goal after the plan ends")
      ->capture_default_str();
  app.add_option("--arrival-tolerance", options.arrival_tolerance,
                 "After --arrival-hold, hold on until the tool is this close (m) to its goal (no tool goal: the base\n"
                 "to the plan's end) and the base slower than --arrival-settle-speed")
      ->capture_default_str();
  app.add_option("--flight-margin", options.flight_margin,
                 "Plans flown aim this much (m) farther from the scene than the planner's collision_margin: the\n"
                 "flown path strays from the plan by several mm near obstacles")
      ->capture_default_str();
  app.add_option("--gripper-tolerance", options.gripper_tolerance,
                 "A mission's gripper acts once the tool is this close (m) to its planned pose in the grasp or\n"
                 "release step; not there by the middle of the step: the mission ends holding")
      ->capture_default_str();
  app.add_option("--junction-tolerance", options.junction_tolerance,
                 "A mission's plan waits at each junction of its legs (at rest) until the tool is this close (m) to\n"
                 "its planned pose and the base slower than --arrival-settle-speed")
      ->capture_default_str();
  app.add_option("--junction-timeout", options.junction_timeout,
                 "Most seconds of waiting at one junction; not settled by then: the mission ends holding there")
      ->capture_default_str();
  app.add_option("--tool-trim", options.tool_trim,
                 "Waiting at a mission's junction, shift the base's setpoints by up to this much (m) to bring a tool\n"
                 "that a steady force (wind, a payload) holds off its pose there, where the next leg so shifted\n"
                 "keeps the clearance; kept over that leg (0: no shift)")
      ->capture_default_str();
  app.add_option("--setpoint-lead", options.setpoint_lead,
                 "Sample each setpoint this many seconds ahead of its sending (the autopilot flies it until the\n"
                 "next comes), at most 0.1; negative: half the measured streaming period")
      ->capture_default_str();
  app.add_option("--arrival-settle-speed", options.arrival_settle_speed,
                 "Base speed (m/s) below which the vehicle counts as settled at the goal")
      ->capture_default_str();
  app.add_option("--arrival-timeout", options.arrival_timeout,
                 "Most seconds of holding at the goal, settled or not (equal to --arrival-hold: a fixed hold)")
      ->capture_default_str();
  app.add_option("--max-duration", max_duration, "Stop streaming and exit after this many seconds (0: no limit)")
      ->capture_default_str();
  app.add_flag("--no-timesync", no_timesync,
               "Fly without TIMESYNC: a state's arrival time is taken as its time, the latency is unknown and the\n"
               "link budget is off (only for a vehicle that does not answer TIMESYNC, over a fast link)");
  app.add_option("--max-state-age", options.max_state_age,
                 "Replan only from a state at most this old (s, the vehicle's stamp to now), in (0, 5]")
      ->capture_default_str();
  app.add_option("--link-budget", options.link_budget,
                 "Fly at most link-budget safety distances in the time the vehicle is unseen (the newest state's\n"
                 "age + the uplink latency): plans are slowed down to it, and a vehicle much faster than it brakes\n"
                 "along the plan and holds until the link is good, in (0, 1000]")
      ->capture_default_str();
  app.add_option("--max-blind-time", options.max_blind_time,
                 "Brake along the plan and hold when no state is fresher than this (age + uplink, s), in (0, 60]")
      ->capture_default_str();
  app.add_option("--min-link-speed", options.min_link_speed,
                 "Below this speed (m/s) allowed by the link, wait instead of planning, in (0, 10]")
      ->capture_default_str();
  app.add_option("--clearance-tolerance", options.clearance_tolerance,
                 "Exit 0 needs the flown path to keep the safety distance less this (m), in [0, 0.05]")
      ->capture_default_str();
  app.add_option("--max-judged-gap", options.max_judged_gap,
                 "Exit 0 needs a state at least every this many seconds while flying, in (0, 5]")
      ->capture_default_str();
  app.add_flag("--no-abort{false}", options.abort_near_goal,
               "Do not abort near the goal: by default a state closer to the scene than the safety distance less "
               "--clearance-tolerance on the insertion or at the goal makes the vehicle retreat along the plan to "
               "the insertion's start (exit 7)");
  app.add_option("--innovation-gate", options.innovation_gate,
                 "A position estimate this far (m, plus what the motion explains) from its prediction is a jump; "
                 "in (0, 1]")
      ->capture_default_str();
  app.add_flag("--follow-estimate-jumps{false}", options.shift_setpoints_on_jump,
               "Let the vehicle fly an estimate jump: by default every setpoint after a jump is shifted by it, so "
               "that the vehicle stays where it was and the flight goes on in the frame it began in (as PX4 does on "
               "an EKF2 reset); with this flag exit 0 also needs the flown clearance less the jumps to hold");
  // A moving target (goal.tool.motion), measured over LANDING_TARGET.
  double target_acceleration_noise = options.target_tracker.acceleration_noise;
  app.add_option("--target-acceleration-noise", target_acceleration_noise,
                 "A moving target: its filter's white acceleration, m^2/s^3 (and rad^2/s^3 for its heading); the "
                 "default suits a belt or turntable running at its speed, 0.01 a cup pushed by hand")
      ->capture_default_str();
  app.add_option("--target-noise", options.target_tracker.position_noise,
                 "A moving target: its measurements' position noise, m (one sigma per axis)")
      ->capture_default_str();
  app.add_option("--target-replan-threshold", options.target_replan_threshold,
                 "A moving target: replan when its prediction at the arrival moves by more than this, m")
      ->capture_default_str();
  app.add_option("--target-timeout", options.target_timeout,
                 "A moving target: seconds without a measurement, while flying, after which it is lost (exit 1)")
      ->capture_default_str();
  app.add_option("--target-tolerance", options.target_arrival_tolerance,
                 "A moving target: the tool within this many metres of it at the arrival counts as settled")
      ->capture_default_str();
  app.add_option("--target-system", target_system, "The vehicle's MAVLink system id")->capture_default_str();
  app.add_option("--target-component", target_component, "The vehicle's MAVLink component id")->capture_default_str();
  app.add_option("--system-id", system_id, "Our MAVLink system id")->capture_default_str();
  app.add_option("--component-id", component_id, "Our MAVLink component id (191: MAV_COMP_ID_ONBOARD_COMPUTER)")
      ->capture_default_str();
  // Flying on a sensor (docs/perception.md, "Flying online on the sensor").
  bool perception_mode = false;
  std::string frames_url = "udp://127.0.0.1:14600";
  online::PerceptionSetup perception;
  explore::LocalPlannerOptions local_options;
  bool no_prior = false;
  app.add_flag("--perception", perception_mode,
               "Plan only from the sensor frames arriving on --frames; the task's scene, when it has one, is a prior "
               "map that adds obstacles where the sensor has seen nothing and frees no space (docs/perception.md, "
               "\"A prior map\"); the flight is judged against what the sensor saw and the prior");
  app.add_flag("--no-prior", no_prior, "--perception: leave the task's scene out (a flight into the unknown)");
  app.add_option("--frames", frames_url, "--perception: receive sensor frames here (docs/link.md), udp://ADDR:PORT")
      ->capture_default_str();
  app.add_option("--map-resolution", perception.map.resolution, "--perception: the rolling map's voxel edge, m")
      ->capture_default_str();
  app.add_option("--map-threads", perception.map.ray_threads, "--perception: threads that walk each frame's rays into the map")
      ->capture_default_str();
  app.add_option("--map-stop-ray-after", perception.map.stop_ray_after_crossed,
                 "--perception: walk each ray back from its end and stop it after this many voxels in a row that earlier rays of the frame crossed (0: whole rays; docs/perception.md)")
      ->capture_default_str();
  app.add_option("--sensor-timeout", perception.sensor_timeout,
                 "--perception: s without a frame taken before the vehicle brakes and holds")
      ->capture_default_str();
  app.add_option("--max-frame-age", perception.gate.max_age, "--perception: a frame older than this on arrival is dropped, s")
      ->capture_default_str();
  app.add_option("--local-replan-period", perception.replan_period, "--perception: s between local replans")
      ->capture_default_str();
  app.add_option("--stuck-time", perception.stuck_time,
                 "--perception: s without a new plan while holding before the flight ends holding")
      ->capture_default_str();
  app.add_option("--local-max-speed", local_options.max_speed, "--perception: local plans fly at most this fast, m/s")
      ->capture_default_str();
  app.add_option("--guide-cell", local_options.guide_cell,
                 "--perception: local targets are ranked by the way to the goal round what was seen occupied, on "
                 "cells of this edge, m, e.g. 0.4 (0: by the straight distance)")
      ->capture_default_str();
  std::vector<std::string> package_path;
  quadhand::apps::AddPackagePathOption(&app, &package_path);
  app.add_flag("-q,--quiet", quiet, "Print only the final summary (and errors)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }

  // Options first: every bad value is reported before anything is loaded.
  if (!(std::isfinite(rate) && rate >= 1.0 && rate <= 500.0)) return Fail("--rate must be in [1, 500] Hz");
  // Upper bounds: a minute of silence, of holding before OFFBOARD or of
  // holding at the goal is already far beyond any use; more is a typo.
  if (!(std::isfinite(options.vehicle_timeout) && options.vehicle_timeout > 0.0 && options.vehicle_timeout <= 60.0)) {
    return Fail("--vehicle-timeout must be in (0, 60] s");
  }
  if (!(std::isfinite(options.ack_timeout) && options.ack_timeout > 0.0 && options.ack_timeout <= 10.0)) {
    return Fail("--ack-timeout must be in (0, 10] s");
  }
  if (options.max_command_attempts < 1 || options.max_command_attempts > 100) {
    return Fail("--command-attempts must be in [1, 100]");
  }
  if (!(std::isfinite(options.outage_timeout) && options.outage_timeout >= options.vehicle_timeout &&
        options.outage_timeout <= 600.0)) {
    return Fail("--outage-timeout must be in [--vehicle-timeout, 600] s");
  }
  if (!(std::isfinite(options.resume_tolerance) && options.resume_tolerance > 0.0 &&
        options.resume_tolerance <= 0.1)) {
    return Fail("--resume-tolerance must be in (0, 0.1] m");
  }
  if (!(std::isfinite(options.replan_threshold) && options.replan_threshold > 0.0)) return Fail("--replan-threshold must be positive");
  if (!(std::isfinite(options.replan_period) && options.replan_period >= 0.0)) return Fail("--replan-period must be >= 0 (0: off)");
  if (!(std::isfinite(options.periodic_max_velocity_error) && options.periodic_max_velocity_error > 0.0)) {
    return Fail("--periodic-max-velocity-error must be positive");
  }
  if (!(std::isfinite(options.hold_time) && options.hold_time >= 1.0 && options.hold_time <= 60.0)) return Fail("--hold-time must be in [1, 60] s");
  if (!(std::isfinite(max_duration) && max_duration >= 0.0)) return Fail("--max-duration must be >= 0");
  if (!(std::isfinite(options.arrival_hold) && options.arrival_hold >= 0.0 && options.arrival_hold <= 60.0)) {
    return Fail("--arrival-hold must be in [0, 60] s");
  }
  if (!(std::isfinite(options.arrival_tolerance) && options.arrival_tolerance > 0.0 && options.arrival_tolerance <= 1.0)) {
    return Fail("--arrival-tolerance must be in (0, 1] m");
  }
  if (!(std::isfinite(options.flight_margin) && options.flight_margin >= 0.0 && options.flight_margin <= 0.1)) {
    return Fail("--flight-margin must be in [0, 0.1] m");
  }
  if (!(std::isfinite(options.gripper_tolerance) && options.gripper_tolerance > 0.0 && options.gripper_tolerance <= 0.1)) {
    return Fail("--gripper-tolerance must be in (0, 0.1] m");
  }
  if (!(std::isfinite(options.junction_tolerance) && options.junction_tolerance > 0.0 &&
        options.junction_tolerance <= 0.1)) {
    return Fail("--junction-tolerance must be in (0, 0.1] m");
  }
  if (!(std::isfinite(options.tool_trim) && options.tool_trim >= 0.0 && options.tool_trim <= 0.1)) {
    return Fail("--tool-trim must be in [0, 0.1] m");
  }
  if (!(std::isfinite(options.setpoint_lead) && options.setpoint_lead <= 0.1)) {
    return Fail("--setpoint-lead must be at most 0.1 s (negative: half the streaming period)");
  }
  if (!(std::isfinite(options.junction_timeout) && options.junction_timeout >= 0.0 &&
        options.junction_timeout <= 600.0)) {
    return Fail("--junction-timeout must be in [0, 600] s");
  }
  if (!(std::isfinite(options.arrival_settle_speed) && options.arrival_settle_speed > 0.0 && options.arrival_settle_speed <= 1.0)) {
    return Fail("--arrival-settle-speed must be in (0, 1] m/s");
  }
  // A longer --arrival-hold alone raises the default timeout with it.
  if (app.count("--arrival-timeout") == 0) options.arrival_timeout = std::max(options.arrival_timeout, options.arrival_hold);
  if (!(std::isfinite(options.arrival_timeout) && options.arrival_timeout >= options.arrival_hold && options.arrival_timeout <= 60.0)) {
    return Fail("--arrival-timeout must be in [--arrival-hold, 60] s");
  }
  const std::pair<int, const char*> ids[] = {{target_system, "--target-system"},
                                             {target_component, "--target-component"},
                                             {system_id, "--system-id"},
                                             {component_id, "--component-id"}};
  for (const auto& [value, name] : ids) {
    if (value < 0 || value > 255) return Fail(std::string(name) + " must be in [0, 255]");
  }
  auto in_range = [](double v, double lo, double hi, bool open_low) {
    return std::isfinite(v) && (open_low ? v > lo : v >= lo) && v <= hi;
  };
  if (!in_range(options.max_state_age, 0.0, 5.0, true)) return Fail("--max-state-age must be in (0, 5] s");
  if (!in_range(target_acceleration_noise, 0.0, 100.0, true)) {
    return Fail("--target-acceleration-noise must be in (0, 100] m^2/s^3");
  }
  if (!in_range(options.target_tracker.position_noise, 0.0, 1.0, true)) return Fail("--target-noise must be in (0, 1] m");
  if (!in_range(options.target_replan_threshold, 0.0, 1.0, true)) {
    return Fail("--target-replan-threshold must be in (0, 1] m");
  }
  if (!in_range(options.target_timeout, 0.0, 60.0, true)) return Fail("--target-timeout must be in (0, 60] s");
  if (!in_range(options.target_arrival_tolerance, 0.0, 1.0, true)) return Fail("--target-tolerance must be in (0, 1] m");
  if (!in_range(options.link_budget, 0.0, 1000.0, true)) return Fail("--link-budget must be in (0, 1000]");
  if (!in_range(options.max_blind_time, 0.0, 60.0, true)) return Fail("--max-blind-time must be in (0, 60] s");
  if (!in_range(options.min_link_speed, 0.0, 10.0, true)) return Fail("--min-link-speed must be in (0, 10] m/s");
  if (!in_range(options.clearance_tolerance, 0.0, 0.05, false)) return Fail("--clearance-tolerance must be in [0, 0.05] m");
  if (!in_range(options.max_judged_gap, 0.0, 5.0, true)) return Fail("--max-judged-gap must be in (0, 5] s");
  if (!in_range(options.innovation_gate, 0.0, 1.0, true)) return Fail("--innovation-gate must be in (0, 1] m");
  if (perception_mode) {
    if (std::string why; !perception.IsValid(&why)) return Fail("--perception: " + why);
    if (std::string why; !local_options.IsValid(&why)) return Fail("--perception: " + why);
    if (dry_run) return Fail("--perception: --dry-run plans against the task's scene, which --perception does not plan against");
  } else if (no_prior) {
    return Fail("--no-prior needs --perception");
  }
  std::optional<link::UdpEndpoint> frames_bind;
  if (perception_mode) {
    auto parsed = link::ParseUdpUrl(frames_url, /*allow_port_zero=*/true);
    if (!parsed.ok()) return Fail("--frames " + parsed.status().message());
    frames_bind = *parsed;
  }
  if (require_signing && key_path.empty()) return Fail("--require-signing needs --signing-key FILE");
  if (dry_run && !log_path.empty()) return Fail("--log: --dry-run streams nothing, so there is no flight to log");
  if (!dry_run && vehicle_url.empty()) return Fail("--vehicle udp://HOST:PORT is required (or --dry-run)");
  std::optional<link::UdpEndpoint> vehicle, bind;
  std::optional<link::SigningKey> key;
  if (!dry_run) {
    auto parsed = link::ParseUdpUrl(vehicle_url);
    if (!parsed.ok()) return Fail("--vehicle " + parsed.status().message());
    vehicle = *parsed;
    auto local = link::ParseUdpUrl(bind_url, /*allow_port_zero=*/true);
    if (!local.ok()) return Fail("--bind " + local.status().message());
    bind = *local;
    if (!key_path.empty()) {
      auto loaded = link::LoadSigningKey(key_path);
      if (!loaded.ok()) return Fail("--signing-key " + loaded.status().message());
      key = *loaded;
    }
    if (!log_path.empty()) {
      if (core::Status s = core::CheckOutputPathAndFolder(log_path); !s.ok()) return Fail("--log: " + s.message());
    }
  }

  if (core::Status s = solvers::RegisterBuiltinSolvers(); !s.ok()) return Fail(s.message());
  auto solver = opt::CreateSolver("lbfgs");
  if (!solver.ok()) return Fail(solver.status().message());
  auto config = planner::LoadPlannerConfigOrDefaults(planner_config_path);
  if (!config.ok()) return Fail(config.status().message());
  if (threads >= 0) planner::SetWorkerThreads(threads, &*config);
  if (perception_mode && planner_config_path.empty()) explore::UseLocalPlanningDefaults(&*config, perception.map.resolution);
  robot::PrependRosPackagePath(package_path);
  auto context = perception_mode ? explore::BaseContextOfTaskFile(task_path, *config)
                                 : planner::PlanningContext::Load(task_path, planner::ContextOptions(*config, {"mrc_sdf"}));
  if (!context.ok()) return Fail(context.status().message());
  const planner::PlanningContext& ctx = **context;
  options.target_tracker.acceleration_noise = target_acceleration_noise;
  options.target_tracker.yaw_acceleration_noise = target_acceleration_noise;
  // A moving target's points: judged where the tracker had the target.
  const planner::MovingScene* moving = ctx.moving_scene();
  online::MovingJudge moving_judge;
  if (moving != nullptr) {
    moving_judge.exact = moving->exact;
    moving_judge.task_target = moving->target_at_zero;
    if (moving->exact != nullptr) moving->exact->BuildAllQueries();
  }
  // A replan in flight must not wait for an exact-mesh tree to be built.
  ctx.exact().BuildAllQueries();
  for (const std::string& repair : robot::TakeMeshRepairReports()) {
    std::fprintf(stderr, "quadhand-online: %s\n", repair.c_str());
  }
  for (const std::string& caution : planner::TaskCautions(ctx.task())) {
    std::fprintf(stderr, "quadhand-online: caution: %s\n", caution.c_str());
  }
  online::PlanningSetup setup{ctx.Scene(), &ctx.task(), config->planner, config->replan, solver->get()};
  setup.plan_options.collision_margin += options.flight_margin;
  // A mission of more than one step (docs/missions.md): planned as a whole,
  // flown without replans, the gripper commanded at its grasps and releases.
  const bool mission = !planner::PlansAsGoal(ctx.task());
  planner::MissionPhaseCache mission_phases;
  setup.context = &ctx;
  setup.mission_phases = &mission_phases;
  if (dry_run) return DryRun(ctx, setup, rate, options.hold_time);
  std::unique_ptr<explore::LocalPlanner> local_planner;
  if (perception_mode) {
    auto created = explore::LocalPlanner::Create(ctx, setup.plan_options, *solver->get(), local_options);
    if (!created.ok()) return Fail(task_path + ": --perception: " + created.status().message());
    local_planner = std::move(*created);
    perception.planner = local_planner.get();
    if (!no_prior) {
      auto prior = planner::ScenePoints(ctx.task());
      if (!prior.ok()) return Fail(task_path + ": the prior map: " + prior.status().message());
      if (!prior->empty()) {
        if (!quiet) std::fprintf(stderr, "prior map: %zu points from the task's scene\n", prior->size());
        perception.prior = std::make_shared<const std::vector<Vec3>>(std::move(*prior));
      }
    }
    setup.perception = perception;
  }

  options.replanning = !no_replan && !mission;
  options.require_clock_sync = !no_timesync;
  auto controller_or = online::OnlineController::Create(setup, options);
  if (!controller_or.ok()) return Fail(controller_or.status().message());
  online::OnlineController& controller = **controller_or;

  auto socket = link::UdpSocket::Bind(*bind);
  if (!socket.ok()) return Fail("--bind " + bind_url + ": " + socket.status().message());
  link::EncoderOptions encoder;
  encoder.system_id = static_cast<uint8_t>(system_id);
  encoder.component_id = static_cast<uint8_t>(component_id);
  encoder.signing_key = key;
  link::ParserOptions parser;
  parser.signing_key = key;
  parser.require_signing = require_signing;
  link::Connection connection(std::move(*socket), encoder, parser, vehicle);
  std::optional<link::UdpSocket> frames_socket;
  link::SensorFrameAssembler assembler;
  if (perception_mode) {
    auto opened = link::UdpSocket::Bind(*frames_bind);
    if (!opened.ok()) return Fail("--frames " + frames_url + ": " + opened.status().message());
    frames_socket.emplace(std::move(*opened));
    frames_socket->SetReceiveBuffer(16u << 20);  // a frame's burst of chunks
  }
  const online::LinkTargets targets{static_cast<uint8_t>(target_system), static_cast<uint8_t>(target_component)};

  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  if (!quiet) {
    std::printf("quadhand-online: %s -> vehicle %s (local port %u), %.0f Hz\n", task_path.c_str(),
                vehicle->ToString().c_str(), connection.local_port(), rate);
    std::fflush(stdout);
  }

  const auto start = Clock::now();
  auto now = [&start] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  const double period = 1.0 / rate;
  double next_tick = 0.0;
  online::FlightLog log(moving != nullptr);
  std::optional<GrowingLog> growing_log;
  if (!log_path.empty()) growing_log.emplace(log_path, ctx.robot().ActuatedJointNames());
  double last_log_flush = 0.0;
  std::vector<double> send_times;  // of each setpoint
  long send_errors = 0;
  std::string first_send_error;
  bool interrupted = false;
  double last_tick = 0.0;
  unsigned long long from_other_systems = 0;  // accepted frames the controller ignored for their sender
  for (;;) {
    const double wait = next_tick - now();
    if (wait > 0.0) connection.WaitReadable(std::min(wait, 0.05));
    for (const link::ReceivedMessage& r : connection.Poll()) {
      const double t = now();
      if (r.frame.system_id != targets.vehicle_system) ++from_other_systems;
      const bool used = online::DeliverToController(r.message, r.frame.system_id, t, targets, &controller);
      if (used && std::holds_alternative<link::LocalPositionNed>(r.message) && controller.has_measured_state()) {
        const online::MeasuredState measured = controller.measured();
        log.Record(measured, controller.last_setpoint(), controller.phase(), controller.TargetPoseAt(measured.time),
                   controller.last_setpoint_shift());
      }
    }
    if (frames_socket) {
      while (auto datagram = frames_socket->Receive()) {
        if (auto frame = assembler.Add(datagram->bytes.data(), datagram->bytes.size())) {
          controller.OnSensorFrame(now(), std::move(*frame));
        }
      }
    }
    const double t = now();
    if (t < next_tick) continue;
    if (g_stop || (max_duration > 0.0 && t >= max_duration)) {
      interrupted = true;
      break;
    }
    const online::ControllerOutput out = controller.Tick(t);
    last_tick = t;
    if (growing_log && t - last_log_flush >= 1.0) {
      growing_log->Flush(log);
      last_log_flush = t;
    }
    for (const link::Message& m : online::MessagesFor(out, t, targets)) {
      if (core::Status s = connection.Send(m); !s.ok()) {
        if (send_errors++ == 0) first_send_error = s.message();
      }
    }
    if (out.setpoint) send_times.push_back(t);
    if (!quiet) {
      for (const std::string& event : out.events) std::printf("[%7.2f s] %s\n", t, event.c_str());
      std::fflush(stdout);
    }
    if (controller.finished()) break;
    next_tick += period;
    if (next_tick < t) next_tick = t + period;  // fell behind (e.g. the machine was busy): skip, do not burst
  }

  // Summary and exit code.
  const online::Phase phase = controller.phase();
  int code = kExitSuccess;
  const char* outcome = "arrived";
  std::string holding_outcome;  // outcome's storage for a flight that ended holding
  if (phase == online::Phase::kVehicleLost) {
    code = kExitVehicleLost;
    outcome = "VEHICLE LOST";
  } else if (phase == online::Phase::kHandshakeFailed) {
    code = kExitRefused;
    outcome = "REFUSED";
  } else if (controller.aborted()) {
    code = kExitAborted;
    outcome = controller.joint_stalled() ? "ABORTED (a joint stalled; braked along the plan and held)"
                                         : "ABORTED (retreated along the plan)";
  } else if (phase == online::Phase::kHoldingAfterFailure) {
    code = kExitPlanFailed;
    const online::HoldCause cause = controller.hold_cause();
    if (cause == online::HoldCause::kPlanFailed || cause == online::HoldCause::kNone) {
      outcome = "PLANNING FAILED (holding)";
    } else {
      holding_outcome = std::string("HOLDING (") + online::HoldCauseName(cause) + ")";
      outcome = holding_outcome.c_str();
    }
  } else if (interrupted && !controller.finished()) {
    code = kExitInterrupted;
    outcome = "INTERRUPTED";
  }
  if (code == kExitSuccess && phase == online::Phase::kArrived && !controller.arrival_settled()) {
    outcome = "arrived (not settled at the goal)";
  }
  // What was flown decides last: the vehicle's own states against the exact
  // meshes. A success is claimed only for a path that kept its clearance
  // and was seen all along.
  std::optional<online::FlightMetrics> metrics;
  std::string judgement;
  // --perception: judged against everything the sensor saw occupied.
  std::unique_ptr<planner::PlanningContext> seen_judge;
  size_t seen_points = 0;
  std::vector<Vec3> seen;
  if (perception_mode) seen = controller.SeenPoints();  // also the map's figures, into stats()
  if (perception_mode && controller.current_plan()) {
    seen_points = seen.size();
    if (seen.empty()) seen.push_back(ctx.task().start.position + Vec3(0.0, 0.0, 20.0));  // nothing seen: nothing near
    auto judge = planner::PlanningContext::Create(ctx.task(), ctx.robot(),
                                                  std::make_shared<const std::vector<Vec3>>(std::move(seen)), 0,
                                                  planner::ContextOptions(*config, {}));
    if (!judge.ok()) return Fail("the points the sensor saw: " + judge.status().message());
    seen_judge = std::move(*judge);
  }
  const env::ExactMeshModel& judged_against = seen_judge ? seen_judge->exact() : ctx.exact();
  const char* scene_words = seen_judge ? "what the sensor saw" : "the scene";
  if (controller.current_plan()) {
    // A flight that ended on its own is judged up to its last tick: a vehicle
    // silent at the end was not seen arriving.
    const planner::PlanResult& flown_plan = *controller.current_plan();
    const double end_time = code == kExitSuccess ? last_tick : online::kNoEndTime;
    // A moving target's base ends where the follow had it, not at the plan's end.
    Vec3 terminal = flown_plan.terminal.position;
    if (moving != nullptr && !log.samples().empty()) {
      if (const auto followed = controller.Reference(log.samples().back().measured.time)) terminal = followed->position;
    }
    metrics = mission ? online::EvaluateMissionFlight(log.samples(), flown_plan, controller.plan_clock(),
                                                      ctx.task(), options.clearance_tolerance, 0.3, end_time,
                                                      controller.failed_plan_time())
                      : online::EvaluateFlight(log.samples(), ctx.robot(), judged_against, ctx.task(),
                                               terminal, 0.3, end_time, moving_judge);
    const double required = planner::AcceptedClearance(ctx.task(), options.clearance_tolerance);
    if (metrics->held_object_margin < 0.0) {
      code = kExitClearanceLost;
      outcome = "CLEARANCE LOST";
      judgement = core::Format("the held object came within %.4f m of the scene (t = %.2f s); it had to keep %.4f m "
                               "less the tolerance there",
                               metrics->held_object_min_clearance, metrics->held_object_min_clearance_time,
                               metrics->held_object_bound);
    } else if (metrics->min_clearance < required) {
      code = kExitClearanceLost;
      outcome = "CLEARANCE LOST";
      judgement = core::Format("the flown path came within %.4f m of ", metrics->min_clearance) + scene_words +
                  core::Format(" (link %s, t = %.2f s); the safety distance less the tolerance is %.4f m",
                               metrics->closest_link.c_str(), metrics->min_clearance_time, required);
    } else if (code == kExitSuccess && !options.shift_setpoints_on_jump &&
               metrics->min_clearance - controller.stats().estimate_jump_sum < required) {
      code = kExitClearanceLost;
      outcome = "CLEARANCE NOT VERIFIED";
      judgement = core::Format("the position estimate jumped %d time(s), by %.4f m in all (the largest %.4f m at "
                               "t = %.2f s): the flown path's clearance %.4f m less that is below the safety distance "
                               "less the tolerance, %.4f m",
                               controller.stats().estimate_jumps, controller.stats().estimate_jump_sum,
                               controller.stats().largest_estimate_jump, controller.stats().largest_estimate_jump_time,
                               metrics->min_clearance, required);
    } else if (code == kExitSuccess && metrics->max_state_gap > options.max_judged_gap) {
      code = kExitClearanceLost;
      outcome = "CLEARANCE NOT VERIFIED";
      judgement = core::Format("no state from the vehicle for %.3f s while flying (t = %.2f s; limit %.3f s): the "
                               "path in between was not seen",
                               metrics->max_state_gap, metrics->max_state_gap_time, options.max_judged_gap);
    }
  }

  const online::OnlineStats& stats = controller.stats();
  std::printf("%s after %.2f s: phase %s, %ld setpoints", outcome, now(), online::PhaseName(phase), stats.setpoints);
  if (send_times.size() >= 2) {
    double max_gap = 0.0;
    for (size_t i = 1; i < send_times.size(); ++i) max_gap = std::max(max_gap, send_times[i] - send_times[i - 1]);
    std::printf(" at %.2f Hz (target %.0f Hz, longest gap %.1f ms)",
                (send_times.size() - 1) / (send_times.back() - send_times.front()), rate, max_gap * 1e3);
  }
  std::printf("\n");
  if (!judgement.empty()) std::printf("  %s\n", judgement.c_str());
  // What the vehicle does now that quadhand-online stops steering it.
  std::printf("  the autopilot was last seen in %s, %s\n", online::AutopilotModeName(controller.autopilot_mode()),
              controller.autopilot_armed() ? "armed" : "disarmed");
  if (send_errors > 0) std::printf("  %ld sends failed (first: %s)\n", send_errors, first_send_error.c_str());
  std::vector<double> replan_ms, warm_ms;
  int replan_failures = 0, fallbacks = 0, dropped_as_slower = 0;
  for (const online::PlanRecord& r : stats.plans) {
    if (!r.replan) {
      std::printf("  first plan: %s in %.1f ms%s%s\n", planner::PlanStatusName(r.status), r.latency_ms, r.success ? "" : ": ",
                  r.success ? "" : r.message.c_str());
      continue;
    }
    replan_ms.push_back(r.latency_ms);
    warm_ms.push_back(r.warm_ms);
    replan_failures += !r.success && r.status != planner::PlanStatus::kInsertionInProgress;
    fallbacks += r.cold_fallback;
    dropped_as_slower += r.dropped_as_slower;
  }
  std::printf("  replans: %d triggered (%d periodic), %d spliced, %d failed, %d cold fallbacks, %d periodic dropped as "
              "slower than the current plan",
              stats.replans_triggered, stats.periodic_replans, stats.splices, replan_failures, fallbacks,
              dropped_as_slower);
  // (--perception: local plans, no warm start; their figures are below.)
  if (!replan_ms.empty() && !perception_mode) {
    std::printf("; latency median %.1f ms, p95 %.1f ms (warm start alone: median %.1f ms)", Quantile(replan_ms, 0.5),
                Quantile(replan_ms, 0.95), Quantile(warm_ms, 0.5));
  }
  std::printf("\n  setpoint motion: max step %.4f m between ticks, max speed %.3f m/s (during splices: %.4f m, "
              "%.3f m/s)\n",
              stats.max_setpoint_step, stats.max_setpoint_speed, stats.max_splice_step, stats.max_splice_speed);
  if (metrics) {
    const online::FlightMetrics& m = *metrics;
    std::printf("  tracking error (3-D, while flying, %ld samples): mean %.4f m, median %.4f m, p95 %.4f m, max %.4f m\n",
                m.flying_samples, m.tracking_mean, m.tracking_median, m.tracking_p95, m.tracking_max);
    // No closest link: nothing came within the reach the clearance search
    // covers, and the figure is that reach.
    const std::string where = m.closest_link.empty()
                                  ? std::string("exact; no link came nearer, the reach searched")
                                  : core::Format("exact, link %s, ", m.closest_link.c_str()) +
                                        core::Format("t = %.2f s", m.min_clearance_time);
    // A mission has no single tool goal (each gripper step's tool is below).
    const std::string tool = std::isfinite(m.final_tool_error)
                                 ? core::Format("final tool error %.4f m, ", m.final_tool_error)
                                 : std::string("no single tool goal; ");
    std::printf(moving != nullptr ? "  flown path: min clearance %.4f m (%s); %sbase %.4f m from where the follow had it\n"
                                  : "  flown path: min clearance %.4f m (%s); %sbase %.4f m from the plan's terminal state\n",
                m.min_clearance, where.c_str(), tool.c_str(), m.final_base_error);
    std::printf("  judged on %ld of the vehicle's time-stamped states; longest gap between two %.3f s\n",
                m.judged_samples, m.max_state_gap);
    if (std::isfinite(m.held_object_margin)) {
      std::printf("  held object: min clearance %.4f m (exact, t = %.2f s; it had to keep %.4f m there)\n",
                  m.held_object_min_clearance, m.held_object_min_clearance_time, m.held_object_bound);
    }
    for (const auto& [step, error] : m.gripper_tool_errors) {
      std::printf("  gripper at %s: the flown tool %.4f m from the planned one\n",
                  planner::StepName(ctx.task().mission, step).c_str(), error);
    }
  }
  if (perception_mode) {
    const online::PerceptionStats& p = stats.perception;
    assembler.Flush();
    const link::SensorStreamCounts& stream = assembler.counts();
    std::printf("  frames: %ld datagrams, %ld frames assembled; dropped datagrams: %ld malformed, %ld truncated, %ld "
                "corrupted, %ld inconsistent, %ld duplicates; %ld incomplete frames\n",
                stream.datagrams, stream.frames, stream.malformed, stream.truncated, stream.corrupted,
                stream.inconsistent, stream.duplicates, stream.incomplete_frames);
    std::printf("  sensor: %ld frames taken (%ld empty); dropped by the gate: %ld malformed, %ld bad pose, %ld from the "
                "future, %ld out of order, %ld stale; %ld dropped waiting for the map; map update median %.1f ms, p95 %.1f "
                "ms; map %.1f MB at most\n",
                p.frames.taken, p.empty_frames, p.frames.malformed, p.frames.bad_pose, p.frames.from_the_future,
                p.frames.out_of_order, p.frames.stale, p.map_overrun, p.map_update_ms.empty() ? 0.0 : Quantile(p.map_update_ms, 0.5),
                p.map_update_ms.empty() ? 0.0 : Quantile(p.map_update_ms, 0.95), p.peak_map_bytes / 1e6);
    int to_goal = 0, to_target = 0, not_planned = 0, recoveries = 0;
    std::vector<double> local_ms;
    for (const online::PlanRecord& r : stats.plans) {
      if (r.local_status < 0) continue;
      local_ms.push_back(r.latency_ms);
      const auto status = static_cast<explore::LocalPlanStatus>(r.local_status);
      to_goal += status == explore::LocalPlanStatus::kToGoal;
      to_target += status == explore::LocalPlanStatus::kToLocalTarget;
      not_planned += !r.success;
      recoveries += r.recovery && r.success;
    }
    std::printf("  local plans: %zu (%d to the goal, %d to local targets, %d without a plan; %d recoveries from inside "
                "the certificate's floor), latency median %.1f ms, p95 %.1f ms (the map's snapshot included); %d late "
                "(dropped)\n",
                local_ms.size(), to_goal, to_target, not_planned, recoveries,
                local_ms.empty() ? 0.0 : Quantile(local_ms, 0.5), local_ms.empty() ? 0.0 : Quantile(local_ms, 0.95),
                p.late_plans);
    std::printf("  new obstacles across a plan: %d (%d across the plan flown); sensor silences: %d; brakes for the "
                "sensor: %d; judged against %zu points the sensor saw (the map's last word on each voxel)\n",
                p.conflicts, p.flown_conflicts, p.silences, p.sensor_brakes, seen_points);
  }
  const online::ClockSync& clock = controller.clock_sync();
  if (clock.synced()) {
    const online::LinkLatency l = clock.latency();
    std::printf("  latency: TIMESYNC round trip median %.1f ms, max %.1f ms (last %.0f s); uplink median %.1f ms; "
                "state age mean %.1f ms, max %.1f ms; %ld stale states dropped\n",
                l.round_trip * 1e3, l.round_trip_max * 1e3, online::OnlineOptions{}.clock_sync.window, l.uplink * 1e3,
                stats.position_measurements > 0 ? 1e3 * stats.sum_state_age / stats.position_measurements : 0.0,
                stats.max_state_age * 1e3, stats.stale_states_dropped);
  } else {
    std::printf("  latency: not measured (%s)\n",
                no_timesync ? "--no-timesync: states judged at their arrival" : "the vehicle never answered TIMESYNC");
  }
  std::printf("  link budget: %d holds (braked along the plan), %d fresh plans after them (%d after re-engaging "
              "OFFBOARD), %d replans not started from a stale state\n",
              stats.link_holds, stats.link_resumes, stats.reengagements, stats.replans_skipped_stale);
  std::printf("  estimate: %d jump(s) beyond the innovation gate (%.4f m), %.4f m in all, the largest %.4f m",
              stats.estimate_jumps, options.innovation_gate, stats.estimate_jump_sum, stats.largest_estimate_jump);
  if (stats.estimate_jumps > 0 && options.shift_setpoints_on_jump) {
    std::printf("; setpoints shifted by (%.4f, %.4f, %.4f) m at the end", stats.estimate_shift.x(),
                stats.estimate_shift.y(), stats.estimate_shift.z());
  }
  std::printf("\n");
  if (controller.tracks_target()) {
    std::vector<double> prediction_ms;
    for (const online::PlanRecord& r : stats.plans) {
      if (r.moving_target) prediction_ms.push_back(r.prediction_ms);
    }
    std::printf("  target: %ld measurements used; dropped %ld stale and %ld malformed; %ld rejected by the gate, %d "
                "restarts; %d replans for its prediction (building its points' models: median %.1f ms of each "
                "plan's latency)\n",
                stats.target_measurements, stats.target_dropped_stale, stats.target_dropped_malformed,
                stats.target_rejected, stats.target_restarts, stats.target_replans,
                prediction_ms.empty() ? 0.0 : Quantile(prediction_ms, 0.5));
    if (!std::isnan(stats.arrival_target_error)) {
      const double arrival = controller.current_plan_start() + controller.current_plan()->trajectory->duration();
      std::printf("  tool to target (as measured): %.4f m at the arrival (the vehicle's t = %.3f s), at most %.4f m "
                  "while following it\n",
                  stats.arrival_target_error, clock.synced() ? clock.ToVehicle(arrival) : arrival,
                  stats.max_follow_target_error);
    }
  }
  if (clock.synced()) std::printf("  ended at the vehicle's t = %.3f s\n", clock.ToVehicle(last_tick));
  const link::ParserStats& link_stats = connection.stats();
  std::printf("  link: %llu frames accepted (%llu from other systems, ignored), %llu sent; dropped: %llu bad CRC, "
              "%llu unsigned, %llu bad signature, %llu replayed, %llu unknown message; %llu bytes skipped\n",
              static_cast<unsigned long long>(link_stats.frames_accepted), from_other_systems,
              static_cast<unsigned long long>(connection.frames_sent()),
              static_cast<unsigned long long>(link_stats.bad_checksum),
              static_cast<unsigned long long>(link_stats.unsigned_rejected),
              static_cast<unsigned long long>(link_stats.bad_signature),
              static_cast<unsigned long long>(link_stats.replayed),
              static_cast<unsigned long long>(link_stats.unknown_message),
              static_cast<unsigned long long>(link_stats.bytes_skipped));
  if (growing_log) {
    const core::Status s = growing_log->Finish(log);
    if (!s.ok()) {
      core::PrintError("quadhand-online", "--log " + s.message());
      if (code == kExitSuccess) code = kExitBadInput;
    } else {
      std::printf("  log: %s (%zu rows)\n", log_path.c_str(), log.samples().size());
    }
  }
  return code;
}
