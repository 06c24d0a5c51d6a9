// A folder of recorded sensor frames (docs/sim.md, "The frames folder"):
// one point cloud per frame, in the sensor's frame, and frames.csv giving
// each frame's time, file and sensor pose in the world. quadhand-sim
// --frames writes it; a real sensor's recording in the same layout reads
// the same way. quadhand-map maps it, and a task's scene may list it
// (scene/scans.h).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::scene {

// The tolerance of the frame gate (perception::FrameGateOptions) too: a
// recording and a live stream accept the same poses.
inline constexpr double kFramePoseQuaternionTolerance = 1e-3;

struct FrameRecord {
  long index = 0;
  double t = 0.0;        // s
  std::string path;      // the frame's cloud, resolved against the folder
  Pose sensor_to_world = Pose::Identity();
};

// The rows of DIR/frames.csv that can be used, in order, and the rows
// dropped and why (each counted, never used): a row of the wrong width or
// with a cell that is not a finite number ("malformed"), a pose whose
// quaternion is not of unit length within kFramePoseQuaternionTolerance
// ("bad pose"), a time not after the previous kept row's ("out of order").
struct FrameIndex {
  std::vector<FrameRecord> frames;
  long malformed = 0, bad_pose = 0, out_of_order = 0;
  long dropped() const { return malformed + bad_pose + out_of_order; }
};

// InvalidArgument, naming the file, when frames.csv cannot be read or its
// header lacks one of the columns index,t,file,x,y,z,qw,qx,qy,qz (any order,
// other columns ignored).
core::Result<FrameIndex> ReadFrameIndex(const std::string& dir);

// What ForEachFrameCloud read.
struct FrameCloudCounts {
  long used = 0;               // handed to the visitor
  long unreadable = 0;         // a cloud missing, truncated or malformed: not visited
  long empty = 0;              // no return (the sensor saw nothing in range): not visited
  long non_finite_points = 0;  // returns dropped from the clouds read
};

// Calls `visit` with each frame of `index` whose cloud can be read and holds
// a return, the returns moved into the world by the frame's pose, in the
// index's order. A non-OK status from `visit` stops the reading and is
// returned.
core::Status ForEachFrameCloud(const FrameIndex& index,
                               const std::function<core::Status(const FrameRecord&, std::vector<Vec3>&)>& visit,
                               FrameCloudCounts* counts);

}  // namespace quadhand::scene
