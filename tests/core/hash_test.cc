#include "quadhand/core/hash.h"

#include <cstring>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace quadhand::core {
namespace {

TEST(HashTest, Fnv1a64MatchesThePublishedTestVectors) {
  EXPECT_EQ(Fnv1a64("", 0), 0xcbf29ce484222325ull);
  EXPECT_EQ(Fnv1a64("a", 1), 0xaf63dc4c8601ec8cull);
  EXPECT_EQ(Fnv1a64("foobar", 6), 0x85944171f73967e8ull);
  // Chained calls hash the concatenation.
  EXPECT_EQ(Fnv1a64("bar", 3, Fnv1a64("foo", 3)), Fnv1a64("foobar", 6));
}

std::vector<unsigned char> Buffer(size_t size) {
  std::vector<unsigned char> bytes(size);
  for (size_t i = 0; i < size; ++i) bytes[i] = static_cast<unsigned char>(i * 131 + 7);
  return bytes;
}

TEST(HashTest, FastHash64ChangesWithEveryBitFlipAndEveryLength) {
  const std::vector<unsigned char> base = Buffer(200);  // 6 blocks of 32 bytes and an 8-byte tail
  const uint64_t reference = FastHash64(base.data(), base.size());
  std::set<uint64_t> seen = {reference};
  for (size_t byte = 0; byte < base.size(); ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<unsigned char> flipped = base;
      flipped[byte] ^= static_cast<unsigned char>(1u << bit);
      EXPECT_TRUE(seen.insert(FastHash64(flipped.data(), flipped.size())).second) << byte << ":" << bit;
    }
  }
  for (size_t size = 0; size < base.size(); ++size) {
    EXPECT_TRUE(seen.insert(FastHash64(base.data(), size)).second) << size;
  }
}

TEST(HashTest, FastHash64SeesTwoFlipsOfTheTopBitInOneLane) {
  // Words 0 and 4 feed the same lane; a plain multiply would carry a flip of
  // bit 63 only into bit 63, and the second flip would cancel the first.
  std::vector<unsigned char> base = Buffer(64);
  std::vector<unsigned char> flipped = base;
  flipped[7] ^= 0x80;
  flipped[32 + 7] ^= 0x80;
  EXPECT_NE(FastHash64(base.data(), base.size()), FastHash64(flipped.data(), flipped.size()));
}

TEST(HashTest, FastHash64SeesSwappedWordsAndDependsOnTheSeed) {
  std::vector<unsigned char> base = Buffer(64);
  std::vector<unsigned char> swapped = base;
  std::memcpy(swapped.data(), base.data() + 32, 8);
  std::memcpy(swapped.data() + 32, base.data(), 8);
  EXPECT_NE(FastHash64(base.data(), base.size()), FastHash64(swapped.data(), swapped.size()));
  EXPECT_NE(FastHash64(base.data(), base.size(), 1), FastHash64(base.data(), base.size(), 2));
}

TEST(HashTest, AChecksummedBodyReadsBackOnlyUnchanged) {
  std::string bytes = "the body of a file";
  core::AppendFastHash64Checksum(&bytes);
  ASSERT_EQ(bytes.size(), 18u + 8u);
  const auto body = FastHash64ChecksummedBody(bytes);
  ASSERT_TRUE(body.has_value());
  EXPECT_EQ(*body, "the body of a file");
  std::string corrupted = bytes;
  corrupted[3] ^= 0x01;
  EXPECT_FALSE(FastHash64ChecksummedBody(corrupted).has_value());
  EXPECT_FALSE(FastHash64ChecksummedBody(bytes.substr(0, bytes.size() - 1)).has_value());
  EXPECT_FALSE(FastHash64ChecksummedBody("short").has_value());
}

}  // namespace
}  // namespace quadhand::core
