// MAVLink 2 framing: round trips of every message, truncation, CRC, resync,
// counters, sequence numbers and signing (with a known-answer frame computed
// outside this library: Python's hashlib and a separate CRC implementation).
#include <gtest/gtest.h>
#include <openssl/sha.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "quadhand/link/frame.h"
#include "quadhand/link/messages.h"
#include "link/sample_messages.h"

namespace quadhand::link {
namespace {

std::vector<uint8_t> FromHex(const std::string& hex) {
  std::vector<uint8_t> bytes;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) bytes.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return bytes;
}

SigningKey KeyOf(uint8_t first) {
  SigningKey key;
  for (size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(first + i);
  return key;
}

using link_testing::SampleMessages;

std::vector<Frame> ParseAll(Parser& parser) {
  std::vector<Frame> frames;
  while (std::optional<Frame> f = parser.Next()) frames.push_back(std::move(*f));
  return frames;
}

TEST(FrameTest, Crc16IsMcrf4xx) {
  const std::string check = "123456789";
  EXPECT_EQ(Crc16(reinterpret_cast<const uint8_t*>(check.data()), check.size()), 0x6F91);  // catalogue check value
}

TEST(FrameTest, EncodesTheKnownAnswerFrame) {
  // Computed outside this library (Python: CRC-16/MCRF4XX + CRC_EXTRA 50).
  Heartbeat heartbeat;
  heartbeat.custom_mode = 3u << 16;
  heartbeat.type = 2;
  heartbeat.autopilot = 12;
  heartbeat.base_mode = 129;
  heartbeat.system_status = 4;
  heartbeat.mavlink_version = 3;
  Encoder encoder;
  EXPECT_EQ(encoder.Encode(heartbeat), FromHex("fd09000000010100000000000300020c810403b306"));
}

TEST(FrameTest, EveryMessageRoundTripsUnsignedAndSigned) {
  for (const bool sign : {false, true}) {
    SCOPED_TRACE(sign ? "signed" : "unsigned");
    EncoderOptions eo;
    eo.system_id = 42;
    eo.component_id = 191;
    eo.link_id = 3;
    if (sign) eo.signing_key = KeyOf(1);
    Encoder encoder(eo);
    ParserOptions po;
    po.signing_key = KeyOf(1);
    po.require_signing = sign;
    Parser parser(po);
    const std::vector<Message> messages = SampleMessages();
    for (const Message& m : messages) parser.Feed(encoder.Encode(m));
    const std::vector<Frame> frames = ParseAll(parser);
    ASSERT_EQ(frames.size(), messages.size());
    for (size_t i = 0; i < frames.size(); ++i) {
      SCOPED_TRACE(i);
      EXPECT_EQ(frames[i].system_id, 42);
      EXPECT_EQ(frames[i].component_id, 191);
      EXPECT_EQ(static_cast<size_t>(frames[i].sequence), i);
      EXPECT_EQ(frames[i].is_signed, sign);
      if (sign) {
        EXPECT_EQ(frames[i].link_id, 3);
      }
      const std::optional<Message> decoded = Decode(frames[i]);
      ASSERT_TRUE(decoded);
      // Field-by-field equality through the canonical serialisation.
      EXPECT_EQ(SerializePayload(*decoded), SerializePayload(messages[i]));
    }
    EXPECT_EQ(parser.stats().frames_accepted, messages.size());
    EXPECT_EQ(parser.stats().bytes_skipped, 0u);
    EXPECT_EQ(parser.stats().sequence_gaps, 0u);
  }
}

TEST(FrameTest, TrailingZerosAreStrippedButOneByteIsKept) {
  Encoder encoder;
  Heartbeat heartbeat;  // mavlink_version 3 is the last byte: nothing to strip
  EXPECT_EQ(encoder.Encode(heartbeat)[1], 9);
  heartbeat.mavlink_version = 0;
  heartbeat.type = 2;  // byte 4; bytes 5..8 are zero
  EXPECT_EQ(encoder.Encode(heartbeat)[1], 5);
  // An all-zero message keeps its first byte, as the reference C library does.
  const std::vector<uint8_t> zero = encoder.Encode(CommandAck{});
  EXPECT_EQ(zero[1], 1);
  EXPECT_EQ(zero.size(), kHeaderLength + 1 + kChecksumLength);
  // DEBUG_FLOAT_ARRAY's 58-float extension is cut after the last non-zero value.
  DebugFloatArray joints;
  joints.name = "JOINTS";
  joints.data = {1.0f, 2.0f};
  EXPECT_EQ(encoder.Encode(joints)[1], 8 + 2 + 10 + 8);
  // ...and decodes with the stripped bytes as zeros.
  Parser parser;
  parser.Feed(encoder.Encode(joints));
  const std::optional<Frame> frame = parser.Next();
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->payload.size(), 28u);
  const auto decoded = std::get<DebugFloatArray>(*Decode(*frame));
  EXPECT_EQ(decoded.data[1], 2.0f);
  EXPECT_EQ(decoded.data[2], 0.0f);
}

// A frame built by hand, for lengths and flags the encoder never produces.
std::vector<uint8_t> HandFrame(uint32_t id, uint8_t crc_extra, const std::vector<uint8_t>& payload,
                               uint8_t incompat = 0) {
  std::vector<uint8_t> f = {kMagicV2, static_cast<uint8_t>(payload.size()), incompat, 0, 9, 1, 1,
                            static_cast<uint8_t>(id), static_cast<uint8_t>(id >> 8), static_cast<uint8_t>(id >> 16)};
  f.insert(f.end(), payload.begin(), payload.end());
  uint16_t crc = Crc16(f.data() + 1, f.size() - 1);
  crc = Crc16(&crc_extra, 1, crc);
  f.push_back(static_cast<uint8_t>(crc));
  f.push_back(static_cast<uint8_t>(crc >> 8));
  return f;
}

TEST(FrameTest, LengthZeroPayloadIsAccepted) {
  // node-mavlink sends an all-zero message with an empty payload.
  Parser parser;
  parser.Feed(HandFrame(Heartbeat::kId, Heartbeat::kCrcExtra, {}));
  const std::optional<Frame> frame = parser.Next();
  ASSERT_TRUE(frame);
  EXPECT_TRUE(frame->payload.empty());
  const std::optional<Message> m = Decode(*frame);
  ASSERT_TRUE(m);
  EXPECT_EQ(std::get<Heartbeat>(*m).custom_mode, 0u);
  EXPECT_EQ(std::get<Heartbeat>(*m).mavlink_version, 0);
}

TEST(FrameTest, CorruptedByteIsDroppedAndCounted) {
  Encoder encoder;
  const std::vector<Message> messages = SampleMessages();
  std::vector<uint8_t> bad = encoder.Encode(messages[2]);
  bad[12] ^= 0x40;  // a payload byte
  Parser parser;
  parser.Feed(bad);
  parser.Feed(encoder.Encode(messages[0]));
  const std::vector<Frame> frames = ParseAll(parser);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].message_id, Heartbeat::kId);
  EXPECT_EQ(parser.stats().bad_checksum, 1u);
  EXPECT_EQ(parser.stats().bytes_skipped, bad.size());
  // A wrong CRC_EXTRA (another definition of the message) fails the same way.
  parser.Feed(encoder.EncodeRaw(Heartbeat::kId, Heartbeat::kCrcExtra + 1, SerializePayload(messages[0])));
  EXPECT_FALSE(parser.Next());
  EXPECT_EQ(parser.stats().bad_checksum, 2u);
}

