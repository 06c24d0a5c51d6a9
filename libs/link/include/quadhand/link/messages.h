// The MAVLink messages QuadHand's link uses, written from the official
// common.xml definitions: each with its id, CRC_EXTRA, and its fields in wire
// order (base fields sorted by type size, largest first; extension fields
// after them in declaration order). Units and frames are MAVLink's (NED/FRD).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace quadhand::link {

// Enum values used by the link (common.xml / PX4).
namespace mav {
constexpr uint8_t kTypeQuadrotor = 2;            // MAV_TYPE_QUADROTOR
constexpr uint8_t kTypeOnboardController = 18;   // MAV_TYPE_ONBOARD_CONTROLLER
constexpr uint8_t kAutopilotGeneric = 0;         // MAV_AUTOPILOT_GENERIC
constexpr uint8_t kAutopilotInvalid = 8;         // MAV_AUTOPILOT_INVALID
constexpr uint8_t kAutopilotPx4 = 12;            // MAV_AUTOPILOT_PX4
constexpr uint8_t kModeFlagCustomModeEnabled = 1;   // MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
constexpr uint8_t kModeFlagSafetyArmed = 128;       // MAV_MODE_FLAG_SAFETY_ARMED
constexpr uint8_t kStateStandby = 3;             // MAV_STATE_STANDBY
constexpr uint8_t kStateActive = 4;              // MAV_STATE_ACTIVE
constexpr uint8_t kFrameLocalNed = 1;            // MAV_FRAME_LOCAL_NED
constexpr uint16_t kCmdDoSetMode = 176;          // MAV_CMD_DO_SET_MODE
constexpr uint16_t kCmdComponentArmDisarm = 400; // MAV_CMD_COMPONENT_ARM_DISARM
// MAV_CMD_DO_GRIPPER: param1 the gripper instance (1-6), param2 the action
// (GRIPPER_ACTIONS: 0 release, 1 grab).
constexpr uint16_t kCmdDoGripper = 211;
constexpr int kGripperActionRelease = 0;         // GRIPPER_ACTION_RELEASE
constexpr int kGripperActionGrab = 1;            // GRIPPER_ACTION_GRAB
constexpr uint8_t kResultAccepted = 0;           // MAV_RESULT_ACCEPTED
constexpr uint8_t kResultTemporarilyRejected = 1;
constexpr uint8_t kResultDenied = 2;
constexpr uint8_t kResultUnsupported = 3;
constexpr uint8_t kResultFailed = 4;
// PX4 custom mode: main mode in bits 16..23 of custom_mode, sub mode in
// bits 24..31 (AUTO's LAND is main 4, sub 6).
constexpr uint32_t kPx4MainModePosition = 3;
constexpr uint32_t kPx4MainModeAuto = 4;
constexpr uint32_t kPx4MainModeOffboard = 6;
constexpr uint32_t kPx4AutoSubModeLand = 6;
constexpr uint32_t Px4CustomMode(uint32_t main_mode, uint32_t sub_mode = 0) {
  return (main_mode << 16) | (sub_mode << 24);
}
}  // namespace mav

struct Heartbeat {  // HEARTBEAT (0)
  static constexpr uint32_t kId = 0;
  static constexpr uint8_t kCrcExtra = 50;
  uint32_t custom_mode = 0;
  uint8_t type = 0;
  uint8_t autopilot = 0;
  uint8_t base_mode = 0;
  uint8_t system_status = 0;
  uint8_t mavlink_version = 3;
};

struct AttitudeQuaternion {  // ATTITUDE_QUATERNION (31)
  static constexpr uint32_t kId = 31;
  static constexpr uint8_t kCrcExtra = 246;
  uint32_t time_boot_ms = 0;
  float q1 = 1, q2 = 0, q3 = 0, q4 = 0;  // w, x, y, z: body FRD -> local NED
  float rollspeed = 0, pitchspeed = 0, yawspeed = 0;  // rad/s, body FRD
  std::array<float, 4> repr_offset_q{};  // extension
};

struct LocalPositionNed {  // LOCAL_POSITION_NED (32)
  static constexpr uint32_t kId = 32;
  static constexpr uint8_t kCrcExtra = 185;
  uint32_t time_boot_ms = 0;
  float x = 0, y = 0, z = 0;     // m, NED
  float vx = 0, vy = 0, vz = 0;  // m/s, NED
};

struct CommandLong {  // COMMAND_LONG (76)
  static constexpr uint32_t kId = 76;
  static constexpr uint8_t kCrcExtra = 152;
  float param1 = 0, param2 = 0, param3 = 0, param4 = 0, param5 = 0, param6 = 0, param7 = 0;
  uint16_t command = 0;
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  uint8_t confirmation = 0;
};

