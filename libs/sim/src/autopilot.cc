// The PX4-like autopilot of quadhand-sim --udp (see autopilot.h, docs/sim.md).
#include "quadhand/sim/autopilot.h"

#include <limits>

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "quadhand/core/file_util.h"
#include "quadhand/core/text.h"
#include "quadhand/core/yaml_text.h"
#include "quadhand/link/frames.h"
#include "quadhand/traj/flatness.h"

namespace quadhand::sim {
namespace {

constexpr double kTimeEpsilon = 1e-9;
constexpr uint8_t kSeverityWarning = 4;  // MAV_SEVERITY_WARNING
constexpr uint8_t kSeverityInfo = 6;     // MAV_SEVERITY_INFO

link::StatusText Text(uint8_t severity, const std::string& text) {
  link::StatusText s;
  s.severity = severity;
  s.text = text;
  return s;
}

bool AllFinite(std::initializer_list<float> values) {
  for (float v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

// Reads a list of numbers from a YAML node; nullopt when it is not one.
std::optional<std::vector<double>> Numbers(const YAML::Node& node) {
  if (!node || !node.IsSequence()) return std::nullopt;
  std::vector<double> values;
  for (const YAML::Node& item : node) {
    if (!item.IsScalar()) return std::nullopt;
    double v = 0.0;
    if (!YAML::convert<double>::decode(item, v) || !std::isfinite(v)) return std::nullopt;
    values.push_back(v);
  }
  return values;
}

}  // namespace

bool AutopilotOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* message) {
    if (why) *why = message;
    return false;
  };
  if (!(telemetry_period > 0.0 && std::isfinite(telemetry_period))) return fail("telemetry_period must be > 0");
  if (!(heartbeat_period > 0.0 && std::isfinite(heartbeat_period))) return fail("heartbeat_period must be > 0");
  if (!(offboard_timeout > 0.0 && std::isfinite(offboard_timeout))) return fail("offboard_timeout must be > 0");
  if (!(offboard_min_stream >= 0.0 && std::isfinite(offboard_min_stream))) {
    return fail("offboard_min_stream must be >= 0");
  }
  if (target && !target->options().IsValid(why)) return false;
  for (size_t i = 0; i < gripper_loads.size(); ++i) {
    const GripperLoad& load = gripper_loads[i];
    if (!(load.mass >= 0.0 && load.mass <= 100.0) || !load.position.allFinite()) {
      return fail("gripper_loads: masses in [0, 100] kg, finite positions");
    }
    if (load.held_at_start && i != 0) return fail("gripper_loads: only the first load may be held at the start");
  }
  return true;
}

const char* FlightModeName(FlightMode mode) {
  switch (mode) {
    case FlightMode::kOffboard:
      return "OFFBOARD";
    case FlightMode::kLand:
      return "LAND";
    case FlightMode::kPosition:
      break;
  }
  return "POSITION";
}

core::Result<StartPose> ParseStartPose(const std::string& text) {
  auto bad = [&]() {
    return core::Status::InvalidArgument("--start '" + text + "': expected x,y,z or x,y,z,yaw (m, rad; ENU)");
  };
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(v)) return bad();
    values.push_back(v);
  }
  if (!text.empty() && text.back() == ',') return bad();
  if (values.size() != 3 && values.size() != 4) return bad();
  StartPose start;
  start.position = Vec3(values[0], values[1], values[2]);
  start.yaw = values.size() == 4 ? values[3] : 0.0;
  return start;
}

namespace {

// A task file's YAML, with the checks every reader of it makes.
core::Result<YAML::Node> LoadTaskYaml(const std::string& task_path) {
  auto text = core::ReadFileToString(task_path);
  if (!text.ok()) return text.status();
  QUADHAND_RETURN_IF_ERROR(core::CheckYamlText(*text, task_path));
  try {
    return YAML::Load(*text);
  } catch (const YAML::Exception& e) {
    return core::Status::InvalidArgument(task_path + ": not valid YAML: " + e.what());
  }
}

}  // namespace

