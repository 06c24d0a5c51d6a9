// MAVLink 2 framing: the frame layout, CRC-16/MCRF4XX (X.25) with each
// message's CRC_EXTRA, trailing-zero payload truncation, sequence numbers,
// message signing (SHA-256, 48-bit signature, link id, 10-microsecond
// timestamps since 2015-01-01), and a byte-stream parser that resynchronises
// after garbage.
//
// Frame: 0xFD len incompat compat seq sysid compid msgid(3, LE) payload(len)
//        crc(2, LE) [link_id timestamp(6, LE) signature(6)] when incompat & 0x01.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/link/messages.h"

namespace quadhand::link {

constexpr uint8_t kMagicV2 = 0xFD;
constexpr uint8_t kIncompatSigned = 0x01;
constexpr size_t kHeaderLength = 10;     // magic .. msgid
constexpr size_t kChecksumLength = 2;
constexpr size_t kSignatureLength = 13;  // link id + timestamp + signature
constexpr size_t kMaxFrameLength = kHeaderLength + 255 + kChecksumLength + kSignatureLength;

// CRC-16/MCRF4XX (the X.25 CRC of MAVLink): init 0xFFFF, reflected poly 0x8408.
uint16_t Crc16(const uint8_t* data, size_t length, uint16_t crc = 0xFFFF);

// A 32-byte secret key shared by both ends.
using SigningKey = std::array<uint8_t, 32>;
// Reads a key file: 64 hexadecimal digits (whitespace ignored) or exactly 32 raw bytes.
core::Result<SigningKey> LoadSigningKey(const std::string& path);

// The signing timestamp now: units of 10 microseconds since 2015-01-01 00:00 UTC.
uint64_t SigningTimestampNow();

// One parsed frame (after CRC and, when required, signature checks).
struct Frame {
  uint8_t sequence = 0;
  uint8_t system_id = 0;
  uint8_t component_id = 0;
  uint32_t message_id = 0;
  std::vector<uint8_t> payload;  // as received (possibly truncated)
  bool is_signed = false;
  uint8_t link_id = 0;
  uint64_t timestamp = 0;        // signing timestamp, when signed
};

struct EncoderOptions {
  uint8_t system_id = 1;
  uint8_t component_id = 1;
  // When set, every frame is signed with this key and link id; timestamps
  // come from SigningTimestampNow(), strictly increasing.
  std::optional<SigningKey> signing_key;
  uint8_t link_id = 0;
};

// Builds frames; sequence numbers count up from 0 and wrap at 256.
class Encoder {
 public:
  explicit Encoder(EncoderOptions options = {});
  std::vector<uint8_t> Encode(const Message& message);
  // A frame for an arbitrary id and payload (the payload is truncated of
  // trailing zeros; unknown ids use crc_extra as given). For tests and tools.
  std::vector<uint8_t> EncodeRaw(uint32_t message_id, uint8_t crc_extra, std::vector<uint8_t> payload);
  uint8_t next_sequence() const { return sequence_; }

 private:
  EncoderOptions options_;
  uint8_t sequence_ = 0;
  uint64_t last_timestamp_ = 0;
};

struct ParserOptions {
  // Key to verify signatures with; signed frames are accepted unverified
  // without one (and with require_signing false).
  std::optional<SigningKey> signing_key;
  // Drop unsigned frames, frames whose signature does not verify, and
  // replays (a timestamp not newer than the last accepted one from the same
  // (system, component, link id)).
  bool require_signing = false;
};

// Why frames were dropped, counted.
struct ParserStats {
  uint64_t frames_accepted = 0;
  uint64_t bytes_skipped = 0;           // garbage before a magic byte, or of dropped frames
  uint64_t bad_checksum = 0;
  uint64_t unknown_message = 0;         // ids without a CRC_EXTRA known here
  uint64_t unknown_incompat_flags = 0;
  uint64_t oversized_payload = 0;       // longer than the message's full length
  uint64_t unsigned_rejected = 0;
  uint64_t bad_signature = 0;
  uint64_t replayed = 0;
  uint64_t sequence_gaps = 0;           // missing sequence numbers per (system, component)
};

// Parses a byte stream (or datagrams fed one after another) into frames.
class Parser {
 public:
  explicit Parser(ParserOptions options = {});
  // Appends bytes; complete frames become available from Next().
  void Feed(const uint8_t* data, size_t length);
  void Feed(const std::vector<uint8_t>& bytes) { Feed(bytes.data(), bytes.size()); }
  // The next accepted frame, or nullopt when no complete frame is buffered.
  std::optional<Frame> Next();
  const ParserStats& stats() const { return stats_; }

 private:
  struct State;
  ParserOptions options_;
  ParserStats stats_;
  std::vector<uint8_t> buffer_;
  std::vector<std::array<uint64_t, 3>> last_timestamps_;  // (sys<<16|comp<<8|link, timestamp, -)
  std::vector<std::array<uint32_t, 2>> last_sequences_;   // (sys<<8|comp, seq)
  uint64_t newest_timestamp_ = 0;  // newest signing timestamp accepted from any stream
};

// Decodes a frame's message; nullopt for unknown ids.
inline std::optional<Message> Decode(const Frame& frame) {
  return DeserializePayload(frame.message_id, frame.payload.data(), frame.payload.size());
}

}  // namespace quadhand::link