struct CommandAck {  // COMMAND_ACK (77)
  static constexpr uint32_t kId = 77;
  static constexpr uint8_t kCrcExtra = 143;
  uint16_t command = 0;
  uint8_t result = 0;
  uint8_t progress = 0;        // extension
  int32_t result_param2 = 0;   // extension
  uint8_t target_system = 0;   // extension
  uint8_t target_component = 0;  // extension
};

struct SetPositionTargetLocalNed {  // SET_POSITION_TARGET_LOCAL_NED (84)
  static constexpr uint32_t kId = 84;
  static constexpr uint8_t kCrcExtra = 143;
  uint32_t time_boot_ms = 0;
  float x = 0, y = 0, z = 0;        // m, NED
  float vx = 0, vy = 0, vz = 0;     // m/s
  float afx = 0, afy = 0, afz = 0;  // m/s^2
  float yaw = 0, yaw_rate = 0;      // rad, rad/s (NED: about down, from north)
  uint16_t type_mask = 0;           // 0: every field is used
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  uint8_t coordinate_frame = mav::kFrameLocalNed;
};

// Clock synchronisation (PX4 and ArduPilot answer it). A request has tc1 = 0
// and ts1 = the sender's time; the answer has tc1 = the answerer's time and
// ts1 copied from the request, so the requester learns the round trip and
// the offset between the two clocks. Times in ns.
struct Timesync {  // TIMESYNC (111)
  static constexpr uint32_t kId = 111;
  static constexpr uint8_t kCrcExtra = 34;
  int64_t tc1 = 0;
  int64_t ts1 = 0;
  uint8_t target_system = 0;     // extension
  uint8_t target_component = 0;  // extension
};

struct StatusText {  // STATUSTEXT (253)
  static constexpr uint32_t kId = 253;
  static constexpr uint8_t kCrcExtra = 83;
  uint8_t severity = 6;  // MAV_SEVERITY_INFO
  std::string text;      // at most 50 characters on the wire
  uint16_t id = 0;       // extension
  uint8_t chunk_seq = 0; // extension
};

struct DebugFloatArray {  // DEBUG_FLOAT_ARRAY (350)
  static constexpr uint32_t kId = 350;
  static constexpr uint8_t kCrcExtra = 232;
  static constexpr int kMaxData = 58;
  uint64_t time_usec = 0;
  uint16_t array_id = 0;
  std::string name;         // at most 10 characters on the wire
  // Extension, at most 58 values (zero-padded on the wire). Decoded arrays
  // always hold all 58: trailing zeros cannot be told from padding.
  std::vector<float> data;
};

// The pose of a target the vehicle sees (a moving grasp target,
// docs/moving_targets.md); QuadHand uses the local-frame position and
// orientation of its MAVLink 2 extension (frame MAV_FRAME_LOCAL_NED,
// position_valid 1), not the camera angles.
struct LandingTarget {  // LANDING_TARGET (149)
  static constexpr uint32_t kId = 149;
  static constexpr uint8_t kCrcExtra = 200;
  uint64_t time_usec = 0;
  float angle_x = 0, angle_y = 0, distance = 0, size_x = 0, size_y = 0;
  uint8_t target_num = 0;
  uint8_t frame = mav::kFrameLocalNed;
  float x = 0, y = 0, z = 0;               // extension: m, in `frame`
  std::array<float, 4> q{1, 0, 0, 0};      // extension: w, x, y, z
  uint8_t type = 0;                        // extension: LANDING_TARGET_TYPE
  uint8_t position_valid = 0;              // extension: 1 when x, y, z, q hold the target's pose
};

using Message = std::variant<Heartbeat, AttitudeQuaternion, LocalPositionNed, CommandLong, CommandAck,
                             SetPositionTargetLocalNed, Timesync, StatusText, DebugFloatArray, LandingTarget>;

// Id, CRC_EXTRA and full payload length (with extensions) of a known message
// id; nullopt for ids this link does not know.
struct MessageInfo {
  uint32_t id;
  uint8_t crc_extra;
  uint8_t max_length;  // payload bytes with all extension fields
  const char* name;    // as in common.xml, e.g. "HEARTBEAT"
};
std::optional<MessageInfo> FindMessageInfo(uint32_t id);
uint32_t MessageId(const Message& message);

// Serialises a message's fields (little-endian, wire order) into its full,
// untruncated payload; the framer truncates trailing zeros.
std::vector<uint8_t> SerializePayload(const Message& message);
// Decodes a payload of any length up to the full one (missing trailing bytes
// are zero, as MAVLink 2 truncation requires); nullopt for unknown ids or a
// payload longer than the message.
std::optional<Message> DeserializePayload(uint32_t id, const uint8_t* payload, size_t length);

}  // namespace quadhand::link