core::Result<StartPose> LoadTaskStartPose(const std::string& task_path) {
  auto loaded = LoadTaskYaml(task_path);
  if (!loaded.ok()) return loaded.status();
  const YAML::Node& root = *loaded;
  const YAML::Node start = root.IsMap() ? root["start"] : YAML::Node();
  if (!start || !start.IsMap()) return core::Status::InvalidArgument(task_path + ": start: missing (a map)");
  StartPose pose;
  const std::optional<std::vector<double>> position = Numbers(start["position"]);
  if (!position || position->size() != 3) {
    return core::Status::InvalidArgument(task_path + ": start.position: expected a list of 3 numbers");
  }
  pose.position = Vec3((*position)[0], (*position)[1], (*position)[2]);
  double yaw = 0.0;
  if (!start["yaw"] || !start["yaw"].IsScalar() || !YAML::convert<double>::decode(start["yaw"], yaw) ||
      !std::isfinite(yaw)) {
    return core::Status::InvalidArgument(task_path + ": start.yaw: expected a number");
  }
  pose.yaw = yaw;
  const std::optional<std::vector<double>> joints = Numbers(start["joints"]);
  if (!joints) return core::Status::InvalidArgument(task_path + ": start.joints: expected a list of numbers");
  pose.joints = Eigen::Map<const VecX>(joints->data(), static_cast<Eigen::Index>(joints->size()));
  return pose;
}

core::Result<std::vector<GripperLoad>> LoadTaskGripperLoads(const std::string& task_path) {
  auto loaded = LoadTaskYaml(task_path);
  if (!loaded.ok()) return loaded.status();
  const YAML::Node& root = *loaded;
  std::vector<GripperLoad> loads;
  const YAML::Node mission = root.IsMap() ? root["mission"] : YAML::Node();
  if (!mission) return loads;
  if (!mission.IsSequence()) return core::Status::InvalidArgument(task_path + ": mission: expected a list of steps");
  for (size_t i = 0; i < mission.size(); ++i) {
    const YAML::Node step = mission[i];
    if (!step.IsMap() || !step["grasp"]) continue;
    const std::string key = "mission[" + std::to_string(i) + "].grasp.object";
    const YAML::Node object = step["grasp"].IsMap() ? step["grasp"]["object"] : YAML::Node();
    if (!object || !object.IsMap()) return core::Status::InvalidArgument(task_path + ": " + key + ": missing (a map)");
    GripperLoad load;
    load.held_at_start = i == 0;
    const YAML::Node pose = object["pose"];
    const std::optional<std::vector<double>> position =
        pose && pose.IsMap() ? Numbers(pose["position"]) : std::optional<std::vector<double>>();
    if (!position || position->size() != 3) {
      return core::Status::InvalidArgument(task_path + ": " + key + ".pose.position: expected a list of 3 numbers");
    }
    load.position = Vec3((*position)[0], (*position)[1], (*position)[2]);
    if (object["mass"]) {
      if (!object["mass"].IsScalar() || !YAML::convert<double>::decode(object["mass"], load.mass) ||
          !(load.mass >= 0.0 && load.mass <= 100.0)) {
        return core::Status::InvalidArgument(task_path + ": " + key + ".mass: expected a number in [0, 100] kg");
      }
    }
    if (!load.position.allFinite()) {
      return core::Status::InvalidArgument(task_path + ": " + key + ".pose.position: values must be finite");
    }
    loads.push_back(load);
  }
  return loads;
}

