// The link's messages against their common.xml definitions: CRC_EXTRA and
// full lengths recomputed here from the XML field lists (an independent
// implementation of mavgen's rule), and every field found at the offset the
// wire-order rule gives it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "quadhand/link/frame.h"
#include "quadhand/link/messages.h"

namespace quadhand::link {
namespace {

// One <field> of common.xml, in declaration order.
struct XmlField {
  std::string type;  // as in the XML without the array suffix ("uint8_t_mavlink_version" kept)
  std::string name;
  int array_length = 0;  // 0: not an array
  bool extension = false;
};

struct XmlMessage {
  std::string name;
  uint32_t id;
  std::vector<XmlField> fields;
};

// Copied by hand from message_definitions/v1.0/common.xml (and minimal.xml
// for HEARTBEAT), in the order the XML declares them.
std::vector<XmlMessage> XmlDefinitions() {
  return {
      {"HEARTBEAT",
       0,
       {{"uint8_t", "type"},
        {"uint8_t", "autopilot"},
        {"uint8_t", "base_mode"},
        {"uint32_t", "custom_mode"},
        {"uint8_t", "system_status"},
        {"uint8_t_mavlink_version", "mavlink_version"}}},
      {"ATTITUDE_QUATERNION",
       31,
       {{"uint32_t", "time_boot_ms"},
        {"float", "q1"},
        {"float", "q2"},
        {"float", "q3"},
        {"float", "q4"},
        {"float", "rollspeed"},
        {"float", "pitchspeed"},
        {"float", "yawspeed"},
        {"float", "repr_offset_q", 4, true}}},
      {"LOCAL_POSITION_NED",
       32,
       {{"uint32_t", "time_boot_ms"},
        {"float", "x"},
        {"float", "y"},
        {"float", "z"},
        {"float", "vx"},
        {"float", "vy"},
        {"float", "vz"}}},
      {"COMMAND_LONG",
       76,
       {{"uint8_t", "target_system"},
        {"uint8_t", "target_component"},
        {"uint16_t", "command"},
        {"uint8_t", "confirmation"},
        {"float", "param1"},
        {"float", "param2"},
        {"float", "param3"},
        {"float", "param4"},
        {"float", "param5"},
        {"float", "param6"},
        {"float", "param7"}}},
      {"COMMAND_ACK",
       77,
       {{"uint16_t", "command"},
        {"uint8_t", "result"},
        {"uint8_t", "progress", 0, true},
        {"int32_t", "result_param2", 0, true},
        {"uint8_t", "target_system", 0, true},
        {"uint8_t", "target_component", 0, true}}},
      {"SET_POSITION_TARGET_LOCAL_NED",
       84,
       {{"uint32_t", "time_boot_ms"},
        {"uint8_t", "target_system"},
        {"uint8_t", "target_component"},
        {"uint8_t", "coordinate_frame"},
        {"uint16_t", "type_mask"},
        {"float", "x"},
        {"float", "y"},
        {"float", "z"},
        {"float", "vx"},
        {"float", "vy"},
        {"float", "vz"},
        {"float", "afx"},
        {"float", "afy"},
        {"float", "afz"},
        {"float", "yaw"},
        {"float", "yaw_rate"}}},
      {"TIMESYNC",
       111,
       {{"int64_t", "tc1"},
        {"int64_t", "ts1"},
        {"uint8_t", "target_system", 0, true},
        {"uint8_t", "target_component", 0, true}}},
      {"STATUSTEXT",
       253,
       {{"uint8_t", "severity"}, {"char", "text", 50}, {"uint16_t", "id", 0, true}, {"uint8_t", "chunk_seq", 0, true}}},
      {"DEBUG_FLOAT_ARRAY",
       350,
       {{"uint64_t", "time_usec"}, {"char", "name", 10}, {"uint16_t", "array_id"}, {"float", "data", 58, true}}},
      {"LANDING_TARGET",
       149,
       {{"uint64_t", "time_usec"}, {"uint8_t", "target_num"}, {"uint8_t", "frame"}, {"float", "angle_x"},
        {"float", "angle_y"}, {"float", "distance"}, {"float", "size_x"}, {"float", "size_y"},
        {"float", "x", 0, true}, {"float", "y", 0, true}, {"float", "z", 0, true}, {"float", "q", 4, true},
        {"uint8_t", "type", 0, true}, {"uint8_t", "position_valid", 0, true}}},
  };
}

int TypeSize(const std::string& type) {
  static const std::map<std::string, int> sizes = {
      {"char", 1},     {"uint8_t", 1},  {"int8_t", 1},   {"uint8_t_mavlink_version", 1},
      {"uint16_t", 2}, {"int16_t", 2},  {"uint32_t", 4}, {"int32_t", 4},
      {"float", 4},    {"uint64_t", 8}, {"int64_t", 8},  {"double", 8}};
  return sizes.at(type);
}

// mavgen's wire order: base fields stably sorted by element size, largest
// first; extension fields after them in declaration order.
std::vector<XmlField> WireOrder(const std::vector<XmlField>& fields) {
  std::vector<XmlField> base, extensions;
  for (const XmlField& f : fields) (f.extension ? extensions : base).push_back(f);
  std::stable_sort(base.begin(), base.end(),
                   [](const XmlField& a, const XmlField& b) { return TypeSize(a.type) > TypeSize(b.type); });
  base.insert(base.end(), extensions.begin(), extensions.end());
  return base;
}

// Independent CRC-16/MCRF4XX, bit by bit (the library uses the byte-wise form).
uint16_t BitwiseCrc(const std::string& bytes, uint16_t crc) {
  for (unsigned char c : bytes) {
    crc ^= c;
    for (int i = 0; i < 8; ++i) crc = (crc & 1) ? static_cast<uint16_t>((crc >> 1) ^ 0x8408) : static_cast<uint16_t>(crc >> 1);
  }
  return crc;
}

// CRC_EXTRA: CRC over "NAME " then, per base field in wire order, "type "
// "name " and (arrays) the length byte; folded to 8 bits.
uint8_t CrcExtra(const XmlMessage& message) {
  uint16_t crc = BitwiseCrc(message.name + " ", 0xFFFF);
  for (const XmlField& f : WireOrder(message.fields)) {
    if (f.extension) continue;
    const std::string type = f.type == "uint8_t_mavlink_version" ? "uint8_t" : f.type;
    crc = BitwiseCrc(type + " ", crc);
    crc = BitwiseCrc(f.name + " ", crc);
    if (f.array_length > 0) crc = BitwiseCrc(std::string(1, static_cast<char>(f.array_length)), crc);
  }
  return static_cast<uint8_t>((crc & 0xFF) ^ (crc >> 8));
}

int FullLength(const XmlMessage& message) {
  int length = 0;
  for (const XmlField& f : message.fields) length += TypeSize(f.type) * std::max(1, f.array_length);
  return length;
}

TEST(MessagesTest, CrcExtraAndLengthsMatchTheXmlDefinitions) {
  const std::map<uint32_t, uint8_t> declared = {
      {Heartbeat::kId, Heartbeat::kCrcExtra},
      {AttitudeQuaternion::kId, AttitudeQuaternion::kCrcExtra},
      {LocalPositionNed::kId, LocalPositionNed::kCrcExtra},
      {CommandLong::kId, CommandLong::kCrcExtra},
      {CommandAck::kId, CommandAck::kCrcExtra},
      {SetPositionTargetLocalNed::kId, SetPositionTargetLocalNed::kCrcExtra},
      {Timesync::kId, Timesync::kCrcExtra},
      {StatusText::kId, StatusText::kCrcExtra},
      {DebugFloatArray::kId, DebugFloatArray::kCrcExtra},
      {LandingTarget::kId, LandingTarget::kCrcExtra},
  };
  for (const XmlMessage& m : XmlDefinitions()) {
    SCOPED_TRACE(m.name);
    const std::optional<MessageInfo> info = FindMessageInfo(m.id);
    ASSERT_TRUE(info.has_value());
    EXPECT_EQ(info->name, m.name);
    EXPECT_EQ(int{CrcExtra(m)}, int{info->crc_extra});
    EXPECT_EQ(int{CrcExtra(m)}, int{declared.at(m.id)});
    EXPECT_EQ(FullLength(m), int{info->max_length});
  }
  // Published values, as a check of the computation itself (mavgen output).
  EXPECT_EQ(CrcExtra(XmlDefinitions()[0]), 50);
  EXPECT_FALSE(FindMessageInfo(1).has_value());
}

// A marker value written into one field, and the bytes it must produce.
struct FieldProbe {
  std::function<void(Message&)> set;
  std::vector<uint8_t> bytes;
};

std::vector<uint8_t> FloatBytes(float f) {
  uint32_t bits;
  std::memcpy(&bits, &f, 4);
  return {static_cast<uint8_t>(bits), static_cast<uint8_t>(bits >> 8), static_cast<uint8_t>(bits >> 16),
          static_cast<uint8_t>(bits >> 24)};
}

template <typename M>
std::function<void(Message&)> Set(std::function<void(M&)> f) {
  return [f](Message& m) { f(std::get<M>(m)); };
}

const std::vector<uint8_t> kU8 = {0xA5};
const std::vector<uint8_t> kU16 = {0x1B, 0xA5};
const std::vector<uint8_t> kU32 = {0x3D, 0x2C, 0x1B, 0xA5};
const std::vector<uint8_t> kU64 = {0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0xA1};
constexpr uint16_t kV16 = 0xA51B;
constexpr uint32_t kV32 = 0xA51B2C3D;
constexpr uint64_t kV64 = 0xA102030405060708ULL;
constexpr float kF = -3.25f;

#define PROBE(M, field, value, bytes) \
  {#field, FieldProbe{Set<M>([](M& m) { m.field = value; }), bytes}}

std::map<std::string, FieldProbe> Probes(uint32_t id) {
  const std::vector<uint8_t> f = FloatBytes(kF);
  switch (id) {
    case Heartbeat::kId:
      return {PROBE(Heartbeat, type, 0xA5, kU8), PROBE(Heartbeat, autopilot, 0xA5, kU8),
              PROBE(Heartbeat, base_mode, 0xA5, kU8), PROBE(Heartbeat, custom_mode, kV32, kU32),
              PROBE(Heartbeat, system_status, 0xA5, kU8), PROBE(Heartbeat, mavlink_version, 0xA5, kU8)};
    case AttitudeQuaternion::kId:
      return {PROBE(AttitudeQuaternion, time_boot_ms, kV32, kU32), PROBE(AttitudeQuaternion, q1, kF, f),
              PROBE(AttitudeQuaternion, q2, kF, f), PROBE(AttitudeQuaternion, q3, kF, f),
              PROBE(AttitudeQuaternion, q4, kF, f), PROBE(AttitudeQuaternion, rollspeed, kF, f),
              PROBE(AttitudeQuaternion, pitchspeed, kF, f), PROBE(AttitudeQuaternion, yawspeed, kF, f),
              PROBE(AttitudeQuaternion, repr_offset_q[0], kF, f)};
    case LocalPositionNed::kId:
      return {PROBE(LocalPositionNed, time_boot_ms, kV32, kU32), PROBE(LocalPositionNed, x, kF, f),
              PROBE(LocalPositionNed, y, kF, f), PROBE(LocalPositionNed, z, kF, f),
              PROBE(LocalPositionNed, vx, kF, f), PROBE(LocalPositionNed, vy, kF, f),
              PROBE(LocalPositionNed, vz, kF, f)};
    case CommandLong::kId:
      return {PROBE(CommandLong, target_system, 0xA5, kU8), PROBE(CommandLong, target_component, 0xA5, kU8),
              PROBE(CommandLong, command, kV16, kU16), PROBE(CommandLong, confirmation, 0xA5, kU8),
              PROBE(CommandLong, param1, kF, f), PROBE(CommandLong, param2, kF, f),
              PROBE(CommandLong, param3, kF, f), PROBE(CommandLong, param4, kF, f),
              PROBE(CommandLong, param5, kF, f), PROBE(CommandLong, param6, kF, f),
              PROBE(CommandLong, param7, kF, f)};
    case CommandAck::kId:
      return {PROBE(CommandAck, command, kV16, kU16), PROBE(CommandAck, result, 0xA5, kU8),
              PROBE(CommandAck, progress, 0xA5, kU8), PROBE(CommandAck, result_param2, static_cast<int32_t>(kV32), kU32),
              PROBE(CommandAck, target_system, 0xA5, kU8), PROBE(CommandAck, target_component, 0xA5, kU8)};
    case SetPositionTargetLocalNed::kId:
      return {PROBE(SetPositionTargetLocalNed, time_boot_ms, kV32, kU32),
              PROBE(SetPositionTargetLocalNed, target_system, 0xA5, kU8),
              PROBE(SetPositionTargetLocalNed, target_component, 0xA5, kU8),
              PROBE(SetPositionTargetLocalNed, coordinate_frame, 0xA5, kU8),
              PROBE(SetPositionTargetLocalNed, type_mask, kV16, kU16),
              PROBE(SetPositionTargetLocalNed, x, kF, f),
              PROBE(SetPositionTargetLocalNed, y, kF, f),
              PROBE(SetPositionTargetLocalNed, z, kF, f),
              PROBE(SetPositionTargetLocalNed, vx, kF, f),
              PROBE(SetPositionTargetLocalNed, vy, kF, f),
              PROBE(SetPositionTargetLocalNed, vz, kF, f),
              PROBE(SetPositionTargetLocalNed, afx, kF, f),
              PROBE(SetPositionTargetLocalNed, afy, kF, f),
              PROBE(SetPositionTargetLocalNed, afz, kF, f),
              PROBE(SetPositionTargetLocalNed, yaw, kF, f),
              PROBE(SetPositionTargetLocalNed, yaw_rate, kF, f)};
    case Timesync::kId:
      return {PROBE(Timesync, tc1, static_cast<int64_t>(kV64), kU64), PROBE(Timesync, ts1, static_cast<int64_t>(kV64), kU64),
              PROBE(Timesync, target_system, 0xA5, kU8), PROBE(Timesync, target_component, 0xA5, kU8)};
    case StatusText::kId:
      return {PROBE(StatusText, severity, 0xA5, kU8), PROBE(StatusText, text, "Ab", (std::vector<uint8_t>{'A', 'b'})),
              PROBE(StatusText, id, kV16, kU16), PROBE(StatusText, chunk_seq, 0xA5, kU8)};
    case DebugFloatArray::kId:
      return {PROBE(DebugFloatArray, time_usec, kV64, kU64), PROBE(DebugFloatArray, name, "Ab", (std::vector<uint8_t>{'A', 'b'})),
              PROBE(DebugFloatArray, array_id, kV16, kU16), PROBE(DebugFloatArray, data, std::vector<float>{kF}, f)};
    case LandingTarget::kId:
      return {PROBE(LandingTarget, time_usec, kV64, kU64), PROBE(LandingTarget, target_num, 0xA5, kU8),
              PROBE(LandingTarget, frame, 0xA5, kU8), PROBE(LandingTarget, angle_x, kF, f),
              PROBE(LandingTarget, angle_y, kF, f), PROBE(LandingTarget, distance, kF, f),
              PROBE(LandingTarget, size_x, kF, f), PROBE(LandingTarget, size_y, kF, f),
              PROBE(LandingTarget, x, kF, f), PROBE(LandingTarget, y, kF, f), PROBE(LandingTarget, z, kF, f),
              PROBE(LandingTarget, q[0], kF, f), PROBE(LandingTarget, type, 0xA5, kU8),
              PROBE(LandingTarget, position_valid, 0xA5, kU8)};
    default:
      return {};
  }
}
#undef PROBE

Message DefaultMessage(uint32_t id) {
  switch (id) {
    case Heartbeat::kId: return Heartbeat{};
    case AttitudeQuaternion::kId: return AttitudeQuaternion{};
    case LocalPositionNed::kId: return LocalPositionNed{};
    case CommandLong::kId: return CommandLong{};
    case CommandAck::kId: return CommandAck{};
    case SetPositionTargetLocalNed::kId: return SetPositionTargetLocalNed{};
    case Timesync::kId: return Timesync{};
    case StatusText::kId: return StatusText{};
    case LandingTarget::kId: return LandingTarget{};
    default: return DebugFloatArray{};
  }
}

// Each field changes exactly the bytes at the offset the wire-order rule
// gives it, little-endian, and nothing else.
TEST(MessagesTest, EveryFieldSitsAtItsWireOffset) {
  for (const XmlMessage& m : XmlDefinitions()) {
    SCOPED_TRACE(m.name);
    const Message base = DefaultMessage(m.id);
    ASSERT_EQ(MessageId(base), m.id);
    const std::vector<uint8_t> base_bytes = SerializePayload(base);
    ASSERT_EQ(static_cast<int>(base_bytes.size()), FullLength(m));
    std::map<std::string, FieldProbe> probes = Probes(m.id);
    ASSERT_EQ(probes.size(), m.fields.size());
    int offset = 0;
    for (const XmlField& f : WireOrder(m.fields)) {
      SCOPED_TRACE(f.name);
      const std::string key = f.name == "repr_offset_q" ? "repr_offset_q[0]" : f.name == "q" ? "q[0]" : f.name;
      ASSERT_TRUE(probes.count(key));
      Message probe = base;
      probes.at(key).set(probe);
      const std::vector<uint8_t> bytes = SerializePayload(probe);
      const std::vector<uint8_t>& expected = probes.at(key).bytes;
      ASSERT_EQ(bytes.size(), base_bytes.size());
      for (size_t i = 0; i < bytes.size(); ++i) {
        const int rel = static_cast<int>(i) - offset;
        if (rel >= 0 && rel < static_cast<int>(expected.size())) {
          EXPECT_EQ(int{bytes[i]}, int{expected[static_cast<size_t>(rel)]}) << "byte " << i;
        } else {
          EXPECT_EQ(int{bytes[i]}, int{base_bytes[i]}) << "byte " << i << " changed";
        }
      }
      offset += TypeSize(f.type) * std::max(1, f.array_length);
    }
  }
}

TEST(MessagesTest, StringsAreCutToTheirFieldAndArraysPadded) {
  StatusText text;
  text.text = std::string(60, 'x');
  const std::vector<uint8_t> bytes = SerializePayload(text);
  ASSERT_EQ(bytes.size(), 54u);
  const std::optional<Message> back = DeserializePayload(StatusText::kId, bytes.data(), bytes.size());
  ASSERT_TRUE(back);
  EXPECT_EQ(std::get<StatusText>(*back).text, std::string(50, 'x'));  // exactly 50, no terminator

  DebugFloatArray array;
  array.name = "JOINTS_LONG_NAME";
  array.data = {1.0f, 2.0f};
  const std::vector<uint8_t> a = SerializePayload(array);
  const std::optional<Message> decoded = DeserializePayload(DebugFloatArray::kId, a.data(), a.size());
  ASSERT_TRUE(decoded);
  const auto& d = std::get<DebugFloatArray>(*decoded);
  EXPECT_EQ(d.name, "JOINTS_LON");
  ASSERT_EQ(d.data.size(), 58u);
  EXPECT_EQ(d.data[0], 1.0f);
  EXPECT_EQ(d.data[1], 2.0f);
  EXPECT_EQ(d.data[57], 0.0f);
}

TEST(MessagesTest, ShortPayloadsAreZeroFilledAndLongOnesRejected) {
  LocalPositionNed position;
  position.time_boot_ms = 0x01020304;
  position.x = 5.0f;
  std::vector<uint8_t> bytes = SerializePayload(position);
  // Only time_boot_ms and the first two bytes of x arrive.
  std::optional<Message> decoded = DeserializePayload(LocalPositionNed::kId, bytes.data(), 6);
  ASSERT_TRUE(decoded);
  const auto& p = std::get<LocalPositionNed>(*decoded);
  EXPECT_EQ(p.time_boot_ms, 0x01020304u);
  EXPECT_EQ(p.x, 0.0f);  // 5.0f is 0x40A00000: its low bytes are zero, the high ones were cut
  EXPECT_EQ(p.vz, 0.0f);
  // Length 0: every field zero.
  decoded = DeserializePayload(Heartbeat::kId, nullptr, 0);
  ASSERT_TRUE(decoded);
  EXPECT_EQ(std::get<Heartbeat>(*decoded).mavlink_version, 0);
  // Longer than the full message: not this message.
  bytes.push_back(1);
  EXPECT_FALSE(DeserializePayload(LocalPositionNed::kId, bytes.data(), bytes.size()));
  EXPECT_FALSE(DeserializePayload(12345, bytes.data(), 3));
}

}  // namespace
}  // namespace quadhand::link
