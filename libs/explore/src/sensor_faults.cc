#include "quadhand/explore/sensor_faults.h"

#include <cmath>
#include <cstdlib>
#include <limits>

namespace quadhand::explore {

bool SensorFaultOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  for (const Window& w : silences) {
    if (!(std::isfinite(w.from) && std::isfinite(w.to) && w.from >= 0.0 && w.from < w.to)) {
      return fail("a silence must be FROM-TO with 0 <= FROM < TO, in s");
    }
  }
  if (!(bad_frame_probability >= 0.0 && bad_frame_probability <= 1.0)) {
    return fail("the bad-frame probability must be in [0, 1]");
  }
  return true;
}

bool ParseSilence(const std::string& text, SensorFaultOptions::Window* window) {
  const size_t dash = text.find('-', 1);  // the first character may be a sign
  if (dash == std::string::npos) return false;
  const std::string from = text.substr(0, dash), to = text.substr(dash + 1);
  char* end = nullptr;
  const double a = std::strtod(from.c_str(), &end);
  if (from.empty() || *end != '\0') return false;
  const double b = std::strtod(to.c_str(), &end);
  if (to.empty() || *end != '\0') return false;
  window->from = a;
  window->to = b;
  SensorFaultOptions check;
  check.silences = {*window};
  return check.IsValid(nullptr);
}

const char* SensorFaultKindName(SensorFaultKind kind) {
  switch (kind) {
    case SensorFaultKind::kNanPose: return "nan_pose";
    case SensorFaultKind::kUnnormalised: return "unnormalised_attitude";
    case SensorFaultKind::kFutureStamp: return "future_stamp";
    case SensorFaultKind::kLate: return "late";
    case SensorFaultKind::kNanPoints: return "nan_points";
  }
  return "unknown";
}

SensorFaults::SensorFaults(const SensorFaultOptions& options, uint64_t seed) : options_(options), random_(seed) {}

std::vector<perception::SensorFrame> SensorFaults::Pass(perception::SensorFrame frame, double now) {
  for (const SensorFaultOptions::Window& w : options_.silences) {
    if (now >= w.from && now < w.to) {
      ++counts_.silenced;
      return {};
    }
  }
  std::vector<perception::SensorFrame> arriving;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  bool hold = false;
  if (options_.bad_frame_probability > 0.0 && unit(random_) < options_.bad_frame_probability) {
    const auto kind = static_cast<SensorFaultKind>(
        std::uniform_int_distribution<int>(0, kNumSensorFaultKinds - 1)(random_));
    ++counts_.spoiled[static_cast<int>(kind)];
    switch (kind) {
      case SensorFaultKind::kNanPose: frame.position.y() = std::numeric_limits<double>::quiet_NaN(); break;
      case SensorFaultKind::kUnnormalised: frame.attitude *= 1.5; break;
      case SensorFaultKind::kFutureStamp: frame.t += 1.0; break;
      case SensorFaultKind::kLate: hold = true; break;
      case SensorFaultKind::kNanPoints:
        for (size_t i = 0; i < frame.points.size(); i += 10) frame.points[i].x() = std::numeric_limits<double>::quiet_NaN();
        break;
    }
  }
  std::vector<perception::SensorFrame> held = std::move(held_);
  held_.clear();
  if (hold) {
    held_.push_back(std::move(frame));
  } else {
    arriving.push_back(std::move(frame));
  }
  for (perception::SensorFrame& f : held) arriving.push_back(std::move(f));
  return arriving;
}

}  // namespace quadhand::explore