core::Result<TaskTarget> LoadTaskTarget(const std::string& task_path) {
  auto loaded = LoadTaskYaml(task_path);
  if (!loaded.ok()) return loaded.status();
  const YAML::Node& root = *loaded;
  auto fail = [&task_path](const std::string& key, const std::string& problem) {
    return core::Status::InvalidArgument(task_path + ": " + key + ": " + problem);
  };
  const YAML::Node goal = root.IsMap() ? root["goal"] : YAML::Node();
  const YAML::Node tool = goal && goal.IsMap() ? goal["tool"] : YAML::Node();
  const YAML::Node motion = tool && tool.IsMap() ? tool["motion"] : YAML::Node();
  if (!motion || !motion.IsMap()) return fail("goal.tool.motion", "missing: the task's target does not move");
  TaskTarget target;
  const auto position = Numbers(tool["position"]);
  if (!position || position->size() != 3) return fail("goal.tool.position", "expected a list of 3 numbers");
  const auto q = Numbers(tool["orientation"]);
  if (!q || q->size() != 4 ||
      std::abs(std::sqrt((*q)[0] * (*q)[0] + (*q)[1] * (*q)[1] + (*q)[2] * (*q)[2] + (*q)[3] * (*q)[3]) - 1.0) > 1e-3) {
    return fail("goal.tool.orientation", "expected a unit quaternion [w, x, y, z]");
  }
  target.pose = MakePose(Vec3((*position)[0], (*position)[1], (*position)[2]),
                         Quat((*q)[0], (*q)[1], (*q)[2], (*q)[3]).normalized().toRotationMatrix());
  const Vec3 origin = target.pose.translation();
  if (const YAML::Node file = motion["file"]) {
    if (!file.IsScalar()) return fail("goal.tool.motion.file", "expected a path");
    const std::string path = core::ResolvePath(core::DirectoryOf(task_path), file.as<std::string>());
    auto path_text = core::ReadFileToString(path);
    if (!path_text.ok()) return fail("goal.tool.motion.file", path_text.status().message());
    auto samples = traj::ParseTargetPath(*path_text, path);
    if (!samples.ok()) return fail("goal.tool.motion.file", samples.status().message());
    target.motion = traj::TargetMotion::Sampled(std::move(*samples));
    return target;
  }
  const auto velocity = Numbers(motion["velocity"]);
  if (!velocity || velocity->size() != 3) return fail("goal.tool.motion.velocity", "expected a list of 3 numbers");
  Vec3 acceleration = Vec3::Zero();
  if (motion["acceleration"]) {
    const auto a = Numbers(motion["acceleration"]);
    if (!a || a->size() != 3) return fail("goal.tool.motion.acceleration", "expected a list of 3 numbers");
    acceleration = Vec3((*a)[0], (*a)[1], (*a)[2]);
  }
  double yaw_rate = 0.0;
  if (motion["yaw_rate"] && (!motion["yaw_rate"].IsScalar() ||
                             !YAML::convert<double>::decode(motion["yaw_rate"], yaw_rate) || !std::isfinite(yaw_rate))) {
    return fail("goal.tool.motion.yaw_rate", "expected a number");
  }
  target.motion = traj::TargetMotion::Constant(origin, Vec3((*velocity)[0], (*velocity)[1], (*velocity)[2]),
                                               acceleration, yaw_rate);
  return target;
}

Autopilot::Autopilot(Simulator simulator, const AutopilotOptions& options)
    : simulator_(std::move(simulator)), options_(options) {}

core::Result<Autopilot> Autopilot::Create(Simulator simulator, const StartPose& start,
                                          const AutopilotOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) return core::Status::InvalidArgument("autopilot options: " + why);
  const VehicleModel& model = simulator.model();
  const VecX joints = start.joints.size() == 0 ? NominalJoints(model) : start.joints;
  if (joints.size() != model.num_actuated()) {
    return core::Status::InvalidArgument("start: " + std::to_string(joints.size()) + " joint angles for a robot with " +
                                         std::to_string(model.num_actuated()) + " actuated joints");
  }
  if (!start.position.allFinite() || !std::isfinite(start.yaw) || !joints.allFinite()) {
    return core::Status::InvalidArgument("start: values must be finite");
  }
  VehicleState state = VehicleState::AtRest(model, start.position, joints);
  state.attitude = Quat(Eigen::AngleAxisd(start.yaw, Vec3::UnitZ()));
  simulator.Reset(state, 0.0);
  Autopilot autopilot(std::move(simulator), options);
  if (!options.gripper_loads.empty() && options.gripper_loads.front().held_at_start) {
    const GripperLoad& load = options.gripper_loads.front();
    QUADHAND_RETURN_IF_ERROR(autopilot.simulator_.SetPayload(load.mass, load.position));
    autopilot.gripper_closed_ = true;
    autopilot.next_load_ = 1;
    // The held weight from the first instant: thrusts that hold it.
    VehicleState held = VehicleState::AtRest(autopilot.simulator_.model(), start.position, joints);
    held.attitude = state.attitude;
    autopilot.simulator_.Reset(held, 0.0);
  }
  autopilot.EnterHold();
  autopilot.joint_target_ = joints;
  autopilot.joint_rate_target_ = VecX::Zero(joints.size());
  return autopilot;
}

