#include "quadhand/online/clock_sync.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace quadhand::online {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(mid), v.end());
  return v[mid];
}

}  // namespace

bool ClockSyncOptions::IsValid(const char** why) const {
  auto fail = [why](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!(std::isfinite(request_period) && request_period > 0.0)) return fail("request_period must be positive");
  if (!(std::isfinite(window) && window >= request_period)) return fail("window must be >= request_period");
  if (!(std::isfinite(max_round_trip) && max_round_trip > 0.0)) return fail("max_round_trip must be positive");
  return true;
}

ClockSync::ClockSync(const ClockSyncOptions& options) : options_(options) {}

std::optional<int64_t> ClockSync::RequestDue(double t) {
  if (requested_ && t < next_request_) return std::nullopt;
  if (!requested_) first_request_ = t;
  requested_ = true;
  next_request_ = t + options_.request_period;
  return static_cast<int64_t>(std::llround(t * 1e9));
}

bool ClockSync::OnAnswer(double t, int64_t tc1, int64_t ts1) {
  if (!requested_ || tc1 == 0) return false;  // tc1 == 0 is a request, not an answer
  const double sent = static_cast<double>(ts1) * 1e-9;
  // ts1 is our time rounded to the nanosecond: an answer at once may seem
  // to come back a fraction of a nanosecond before its request left.
  double round_trip = t - sent;
  if (round_trip < 0.0 && round_trip > -1e-9) round_trip = 0.0;
  // Not one of ours: sent before our first request, or in our future.
  if (sent < first_request_ - 1e-9 || round_trip < 0.0 || round_trip > options_.max_round_trip) return false;
  Exchange e;
  e.received = t;
  e.sent = sent;
  e.round_trip = round_trip;
  e.vehicle_time = static_cast<double>(tc1) * 1e-9;
  e.offset = e.vehicle_time - 0.5 * (sent + t);
  window_.push_back(e);
  ++answers_;
  while (!window_.empty() && window_.front().received < t - options_.window) window_.pop_front();
  Estimate();
  return true;
}

double ClockSync::LongestAnswerGap(double now, double since) const {
  if (window_.empty()) return requested_ ? std::max(0.0, now - first_request_) : 0.0;
  double longest = std::max(0.0, now - window_.back().received);
  for (size_t i = 1; i < window_.size(); ++i) {
    if (window_[i].received > since) longest = std::max(longest, window_[i].received - window_[i - 1].received);
  }
  return longest;
}

void ClockSync::Estimate() {
  const Exchange* best = nullptr;
  for (const Exchange& e : window_) {
    if (best == nullptr || e.round_trip < best->round_trip) best = &e;
  }
  if (best != nullptr) estimate_ = best->offset;
}

double ClockSync::ToLocal(double vehicle_time) const { return vehicle_time - estimate_.value_or(0.0); }
double ClockSync::ToVehicle(double local_time) const { return local_time + estimate_.value_or(0.0); }

LinkLatency ClockSync::latency() const {
  LinkLatency l;
  if (window_.empty() || !estimate_) return l;
  std::vector<double> round_trips, uplinks;
  double shortest = window_.front().round_trip;
  for (const Exchange& e : window_) {
    round_trips.push_back(e.round_trip);
    // Clamped to [0, round trip]: the estimate's error can put a receipt
    // before the send on a link much faster one way than the other.
    uplinks.push_back(std::clamp(ToLocal(e.vehicle_time) - e.sent, 0.0, e.round_trip));
    shortest = std::min(shortest, e.round_trip);
  }
  l.exchanges = static_cast<int>(window_.size());
  l.round_trip = Median(round_trips);
  l.round_trip_max = *std::max_element(round_trips.begin(), round_trips.end());
  l.uplink = Median(uplinks);
  l.uplink_max = *std::max_element(uplinks.begin(), uplinks.end());
  l.uncertainty = 0.5 * shortest;
  return l;
}

}  // namespace quadhand::online
