// Sensor frames on UDP (link/sensor_stream.h): a frame split into chunks
// comes back whole whatever their order, over a real loopback socket too;
// every kind of bad datagram is dropped under its own count and never
// yields a frame; a hostile header cannot make the receiver take memory.
#include "quadhand/link/sensor_stream.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>

#include "quadhand/link/frame.h"
#include "quadhand/link/udp.h"

namespace quadhand::link {
namespace {

perception::SensorFrame MakeFrame(size_t returns, size_t misses, double t = 12.5) {
  perception::SensorFrame frame;
  frame.t = t;
  frame.position = Vec3(1.25, -2.5, 3.75);
  const Quat q(Eigen::AngleAxisd(0.7, Vec3(0.2, -1.0, 0.4).normalized()));
  frame.attitude = Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
  std::mt19937 random(3);
  std::uniform_real_distribution<float> coordinate(-6.0f, 6.0f);
  for (size_t i = 0; i < returns; ++i) frame.points.emplace_back(coordinate(random), coordinate(random), coordinate(random));
  for (size_t i = 0; i < misses; ++i) frame.misses.emplace_back(coordinate(random), coordinate(random), 6.0);
  return frame;
}

// The coordinates travel as f32: the frame as the receiver should see it.
void ExpectSameFrame(const perception::SensorFrame& got, const perception::SensorFrame& sent) {
  EXPECT_EQ(got.t, sent.t);
  EXPECT_EQ(got.position, sent.position);
  EXPECT_EQ(got.attitude, sent.attitude);
  ASSERT_EQ(got.points.size(), sent.points.size());
  ASSERT_EQ(got.misses.size(), sent.misses.size());
  for (size_t i = 0; i < sent.points.size(); ++i) {
    ASSERT_EQ(got.points[i], sent.points[i].cast<float>().cast<double>()) << i;
  }
  for (size_t i = 0; i < sent.misses.size(); ++i) {
    ASSERT_EQ(got.misses[i], sent.misses[i].cast<float>().cast<double>()) << i;
  }
}

TEST(SensorStreamTest, AFrameInChunksComesBackWholeInAnyOrder) {
  const perception::SensorFrame frame = MakeFrame(30000, 4800);
  const auto chunks = EncodeSensorFrame(frame, 7);
  ASSERT_GT(chunks.size(), 5u);  // 34,800 elements of 12 bytes in 60,000-byte chunks
  for (const auto& c : chunks) EXPECT_LE(c.size(), kDefaultSensorDatagramBytes);
  for (unsigned seed : {1u, 2u, 3u}) {
    auto shuffled = chunks;
    std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(seed));
    SensorFrameAssembler assembler;
    std::optional<perception::SensorFrame> got;
    for (size_t i = 0; i < shuffled.size(); ++i) {
      auto r = assembler.Add(shuffled[i].data(), shuffled[i].size());
      EXPECT_EQ(r.has_value(), i + 1 == shuffled.size()) << i;  // only the last completes it
      if (r) got = std::move(r);
    }
    ASSERT_TRUE(got.has_value());
    ExpectSameFrame(*got, frame);
    EXPECT_EQ(assembler.counts().frames, 1);
    EXPECT_EQ(assembler.counts().datagrams, static_cast<long>(chunks.size()));
  }
  // An empty frame is one chunk; small chunks make many.
  SensorFrameAssembler assembler;
  const auto empty = EncodeSensorFrame(MakeFrame(0, 0), 1);
  ASSERT_EQ(empty.size(), 1u);
  auto got = assembler.Add(empty[0].data(), empty[0].size());
  ASSERT_TRUE(got.has_value());
  EXPECT_TRUE(got->points.empty() && got->misses.empty());
  const perception::SensorFrame small = MakeFrame(100, 7);
  const auto many = EncodeSensorFrame(small, 2, 96 + 2 + 10 * 12);
  ASSERT_EQ(many.size(), 11u);
  for (size_t i = 0; i < many.size(); ++i) got = assembler.Add(many[i].data(), many[i].size());
  ASSERT_TRUE(got.has_value());
  ExpectSameFrame(*got, small);
  // Non-finite coordinates travel as they are (the map drops them).
  perception::SensorFrame odd = MakeFrame(3, 0);
  odd.points[1].y() = std::numeric_limits<double>::quiet_NaN();
  const auto odd_chunks = EncodeSensorFrame(odd, 3);
  got = assembler.Add(odd_chunks[0].data(), odd_chunks[0].size());
  ASSERT_TRUE(got.has_value());
  EXPECT_TRUE(std::isnan(got->points[1].y()));
}

TEST(SensorStreamTest, EachBadDatagramIsDroppedAndCountedByItsReason) {
  const perception::SensorFrame frame = MakeFrame(20000, 0);
  const auto chunks = EncodeSensorFrame(frame, 9);
  ASSERT_GE(chunks.size(), 4u);
  SensorFrameAssembler assembler;
  auto add = [&](std::vector<uint8_t> d) { return assembler.Add(d.data(), d.size()); };

  // Not a chunk at all: another magic, a version, garbage, nothing.
  auto bad = chunks[0];
  bad[0] = 'X';
  EXPECT_FALSE(add(bad));
  bad = chunks[0];
  bad[4] = 2;
  EXPECT_FALSE(add(bad));
  EXPECT_FALSE(add({1, 2, 3}));
  EXPECT_FALSE(assembler.Add(nullptr, 0));
  EXPECT_EQ(assembler.counts().malformed, 4);
  // Cut short, in the header or in the elements.
  EXPECT_FALSE(add(std::vector<uint8_t>(chunks[0].begin(), chunks[0].begin() + 50)));
  EXPECT_FALSE(add(std::vector<uint8_t>(chunks[0].begin(), chunks[0].end() - 100)));
  EXPECT_EQ(assembler.counts().truncated, 2);
  // Too long for its header, or fields that contradict each other.
  bad = chunks[0];
  bad.push_back(0);
  EXPECT_FALSE(add(bad));
  bad = chunks[0];
  bad[12] = 0xFF;  // chunk index 255 of 4
  bad[13] = 0x00;
  EXPECT_FALSE(add(bad));
  EXPECT_EQ(assembler.counts().malformed, 6);
  // One bit flipped in a coordinate: the checksum sees it.
  bad = chunks[1];
  bad[500] ^= 0x10;
  EXPECT_FALSE(add(bad));
  EXPECT_EQ(assembler.counts().corrupted, 1);
  // A duplicate chunk is ignored; the frame still completes once.
  EXPECT_FALSE(add(chunks[0]));
  EXPECT_FALSE(add(chunks[0]));
  EXPECT_EQ(assembler.counts().duplicates, 1);
  std::optional<perception::SensorFrame> got;
  for (size_t i = 1; i < chunks.size(); ++i) got = add(chunks[i]);
  ASSERT_TRUE(got.has_value());
  ExpectSameFrame(*got, frame);
  EXPECT_EQ(assembler.counts().frames, 1);
  // Every datagram counted once.
  const SensorStreamCounts& c = assembler.counts();
  EXPECT_EQ(c.datagrams, c.malformed + c.truncated + c.corrupted + c.duplicates + c.inconsistent +
                             static_cast<long>(chunks.size()));
}

TEST(SensorStreamTest, AFrameMissingAChunkIsDroppedAndTwoFramesUnderOneNumberAreNeitherTaken) {
  SensorFrameAssembler assembler(2);
  const auto a = EncodeSensorFrame(MakeFrame(20000, 0, 1.0), 1);
  const auto b = EncodeSensorFrame(MakeFrame(20000, 0, 2.0), 2);
  const auto c = EncodeSensorFrame(MakeFrame(20000, 0, 3.0), 3);
  // Frame 1 loses its last chunk; frames 2 and 3 begin: 1 is evicted.
  for (size_t i = 0; i + 1 < a.size(); ++i) EXPECT_FALSE(assembler.Add(a[i].data(), a[i].size()));
  EXPECT_FALSE(assembler.Add(b[0].data(), b[0].size()));
  EXPECT_FALSE(assembler.Add(c[0].data(), c[0].size()));
  EXPECT_EQ(assembler.counts().incomplete_frames, 1);
  // Its last chunk, late, starts it afresh (evicting 2), and it never completes.
  EXPECT_FALSE(assembler.Add(a.back().data(), a.back().size()));
  EXPECT_EQ(assembler.counts().incomplete_frames, 2);
  std::optional<perception::SensorFrame> got;
  for (size_t i = 1; i < c.size(); ++i) got = assembler.Add(c[i].data(), c[i].size());
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->t, 3.0);
  assembler.Flush();
  EXPECT_EQ(assembler.counts().incomplete_frames, 3);