TEST(FrameTest, TruncatedFrameWaitsForMoreThenCompletes) {
  Encoder encoder;
  const std::vector<uint8_t> frame = encoder.Encode(SampleMessages()[1]);
  Parser parser;
  for (size_t split : {size_t{1}, size_t{5}, kHeaderLength, frame.size() - 1}) {
    SCOPED_TRACE(split);
    parser.Feed(frame.data(), split);
    EXPECT_FALSE(parser.Next());
    parser.Feed(frame.data() + split, frame.size() - split);
    EXPECT_TRUE(parser.Next());
  }
  EXPECT_EQ(parser.stats().bytes_skipped, 0u);
  EXPECT_EQ(parser.stats().frames_accepted, 4u);
}

TEST(FrameTest, CutFrameFollowedByAnotherIsDropped) {
  Encoder encoder;
  const std::vector<Message> messages = SampleMessages();
  const std::vector<uint8_t> cut = encoder.Encode(messages[5]);
  Parser parser;
  parser.Feed(cut.data(), cut.size() / 2);  // the rest never arrives
  parser.Feed(encoder.Encode(messages[0]));
  parser.Feed(encoder.Encode(messages[2]));
  const std::vector<Frame> frames = ParseAll(parser);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].message_id, Heartbeat::kId);
  EXPECT_EQ(frames[1].message_id, LocalPositionNed::kId);
  EXPECT_GE(parser.stats().bad_checksum, 1u);
}

