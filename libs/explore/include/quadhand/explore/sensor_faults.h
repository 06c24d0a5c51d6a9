// Faults on a simulated sensor's stream of frames (quadhand-explore
// --silence, --bad-frames; docs/perception.md, "Bad frames and a silent
// sensor"): what a real sensor, its driver and its link do to frames on
// their way to the planner. Silences stop every frame for a while; a
// spoiled frame is spoiled one way, drawn at random.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "quadhand/perception/sensor_frame.h"

namespace quadhand::explore {

struct SensorFaultOptions {
  struct Window {
    double from = 0.0, to = 0.0;  // s: no frame arrives while from <= t < to
  };
  std::vector<Window> silences;
  // Each frame outside a silence is spoiled with this probability, in one
  // of SensorFaultKind's ways drawn uniformly.
  double bad_frame_probability = 0.0;
  bool IsValid(std::string* why) const;
  bool any() const { return !silences.empty() || bad_frame_probability > 0.0; }
};

// Parses "FROM-TO" (s, FROM < TO), as --silence takes it.
bool ParseSilence(const std::string& text, SensorFaultOptions::Window* window);

enum class SensorFaultKind {
  kNanPose,           // a NaN in the pose's position
  kUnnormalised,      // the attitude quaternion scaled by 1.5
  kFutureStamp,       // stamped 1 s ahead of its time
  kLate,              // held back and delivered after the next frame
  kNanPoints,         // a tenth of its returns NaN (the map drops them; the frame is still good)
};
constexpr int kNumSensorFaultKinds = 5;
const char* SensorFaultKindName(SensorFaultKind kind);  // "nan_pose", ...

struct SensorFaultCounts {
  long silenced = 0;  // frames that never arrived
  long spoiled[kNumSensorFaultKinds] = {};
};

class SensorFaults {
 public:
  SensorFaults(const SensorFaultOptions& options, uint64_t seed);
  // The frames that arrive at `now` when `frame` is sent then: none in a
  // silence; else the frame (perhaps spoiled, perhaps held back), and after
  // it any frame held back before.
  std::vector<perception::SensorFrame> Pass(perception::SensorFrame frame, double now);
  const SensorFaultCounts& counts() const { return counts_; }

 private:
  SensorFaultOptions options_;
  std::mt19937_64 random_;
  std::vector<perception::SensorFrame> held_;
  SensorFaultCounts counts_;
};

}  // namespace quadhand::explore
