#include "quadhand/online/mavlink_bridge.h"

#include <cmath>

#include "quadhand/link/frames.h"

namespace quadhand::online {
namespace {

constexpr uint8_t kResultInProgress = 5;  // MAV_RESULT_IN_PROGRESS

// PX4's custom mode: main mode in bits 16..23, AUTO's sub mode in 24..31.
AutopilotMode Px4Mode(bool custom, uint32_t custom_mode) {
  if (!custom) return AutopilotMode::kOther;
  const uint32_t main_mode = (custom_mode >> 16) & 0xFFu, sub_mode = (custom_mode >> 24) & 0xFFu;
  constexpr uint32_t kAutoSubModeLoiter = 3;  // PX4's Hold
  if (main_mode == link::mav::kPx4MainModeOffboard) return AutopilotMode::kOffboard;
  if (main_mode == link::mav::kPx4MainModePosition) return AutopilotMode::kPosition;
  if (main_mode == link::mav::kPx4MainModeAuto && sub_mode == link::mav::kPx4AutoSubModeLand) return AutopilotMode::kLand;
  if (main_mode == link::mav::kPx4MainModeAuto && sub_mode == kAutoSubModeLoiter) return AutopilotMode::kHold;
  return AutopilotMode::kOther;
}

uint32_t TimeBootMs(double t) { return static_cast<uint32_t>(std::llround(std::max(0.0, t) * 1e3)); }

}  // namespace

std::optional<TargetMeasurement> TargetFromLandingTarget(const link::LandingTarget& message) {
  if (message.position_valid != 1 || message.frame != link::mav::kFrameLocalNed) return std::nullopt;
  const Quat q_ned(message.q[0], message.q[1], message.q[2], message.q[3]);
  const Vec3 position_ned(message.x, message.y, message.z);
  if (!position_ned.allFinite() || !q_ned.coeffs().allFinite() || std::abs(q_ned.norm() - 1.0) > 1e-3) {
    return std::nullopt;
  }
  TargetMeasurement measurement;
  measurement.vehicle_time = static_cast<double>(message.time_usec) * 1e-6;
  measurement.position = link::NedToEnu(position_ned);
  const Mat3 r = link::AttitudeNedFrdToEnuFlu(q_ned.normalized()).toRotationMatrix();
  measurement.yaw = std::atan2(r(1, 0), r(0, 0));
  measurement.target_num = message.target_num;
  return measurement;
}

bool DeliverToController(const link::Message& message, uint8_t from_system, double t, const LinkTargets& targets,
                         OnlineController* controller) {
  if (targets.vehicle_system != 0 && from_system != targets.vehicle_system) return false;
  if (const auto* heartbeat = std::get_if<link::Heartbeat>(&message)) {
    if (heartbeat->type == link::mav::kTypeOnboardController) return false;  // another companion, not the vehicle
    const bool armed = (heartbeat->base_mode & link::mav::kModeFlagSafetyArmed) != 0;
    const bool custom = (heartbeat->base_mode & link::mav::kModeFlagCustomModeEnabled) != 0;
    const uint32_t main_mode = (heartbeat->custom_mode >> 16) & 0xFFu;
    controller->OnHeartbeat(t, armed, custom && main_mode == link::mav::kPx4MainModeOffboard);
    controller->OnAutopilotMode(t, Px4Mode(custom, heartbeat->custom_mode), armed);
    return true;
  }
  if (const auto* position = std::get_if<link::LocalPositionNed>(&message)) {
    controller->OnPosition(controller->MeasurementTime(t, position->time_boot_ms * 1e-3),
                           link::NedToEnu(Vec3(position->x, position->y, position->z)),
                           link::NedToEnu(Vec3(position->vx, position->vy, position->vz)), position->time_boot_ms * 1e-3);
    return true;
  }
  if (const auto* attitude = std::get_if<link::AttitudeQuaternion>(&message)) {
    const Quat q_ned_frd(attitude->q1, attitude->q2, attitude->q3, attitude->q4);
    if (!(q_ned_frd.norm() > 0.5)) return false;
    controller->OnAttitude(controller->MeasurementTime(t, attitude->time_boot_ms * 1e-3),
                           link::AttitudeNedFrdToEnuFlu(q_ned_frd),
                           link::FrdToFlu(Vec3(attitude->rollspeed, attitude->pitchspeed, attitude->yawspeed)));
    return true;
  }
  if (const auto* array = std::get_if<link::DebugFloatArray>(&message)) {
    // The wire always carries 58 values (zero-padded, and the padding may be
    // truncated away): the robot's joint count says where the rates start.
    const int n = controller->num_joints();
    if (array->name == kJointGoalsArrayName && n >= 1 && n <= link::DebugFloatArray::kMaxData) {
      VecX goals = VecX::Zero(n);
      for (int k = 0; k < n && static_cast<size_t>(k) < array->data.size(); ++k) goals[k] = array->data[static_cast<size_t>(k)];
      controller->OnJointGoals(controller->MeasurementTime(t, static_cast<double>(array->time_usec) * 1e-6), goals);
      return true;
    }
    if (array->name != kJointsArrayName || n < 1 || 2 * n > link::DebugFloatArray::kMaxData) return false;
    VecX q = VecX::Zero(n), qd = VecX::Zero(n);
    for (int k = 0; k < n; ++k) {
      if (static_cast<size_t>(k) < array->data.size()) q[k] = array->data[static_cast<size_t>(k)];
      if (static_cast<size_t>(n + k) < array->data.size()) qd[k] = array->data[static_cast<size_t>(n + k)];
    }
    controller->OnJoints(controller->MeasurementTime(t, static_cast<double>(array->time_usec) * 1e-6), q, qd);
    return true;
  }
  if (const auto* landing = std::get_if<link::LandingTarget>(&message)) {
    const std::optional<TargetMeasurement> measurement = TargetFromLandingTarget(*landing);
    if (!measurement) {
      controller->OnMalformedTarget();
      return false;
    }
    const double when = controller->MeasurementTime(t, measurement->vehicle_time);
    controller->OnTarget(when, measurement->position, measurement->yaw, t - when);
    return controller->tracks_target();
  }
  if (const auto* sync = std::get_if<link::Timesync>(&message)) {
    if (sync->tc1 == 0) return false;  // the vehicle's own request: not answered (optional in MAVLink)
    controller->OnTimesync(t, sync->tc1, sync->ts1);
    return true;
  }
  if (const auto* ack = std::get_if<link::CommandAck>(&message)) {
    Command command;
    if (ack->command == link::mav::kCmdDoSetMode) command = Command::kSetOffboardMode;
    else if (ack->command == link::mav::kCmdComponentArmDisarm) command = Command::kArm;
    else if (ack->command == link::mav::kCmdDoGripper) command = Command::kGripper;
    else return false;
    AckResult result = AckResult::kRejected;
    if (ack->result == link::mav::kResultAccepted) result = AckResult::kAccepted;
    else if (ack->result == link::mav::kResultTemporarilyRejected || ack->result == kResultInProgress) {
      result = AckResult::kTemporarilyRejected;
    }
    controller->OnCommandAck(t, command, result);
    return true;
  }
  return false;
}

link::SetPositionTargetLocalNed ToPositionTarget(const Setpoint& setpoint, double t, const LinkTargets& targets) {
  link::SetPositionTargetLocalNed m;
  m.time_boot_ms = TimeBootMs(t);
  const Vec3 p = link::EnuToNed(setpoint.position), v = link::EnuToNed(setpoint.velocity),
             a = link::EnuToNed(setpoint.acceleration);
  m.x = static_cast<float>(p.x());
  m.y = static_cast<float>(p.y());
  m.z = static_cast<float>(p.z());
  m.vx = static_cast<float>(v.x());
  m.vy = static_cast<float>(v.y());
  m.vz = static_cast<float>(v.z());
  m.afx = static_cast<float>(a.x());
  m.afy = static_cast<float>(a.y());
  m.afz = static_cast<float>(a.z());
  m.yaw = static_cast<float>(link::YawEnuToNed(setpoint.yaw));
  m.yaw_rate = static_cast<float>(-setpoint.yaw_rate);  // about up -> about down
  m.type_mask = 0;
  m.target_system = targets.vehicle_system;
  m.target_component = targets.vehicle_component;
  m.coordinate_frame = link::mav::kFrameLocalNed;
  return m;
}

link::DebugFloatArray ToJointSetpoint(const Setpoint& setpoint, double t) {
  link::DebugFloatArray m;
  m.time_usec = static_cast<uint64_t>(std::llround(std::max(0.0, t) * 1e6));
  m.array_id = kJointSetpointArrayId;
  m.name = kJointSetpointArrayName;
  for (int k = 0; k < setpoint.joints.size(); ++k) m.data.push_back(static_cast<float>(setpoint.joints[k]));
  for (int k = 0; k < setpoint.joint_rates.size(); ++k) m.data.push_back(static_cast<float>(setpoint.joint_rates[k]));
  return m;
}

link::CommandLong ToCommandLong(const CommandRequest& request, const LinkTargets& targets) {
  link::CommandLong m;
  m.target_system = targets.vehicle_system;
  m.target_component = targets.vehicle_component;
  m.confirmation = static_cast<uint8_t>(std::min(request.attempt, 255));
  if (request.command == Command::kSetOffboardMode) {
    m.command = link::mav::kCmdDoSetMode;
    m.param1 = link::mav::kModeFlagCustomModeEnabled;
    m.param2 = static_cast<float>(link::mav::kPx4MainModeOffboard);
  } else if (request.command == Command::kGripper) {
    m.command = link::mav::kCmdDoGripper;
    m.param1 = 1.0f;  // the first gripper
    m.param2 = static_cast<float>(request.grab ? link::mav::kGripperActionGrab : link::mav::kGripperActionRelease);
  } else {
    m.command = link::mav::kCmdComponentArmDisarm;
    m.param1 = 1.0f;
  }
  return m;
}

std::vector<link::Message> MessagesFor(const ControllerOutput& output, double t, const LinkTargets& targets) {
  std::vector<link::Message> messages;
  if (output.send_heartbeat) {
    link::Heartbeat heartbeat;
    heartbeat.type = link::mav::kTypeOnboardController;
    heartbeat.autopilot = link::mav::kAutopilotInvalid;
    heartbeat.system_status = link::mav::kStateActive;
    messages.push_back(heartbeat);
  }
  if (output.setpoint) {
    messages.push_back(ToPositionTarget(*output.setpoint, t, targets));
    messages.push_back(ToJointSetpoint(*output.setpoint, t));
  }
  for (const CommandRequest& request : output.commands) messages.push_back(ToCommandLong(request, targets));
  if (output.timesync_request) {
    link::Timesync sync;
    sync.tc1 = 0;
    sync.ts1 = *output.timesync_request;
    sync.target_system = targets.vehicle_system;
    sync.target_component = targets.vehicle_component;
    messages.push_back(sync);
  }
  return messages;
}

}  // namespace quadhand::online