  // A chunk of another frame under the same number: the frame is dropped.
  SensorFrameAssembler mixed;
  const auto d = EncodeSensorFrame(MakeFrame(20000, 0, 4.0), 5);
  const auto e = EncodeSensorFrame(MakeFrame(20000, 0, 5.0), 5);
  EXPECT_FALSE(mixed.Add(d[0].data(), d[0].size()));
  EXPECT_FALSE(mixed.Add(e[1].data(), e[1].size()));
  for (size_t i = 1; i < d.size(); ++i) EXPECT_FALSE(mixed.Add(d[i].data(), d[i].size()));
  EXPECT_EQ(mixed.counts().inconsistent, 1);
  EXPECT_EQ(mixed.counts().incomplete_frames, 1);
  EXPECT_EQ(mixed.counts().frames, 0);
}

TEST(SensorStreamTest, AHostileHeaderCannotMakeTheReceiverTakeMemory) {
  // A last chunk claiming a frame of 2^31 elements in two chunks of 2^30:
  // refused before anything is allocated (the process would not survive
  // the allocation).
  auto chunks = EncodeSensorFrame(MakeFrame(1, 0), 1);
  std::vector<uint8_t> d = chunks[0];
  auto put = [&](size_t at, uint64_t value, int bytes) {
    for (int i = 0; i < bytes; ++i) d[at + i] = static_cast<uint8_t>(value >> (8 * i));
  };
  put(12, 1, 2);             // index 1
  put(14, 2, 2);             // of 2
  put(16, (1u << 31) + 1, 4);  // returns
  put(24, 1u << 31, 4);      // per chunk
  put(28, 1, 4);             // this chunk's count: the rest
  put(d.size() - 2, Crc16(d.data(), d.size() - 2), 2);
  SensorFrameAssembler assembler;
  EXPECT_FALSE(assembler.Add(d.data(), d.size()));
  EXPECT_EQ(assembler.counts().malformed, 1);
}

