// Payload (de)serialisation of the link's MAVLink messages. Field order,
// sizes, ids and CRC_EXTRA values follow common.xml; tests/link/messages_test.cc
// recomputes every CRC_EXTRA from the XML field lists independently.
#include "quadhand/link/messages.h"

#include <algorithm>
#include <cstring>
#include <type_traits>

namespace quadhand::link {
namespace {

// Full payload lengths (base fields + extensions), from the field lists.
constexpr uint8_t kHeartbeatLength = 9;             // 4 + 5 * 1
constexpr uint8_t kAttitudeQuaternionLength = 48;   // 4 + 7 * 4 + ext 4 * 4
constexpr uint8_t kLocalPositionNedLength = 28;     // 4 + 6 * 4
constexpr uint8_t kCommandLongLength = 33;          // 7 * 4 + 2 + 3 * 1
constexpr uint8_t kCommandAckLength = 10;           // 2 + 1 + ext (1 + 4 + 1 + 1)
constexpr uint8_t kSetPositionTargetLength = 53;    // 4 + 11 * 4 + 2 + 3 * 1
constexpr uint8_t kTimesyncLength = 18;            // 2 * 8 + ext 2 * 1
constexpr uint8_t kStatusTextLength = 54;           // 1 + 50 + ext (2 + 1)
constexpr uint8_t kDebugFloatArrayLength = 252;     // 8 + 2 + 10 + ext 58 * 4
constexpr uint8_t kLandingTargetLength = 60;        // 8 + 5 * 4 + 2 * 1 + ext (3 * 4 + 4 * 4 + 2 * 1)
constexpr size_t kStatusTextChars = 50;
constexpr size_t kDebugNameChars = 10;

constexpr MessageInfo kInfos[] = {
    {Heartbeat::kId, Heartbeat::kCrcExtra, kHeartbeatLength, "HEARTBEAT"},
    {AttitudeQuaternion::kId, AttitudeQuaternion::kCrcExtra, kAttitudeQuaternionLength, "ATTITUDE_QUATERNION"},
    {LocalPositionNed::kId, LocalPositionNed::kCrcExtra, kLocalPositionNedLength, "LOCAL_POSITION_NED"},
    {CommandLong::kId, CommandLong::kCrcExtra, kCommandLongLength, "COMMAND_LONG"},
    {CommandAck::kId, CommandAck::kCrcExtra, kCommandAckLength, "COMMAND_ACK"},
    {SetPositionTargetLocalNed::kId, SetPositionTargetLocalNed::kCrcExtra, kSetPositionTargetLength,
     "SET_POSITION_TARGET_LOCAL_NED"},
    {Timesync::kId, Timesync::kCrcExtra, kTimesyncLength, "TIMESYNC"},
    {StatusText::kId, StatusText::kCrcExtra, kStatusTextLength, "STATUSTEXT"},
    {DebugFloatArray::kId, DebugFloatArray::kCrcExtra, kDebugFloatArrayLength, "DEBUG_FLOAT_ARRAY"},
    {LandingTarget::kId, LandingTarget::kCrcExtra, kLandingTargetLength, "LANDING_TARGET"},
};

// Little-endian writer into a payload of fixed full length. MAVLink is
// little-endian on the wire whatever the host is, so bytes are assembled
// explicitly rather than memcpy'd from host integers.
class Writer {
 public:
  explicit Writer(size_t length) : bytes_(length, 0) {}
  void U8(uint8_t v) { bytes_[pos_++] = v; }
  void U16(uint16_t v) {
    for (int i = 0; i < 2; ++i) bytes_[pos_++] = static_cast<uint8_t>(v >> (8 * i));
  }
  void U32(uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes_[pos_++] = static_cast<uint8_t>(v >> (8 * i));
  }
  void U64(uint64_t v) {
    for (int i = 0; i < 8; ++i) bytes_[pos_++] = static_cast<uint8_t>(v >> (8 * i));
  }
  void I32(int32_t v) { U32(static_cast<uint32_t>(v)); }
  void F32(float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    U32(bits);
  }
  // A char[n] field: the string's first n bytes, NUL-padded (no terminator
  // when it fills the field, as MAVLink allows).
  void Chars(const std::string& s, size_t n) {
    const size_t copied = std::min(s.size(), n);
    std::memcpy(bytes_.data() + pos_, s.data(), copied);
    pos_ += n;
  }
  std::vector<uint8_t> Take() { return std::move(bytes_); }