TEST(FrameTest, OversizedPayloadIsDroppedAndCounted) {
  Encoder encoder;
  // 20 non-zero bytes for HEARTBEAT, whose full payload is 9.
  std::vector<uint8_t> payload(20, 0x11);
  Parser parser;
  parser.Feed(encoder.EncodeRaw(Heartbeat::kId, Heartbeat::kCrcExtra, payload));
  parser.Feed(encoder.Encode(SampleMessages()[0]));
  const std::vector<Frame> frames = ParseAll(parser);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].sequence, 1);
  EXPECT_EQ(parser.stats().oversized_payload, 1u);
  EXPECT_EQ(parser.stats().sequence_gaps, 0u);  // sequence 0 was never accepted from this source
}

TEST(FrameTest, GarbagePrefixIsSkipped) {
  Encoder encoder;
  // Garbage with false magic bytes: one followed by a known id and a length
  // that makes the parser wait, one with an unknown id.
  std::vector<uint8_t> stream = {0x00, 0xFD, 0xFF, 0x13, kMagicV2, 0x05, 0x00, 0x00, 0x00, 0x01, 0x01,
                                 0x00, 0x00, 0x00, 0x37, kMagicV2, 0x02, 0x00, 0x00, 0x00, 0x01, 0x01,
                                 0x39, 0x30, 0x00, 0x77};
  const size_t garbage = stream.size();
  const std::vector<Message> messages = SampleMessages();
  for (const Message& m : messages) {
    const std::vector<uint8_t> f = encoder.Encode(m);
    stream.insert(stream.end(), f.begin(), f.end());
  }
  // Fed in small pieces, as a serial port would deliver them.
  Parser parser;
  std::vector<Frame> frames;
  for (size_t i = 0; i < stream.size(); i += 7) {
    parser.Feed(stream.data() + i, std::min<size_t>(7, stream.size() - i));
    for (Frame& f : ParseAll(parser)) frames.push_back(std::move(f));
  }
  ASSERT_EQ(frames.size(), messages.size());
  for (size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(frames[i].message_id, MessageId(messages[i]));
  EXPECT_EQ(parser.stats().bytes_skipped, garbage);
}

TEST(FrameTest, UnknownIncompatFlagIsDroppedAndCounted) {
  Encoder encoder;
  Parser parser;
  parser.Feed(HandFrame(Heartbeat::kId, Heartbeat::kCrcExtra, SerializePayload(Heartbeat{}), 0x02));
  parser.Feed(encoder.Encode(Heartbeat{}));
  const std::vector<Frame> frames = ParseAll(parser);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(parser.stats().unknown_incompat_flags, 1u);
  EXPECT_EQ(parser.stats().bad_checksum, 0u);
}

TEST(FrameTest, UnknownMessageIsSkippedAndCounted) {
  Encoder encoder;
  Parser parser;
  parser.Feed(encoder.EncodeRaw(9999, 7, {1, 2, 3}));
  parser.Feed(encoder.Encode(Heartbeat{}));
  const std::vector<Frame> frames = ParseAll(parser);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].message_id, Heartbeat::kId);
  EXPECT_EQ(parser.stats().unknown_message, 1u);
}

TEST(FrameTest, SequenceNumbersWrapAndGapsAreCounted) {
  Encoder encoder;
  Parser parser;
  for (int i = 0; i < 600; ++i) {
    const std::vector<uint8_t> f = encoder.Encode(Heartbeat{});
    EXPECT_EQ(f[4], i % 256);
    if (i == 255 || i == 256 || i == 400) continue;  // lost on the way
    parser.Feed(f);
  }
  EXPECT_EQ(ParseAll(parser).size(), 597u);
  EXPECT_EQ(parser.stats().sequence_gaps, 3u);
  EXPECT_EQ(encoder.next_sequence(), 600 % 256);
}

