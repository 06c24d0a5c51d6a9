// MAVLink messages <-> OnlineController, without sockets (the app owns the
// connection). Frames: MAVLink local NED / body FRD on the wire, ENU / FLU in
// the controller (link/frames.h).
//
// Received from the vehicle (system `vehicle_system`, 0 = any):
//   HEARTBEAT (0)             armed = base_mode & MAV_MODE_FLAG_SAFETY_ARMED,
//                             OFFBOARD = custom mode enabled and PX4 main mode 6
//   LOCAL_POSITION_NED (32)   position and velocity, NED -> ENU
//   ATTITUDE_QUATERNION (31)  attitude FRD->NED -> FLU->ENU, body rates FRD -> FLU
//   DEBUG_FLOAT_ARRAY (350)   name "JOINTS": n joint angles (rad) then n joint
//                             rates (rad/s), URDF order of the actuated joints
//                             (n from the robot: the wire pads data to 58 values)
//   DEBUG_FLOAT_ARRAY (350)   name "JOINT_GOAL" (optional): the angle each
//                             servo is commanded to (its goal register), URDF order
//   COMMAND_ACK (77)          for MAV_CMD_DO_SET_MODE and MAV_CMD_COMPONENT_ARM_DISARM
//   LANDING_TARGET (149)      a moving target's pose (TargetFromLandingTarget;
//                             docs/link.md): the extension's x, y, z and q in
//                             MAV_FRAME_LOCAL_NED with position_valid 1
// Sent to it:
//   SET_POSITION_TARGET_LOCAL_NED (84)  position, velocity, acceleration, yaw
//                             (NED: from north, clockwise) and yaw rate (about
//                             down); type_mask 0, MAV_FRAME_LOCAL_NED
//   DEBUG_FLOAT_ARRAY (350)   name "JOINT_SP", array_id 2: n joint angles then
//                             n joint rates, URDF order
//   COMMAND_LONG (76)         MAV_CMD_DO_SET_MODE (param1 1 =
//                             MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, param2 6 =
//                             PX4 OFFBOARD) and MAV_CMD_COMPONENT_ARM_DISARM
//                             (param1 1); confirmation = attempt number
//   HEARTBEAT (0)             MAV_TYPE_ONBOARD_CONTROLLER, MAV_AUTOPILOT_INVALID
// The yaw sent is the planner's Hopf yaw converted to NED; it equals the
// Euler yaw PX4 expects when the vehicle is level and differs from it by
// second-order terms in the tilt.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "quadhand/link/messages.h"
#include "quadhand/online/controller.h"

namespace quadhand::online {

constexpr const char* kJointsArrayName = "JOINTS";
constexpr const char* kJointGoalsArrayName = "JOINT_GOAL";
constexpr const char* kJointSetpointArrayName = "JOINT_SP";
constexpr uint16_t kJointSetpointArrayId = 2;

struct LinkTargets {
  uint8_t vehicle_system = 1;     // target_system of what we send; 0 accepts messages from any system
  uint8_t vehicle_component = 1;  // target_component of what we send
};

// A moving target's measurement (docs/moving_targets.md): its position
// (ENU, m) and heading (about world z, rad, from east) at the vehicle's
// time (s, from time_usec), and which target it is.
struct TargetMeasurement {
  double vehicle_time = 0.0;
  Vec3 position = Vec3::Zero();
  double yaw = 0.0;
  uint8_t target_num = 0;
};

// LANDING_TARGET -> TargetMeasurement: none when position_valid is not 1,
// the frame is not MAV_FRAME_LOCAL_NED, the quaternion is not of unit
// length (1e-3) or a value is not finite. The heading is the yaw of the
// target's orientation (its body x axis projected on the ground).
std::optional<TargetMeasurement> TargetFromLandingTarget(const link::LandingTarget& message);

// Hands one received message to the controller at time t (s). Messages from
// another system than targets.vehicle_system (when not 0), unknown names and
// malformed joint arrays are ignored; returns whether the message was used.
// LANDING_TARGET goes to OnTarget (any target_num: one target is tracked)
// at its stamp's time, or to OnMalformedTarget when it cannot be read.
bool DeliverToController(const link::Message& message, uint8_t from_system, double t, const LinkTargets& targets,
                         OnlineController* controller);

// The messages that carry one controller output: the setpoint (position
// target and joint setpoint), commands and heartbeat. `t` is the controller's
// time, sent as time_boot_ms / time_usec.
std::vector<link::Message> MessagesFor(const ControllerOutput& output, double t, const LinkTargets& targets);

link::SetPositionTargetLocalNed ToPositionTarget(const Setpoint& setpoint, double t, const LinkTargets& targets);
link::DebugFloatArray ToJointSetpoint(const Setpoint& setpoint, double t);
link::CommandLong ToCommandLong(const CommandRequest& request, const LinkTargets& targets);

}  // namespace quadhand::online
