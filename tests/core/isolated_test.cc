// core::RunIsolated: what untrusted work does in its child process reaches
// the caller only as a result or an ordinary error.
#include "quadhand/core/isolated.h"

#include <signal.h>

#include <chrono>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

namespace quadhand::core {
namespace {

const bool kAddressSanitizer = BuiltWithAddressSanitizer();

TEST(RunIsolatedTest, ReturnsTheBytesOfTheWorkAndItsOwnErrors) {
  std::string big(3 << 20, '\0');  // larger than a pipe's buffer, with zero bytes
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>(i * 7);
  auto result = RunIsolated([&]() -> Result<std::string> { return big; }, "work");
  ASSERT_TRUE(result.ok()) << result.status().message();
  EXPECT_EQ(*result, big);
  auto empty = RunIsolated([]() -> Result<std::string> { return std::string(); }, "work");
  ASSERT_TRUE(empty.ok()) << empty.status().message();
  EXPECT_EQ(*empty, "");
  auto failed = RunIsolated([]() -> Result<std::string> { return Status::InvalidArgument("x.dae: no mesh"); }, "work");
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.status().message(), "x.dae: no mesh");
  auto threw = RunIsolated([]() -> Result<std::string> { throw std::runtime_error("bad vertex"); }, "x.dae: reader");
  ASSERT_FALSE(threw.ok());
  EXPECT_EQ(threw.status().message(), "x.dae: reader: threw: bad vertex");
}

TEST(RunIsolatedTest, ACrashIsAnError) {
  for (int signal : {SIGSEGV, SIGABRT, SIGFPE}) {
    auto result = RunIsolated([signal]() -> Result<std::string> {
      raise(signal);
      return std::string("not reached");
    }, "x.dae: reader");
    ASSERT_FALSE(result.ok()) << signal;
    const std::string& message = result.status().message();
    // AddressSanitizer turns some signals into its own report and exit code.
    const bool reported = message.rfind("x.dae: reader: crashed (", 0) == 0 ||
                          (kAddressSanitizer && message.rfind("x.dae: reader: stopped without a result", 0) == 0);
    EXPECT_TRUE(reported) << message;
  }
  auto exited = RunIsolated([]() -> Result<std::string> { std::_Exit(7); }, "x.dae: reader");
  ASSERT_FALSE(exited.ok());
  EXPECT_NE(exited.status().message().find("stopped without a result (exit 7)"), std::string::npos);
}

TEST(RunIsolatedTest, AHangIsKilledAtTheTimeLimit) {
  IsolationLimits limits;
  limits.seconds = 0.3;
  const auto start = std::chrono::steady_clock::now();
  auto result = RunIsolated([]() -> Result<std::string> {
    for (volatile long i = 0;; ++i) {
    }
  }, "x.dae: reader", limits);
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_FALSE(result.ok());
  EXPECT_NE(result.status().message().find("x.dae: reader: took longer than"), std::string::npos)
      << result.status().message();
  EXPECT_LT(took, 5.0);
}

TEST(RunIsolatedTest, AllocationBeyondTheLimitIsAnError) {
  if (kAddressSanitizer) GTEST_SKIP() << "the address-space limit is not applied under AddressSanitizer";
  IsolationLimits limits;
  limits.memory_bytes = std::size_t{256} << 20;
  auto result = RunIsolated([]() -> Result<std::string> {
    std::vector<std::vector<char>> hog;
    for (int i = 0; i < 64; ++i) hog.emplace_back(std::size_t{64} << 20, 'x');  // 4 GiB in all
    return std::string("not reached");
  }, "x.dae: reader", limits);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().message(), "x.dae: reader: needs more memory than the 256 MiB it may use");
}

}  // namespace
}  // namespace quadhand::core