// The fuzz target's seeds were written by a second encoder, in Python,
// from docs/link.md's table alone: the receiver takes them whole (one with
// its chunks in reverse order).
TEST(SensorStreamTest, ChunksWrittenFromTheDocumentedLayoutAreTaken) {
  for (const char* name : {"one_chunk", "three_chunks"}) {
    std::ifstream in(std::string(QUADHAND_SOURCE_DIR) + "/tests/fuzz/corpus/sensor_stream/" + name, std::ios::binary);
    ASSERT_TRUE(in) << name;
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    SensorFrameAssembler assembler;
    std::vector<perception::SensorFrame> frames;
    for (size_t at = 0; at + 2 <= bytes.size();) {
      const size_t length = bytes[at] | (static_cast<size_t>(bytes[at + 1]) << 8);
      at += 2;
      ASSERT_LE(at + length, bytes.size());
      if (auto f = assembler.Add(bytes.data() + at, length)) frames.push_back(std::move(*f));
      at += length;
    }
    ASSERT_EQ(frames.size(), 1u) << name;
    EXPECT_EQ(assembler.counts().malformed + assembler.counts().corrupted + assembler.counts().truncated, 0) << name;
    EXPECT_EQ(perception::CheckPose(frames[0].position, frames[0].attitude, 1e-9), perception::FrameDrop::kNone);
  }
}

TEST(SensorStreamTest, FramesCrossALoopbackSocket) {
  auto receiver = UdpSocket::Bind({"127.0.0.1", 0});
  ASSERT_TRUE(receiver.ok()) << receiver.status().message();
  EXPECT_GT(receiver->SetReceiveBuffer(4u << 20), 0u);
  auto sender = UdpSocket::Bind({"127.0.0.1", 0});
  ASSERT_TRUE(sender.ok());
  const UdpEndpoint to{"127.0.0.1", receiver->local_port()};
  SensorFrameAssembler assembler;
  for (uint32_t k = 0; k < 3; ++k) {
    const perception::SensorFrame frame = MakeFrame(10000, 1000, 1.0 + k);
    for (const auto& chunk : EncodeSensorFrame(frame, k)) ASSERT_TRUE(sender->SendTo(chunk, to).ok());
    std::optional<perception::SensorFrame> got;
    while (!got && receiver->WaitReadable(2.0)) {
      while (auto datagram = receiver->Receive()) {
        if (auto f = assembler.Add(datagram->bytes.data(), datagram->bytes.size())) got = std::move(f);
      }
    }
    ASSERT_TRUE(got.has_value()) << "frame " << k;
    ExpectSameFrame(*got, frame);
  }
}

}  // namespace
}  // namespace quadhand::link
