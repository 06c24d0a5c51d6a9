// A sensor frame as it reaches the planner (from the simulated sensor, a
// recording or, later, a transport), and the gate each frame passes before
// the rolling map takes it (docs/perception.md, "Bad frames and a silent
// sensor"). A frame the gate refuses is dropped and counted by its reason,
// never inserted: a wrong pose would paint obstacles where there are none
// and, worse, free space where there is an obstacle.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "quadhand/core/types.h"

namespace quadhand::perception {

struct SensorFrame {
  double t = 0.0;  // when the sensor saw it, s on the planner's clock
  // The sensor's pose in the world as received: the attitude (w, x, y, z)
  // is checked, never silently normalised.
  Vec3 position = Vec3::Zero();
  Eigen::Vector4d attitude = Eigen::Vector4d(1.0, 0.0, 0.0, 0.0);
  std::vector<Vec3> points;  // returns, in the sensor's frame
  // The far ends of the rays that returned nothing within the sensor's
  // range, in the sensor's frame (RollingMap::Insert's misses).
  std::vector<Vec3> misses;
};

// Why a frame was dropped.
enum class FrameDrop {
  kNone,          // taken
  kMalformed,     // a time or pose coordinate that is not a finite number
  kBadPose,       // an attitude quaternion not of unit length (within quaternion_tolerance)
  kFromTheFuture, // stamped more than max_future after the planner's now
  kOutOfOrder,    // stamped no later than the last frame taken (a duplicate too)
  kStale,         // older than max_age when it arrived
};
const char* FrameDropName(FrameDrop drop);  // "malformed", "bad_pose", ...

struct FrameGateOptions {
  // s: a sensor's clock may run this far ahead of the planner's (sync
  // error) before its frames are refused as from the future.
  double max_future = 0.05;
  // s: a frame this old on arrival describes where the vehicle was, not
  // where it is; refused (infinite: never).
  double max_age = 0.5;
  double quaternion_tolerance = 1e-3;  // | |q| - 1 | allowed
  bool IsValid(std::string* why) const;
};

struct FrameCounts {
  long taken = 0;
  long malformed = 0, bad_pose = 0, from_the_future = 0, out_of_order = 0, stale = 0;
  long dropped() const { return malformed + bad_pose + from_the_future + out_of_order + stale; }
};

// Whether a pose as received can be used: finite coordinates and an
// attitude of unit length within `tolerance` (kNone), else the reason.
FrameDrop CheckPose(const Vec3& position, const Eigen::Vector4d& attitude_wxyz, double tolerance);

class FrameGate {
 public:
  explicit FrameGate(const FrameGateOptions& options = {});
  // Whether `frame`, arriving at planner time `now`, may go into the map
  // (kNone; counted as taken), or why not (counted by reason). Its points
  // are not looked at: the map drops and counts non-finite ones itself.
  FrameDrop Admit(const SensorFrame& frame, double now);
  const FrameCounts& counts() const { return counts_; }
  // The stamp of the last frame taken (-infinity before the first).
  double last_taken() const { return last_taken_; }

 private:
  FrameGateOptions options_;
  FrameCounts counts_;
  double last_taken_ = -std::numeric_limits<double>::infinity();
};

// The sensor's pose of a frame whose pose CheckPose accepted (its attitude
// normalised).
Pose SensorPose(const SensorFrame& frame);
// Sets a frame's position and attitude from the sensor's pose (what a sender
// does; SensorPose reads it back).
void SetSensorPose(const Pose& sensor_to_world, SensorFrame* frame);

}  // namespace quadhand::perception
