// The vehicle's clock in ours, from MAVLink TIMESYNC exchanges, and the
// link's latency. quadhand-online judges every state the vehicle sends by the
// time the vehicle stamped it (time_boot_ms), not by when it arrived: over a
// slow link a state arriving now is already `age` seconds old.
//
// Each exchange: we send tc1 = 0, ts1 = our time; the vehicle answers with
// tc1 = its time and the same ts1; the answer arrives at our time t. Its
// round trip is t - ts1 and it puts the vehicle's clock at
// offset = tc1 - (ts1 + t) / 2 ahead of ours, wrong by at most half the
// round trip (an asymmetric link). The estimate is the offset of the exchange
// with the shortest round trip among the last `window` s (the one that waited
// least in queues), so jitter does not move it; the uncertainty() is half that
// round trip. A clock that drifts is followed as the window slides.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>

namespace quadhand::online {

struct ClockSyncOptions {
  double request_period = 0.1;  // s between TIMESYNC requests
  double window = 3.0;          // s of exchanges the estimate is taken from
  // An answer whose round trip is longer than this is ignored (s): it says
  // nothing useful about the offset, and may be a replay of an old one.
  double max_round_trip = 5.0;
  bool IsValid(const char** why) const;
};

struct LinkLatency {
  double round_trip = 0.0;  // s, median over the window
  double round_trip_max = 0.0;
  double uplink = 0.0;      // s, median of our send -> the vehicle's receipt
  double uplink_max = 0.0;
  double uncertainty = 0.0; // s, half the shortest round trip in the window
  int exchanges = 0;        // in the window
};

class ClockSync {
 public:
  explicit ClockSync(const ClockSyncOptions& options = {});

  // The ts1 (ns of our clock) of a request to send now, when one is due.
  std::optional<int64_t> RequestDue(double t);
  // An answer (tc1: the vehicle's ns, ts1: our request's ns) arrived at t.
  // Returns false when it is not an answer to one of ours or is ignored.
  bool OnAnswer(double t, int64_t tc1, int64_t ts1);

  bool synced() const { return estimate_.has_value(); }
  // Our time (s) of a vehicle time stamp (s of the vehicle's clock); needs synced().
  double ToLocal(double vehicle_time) const;
  // The inverse: the vehicle's time (s) of one of ours; needs synced().
  double ToVehicle(double local_time) const;
  // Latency figures over the window (zeros before the first answer).
  LinkLatency latency() const;
  // Answers received in all (for the summary).
  long answers() const { return answers_; }
  // The longest time without an answer (s) between `since` and `now`: the
  // gaps between the answers' arrivals that end after `since`, and the time
  // since the last one. An answer proves that both directions work, the
  // uplink included, which the vehicle's states alone cannot.
  double LongestAnswerGap(double now, double since) const;

 private:
  struct Exchange {
    double received = 0.0;  // our time
    double round_trip = 0.0;
    double offset = 0.0;    // vehicle - ours, s
    double vehicle_time = 0.0;
    double sent = 0.0;
  };
  void Estimate();

  ClockSyncOptions options_;
  std::deque<Exchange> window_;
  std::optional<double> estimate_;  // vehicle - ours, s
  double next_request_ = 0.0;
  bool requested_ = false;
  double first_request_ = 0.0;
  long answers_ = 0;
};

}  // namespace quadhand::online