void Autopilot::EnterHold() {
  const VehicleState s = simulator_.Estimate();  // it holds where it believes it is
  hold_ = Setpoint{};
  hold_.position = s.position;
  hold_.yaw = traj::HopfYawOf(s.attitude);
  hold_.joints = s.joints;
  hold_.joint_rates = VecX::Zero(s.joints.size());
  mode_ = FlightMode::kPosition;
}

Setpoint Autopilot::CurrentSetpoint() const {
  if (mode_ == FlightMode::kLand) {
    // Straight down from where it held, at the land speed, to the ground.
    const FailsafeConfig& failsafe = simulator_.model().config().failsafe;
    Setpoint sp = hold_;
    const double z = hold_.position.z() - failsafe.land_speed * (time() - land_start_time_);
    sp.position.z() = std::max(failsafe.land_height, z);
    if (z > failsafe.land_height) sp.velocity.z() = -failsafe.land_speed;
    return sp;
  }
  if (mode_ != FlightMode::kOffboard || !armed_ || !have_offboard_) return hold_;
  // Where it believes it is (faults.estimate); the attitude is not faulted.
  const Vec3 position = simulator_.EstimatedPosition();
  const Quat& attitude = simulator_.state().attitude;
  Setpoint sp;
  const uint16_t m = offboard_.type_mask;
  // Ignore bits are per ENU axis here (converted on receipt). An ignored
  // position axis follows the vehicle (no position feedback on it); ignored
  // velocity, acceleration and yaw rate are zero feed-forward; an ignored yaw
  // follows the vehicle's yaw (yaw-rate control).
  for (int i = 0; i < 3; ++i) {
    sp.position[i] = (m & (typemask::kXIgnore << i)) ? position[i] : offboard_.position[i];
    sp.velocity[i] = (m & (typemask::kVxIgnore << i)) ? 0.0 : offboard_.velocity[i];
    sp.acceleration[i] = (m & (typemask::kAxIgnore << i)) ? 0.0 : offboard_.acceleration[i];
  }
  sp.yaw = (m & typemask::kYawIgnore) ? traj::HopfYawOf(attitude) : offboard_.yaw;
  sp.yaw_rate = (m & typemask::kYawRateIgnore) ? 0.0 : offboard_.yaw_rate;
  sp.joints = joint_target_;
  sp.joint_rates = joint_rate_target_;
  return sp;
}

void Autopilot::Handle(const link::Message& message, uint8_t from_system, uint8_t from_component,
                       std::vector<link::Message>* out) {
  auto for_us = [&](uint8_t target) { return target == 0 || options_.system_id == 0 || target == options_.system_id; };
  if (const auto* command = std::get_if<link::CommandLong>(&message)) {
    if (for_us(command->target_system)) HandleCommand(*command, from_system, from_component, out);
  } else if (const auto* setpoint = std::get_if<link::SetPositionTargetLocalNed>(&message)) {
    if (for_us(setpoint->target_system)) HandleSetpoint(*setpoint);
  } else if (const auto* array = std::get_if<link::DebugFloatArray>(&message)) {
    if (array->name == kJointSetpointArrayName) HandleJointSetpoint(*array);
  } else if (const auto* sync = std::get_if<link::Timesync>(&message)) {
    // A request (tc1 0) is answered with our clock, the one time_boot_ms and
    // time_usec are stamped with (ns; never 0, which would read as a request).
    if (sync->tc1 == 0 && (sync->target_system == 0 || for_us(sync->target_system))) {
      link::Timesync answer;
      answer.tc1 = std::max<int64_t>(1, std::llround(time() * 1e9));
      answer.ts1 = sync->ts1;
      answer.target_system = from_system;
      answer.target_component = from_component;
      out->push_back(answer);
    }
  }
}

