// core::ParseWholeNumber: digits only, and never past the limit (nor past
// 2^64 on the way there).
#include "quadhand/core/numbers.h"

#include <gtest/gtest.h>

namespace quadhand::core {
namespace {

TEST(ParseWholeNumberTest, AcceptsDigitsUpToTheLimit) {
  std::uint64_t value = 7;
  EXPECT_TRUE(ParseWholeNumber("0", 10, &value));
  EXPECT_EQ(value, 0u);
  EXPECT_TRUE(ParseWholeNumber("0042", 100, &value));
  EXPECT_EQ(value, 42u);
  EXPECT_TRUE(ParseWholeNumber("4294967295", 0xffffffffULL, &value));
  EXPECT_EQ(value, 0xffffffffULL);
  EXPECT_TRUE(ParseWholeNumber("18446744073709551615", UINT64_MAX, &value));
  EXPECT_EQ(value, UINT64_MAX);
}

TEST(ParseWholeNumberTest, RefusesEverythingElse) {
  std::uint64_t value = 7;
  for (const char* text : {"", "-1", "+1", " 1", "1 ", "1e9", "0x10", "1.0", "4294967296", "18446744073709551616",
                           "99999999999999999999999", "nan"}) {
    EXPECT_FALSE(ParseWholeNumber(text, 0xffffffffULL, &value)) << text;
  }
  EXPECT_FALSE(ParseWholeNumber("18446744073709551616", UINT64_MAX, &value));
  EXPECT_FALSE(ParseWholeNumber("11", 10, &value));
  EXPECT_EQ(value, 7u);  // untouched on failure
}

}  // namespace
}  // namespace quadhand::core
