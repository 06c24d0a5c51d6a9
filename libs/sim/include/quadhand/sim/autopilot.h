// A PX4-like autopilot around the simulator, for quadhand-sim --udp
// (docs/sim.md, "MAVLink mode"). Transport-agnostic: it is given the
// messages received and the simulated time to advance to, and returns the
// messages to send, so it is tested without sockets.
//
// Behaviour (the subset of PX4 that quadhand-online relies on):
// - Modes: POSITION (hold a position, yaw and joint pose) and OFFBOARD (follow
//   SET_POSITION_TARGET_LOCAL_NED and JOINT_SP). Starts in POSITION, hovering
//   at the start state, disarmed: the vehicle is "in the air" from t = 0
//   (no take-off or landing is simulated), and arming only changes the flag
//   that enables OFFBOARD setpoints.
// - COMMAND_LONG: MAV_CMD_DO_SET_MODE (param1 with CUSTOM_MODE_ENABLED,
//   param2 the PX4 main mode: 3 POSITION, 6 OFFBOARD) and
//   MAV_CMD_COMPONENT_ARM_DISARM (param1 1 arm, 0 disarm) are acknowledged
//   with COMMAND_ACK; every other command gets MAV_RESULT_UNSUPPORTED.
//   OFFBOARD is accepted only while setpoints have streamed for at least
//   `offboard_min_stream` s; otherwise MAV_RESULT_TEMPORARILY_REJECTED, which
//   is what PX4's commander answers to a refused mode change.
// - Offboard loss: no SET_POSITION_TARGET_LOCAL_NED for `offboard_timeout` s
//   in OFFBOARD -> POSITION, holding where the vehicle is, with a STATUSTEXT.
//   With the configuration's failsafe.action `land` (config.h), still in
//   that hold `failsafe.delay` s later -> LAND (AUTO.LAND): a vertical
//   descent at `land_speed` to `land_height`, then disarmed. A mode change
//   requested before then cancels it.
// - TIMESYNC: a request (tc1 = 0) is answered with tc1 = the simulated time
//   in ns (the clock of every time stamp it sends) and the request's ts1.
// - Sends HEARTBEAT every `heartbeat_period` and LOCAL_POSITION_NED,
//   ATTITUDE_QUATERNION and DEBUG_FLOAT_ARRAY "JOINTS" and "JOINT_GOAL"
//   (the angle each servo is commanded to, as a servo's goal-position
//   register reads) every `telemetry_period` of simulated time; with a
//   moving target (AutopilotOptions::target), LANDING_TARGET at its rate.
//
// Frames: MAVLink's local NED frame is the simulator's ENU world with axes
// swapped (same origin); attitudes are FRD -> NED (link/frames.h).
// JOINTS and JOINT_SP carry n joint angles (rad) then n joint rates (rad/s),
// in the URDF order of the actuated joints.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/link/messages.h"
#include "quadhand/sim/plan_io.h"
#include "quadhand/sim/simulator.h"
#include "quadhand/sim/target.h"

