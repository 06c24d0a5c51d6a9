#include "quadhand/link/sensor_stream.h"

#include <algorithm>
#include <cstring>

#include "quadhand/link/frame.h"

namespace quadhand::link {
namespace {

constexpr uint8_t kMagic[4] = {'Q', 'H', 'S', 'F'};
constexpr uint8_t kVersion = 1;
constexpr size_t kElementBytes = 12;
constexpr size_t kChecksumBytes = 2;
constexpr uint64_t kMaxElementsPerChunk = (kMaxSensorDatagramBytes - kSensorChunkHeaderBytes - kChecksumBytes) / kElementBytes;

// Little-endian, whatever the host's order.
void PutUnsigned(uint8_t* out, uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out[i] = static_cast<uint8_t>(value >> (8 * i));
}
uint64_t GetUnsigned(const uint8_t* in, int bytes) {
  uint64_t value = 0;
  for (int i = 0; i < bytes; ++i) value |= static_cast<uint64_t>(in[i]) << (8 * i);
  return value;
}
// An f64 or f32 by its bits.
template <typename Real, typename Bits>
void PutReal(uint8_t* out, Real value) {
  static_assert(sizeof(Real) == sizeof(Bits));
  Bits bits;
  std::memcpy(&bits, &value, sizeof bits);
  PutUnsigned(out, bits, static_cast<int>(sizeof bits));
}
template <typename Real, typename Bits>
Real GetReal(const uint8_t* in) {
  static_assert(sizeof(Real) == sizeof(Bits));
  const Bits bits = static_cast<Bits>(GetUnsigned(in, static_cast<int>(sizeof(Bits))));
  Real value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}
void PutDouble(uint8_t* out, double value) { PutReal<double, uint64_t>(out, value); }
double GetDouble(const uint8_t* in) { return GetReal<double, uint64_t>(in); }
void PutFloat(uint8_t* out, float value) { PutReal<float, uint32_t>(out, value); }
float GetFloat(const uint8_t* in) { return GetReal<float, uint32_t>(in); }

// The header bytes every chunk of a frame shares: all but the chunk's
// index (12-13) and its count (28-31).
bool SameFrameHeader(const uint8_t* a, const uint8_t* b) {
  return std::memcmp(a, b, 12) == 0 && std::memcmp(a + 14, b + 14, 14) == 0 &&
         std::memcmp(a + 32, b + 32, kSensorChunkHeaderBytes - 32) == 0;
}

}  // namespace

std::vector<std::vector<uint8_t>> EncodeSensorFrame(const perception::SensorFrame& frame, uint32_t sequence,
                                                    size_t max_datagram) {
  max_datagram = std::clamp(max_datagram, kSensorChunkHeaderBytes + kElementBytes + kChecksumBytes,
                            kMaxSensorDatagramBytes);
  const size_t per_chunk = (max_datagram - kSensorChunkHeaderBytes - kChecksumBytes) / kElementBytes;
  const size_t total = frame.points.size() + frame.misses.size();
  const size_t chunks = std::max<size_t>(1, (total + per_chunk - 1) / per_chunk);
  if (chunks > 0xFFFF || frame.points.size() > 0xFFFFFFFFu || frame.misses.size() > 0xFFFFFFFFu) return {};
  std::vector<std::vector<uint8_t>> out;
  out.reserve(chunks);
  for (size_t c = 0; c < chunks; ++c) {
    const size_t first = c * per_chunk;
    const size_t count = std::min(per_chunk, total - std::min(total, first));
    std::vector<uint8_t> d(kSensorChunkHeaderBytes + count * kElementBytes + kChecksumBytes);
    std::memcpy(d.data(), kMagic, 4);
    d[4] = kVersion;
    d[5] = 0;
    PutUnsigned(&d[6], kSensorChunkHeaderBytes, 2);
    PutUnsigned(&d[8], sequence, 4);
    PutUnsigned(&d[12], c, 2);
    PutUnsigned(&d[14], chunks, 2);
    PutUnsigned(&d[16], frame.points.size(), 4);
    PutUnsigned(&d[20], frame.misses.size(), 4);
    PutUnsigned(&d[24], per_chunk, 4);
    PutUnsigned(&d[28], count, 4);
    PutDouble(&d[32], frame.t);
    for (int a = 0; a < 3; ++a) PutDouble(&d[40 + 8 * a], frame.position[a]);
    for (int a = 0; a < 4; ++a) PutDouble(&d[64 + 8 * a], frame.attitude[a]);
    uint8_t* element = &d[kSensorChunkHeaderBytes];
    for (size_t i = first; i < first + count; ++i, element += kElementBytes) {
      const Vec3& p = i < frame.points.size() ? frame.points[i] : frame.misses[i - frame.points.size()];
      for (int a = 0; a < 3; ++a) PutFloat(element + 4 * a, static_cast<float>(p[a]));
    }
    PutUnsigned(element, Crc16(d.data(), d.size() - kChecksumBytes), 2);
    out.push_back(std::move(d));
  }
  return out;
}

SensorFrameAssembler::SensorFrameAssembler(size_t max_pending, size_t max_elements)
    : max_pending_(std::max<size_t>(1, max_pending)), max_elements_(max_elements) {}

std::optional<perception::SensorFrame> SensorFrameAssembler::Add(const uint8_t* data, size_t size) {
  ++counts_.datagrams;
  if (data == nullptr || size < 8 || std::memcmp(data, kMagic, 4) != 0 || data[4] != kVersion ||
      GetUnsigned(data + 6, 2) != kSensorChunkHeaderBytes) {
    ++counts_.malformed;
    return std::nullopt;
  }
  if (size < kSensorChunkHeaderBytes + kChecksumBytes) {
    ++counts_.truncated;
    return std::nullopt;
  }
  const uint32_t sequence = static_cast<uint32_t>(GetUnsigned(data + 8, 4));
  const size_t index = GetUnsigned(data + 12, 2), chunks = GetUnsigned(data + 14, 2);
  const uint64_t returns = GetUnsigned(data + 16, 4), misses = GetUnsigned(data + 20, 4);
  const uint64_t per_chunk = GetUnsigned(data + 24, 4), count = GetUnsigned(data + 28, 4);
  const uint64_t expected = kSensorChunkHeaderBytes + count * kElementBytes + kChecksumBytes;
  if (size < expected) {
    ++counts_.truncated;
    return std::nullopt;
  }
  const uint64_t total = returns + misses;
  const uint64_t first = index * per_chunk;
  if (size > expected || per_chunk == 0 || per_chunk > kMaxElementsPerChunk || total > max_elements_ || chunks == 0 ||
      index >= chunks ||
      chunks != std::max<uint64_t>(1, (total + per_chunk - 1) / per_chunk) ||
      count != (index + 1 < chunks ? per_chunk : total - std::min(total, first))) {
    ++counts_.malformed;
    return std::nullopt;
  }
  if (GetUnsigned(data + size - kChecksumBytes, 2) != Crc16(data, size - kChecksumBytes)) {
    ++counts_.corrupted;
    return std::nullopt;
  }

  auto it = pending_.find(sequence);
  if (it == pending_.end()) {
    while (pending_.size() >= max_pending_) {
      ++counts_.incomplete_frames;
      pending_.erase(pending_.begin());
    }
    Pending p;
    p.header.assign(data, data + kSensorChunkHeaderBytes);
    p.received.assign(chunks, false);
    p.chunks_left = chunks;
    p.frame.t = GetDouble(data + 32);
    for (int a = 0; a < 3; ++a) p.frame.position[a] = GetDouble(data + 40 + 8 * a);
    for (int a = 0; a < 4; ++a) p.frame.attitude[a] = GetDouble(data + 64 + 8 * a);
    p.frame.points.resize(returns);
    p.frame.misses.resize(misses);
    it = pending_.emplace(sequence, std::move(p)).first;
  }
  Pending& p = it->second;
  if (!SameFrameHeader(p.header.data(), data)) {
    // Two frames under one number, or a chunk altered on the way in a
    // way the checksum could not see: neither can be trusted.
    ++counts_.inconsistent;
    p.inconsistent = true;
    return std::nullopt;
  }
  if (p.received[index]) {
    ++counts_.duplicates;
    return std::nullopt;
  }
  p.received[index] = true;
  const uint8_t* element = data + kSensorChunkHeaderBytes;
  for (uint64_t i = first; i < first + count; ++i, element += kElementBytes) {
    const Vec3 v(GetFloat(element), GetFloat(element + 4), GetFloat(element + 8));
    if (i < returns) {
      p.frame.points[i] = v;
    } else {
      p.frame.misses[i - returns] = v;
    }
  }
  if (--p.chunks_left > 0) return std::nullopt;
  const bool inconsistent = p.inconsistent;
  perception::SensorFrame frame = std::move(p.frame);
  pending_.erase(it);
  if (inconsistent) {
    ++counts_.incomplete_frames;
    return std::nullopt;
  }
  ++counts_.frames;
  return frame;
}

void SensorFrameAssembler::Flush() {
  counts_.incomplete_frames += static_cast<long>(pending_.size());
  pending_.clear();
}

}  // namespace quadhand::link