void Autopilot::HandleCommand(const link::CommandLong& command, uint8_t from_system, uint8_t from_component,
                              std::vector<link::Message>* out) {
  link::CommandAck ack;
  ack.command = command.command;
  ack.target_system = from_system;
  ack.target_component = from_component;
  ack.result = link::mav::kResultUnsupported;
  const double now = time();
  if (command.command == link::mav::kCmdDoSetMode) {
    const long base_mode = std::lround(command.param1);
    const long main_mode = std::lround(command.param2);
    if (!(base_mode & link::mav::kModeFlagCustomModeEnabled)) {
      ack.result = link::mav::kResultDenied;
    } else if (main_mode == static_cast<long>(link::mav::kPx4MainModePosition)) {
      if (mode_ != FlightMode::kPosition) EnterHold();
      land_pending_ = false;
      ack.result = link::mav::kResultAccepted;
    } else if (main_mode == static_cast<long>(link::mav::kPx4MainModeOffboard)) {
      const bool streaming = have_offboard_ && now - last_setpoint_time_ <= options_.offboard_timeout + kTimeEpsilon &&
                             now - stream_start_time_ >= options_.offboard_min_stream - kTimeEpsilon;
      if (mode_ == FlightMode::kOffboard) {
        ack.result = link::mav::kResultAccepted;
      } else if (streaming) {
        mode_ = FlightMode::kOffboard;
        land_pending_ = false;
        // Without a fresh JOINT_SP the arm keeps the pose it holds now.
        if (now - last_joint_setpoint_time_ > options_.offboard_timeout + kTimeEpsilon) {
          joint_target_ = hold_.joints;
          joint_rate_target_ = VecX::Zero(hold_.joints.size());
        }
        ack.result = link::mav::kResultAccepted;
        out->push_back(Text(kSeverityInfo, "Offboard mode"));
      } else {
        ack.result = link::mav::kResultTemporarilyRejected;
        out->push_back(Text(kSeverityWarning, "Offboard rejected: stream setpoints for 1 s first"));
      }
    } else {
      ack.result = link::mav::kResultDenied;
    }
  } else if (command.command == link::mav::kCmdDoGripper) {
    ack.result = HandleGripper(command, out);
  } else if (command.command == link::mav::kCmdComponentArmDisarm) {
    const long action = std::lround(command.param1);
    if (action == 1) {
      armed_ = true;
      ack.result = link::mav::kResultAccepted;
    } else if (action == 0) {
      // Disarmed in the air: a real vehicle would fall; the simulated one
      // keeps hovering in POSITION mode where it is.
      armed_ = false;
      if (mode_ != FlightMode::kPosition) EnterHold();
      land_pending_ = false;
      ack.result = link::mav::kResultAccepted;
    } else {
      ack.result = link::mav::kResultDenied;
    }
  }
  out->push_back(ack);
}