namespace quadhand::sim {

// DEBUG_FLOAT_ARRAY names and ids of the joint arrays.
constexpr const char* kJointsArrayName = "JOINTS";      // sent: measured angles then rates
constexpr const char* kJointSetpointArrayName = "JOINT_SP";  // received: setpoint angles then rates
constexpr uint16_t kJointsArrayId = 1;
constexpr uint16_t kJointSetpointArrayId = 2;  // what quadhand-online sends; any id is accepted
constexpr const char* kJointGoalsArrayName = "JOINT_GOAL";  // sent: each servo's goal angle (what it was last told)
constexpr uint16_t kJointGoalsArrayId = 3;

// SET_POSITION_TARGET_LOCAL_NED type_mask bits (POSITION_TARGET_TYPEMASK).
namespace typemask {
constexpr uint16_t kXIgnore = 1, kYIgnore = 2, kZIgnore = 4;
constexpr uint16_t kVxIgnore = 8, kVyIgnore = 16, kVzIgnore = 32;
constexpr uint16_t kAxIgnore = 64, kAyIgnore = 128, kAzIgnore = 256;
constexpr uint16_t kForceSet = 512;
constexpr uint16_t kYawIgnore = 1024, kYawRateIgnore = 2048;
}  // namespace typemask

// What the gripper picks up at its next grab (MAV_CMD_DO_GRIPPER): a mass
// at a point, the object's centre - world frame (the object as it lies
// before the grasp), or the payload link's frame for one already held at the
// start. The simulator attaches it where the vehicle's own tool is then.
struct GripperLoad {
  double mass = 0.0;  // kg
  Vec3 position = Vec3::Zero();
  bool held_at_start = false;
};

struct AutopilotOptions {
  uint8_t system_id = 1;            // commands for another system are ignored (0 = any)
  double telemetry_period = 0.02;   // s of simulated time (50 Hz)
  double heartbeat_period = 1.0;    // s
  double offboard_timeout = 0.5;    // s without a position setpoint -> POSITION
  double offboard_min_stream = 1.0; // s of setpoints before OFFBOARD is accepted
  bool record_flown = false;        // keep one PlanRow per telemetry period (flown())
  // The loads of the gripper's grabs, in order (a mission's grasps,
  // LoadTaskGripperLoads); a grab beyond them closes on nothing. A first load
  // held at the start is attached from the start.
  std::vector<GripperLoad> gripper_loads;
  // A moving target the vehicle sees: its measurements are sent as
  // LANDING_TARGET (frame MAV_FRAME_LOCAL_NED, position_valid 1, q its
  // turn about the vertical since t = 0) every 1/rate s of simulated time.
  std::optional<SimTarget> target;

  bool IsValid(std::string* why) const;
};

enum class FlightMode { kPosition, kOffboard, kLand };
const char* FlightModeName(FlightMode mode);  // "POSITION", "OFFBOARD", "LAND"

// Where the vehicle starts hovering: ENU position, yaw (rad, from east,
// counter-clockwise) and actuated joint angles (URDF order).
struct StartPose {
  Vec3 position = Vec3(0.0, 0.0, 1.0);
  double yaw = 0.0;
  VecX joints;  // empty: NominalJoints(model)
};

// "x,y,z" or "x,y,z,yaw" (m, m, m, rad); InvalidArgument naming the problem.
core::Result<StartPose> ParseStartPose(const std::string& text);
// The start state of a task file (shared/spec/contracts.md: start.position,
// start.yaw, start.joints). Only `start` is read (with yaml-cpp): the planner
// library, which parses whole tasks, sits above the simulator and would pull
// CGAL, PCL and OctoMap into quadhand-sim. Errors name the file and the key.
core::Result<StartPose> LoadTaskStartPose(const std::string& task_path);
// The loads of a task file's mission (contracts.md 0.3): each grasp's
// object.mass (default 0) and object.pose.position, the first held at the
// start when the mission opens with its grasp. Empty for a task without a
// mission. Only those keys are read; errors name the file and the key.
core::Result<std::vector<GripperLoad>> LoadTaskGripperLoads(const std::string& task_path);

// A task file's moving target (contracts.md 0.3): goal.tool.position and
// orientation (its pose at t = 0) and goal.tool.motion (a constant motion,
// or a path file resolved against the task's folder).
// Read with yaml-cpp, as LoadTaskStartPose reads the start. Errors name the
// file and the key; a task whose goal has no motion is an error too.
struct TaskTarget {
  Pose pose = Pose::Identity();
  traj::TargetMotion motion;
};
core::Result<TaskTarget> LoadTaskTarget(const std::string& task_path);

class Autopilot {
 public:
  // Puts the vehicle at rest at `start` (level, thrusts that hold it), in
  // POSITION mode, disarmed, at simulated time 0. Fails on joints of the
  // wrong count or non-finite values.
  static core::Result<Autopilot> Create(Simulator simulator, const StartPose& start, const AutopilotOptions& options);

  // Handles one message received now (at time()): commands are answered
  // (COMMAND_ACK, appended to `out`), setpoints stored. Messages for
  // another system id and messages the vehicle does not use are ignored.
  void Handle(const link::Message& message, uint8_t from_system, uint8_t from_component,
              std::vector<link::Message>* out);

