// Sensor frames on UDP, beside the MAVLink link and not inside it
// (docs/link.md, "Sensor frames on UDP"). A frame (perception::SensorFrame:
// its time, the sensor's pose, its returns and its rays without return) is
// sent as one or more datagrams, "chunks". Each chunk carries the whole
// header, so a lost chunk loses its own frame only, and a receiver can tell
// a malformed datagram, a truncated one, a corrupted one and a frame that
// misses chunks apart.
//
// A chunk, little-endian, 96 bytes of header, the elements, 2 of checksum:
//    0  magic "QHSF"               4  version u8 (1)    5  flags u8 (0)
//    6  header size u16 (96)       8  frame sequence u32
//   12  chunk index u16           14  chunk count u16 (>= 1)
//   16  returns u32 (the frame's) 20  misses u32 (the frame's)
//   24  per chunk u32 (n >= 1, the frame's)      28  count u32 (this chunk's
//       elements: n, but the last chunk's the rest; chunk i holds elements
//       [i n, i n + count), so the chunks cover each element once)
//   32  t f64 (s, the sender's clock)
//   40  position f64 x3 (m, the sensor in the world)
//   64  attitude f64 x4 (w, x, y, z: sensor to world)
//   96  count elements, each f32 x3 (m, the sensor's frame): the frame's
//       elements are its returns, then its misses' far ends, in order
//   96 + 12 count: X.25 CRC-16 (link/frame.h's Crc16) of every byte before
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "quadhand/perception/sensor_frame.h"

namespace quadhand::link {

inline constexpr size_t kSensorChunkHeaderBytes = 96;
// The largest chunk (the largest IPv4 UDP payload) and the default, which
// stays under it.
inline constexpr size_t kMaxSensorDatagramBytes = 65507;
inline constexpr size_t kDefaultSensorDatagramBytes = 60000;

// The chunks of `frame` as frame number `sequence`, each at most
// `max_datagram` bytes (clamped to [kSensorChunkHeaderBytes + 14,
// kMaxSensorDatagramBytes]); at least one chunk. The coordinates go as f32;
// non-finite ones go as they are (the map drops them). Empty (nothing to
// send) when the frame needs more than 65535 chunks.
std::vector<std::vector<uint8_t>> EncodeSensorFrame(const perception::SensorFrame& frame, uint32_t sequence,
                                                    size_t max_datagram = kDefaultSensorDatagramBytes);

// What a receiver saw: every datagram is counted once, as part of a frame
// or under one of the reasons it was dropped.
struct SensorStreamCounts {
  long datagrams = 0;
  long frames = 0;            // completed
  long malformed = 0;         // not a chunk: magic, version, header size, or fields that contradict each other
  long truncated = 0;         // shorter than its header says
  long corrupted = 0;         // the checksum does not match
  long inconsistent = 0;      // a chunk whose header differs from its frame's other chunks (the frame is dropped)
  long duplicates = 0;        // a chunk already received
  long incomplete_frames = 0; // frames dropped with chunks missing (evicted by newer frames, or at Flush)
};

// Reassembles frames from chunks in any order. At most `max_pending`
// frames wait for chunks; a chunk of a new frame beyond that drops the
// waiting frame with the lowest sequence (incomplete). A chunk of a frame
// of more than `max_elements` returns and misses is malformed: a frame's
// memory is taken at its first chunk, and a hostile header must not take
// it all.
class SensorFrameAssembler {
 public:
  explicit SensorFrameAssembler(size_t max_pending = 4, size_t max_elements = size_t{1} << 21);
  // One datagram; the frame it completes, if it completes one.
  std::optional<perception::SensorFrame> Add(const uint8_t* data, size_t size);
  // The frames still waiting are dropped as incomplete (at the end of a stream).
  void Flush();
  const SensorStreamCounts& counts() const { return counts_; }

 private:
  struct Pending {
    perception::SensorFrame frame;
    std::vector<uint8_t> header;   // the first chunk's header bytes, to compare the others with
    std::vector<bool> received;
    size_t chunks_left = 0;
    bool inconsistent = false;
  };
  size_t max_pending_;
  size_t max_elements_;
  std::map<uint32_t, Pending> pending_;
  SensorStreamCounts counts_;
};

}  // namespace quadhand::link