uint8_t Autopilot::HandleGripper(const link::CommandLong& command, std::vector<link::Message>* out) {
  const long action = std::lround(command.param2);
  if (action == link::mav::kGripperActionRelease) {
    if (gripper_closed_ && !simulator_.SetPayload(0.0, Vec3::Zero()).ok()) return link::mav::kResultFailed;
    if (gripper_closed_) out->push_back(Text(kSeverityInfo, "Gripper open"));
    gripper_closed_ = false;
    return link::mav::kResultAccepted;
  }
  if (action != link::mav::kGripperActionGrab) return link::mav::kResultDenied;
  if (gripper_closed_) return link::mav::kResultAccepted;
  double mass = 0.0;
  Vec3 offset = Vec3::Zero();
  if (next_load_ < static_cast<int>(options_.gripper_loads.size())) {
    const GripperLoad& load = options_.gripper_loads[next_load_];
    mass = load.mass;
    // Where the object is in the tool's frame now: the vehicle's own tool,
    // wherever the flight put it.
    const VehicleModel& model = simulator_.model();
    const int link = model.robot().LinkIndex(model.config().payload.link);
    if (link < 0) return link::mav::kResultFailed;
    const VehicleState& s = simulator_.state();
    const Pose tool = MakePose(s.position, s.attitude.toRotationMatrix()) * model.LinkPosesInBase(s.joints)[link];
    offset = load.held_at_start ? load.position : Vec3(tool.inverse() * load.position);
  }
  ++next_load_;
  if (!simulator_.SetPayload(mass, offset).ok()) return link::mav::kResultFailed;
  gripper_closed_ = true;
  out->push_back(Text(kSeverityInfo, core::Format("Gripper closed (%.3f kg)", mass)));
  return link::mav::kResultAccepted;
}

void Autopilot::HandleSetpoint(const link::SetPositionTargetLocalNed& m) {
  if (m.coordinate_frame != link::mav::kFrameLocalNed ||
      !AllFinite({m.x, m.y, m.z, m.vx, m.vy, m.vz, m.afx, m.afy, m.afz, m.yaw, m.yaw_rate})) {
    ++setpoints_rejected_;
    return;
  }
  OffboardTarget target;
  target.position = link::NedToEnu(Vec3(m.x, m.y, m.z));
  target.velocity = link::NedToEnu(Vec3(m.vx, m.vy, m.vz));
  target.acceleration = link::NedToEnu(Vec3(m.afx, m.afy, m.afz));
  target.yaw = link::YawNedToEnu(m.yaw);
  target.yaw_rate = -m.yaw_rate;  // about down -> about up
  // The mask's x and y bits name NED axes: swap them into ENU axes.
  uint16_t mask = m.type_mask & ~(typemask::kXIgnore | typemask::kYIgnore | typemask::kVxIgnore |
                                  typemask::kVyIgnore | typemask::kAxIgnore | typemask::kAyIgnore);
  auto swap_xy = [&](uint16_t x_bit, uint16_t y_bit) {
    if (m.type_mask & x_bit) mask |= y_bit;
    if (m.type_mask & y_bit) mask |= x_bit;
  };
  swap_xy(typemask::kXIgnore, typemask::kYIgnore);
  swap_xy(typemask::kVxIgnore, typemask::kVyIgnore);
  swap_xy(typemask::kAxIgnore, typemask::kAyIgnore);
  target.type_mask = mask;

  const double now = time();
  if (now - last_setpoint_time_ > options_.offboard_timeout + kTimeEpsilon) stream_start_time_ = now;
  last_setpoint_time_ = now;
  offboard_ = target;
  have_offboard_ = true;
  ++setpoints_received_;
}

void Autopilot::HandleJointSetpoint(const link::DebugFloatArray& array) {
  const int n = simulator_.model().num_actuated();
  if (2 * n > static_cast<int>(array.data.size())) {
    ++setpoints_rejected_;
    return;
  }
  VecX q(n), qd(n);
  for (int k = 0; k < n; ++k) {
    q[k] = array.data[static_cast<size_t>(k)];
    qd[k] = array.data[static_cast<size_t>(n + k)];
  }
  if (!q.allFinite() || !qd.allFinite()) {
    ++setpoints_rejected_;
    return;
  }
  joint_target_ = q;
  joint_rate_target_ = qd;
  last_joint_setpoint_time_ = time();
}