TEST(FrameTest, VerifiesTheKnownAnswerSignedFrame) {
  // Python: hashlib.sha256(key + frame[:-6]).digest()[:6] with key = 0..31,
  // link id 7, timestamp 0x0123456789AB.
  const std::vector<uint8_t> frame = FromHex("fd0901002a010100000000000300020c810403a0f107ab8967452301ed24b1bbdf08");
  ParserOptions options;
  options.signing_key = KeyOf(0);
  options.require_signing = true;
  Parser parser(options);
  parser.Feed(frame);
  const std::optional<Frame> f = parser.Next();
  ASSERT_TRUE(f);
  EXPECT_TRUE(f->is_signed);
  EXPECT_EQ(f->link_id, 7);
  EXPECT_EQ(f->timestamp, 0x0123456789ABULL);
  EXPECT_EQ(f->sequence, 42);
  EXPECT_EQ(std::get<Heartbeat>(*Decode(*f)).autopilot, mav::kAutopilotPx4);
  // The same bytes with one signature bit flipped do not verify.
  std::vector<uint8_t> tampered = frame;
  tampered.back() ^= 0x01;
  Parser other(options);
  other.Feed(tampered);
  EXPECT_FALSE(other.Next());
  EXPECT_EQ(other.stats().bad_signature, 1u);
  EXPECT_EQ(other.stats().bad_checksum, 0u);  // the CRC does not cover the signature
}

TEST(FrameTest, SigningAcceptsRejectsAndCounts) {
  EncoderOptions signed_options;
  signed_options.signing_key = KeyOf(1);
  Encoder good(signed_options);
  signed_options.signing_key = KeyOf(2);
  Encoder wrong_key(signed_options);
  Encoder unsigned_encoder;

  ParserOptions required;
  required.signing_key = KeyOf(1);
  required.require_signing = true;
  Parser parser(required);
  const std::vector<uint8_t> replayed = good.Encode(Heartbeat{});
  parser.Feed(replayed);
  parser.Feed(wrong_key.Encode(Heartbeat{}));
  parser.Feed(unsigned_encoder.Encode(Heartbeat{}));
  parser.Feed(replayed);  // the same frame again: an old timestamp
  parser.Feed(good.Encode(Heartbeat{}));
  EXPECT_EQ(ParseAll(parser).size(), 2u);
  EXPECT_EQ(parser.stats().bad_signature, 1u);
  EXPECT_EQ(parser.stats().unsigned_rejected, 1u);
  EXPECT_EQ(parser.stats().replayed, 1u);
  EXPECT_EQ(parser.stats().frames_accepted, 2u);

  // With a key but signing not required: unsigned frames pass, signed ones
  // are still verified.
  ParserOptions optional;
  optional.signing_key = KeyOf(1);
  Parser lenient(optional);
  lenient.Feed(unsigned_encoder.Encode(Heartbeat{}));
  lenient.Feed(wrong_key.Encode(Heartbeat{}));
  lenient.Feed(good.Encode(Heartbeat{}));
  EXPECT_EQ(ParseAll(lenient).size(), 2u);
  EXPECT_EQ(lenient.stats().bad_signature, 1u);

  // Without a key and without requiring signing, signed frames are accepted unverified.
  Parser open;
  open.Feed(wrong_key.Encode(Heartbeat{}));
  EXPECT_TRUE(open.Next());

  // Requiring signing without a key verifies nothing: every frame is dropped.
  ParserOptions keyless;
  keyless.require_signing = true;
  Parser strict(keyless);
  strict.Feed(good.Encode(Heartbeat{}));
  EXPECT_FALSE(strict.Next());
  EXPECT_EQ(strict.stats().bad_signature, 1u);
}

