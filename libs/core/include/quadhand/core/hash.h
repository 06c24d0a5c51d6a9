// Fast non-cryptographic hashes that find truncation, bit rot and changed
// contents, not tampering. Chain calls by passing the previous result as
// `hash` to hash several buffers as one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>

namespace quadhand::core {

constexpr uint64_t kFnv1a64Offset = 0xcbf29ce484222325ull;
constexpr uint64_t kFnv1a64Prime = 0x100000001b3ull;

// FNV-1a, 64 bit, over bytes: one multiply per byte in one dependency chain,
// about 0.6 GB/s. The checksum of version-1 SDF files.
inline uint64_t Fnv1a64(const void* data, size_t size, uint64_t hash = kFnv1a64Offset) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= kFnv1a64Prime;
  }
  return hash;
}

// A word-wise hash in four interleaved lanes: lane k takes the little-endian
// 64-bit words k, k+4, k+8, ...; each step xors the word in, multiplies by
// the FNV prime and folds the high half down (without the fold, a bit flip
// in the top bit of two words of one lane would cancel). The lanes, then
// the last size % 32 bytes, then the size are folded into `hash` with
// Fnv1a64. Every step is a bijection of the lane for a fixed word and of the
// word for a fixed lane, so a change confined to one word always changes its
// lane. The four multiply chains run side by side: about 3.5 GB/s, for
// hashing tens of megabytes whenever a file is loaded (SDF checksums, the
// repaired-mesh cache's keys). Words are read in the machine's byte order;
// the files that store these hashes are little-endian throughout.
inline uint64_t FastHash64(const void* data, size_t size, uint64_t hash = kFnv1a64Offset) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  uint64_t lanes[4] = {kFnv1a64Offset, kFnv1a64Offset ^ 1u, kFnv1a64Offset ^ 2u, kFnv1a64Offset ^ 3u};
  const size_t blocks = size / 32;
  for (size_t b = 0; b < blocks; ++b) {
    uint64_t words[4];
    std::memcpy(words, bytes + 32 * b, sizeof(words));
    for (int k = 0; k < 4; ++k) {
      const uint64_t mixed = (lanes[k] ^ words[k]) * kFnv1a64Prime;
      lanes[k] = mixed ^ (mixed >> 32);
    }
  }
  hash = Fnv1a64(lanes, sizeof(lanes), hash);
  hash = Fnv1a64(bytes + 32 * blocks, size - 32 * blocks, hash);
  const uint64_t length = size;
  return Fnv1a64(&length, sizeof(length), hash);
}

// The project's binary files (SDFs from version 2, the repaired-mesh and
// surface-sample caches) end with a FastHash64 of every byte before it,
// little-endian. Appends that checksum to `bytes`.
inline void AppendFastHash64Checksum(std::string* bytes) {
  const uint64_t checksum = FastHash64(bytes->data(), bytes->size());
  bytes->append(reinterpret_cast<const char*>(&checksum), sizeof(checksum));
}

// The bytes before such a checksum, when it matches them; nullopt when it
// does not (a corrupted or truncated file) or there are not 8 bytes.
inline std::optional<std::string_view> FastHash64ChecksummedBody(std::string_view bytes) {
  if (bytes.size() < sizeof(uint64_t)) return std::nullopt;
  const size_t end = bytes.size() - sizeof(uint64_t);
  uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + end, sizeof(stored));
  if (stored != FastHash64(bytes.data(), end)) return std::nullopt;
  return bytes.substr(0, end);
}

}  // namespace quadhand::core