 private:
  std::vector<uint8_t> bytes_;
  size_t pos_ = 0;
};

// Reader over a possibly truncated payload: bytes past its end read as zero.
class Reader {
 public:
  Reader(const uint8_t* data, size_t length) : data_(data), length_(length) {}
  uint8_t U8() { return Byte(pos_++); }
  uint16_t U16() { return static_cast<uint16_t>(Unsigned(2)); }
  uint32_t U32() { return static_cast<uint32_t>(Unsigned(4)); }
  uint64_t U64() { return Unsigned(8); }
  int32_t I32() { return static_cast<int32_t>(U32()); }
  float F32() {
    const uint32_t bits = U32();
    float v;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  // A char[n] field up to its first NUL (or all n bytes).
  std::string Chars(size_t n) {
    std::string s;
    for (size_t i = 0; i < n; ++i) {
      const uint8_t c = Byte(pos_ + i);
      if (c == 0) break;
      s.push_back(static_cast<char>(c));
    }
    pos_ += n;
    return s;
  }

 private:
  uint8_t Byte(size_t i) const { return i < length_ ? data_[i] : 0; }
  uint64_t Unsigned(int n) {
    uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<uint64_t>(Byte(pos_ + i)) << (8 * i);
    pos_ += n;
    return v;
  }
  const uint8_t* data_;
  size_t length_;
  size_t pos_ = 0;
};

// One pair of functions per message, fields in wire order.
std::vector<uint8_t> Write(const Heartbeat& m) {
  Writer w(kHeartbeatLength);
  w.U32(m.custom_mode);
  w.U8(m.type);
  w.U8(m.autopilot);
  w.U8(m.base_mode);
  w.U8(m.system_status);
  w.U8(m.mavlink_version);
  return w.Take();
}
Heartbeat ReadHeartbeat(Reader& r) {
  Heartbeat m;
  m.custom_mode = r.U32();
  m.type = r.U8();
  m.autopilot = r.U8();
  m.base_mode = r.U8();
  m.system_status = r.U8();
  m.mavlink_version = r.U8();
  return m;
}

std::vector<uint8_t> Write(const AttitudeQuaternion& m) {
  Writer w(kAttitudeQuaternionLength);
  w.U32(m.time_boot_ms);
  for (float v : {m.q1, m.q2, m.q3, m.q4, m.rollspeed, m.pitchspeed, m.yawspeed}) w.F32(v);
  for (float v : m.repr_offset_q) w.F32(v);
  return w.Take();
}
AttitudeQuaternion ReadAttitudeQuaternion(Reader& r) {
  AttitudeQuaternion m;
  m.time_boot_ms = r.U32();
  m.q1 = r.F32();
  m.q2 = r.F32();
  m.q3 = r.F32();
  m.q4 = r.F32();
  m.rollspeed = r.F32();
  m.pitchspeed = r.F32();
  m.yawspeed = r.F32();
  for (float& v : m.repr_offset_q) v = r.F32();
  return m;
}

std::vector<uint8_t> Write(const LocalPositionNed& m) {
  Writer w(kLocalPositionNedLength);
  w.U32(m.time_boot_ms);
  for (float v : {m.x, m.y, m.z, m.vx, m.vy, m.vz}) w.F32(v);
  return w.Take();
}
LocalPositionNed ReadLocalPositionNed(Reader& r) {
  LocalPositionNed m;
  m.time_boot_ms = r.U32();
  m.x = r.F32();
  m.y = r.F32();
  m.z = r.F32();
  m.vx = r.F32();
  m.vy = r.F32();
  m.vz = r.F32();
  return m;
}

std::vector<uint8_t> Write(const CommandLong& m) {
  Writer w(kCommandLongLength);
  for (float v : {m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7}) w.F32(v);
  w.U16(m.command);
  w.U8(m.target_system);
  w.U8(m.target_component);
  w.U8(m.confirmation);
  return w.Take();
}
CommandLong ReadCommandLong(Reader& r) {
  CommandLong m;
  m.param1 = r.F32();
  m.param2 = r.F32();
  m.param3 = r.F32();
  m.param4 = r.F32();
  m.param5 = r.F32();
  m.param6 = r.F32();
  m.param7 = r.F32();
  m.command = r.U16();
  m.target_system = r.U8();
  m.target_component = r.U8();
  m.confirmation = r.U8();
  return m;
}

std::vector<uint8_t> Write(const CommandAck& m) {
  Writer w(kCommandAckLength);
  w.U16(m.command);
  w.U8(m.result);
  w.U8(m.progress);
  w.I32(m.result_param2);
  w.U8(m.target_system);
  w.U8(m.target_component);
  return w.Take();
}
CommandAck ReadCommandAck(Reader& r) {
  CommandAck m;
  m.command = r.U16();
  m.result = r.U8();
  m.progress = r.U8();
  m.result_param2 = r.I32();
  m.target_system = r.U8();
  m.target_component = r.U8();
  return m;
}

std::vector<uint8_t> Write(const SetPositionTargetLocalNed& m) {
  Writer w(kSetPositionTargetLength);
  w.U32(m.time_boot_ms);
  for (float v : {m.x, m.y, m.z, m.vx, m.vy, m.vz, m.afx, m.afy, m.afz, m.yaw, m.yaw_rate}) w.F32(v);
  w.U16(m.type_mask);
  w.U8(m.target_system);
  w.U8(m.target_component);
  w.U8(m.coordinate_frame);
  return w.Take();
}
SetPositionTargetLocalNed ReadSetPositionTargetLocalNed(Reader& r) {
  SetPositionTargetLocalNed m;
  m.time_boot_ms = r.U32();
  m.x = r.F32();
  m.y = r.F32();
  m.z = r.F32();
  m.vx = r.F32();
  m.vy = r.F32();
  m.vz = r.F32();
  m.afx = r.F32();
  m.afy = r.F32();
  m.afz = r.F32();
  m.yaw = r.F32();
  m.yaw_rate = r.F32();
  m.type_mask = r.U16();
  m.target_system = r.U8();
  m.target_component = r.U8();
  m.coordinate_frame = r.U8();
  return m;
}

std::vector<uint8_t> Write(const Timesync& m) {
  Writer w(kTimesyncLength);
  w.U64(static_cast<uint64_t>(m.tc1));
  w.U64(static_cast<uint64_t>(m.ts1));
  w.U8(m.target_system);
  w.U8(m.target_component);
  return w.Take();
}
Timesync ReadTimesync(Reader& r) {
  Timesync m;
  m.tc1 = static_cast<int64_t>(r.U64());
  m.ts1 = static_cast<int64_t>(r.U64());
  m.target_system = r.U8();
  m.target_component = r.U8();
  return m;
}

std::vector<uint8_t> Write(const StatusText& m) {
  Writer w(kStatusTextLength);
  w.U8(m.severity);
  w.Chars(m.text, kStatusTextChars);
  w.U16(m.id);
  w.U8(m.chunk_seq);
  return w.Take();
}
StatusText ReadStatusText(Reader& r) {
  StatusText m;
  m.severity = r.U8();
  m.text = r.Chars(kStatusTextChars);
  m.id = r.U16();
  m.chunk_seq = r.U8();
  return m;
}

std::vector<uint8_t> Write(const DebugFloatArray& m) {
  Writer w(kDebugFloatArrayLength);
  w.U64(m.time_usec);
  w.U16(m.array_id);
  w.Chars(m.name, kDebugNameChars);
  for (int i = 0; i < DebugFloatArray::kMaxData; ++i) {
    w.F32(i < static_cast<int>(m.data.size()) ? m.data[static_cast<size_t>(i)] : 0.0f);
  }
  return w.Take();
}
DebugFloatArray ReadDebugFloatArray(Reader& r) {
  DebugFloatArray m;
  m.time_usec = r.U64();
  m.array_id = r.U16();
  m.name = r.Chars(kDebugNameChars);
  // The data extension is always 58 values: trailing zero values are
  // indistinguishable from the padding truncated on the wire, so the decoder
  // returns the whole array and the array's meaning (e.g. JOINTS: n angles)
  // says how many values count.
  m.data.resize(DebugFloatArray::kMaxData);
  for (float& v : m.data) v = r.F32();
  return m;
}

std::vector<uint8_t> Write(const LandingTarget& m) {
  Writer w(kLandingTargetLength);
  w.U64(m.time_usec);
  for (float v : {m.angle_x, m.angle_y, m.distance, m.size_x, m.size_y}) w.F32(v);
  w.U8(m.target_num);
  w.U8(m.frame);
  for (float v : {m.x, m.y, m.z}) w.F32(v);
  for (float v : m.q) w.F32(v);
  w.U8(m.type);
  w.U8(m.position_valid);
  return w.Take();
}
LandingTarget ReadLandingTarget(Reader& r) {
  LandingTarget m;
  m.time_usec = r.U64();
  m.angle_x = r.F32();
  m.angle_y = r.F32();
  m.distance = r.F32();
  m.size_x = r.F32();
  m.size_y = r.F32();
  m.target_num = r.U8();
  m.frame = r.U8();
  m.x = r.F32();
  m.y = r.F32();
  m.z = r.F32();
  for (float& v : m.q) v = r.F32();
  m.type = r.U8();
  m.position_valid = r.U8();
  return m;
}

}  // namespace

std::optional<MessageInfo> FindMessageInfo(uint32_t id) {
  for (const MessageInfo& info : kInfos) {
    if (info.id == id) return info;
  }
  return std::nullopt;
}

uint32_t MessageId(const Message& message) {
  return std::visit([](const auto& m) { return std::decay_t<decltype(m)>::kId; }, message);
}

std::vector<uint8_t> SerializePayload(const Message& message) {
  return std::visit([](const auto& m) { return Write(m); }, message);
}

std::optional<Message> DeserializePayload(uint32_t id, const uint8_t* payload, size_t length) {
  const std::optional<MessageInfo> info = FindMessageInfo(id);
  if (!info || length > info->max_length) return std::nullopt;
  Reader r(payload, length);
  switch (id) {
    case Heartbeat::kId: return Message(ReadHeartbeat(r));
    case AttitudeQuaternion::kId: return Message(ReadAttitudeQuaternion(r));
    case LocalPositionNed::kId: return Message(ReadLocalPositionNed(r));
    case CommandLong::kId: return Message(ReadCommandLong(r));
    case CommandAck::kId: return Message(ReadCommandAck(r));
    case SetPositionTargetLocalNed::kId: return Message(ReadSetPositionTargetLocalNed(r));
    case Timesync::kId: return Message(ReadTimesync(r));
    case StatusText::kId: return Message(ReadStatusText(r));
    case DebugFloatArray::kId: return Message(ReadDebugFloatArray(r));
    case LandingTarget::kId: return Message(ReadLandingTarget(r));
    default: return std::nullopt;
  }
}

}  // namespace quadhand::link
