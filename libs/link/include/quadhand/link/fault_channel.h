// A seeded, faulty one-way channel for datagrams: loss (independent or in
// bursts), delay with jitter (and so reordering), duplication, corrupted
// bytes and outages. Transport-agnostic: datagrams are pushed with the time
// they were sent and popped when they fall due, so the same faults can be
// tested without sockets and replayed from a seed. quadhand-linkproxy puts
// one in each direction between quadhand-online and a vehicle
// (docs/link.md, "Faults on the link").
#pragma once

#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "quadhand/core/status.h"

namespace quadhand::link {

// No datagram passes during [start, start + length) s of the channel's clock.
struct LinkOutage {
  double start = 0.0;
  double length = 0.0;
};

// The faults of one direction.
struct LinkFaults {
  // Long-run fraction of datagrams lost, in [0, 1).
  double loss = 0.0;
  // Mean number of consecutive datagrams lost once a loss starts, >= 1
  // (a two-state Gilbert-Elliott chain; 1: every datagram is lost
  // independently with probability `loss`).
  double burst = 1.0;
  // Added one-way delay, s: each datagram's is drawn uniformly from
  // [delay - jitter, delay + jitter] (clipped at 0), so datagrams overtake
  // each other when jitter exceeds their spacing, unless `fifo`.
  double delay = 0.0;
  double jitter = 0.0;
  bool fifo = false;
  double duplicate = 0.0;  // probability that a datagram also arrives a second time (own delay)
  double corrupt = 0.0;    // probability that one random byte of a datagram is changed
  std::vector<LinkOutage> outages;

  bool IsValid(std::string* why) const;
  bool Perfect() const;  // nothing to do: no loss, delay, duplication, corruption or outage
};

struct FaultChannelStats {
  uint64_t pushed = 0;
  uint64_t delivered = 0;      // duplicates counted
  uint64_t lost = 0;           // by the loss chain
  uint64_t lost_in_outage = 0;
  uint64_t duplicated = 0;
  uint64_t corrupted = 0;
  uint64_t reordered = 0;      // delivered before a datagram pushed earlier
};

class FaultChannel {
 public:
  // `faults` must be valid (LinkFaults::IsValid).
  FaultChannel(const LinkFaults& faults, uint64_t seed);

  // A datagram sent at time t (s, non-decreasing over calls).
  void Push(double t, std::vector<uint8_t> bytes);
  // The datagrams due by time t, in delivery order.
  std::vector<std::vector<uint8_t>> PopDue(double t);
  // When the next datagram falls due (none: nothing in flight).
  std::optional<double> NextDue() const;
  const FaultChannelStats& stats() const { return stats_; }

 private:
  struct InFlight {
    double due = 0.0;
    uint64_t sequence = 0;  // order of pushing, ties and reorder counting
    std::vector<uint8_t> bytes;
  };
  double DrawDelay();
  void Schedule(double due, std::vector<uint8_t> bytes);

  LinkFaults faults_;
  std::mt19937_64 random_;
  bool in_burst_ = false;
  double last_due_ = 0.0;  // fifo: no datagram is due before the previous one
  uint64_t next_sequence_ = 0;
  uint64_t highest_delivered_ = 0;
  bool delivered_any_ = false;
  std::vector<InFlight> in_flight_;  // unordered; small
  FaultChannelStats stats_;
};

// The faults of both directions of a link and its seed, as quadhand-linkproxy
// reads them from YAML (docs/link.md):
//   seed: 1
//   both: {loss: 0.1, burst: 5, delay: 0.15, jitter: 0.05}   # both directions
//   up:   {duplicate: 0.01}      # quadhand-online -> vehicle, over `both`
//   down: {corrupt: 0.001}       # vehicle -> quadhand-online, over `both`
//   outages: [{start: 8.0, length: 1.5}]                    # both directions
// Every key is optional; an unknown key, a value of the wrong type or out of
// range is an InvalidArgument naming the file and the key.
struct LinkFaultConfig {
  uint64_t seed = 1;
  LinkFaults up, down;
};
core::Result<LinkFaultConfig> LoadLinkFaultConfig(const std::string& path);
core::Result<LinkFaultConfig> ParseLinkFaultConfig(const std::string& text, const std::string& name);

}  // namespace quadhand::link