core::Status Autopilot::AdvanceTo(double t, std::vector<link::Message>* out) {
  EmitDue(out);
  while (time() < t - kTimeEpsilon) {
    const double h = std::min(simulator_.step(), t - time());
    simulator_.Step(CurrentSetpoint(), h);
    if (!PackState(simulator_.state()).allFinite()) {
      return core::Status::Infeasible("the simulation diverged at t = " + std::to_string(time()) + " s");
    }
    if (mode_ == FlightMode::kOffboard && time() - last_setpoint_time_ > options_.offboard_timeout + kTimeEpsilon) {
      EnterHold();
      out->push_back(Text(kSeverityWarning, "Offboard lost: holding position"));
      land_pending_ = simulator_.model().config().failsafe.action == FailsafeConfig::Action::kLand;
      failsafe_since_ = time();
    }
    AdvanceFailsafe(out);
    EmitDue(out);
  }
  return core::Status::Ok();
}

void Autopilot::AdvanceFailsafe(std::vector<link::Message>* out) {
  const FailsafeConfig& failsafe = simulator_.model().config().failsafe;
  if (land_pending_ && mode_ == FlightMode::kPosition && time() >= failsafe_since_ + failsafe.delay - kTimeEpsilon) {
    land_pending_ = false;
    mode_ = FlightMode::kLand;
    land_start_time_ = time();
    landed_ = false;
    out->push_back(Text(kSeverityWarning, "Failsafe: landing"));
  }
  // Landed once it believes it is at the ground and has stopped (PX4's land
  // detector, without a ground to touch): disarmed, as PX4 disarms after
  // landing; the simulated vehicle then stays there.
  if (mode_ == FlightMode::kLand && !landed_ && CurrentSetpoint().position.z() <= failsafe.land_height &&
      std::abs(simulator_.EstimatedPosition().z() - failsafe.land_height) < 0.05 &&
      simulator_.state().velocity.norm() < 0.1) {
    landed_ = true;
    armed_ = false;
    out->push_back(Text(kSeverityInfo, "Landed"));
  }
}

