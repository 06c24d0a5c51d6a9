#include "quadhand/core/status.h"

#include <gtest/gtest.h>

namespace quadhand::core {
namespace {

Status FailsWhenNegative(int x) {
  if (x < 0) return Status::InvalidArgument("negative");
  return Status::Ok();
}

Status Chained(int x) {
  QUADHAND_RETURN_IF_ERROR(FailsWhenNegative(x));
  return Status::NotFound("reached the end");
}

TEST(StatusTest, CarriesCodeAndMessage) {
  EXPECT_TRUE(Status().ok());
  const Status s = Status::IoError("disk").WithPrefix("file.txt");
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kIoError);
  EXPECT_EQ(s.message(), "file.txt: disk");
  EXPECT_STREQ(StatusCodeName(StatusCode::kInfeasible), "infeasible");
}

TEST(StatusTest, ReturnIfErrorStopsAtTheFirstFailure) {
  EXPECT_EQ(Chained(-1).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(Chained(1).code(), StatusCode::kNotFound);
}

TEST(ResultTest, HoldsAValueOrAStatus) {
  Result<int> value(42);
  ASSERT_TRUE(value.ok());
  EXPECT_EQ(*value, 42);
  Result<int> error(Status::Infeasible("no"));
  EXPECT_FALSE(error.ok());
  EXPECT_EQ(error.status().message(), "no");
}

}  // namespace
}  // namespace quadhand::core