  // Simulates up to time t (s; nothing happens when t <= time()), appending
  // the heartbeats, telemetry and status texts that fall due (including those
  // due at the current time on the first call). Infeasible when the state
  // stops being finite.
  core::Status AdvanceTo(double t, std::vector<link::Message>* out);

  double time() const { return simulator_.time(); }
  FlightMode mode() const { return mode_; }
  bool armed() const { return armed_; }
  const VehicleState& state() const { return simulator_.state(); }
  const Simulator& simulator() const { return simulator_; }
  // For tests that push the vehicle (Simulator::Reset with a changed state).
  Simulator* mutable_simulator() { return &simulator_; }
  // The setpoint the controller is given now (hold or offboard), ENU.
  Setpoint CurrentSetpoint() const;
  // Flown states at the telemetry times (record_flown), in the plan columns,
  // with the gripper (0 open, 1 closed) when records_gripper(): a mission's
  // grasps were given (gripper_loads), and the moving target's true pose
  // when records_target().
  const std::vector<PlanRow>& flown() const { return flown_; }
  bool records_gripper() const { return !options_.gripper_loads.empty(); }
  // With a moving target, flown() rows carry its true pose (PlanRow::target).
  bool records_target() const { return options_.target.has_value(); }
  uint64_t setpoints_received() const { return setpoints_received_; }
  uint64_t setpoints_rejected() const { return setpoints_rejected_; }
  // The gripper: closed (holding its load, if any) and the grabs so far.
  bool gripper_closed() const { return gripper_closed_; }
  int gripper_grabs() const { return next_load_; }

 private:
  Autopilot(Simulator simulator, const AutopilotOptions& options);

  // An offboard target as received, converted to ENU, with its type mask.
  struct OffboardTarget {
    Vec3 position = Vec3::Zero();
    Vec3 velocity = Vec3::Zero();
    Vec3 acceleration = Vec3::Zero();
    double yaw = 0.0;
    double yaw_rate = 0.0;
    uint16_t type_mask = 0;
  };

  void HandleCommand(const link::CommandLong& command, uint8_t from_system, uint8_t from_component,
                     std::vector<link::Message>* out);
  // MAV_CMD_DO_GRIPPER: grab (the next load) or release; the ack's result.
  uint8_t HandleGripper(const link::CommandLong& command, std::vector<link::Message>* out);
  void HandleSetpoint(const link::SetPositionTargetLocalNed& setpoint);
  void HandleJointSetpoint(const link::DebugFloatArray& array);
  // POSITION mode holding the current position, yaw and joints.
  void EnterHold();
  // The failsafe's land after its hold: starts it when due, and disarms
  // once landed (failsafe in config.h).
  void AdvanceFailsafe(std::vector<link::Message>* out);
  void EmitDue(std::vector<link::Message>* out);
  void RecordFlown();

  Simulator simulator_;
  AutopilotOptions options_;
  FlightMode mode_ = FlightMode::kPosition;
  bool armed_ = false;
  Setpoint hold_;
  OffboardTarget offboard_;
  bool have_offboard_ = false;
  // The last estimate telemetry reported and its time (a frozen estimator
  // repeats both).
  VehicleState reported_state_;
  double reported_time_ = 0.0;
  bool reported_ = false;
  VecX joint_target_;
  VecX joint_rate_target_;
  double last_setpoint_time_ = -1e9;
  double last_joint_setpoint_time_ = -1e9;
  double stream_start_time_ = 0.0;
  double next_heartbeat_ = 0.0;
  double next_telemetry_ = 0.0;
  uint64_t setpoints_received_ = 0;
  uint64_t setpoints_rejected_ = 0;
  bool gripper_closed_ = false;
  int next_load_ = 0;
  // The offboard-loss failsafe's land: pending from the loss until it
  // starts or a mode change cancels it.
  bool land_pending_ = false;
  double failsafe_since_ = 0.0;
  double land_start_time_ = 0.0;
  bool landed_ = false;
  std::vector<PlanRow> flown_;
};

}  // namespace quadhand::sim
