// FNV-1a, 64 bit, over bytes: a fast hash that finds truncation, bit rot and
// changed contents, not tampering. Chain calls by passing the previous
// result as `hash` to hash several buffers as one.
#pragma once

#include <cstddef>
#include <cstdint>

namespace quadhand::core {

constexpr uint64_t kFnv1a64Offset = 0xcbf29ce484222325ull;

inline uint64_t Fnv1a64(const void* data, size_t size, uint64_t hash = kFnv1a64Offset) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= 0x100000001b3ull;
  }
  return hash;
}

}  // namespace quadhand::core
