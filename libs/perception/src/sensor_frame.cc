#include "quadhand/perception/sensor_frame.h"

#include <cmath>

namespace quadhand::perception {

const char* FrameDropName(FrameDrop drop) {
  switch (drop) {
    case FrameDrop::kNone: return "taken";
    case FrameDrop::kMalformed: return "malformed";
    case FrameDrop::kBadPose: return "bad_pose";
    case FrameDrop::kFromTheFuture: return "from_the_future";
    case FrameDrop::kOutOfOrder: return "out_of_order";
    case FrameDrop::kStale: return "stale";
  }
  return "unknown";
}

bool FrameGateOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!(std::isfinite(max_future) && max_future >= 0.0 && max_future <= 10.0)) {
    return fail("max_future must be in [0, 10] s");
  }
  if (!(max_age > 0.0)) return fail("max_age must be > 0 s (infinite: never stale)");
  if (!(std::isfinite(quaternion_tolerance) && quaternion_tolerance > 0.0 && quaternion_tolerance < 0.5)) {
    return fail("quaternion_tolerance must be in (0, 0.5)");
  }
  return true;
}

FrameDrop CheckPose(const Vec3& position, const Eigen::Vector4d& attitude_wxyz, double tolerance) {
  if (!position.allFinite() || !attitude_wxyz.allFinite()) return FrameDrop::kMalformed;
  if (!(std::abs(attitude_wxyz.norm() - 1.0) <= tolerance)) return FrameDrop::kBadPose;
  return FrameDrop::kNone;
}

FrameGate::FrameGate(const FrameGateOptions& options) : options_(options) {}

FrameDrop FrameGate::Admit(const SensorFrame& frame, double now) {
  FrameDrop drop = std::isfinite(frame.t) ? CheckPose(frame.position, frame.attitude, options_.quaternion_tolerance)
                                          : FrameDrop::kMalformed;
  // Order before age: a frame behind the last one taken is out of order
  // whatever its age.
  if (drop == FrameDrop::kNone && frame.t > now + options_.max_future) drop = FrameDrop::kFromTheFuture;
  if (drop == FrameDrop::kNone && !(frame.t > last_taken_)) drop = FrameDrop::kOutOfOrder;
  if (drop == FrameDrop::kNone && now - frame.t > options_.max_age) drop = FrameDrop::kStale;
  switch (drop) {
    case FrameDrop::kNone:
      ++counts_.taken;
      last_taken_ = frame.t;
      break;
    case FrameDrop::kMalformed: ++counts_.malformed; break;
    case FrameDrop::kBadPose: ++counts_.bad_pose; break;
    case FrameDrop::kFromTheFuture: ++counts_.from_the_future; break;
    case FrameDrop::kOutOfOrder: ++counts_.out_of_order; break;
    case FrameDrop::kStale: ++counts_.stale; break;
  }
  return drop;
}

Pose SensorPose(const SensorFrame& frame) {
  const Quat q(frame.attitude[0], frame.attitude[1], frame.attitude[2], frame.attitude[3]);
  return MakePose(frame.position, q.normalized().toRotationMatrix());
}

void SetSensorPose(const Pose& sensor_to_world, SensorFrame* frame) {
  frame->position = sensor_to_world.translation();
  const Quat q(sensor_to_world.rotation());
  frame->attitude = Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
}

}  // namespace quadhand::perception