void Autopilot::EmitDue(std::vector<link::Message>* out) {
  const double now = time();
  if (now >= next_heartbeat_ - kTimeEpsilon) {
    link::Heartbeat heartbeat;
    heartbeat.type = link::mav::kTypeQuadrotor;
    heartbeat.autopilot = link::mav::kAutopilotPx4;
    heartbeat.base_mode = link::mav::kModeFlagCustomModeEnabled | (armed_ ? link::mav::kModeFlagSafetyArmed : 0);
    heartbeat.custom_mode =
        mode_ == FlightMode::kOffboard ? link::mav::Px4CustomMode(link::mav::kPx4MainModeOffboard)
        : mode_ == FlightMode::kLand   ? link::mav::Px4CustomMode(link::mav::kPx4MainModeAuto, link::mav::kPx4AutoSubModeLand)
                                       : link::mav::Px4CustomMode(link::mav::kPx4MainModePosition);
    heartbeat.system_status = armed_ ? link::mav::kStateActive : link::mav::kStateStandby;
    out->push_back(heartbeat);
    next_heartbeat_ += options_.heartbeat_period;
    if (next_heartbeat_ <= now) next_heartbeat_ = now + options_.heartbeat_period;
  }
  if (now >= next_telemetry_ - kTimeEpsilon) {
    // What the estimator reports (faults.estimate): a frozen estimator
    // repeats its last output, time stamp included; a NaN fault fills the
    // position and velocity fields.
    const EstimateFault& fault = simulator_.model().config().faults.estimate;
    if (!fault.FrozenAt(now) || !reported_) {
      reported_state_ = simulator_.Estimate();
      reported_time_ = now;
      reported_ = true;
    }
    VehicleState s = reported_state_;
    if (fault.NanAt(now)) s.position = s.velocity = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    const double stamp = reported_time_;
    const uint32_t time_boot_ms = static_cast<uint32_t>(std::llround(stamp * 1e3));
    link::LocalPositionNed position;
    position.time_boot_ms = time_boot_ms;
    const Vec3 p = link::EnuToNed(s.position), v = link::EnuToNed(s.velocity);
    position.x = static_cast<float>(p.x());
    position.y = static_cast<float>(p.y());
    position.z = static_cast<float>(p.z());
    position.vx = static_cast<float>(v.x());
    position.vy = static_cast<float>(v.y());
    position.vz = static_cast<float>(v.z());
    out->push_back(position);

    link::AttitudeQuaternion attitude;
    attitude.time_boot_ms = time_boot_ms;
    const Quat q = link::AttitudeEnuFluToNedFrd(s.attitude);
    attitude.q1 = static_cast<float>(q.w());
    attitude.q2 = static_cast<float>(q.x());
    attitude.q3 = static_cast<float>(q.y());
    attitude.q4 = static_cast<float>(q.z());
    const Vec3 rates = link::FluToFrd(s.body_rate);
    attitude.rollspeed = static_cast<float>(rates.x());
    attitude.pitchspeed = static_cast<float>(rates.y());
    attitude.yawspeed = static_cast<float>(rates.z());
    out->push_back(attitude);

    link::DebugFloatArray joints;
    joints.time_usec = static_cast<uint64_t>(std::llround(stamp * 1e6));
    joints.array_id = kJointsArrayId;
    joints.name = kJointsArrayName;
    for (int k = 0; k < s.joints.size(); ++k) joints.data.push_back(static_cast<float>(s.joints[k]));
    for (int k = 0; k < s.joint_rates.size(); ++k) joints.data.push_back(static_cast<float>(s.joint_rates[k]));
    out->push_back(joints);

    // Each servo's goal (its goal-position register): what it was last told.
    link::DebugFloatArray goals;
    goals.time_usec = joints.time_usec;
    goals.array_id = kJointGoalsArrayId;
    goals.name = kJointGoalsArrayName;
    const VecX goal = CurrentSetpoint().joints;
    for (int k = 0; k < goal.size(); ++k) goals.data.push_back(static_cast<float>(goal[k]));
    out->push_back(goals);

    if (options_.record_flown) RecordFlown();
    next_telemetry_ += options_.telemetry_period;
    if (next_telemetry_ <= now) next_telemetry_ = now + options_.telemetry_period;
  }
  TargetSample sample;
  if (options_.target && options_.target->MeasurementDue(now, &sample)) {
    link::LandingTarget target;
    target.time_usec = static_cast<uint64_t>(std::llround(now * 1e6));
    target.target_num = options_.target->options().target_num;
    target.frame = link::mav::kFrameLocalNed;
    const Vec3 ned = link::EnuToNed(sample.measured_position);
    target.x = static_cast<float>(ned.x());
    target.y = static_cast<float>(ned.y());
    target.z = static_cast<float>(ned.z());
    const Quat q = link::AttitudeEnuFluToNedFrd(Quat(Eigen::AngleAxisd(sample.measured_yaw, Vec3::UnitZ())));
    target.q = {static_cast<float>(q.w()), static_cast<float>(q.x()), static_cast<float>(q.y()),
                static_cast<float>(q.z())};
    target.position_valid = 1;
    out->push_back(target);
  }
}

void Autopilot::RecordFlown() {
  const VehicleState& s = simulator_.state();
  PlanRow row;
  row.t = time();
  row.position = s.position;
  row.velocity = s.velocity;
  row.acceleration = simulator_.CurrentDynamics().acceleration;
  row.attitude = s.attitude;
  row.yaw = traj::HopfYawOf(s.attitude);
  row.yaw_rate = traj::HopfYawRateOf(s.attitude, s.body_rate);
  row.joints = s.joints;
  row.joint_rates = s.joint_rates;
  // A mission's record says when the gripper held something: the checks
  // of the flight change their scene and robot there.
  if (records_gripper()) row.gripper = gripper_closed_ ? 1 : 0;
  // The target where it truly is: what the flight is judged against.
  if (options_.target) row.target = options_.target->PoseAt(row.t);
  flown_.push_back(std::move(row));
}

}  // namespace quadhand::sim
