// The seeded faulty channel of quadhand-linkproxy: each fault on its own,
// measured over many datagrams (the seed makes the counts exact, so the
// bounds are the statistics' own, not tuned to one run), and its YAML.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "quadhand/link/fault_channel.h"

namespace quadhand::link {
namespace {

std::vector<uint8_t> Numbered(uint32_t n) {
  return {static_cast<uint8_t>(n), static_cast<uint8_t>(n >> 8), static_cast<uint8_t>(n >> 16),
          static_cast<uint8_t>(n >> 24), 0xAB, 0xCD};
}
uint32_t NumberOf(const std::vector<uint8_t>& b) {
  return b[0] | (b[1] << 8) | (b[2] << 16) | (static_cast<uint32_t>(b[3]) << 24);
}

struct Delivery {
  double time;
  std::vector<uint8_t> bytes;
};

// Pushes n datagrams every `spacing` s and collects what arrives, popping every 1 ms.
std::vector<Delivery> Pass(FaultChannel* channel, int n, double spacing) {
  std::vector<Delivery> out;
  const double end = n * spacing + 120.0;
  int pushed = 0;
  for (long step = 0; step * 0.001 <= end; ++step) {
    const double t = step * 0.001;
    while (pushed < n && pushed * spacing <= t + 1e-12) {
      channel->Push(pushed * spacing, Numbered(static_cast<uint32_t>(pushed)));
      ++pushed;
    }
    for (auto& bytes : channel->PopDue(t)) out.push_back({t, std::move(bytes)});
    if (pushed == n && !channel->NextDue()) break;
  }
  return out;
}

TEST(FaultChannelTest, APerfectChannelDeliversEverythingAtOnceInOrder) {
  FaultChannel channel(LinkFaults{}, 1);
  const auto out = Pass(&channel, 1000, 0.02);
  ASSERT_EQ(out.size(), 1000u);
  for (uint32_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(NumberOf(out[i].bytes), i);
    EXPECT_NEAR(out[i].time, i * 0.02, 0.0011);
  }
  EXPECT_EQ(channel.stats().lost + channel.stats().reordered + channel.stats().duplicated, 0u);
}

TEST(FaultChannelTest, IndependentLossMatchesItsRate) {
  LinkFaults f;
  f.loss = 0.2;
  FaultChannel channel(f, 7);
  const int n = 20000;
  const auto out = Pass(&channel, n, 0.001);
  // Binomial: sd = sqrt(n p (1 - p)) = 57; 5 sd.
  EXPECT_NEAR(static_cast<double>(channel.stats().lost), 0.2 * n, 5 * std::sqrt(n * 0.2 * 0.8));
  EXPECT_EQ(out.size() + channel.stats().lost, static_cast<size_t>(n));
}

TEST(FaultChannelTest, BurstyLossHasItsRateAndItsMeanBurstLength) {
  LinkFaults f;
  f.loss = 0.1;
  f.burst = 5.0;
  FaultChannel channel(f, 11);
  const int n = 50000;
  const auto out = Pass(&channel, n, 0.0005);
  std::vector<bool> arrived(n, false);
  for (const Delivery& d : out) arrived[NumberOf(d.bytes)] = true;
  int lost = 0, runs = 0;
  for (int i = 0; i < n; ++i) {
    if (!arrived[i]) {
      ++lost;
      if (i == 0 || arrived[i - 1]) ++runs;
    }
  }
  EXPECT_NEAR(lost / static_cast<double>(n), 0.1, 0.02);
  EXPECT_NEAR(lost / static_cast<double>(runs), 5.0, 0.5);
}

TEST(FaultChannelTest, DelayAndJitterStayInTheirRangeAndReorder) {
  LinkFaults f;
  f.delay = 0.15;
  f.jitter = 0.05;
  FaultChannel channel(f, 3);
  const auto out = Pass(&channel, 2000, 0.02);
  ASSERT_EQ(out.size(), 2000u);
  double least = 1e9, most = 0.0;
  for (const Delivery& d : out) {
    const double delay = d.time - NumberOf(d.bytes) * 0.02;
    least = std::min(least, delay);
    most = std::max(most, delay);
  }
  EXPECT_GE(least, 0.10 - 1e-9);
  EXPECT_LE(most, 0.20 + 0.0011);
  EXPECT_LT(least, 0.11);
  EXPECT_GT(most, 0.19);
  EXPECT_GT(channel.stats().reordered, 100u);  // 100 ms of spread over 20 ms spacing
}

TEST(FaultChannelTest, FifoKeepsTheOrderUnderJitter) {
  LinkFaults f;
  f.delay = 0.15;
  f.jitter = 0.05;
  f.fifo = true;
  FaultChannel channel(f, 3);
  const auto out = Pass(&channel, 2000, 0.02);
  for (size_t i = 1; i < out.size(); ++i) EXPECT_GT(NumberOf(out[i].bytes), NumberOf(out[i - 1].bytes));
  EXPECT_EQ(channel.stats().reordered, 0u);
}

TEST(FaultChannelTest, DuplicatesAndCorruptionHitTheirShare) {
  LinkFaults f;
  f.duplicate = 0.1;
  f.corrupt = 0.1;
  FaultChannel channel(f, 5);
  const int n = 10000;
  const auto out = Pass(&channel, n, 0.001);
  EXPECT_EQ(out.size(), n + channel.stats().duplicated);
  EXPECT_NEAR(static_cast<double>(channel.stats().duplicated), 0.1 * n, 5 * std::sqrt(n * 0.09));
  EXPECT_NEAR(static_cast<double>(channel.stats().corrupted), 0.1 * n, 5 * std::sqrt(n * 0.09));
}

TEST(FaultChannelTest, CorruptionChangesExactlyOneByte) {
  LinkFaults f;
  f.corrupt = 1.0;
  FaultChannel channel(f, 5);
  for (int i = 0; i < 500; ++i) channel.Push(0.0, std::vector<uint8_t>(16, 0));
  const auto out = channel.PopDue(0.0);
  ASSERT_EQ(out.size(), 500u);
  for (const std::vector<uint8_t>& bytes : out) {
    EXPECT_EQ(std::count_if(bytes.begin(), bytes.end(), [](uint8_t b) { return b != 0; }), 1);
  }
}

TEST(FaultChannelTest, AnOutageDropsEverythingInItsWindowAndNothingElse) {
  LinkFaults f;
  f.outages.push_back({1.0, 0.5});
  FaultChannel channel(f, 1);
  const auto out = Pass(&channel, 200, 0.01);  // 0 .. 2 s
  for (const Delivery& d : out) {
    const double sent = NumberOf(d.bytes) * 0.01;
    EXPECT_FALSE(sent >= 1.0 - 1e-9 && sent < 1.5 - 1e-9) << sent;
  }
  EXPECT_NEAR(static_cast<double>(channel.stats().lost_in_outage), 50.0, 1.0);
}

TEST(FaultChannelTest, TheSameSeedGivesTheSameFaults) {
  LinkFaults f;
  f.loss = 0.3;
  f.burst = 3;
  f.delay = 0.1;
  f.jitter = 0.08;
  f.duplicate = 0.05;
  FaultChannel a(f, 42), b(f, 42), c(f, 43);
  const auto out_a = Pass(&a, 3000, 0.01), out_b = Pass(&b, 3000, 0.01), out_c = Pass(&c, 3000, 0.01);
  ASSERT_EQ(out_a.size(), out_b.size());
  for (size_t i = 0; i < out_a.size(); ++i) {
    EXPECT_EQ(out_a[i].bytes, out_b[i].bytes);
    EXPECT_EQ(out_a[i].time, out_b[i].time);
  }
  EXPECT_NE(out_a.size(), out_c.size());
}

TEST(LinkFaultConfigTest, BothThenEachDirectionOverIt) {
  auto config = ParseLinkFaultConfig(
      "seed: 9\nboth: {loss: 0.1, burst: 5, delay: 0.15, jitter: 0.05}\nup: {delay: 0.02}\n"
      "down: {corrupt: 0.001, fifo: true}\noutages: [{start: 8, length: 1.5}]\n",
      "faults.yaml");
  ASSERT_TRUE(config.ok()) << config.status().message();
  EXPECT_EQ(config->seed, 9u);
  EXPECT_DOUBLE_EQ(config->up.delay, 0.02);
  EXPECT_DOUBLE_EQ(config->up.loss, 0.1);
  EXPECT_DOUBLE_EQ(config->down.delay, 0.15);
  EXPECT_DOUBLE_EQ(config->down.corrupt, 0.001);
  EXPECT_TRUE(config->down.fifo);
  EXPECT_FALSE(config->up.fifo);
  ASSERT_EQ(config->up.outages.size(), 1u);
  ASSERT_EQ(config->down.outages.size(), 1u);
  EXPECT_DOUBLE_EQ(config->down.outages[0].length, 1.5);
  EXPECT_TRUE(ParseLinkFaultConfig("", "empty.yaml").ok());  // no faults
}

TEST(LinkFaultConfigTest, AMalformedConfigurationNamesTheFileAndTheKey) {
  const std::pair<const char*, const char*> cases[] = {
      {"both: {los: 0.1}\n", "both.los"},
      {"both: {loss: 1.5}\n", "both.loss"},
      {"up: {delay: -1}\n", "up.delay"},
      {"down: {jitter: .nan}\n", "down.jitter"},
      {"both: {burst: 0.5}\n", "both.burst"},
      {"both: {fifo: maybe}\n", "both.fifo"},
      {"outages: [{start: 1}]\n", "outages[0]"},
      {"outages: [{start: 1, length: 0}]\n", "outages[0].length"},
      {"seed: -3\n", "seed"},
      {"wind: 3\n", "wind"},
      {"both: {loss: 0.9, burst: 2}\n", "loss"},
      {"[1, 2]\n", "expected a map"},
  };
  for (const auto& [text, key] : cases) {
    auto config = ParseLinkFaultConfig(text, "faults.yaml");
    ASSERT_FALSE(config.ok()) << text;
    EXPECT_NE(config.status().message().find("faults.yaml"), std::string::npos) << config.status().message();
    EXPECT_NE(config.status().message().find(key), std::string::npos) << config.status().message();
  }
}

}  // namespace
}  // namespace quadhand::link