TEST(FrameTest, SignedTimestampsIncreaseAndAreNearNow) {
  EncoderOptions options;
  options.signing_key = KeyOf(1);
  Encoder encoder(options);
  ParserOptions po;
  po.signing_key = KeyOf(1);
  po.require_signing = true;
  Parser parser(po);
  const uint64_t now = SigningTimestampNow();
  for (int i = 0; i < 100; ++i) parser.Feed(encoder.Encode(Heartbeat{}));  // many within one 10 us tick
  const std::vector<Frame> frames = ParseAll(parser);
  ASSERT_EQ(frames.size(), 100u);
  for (size_t i = 1; i < frames.size(); ++i) EXPECT_GT(frames[i].timestamp, frames[i - 1].timestamp);
  EXPECT_GE(frames.front().timestamp, now);
  // 2015-01-01 is about 3e13 ten-microsecond units before 2025.
  EXPECT_GT(now, 300000000000000ULL / 10);
}

// A signed frame with an arbitrary timestamp (the encoder always uses now).
std::vector<uint8_t> SignedHandFrame(const SigningKey& key, uint8_t link_id, uint64_t timestamp) {
  std::vector<uint8_t> f = HandFrame(Heartbeat::kId, Heartbeat::kCrcExtra, {1}, kIncompatSigned);
  f.push_back(link_id);
  for (int i = 0; i < 6; ++i) f.push_back(static_cast<uint8_t>(timestamp >> (8 * i)));
  std::vector<uint8_t> input(key.begin(), key.end());
  input.insert(input.end(), f.begin(), f.end());
  uint8_t digest[SHA256_DIGEST_LENGTH];
  SHA256(input.data(), input.size(), digest);
  f.insert(f.end(), digest, digest + 6);
  return f;
}

TEST(FrameTest, ReplayIsJudgedPerStreamWithAOneMinuteWindowForNewStreams) {
  ParserOptions po;
  po.signing_key = KeyOf(1);
  po.require_signing = true;
  Parser parser(po);
  const uint64_t t = 500000000000ULL;
  parser.Feed(SignedHandFrame(KeyOf(1), 0, t));
  parser.Feed(SignedHandFrame(KeyOf(1), 1, t - 100));           // another link id: its own stream
  parser.Feed(SignedHandFrame(KeyOf(1), 1, t - 100));           // replay within that stream
  parser.Feed(SignedHandFrame(KeyOf(1), 0, t - 1));             // older than stream 0's last
  parser.Feed(SignedHandFrame(KeyOf(1), 2, t - 61 * 100000));   // a new stream over a minute old
  parser.Feed(SignedHandFrame(KeyOf(1), 3, t - 59 * 100000));   // a new stream within the minute
  EXPECT_EQ(ParseAll(parser).size(), 3u);
  EXPECT_EQ(parser.stats().replayed, 3u);
}

TEST(FrameTest, LoadsSigningKeysInHexAndRaw) {
  const std::string dir = ::testing::TempDir();
  const std::string hex_path = dir + "/link_key.hex";
  const std::string raw_path = dir + "/link_key.bin";
  const std::string bad_path = dir + "/link_key.bad";
  {
    std::ofstream hex(hex_path);
    hex << "000102030405060708090a0b0c0d0e0f\n101112131415161718191A1B1C1D1E1F\n";
    std::ofstream raw(raw_path, std::ios::binary);
    const SigningKey key = KeyOf(0);
    raw.write(reinterpret_cast<const char*>(key.data()), key.size());
    std::ofstream bad(bad_path);
    bad << "0011";
  }
  core::Result<SigningKey> hex = LoadSigningKey(hex_path);
  ASSERT_TRUE(hex.ok()) << hex.status().message();
  EXPECT_EQ(*hex, KeyOf(0));
  core::Result<SigningKey> raw = LoadSigningKey(raw_path);
  ASSERT_TRUE(raw.ok()) << raw.status().message();
  EXPECT_EQ(*raw, KeyOf(0));
  core::Result<SigningKey> bad = LoadSigningKey(bad_path);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find(bad_path), std::string::npos);
  EXPECT_EQ(LoadSigningKey(dir + "/no_such_key").status().code(), core::StatusCode::kNotFound);
  std::remove(hex_path.c_str());
  std::remove(raw_path.c_str());
  std::remove(bad_path.c_str());
}

}  // namespace
}  // namespace quadhand::link
