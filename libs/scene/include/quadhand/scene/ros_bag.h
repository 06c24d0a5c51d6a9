// Recorded range-sensor data in ROS 1 bags (docs/perception.md, "Recorded
// data"): the sensor_msgs/PointCloud2 messages of one topic, each placed in
// the world by the pose of its frame at its stamp, taken from a
// nav_msgs/Odometry topic or from the bag's /tf and /tf_static. Read and
// written with Debian's rosbag_storage (the bag format of ROS 1 Noetic);
// the transforms are looked up with tf2.
//
// rosbag and roscpp trust the lengths and offsets a bag declares, so a
// bag's structure is checked before rosbag reads it, and messages are read
// from their bytes with every length checked (docs/reliability.md, "ROS 1
// bags": what fuzzing found).
//
// A cloud that cannot be used is dropped and counted, never an error: one
// that does not decode, is big-endian, lacks float32 or float64 x/y/z
// fields, or declares more data than it holds (malformed); one whose stamp
// has no pose (no_pose). Errors are for the bag itself: unreadable, not a
// bag, or without the named topic (the message lists the topics it has).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::scene {

struct BagCloudSource {
  std::string path;
  std::string cloud_topic;  // sensor_msgs/PointCloud2
  // Poses from this nav_msgs/Odometry topic: the pose of its child frame,
  // interpolated to each cloud's stamp (linear in position, slerp in
  // rotation), and moved by `extrinsic`, the cloud's frame in that child
  // frame. Empty: poses from /tf and /tf_static instead, world_frame <- the
  // cloud's header.frame_id, at its stamp (tf2 interpolates likewise).
  std::string odom_topic;
  Pose extrinsic = Pose::Identity();
  std::string world_frame = "world";
  // s: a stamp between two odometry messages farther apart than this has
  // no pose (a dropout is not bridged by a straight line).
  double max_pose_gap = 0.5;
  bool IsValid(std::string* why) const;
};

struct BagCloud {
  double t = 0.0;  // the cloud's header stamp (its bag time when the stamp is zero), s
  Pose sensor_to_world = Pose::Identity();
  std::vector<Vec3> points;  // finite returns, in the cloud's own frame
};

struct BagCloudCounts {
  long messages = 0;           // on the cloud topic
  long used = 0;               // handed to the visitor
  long malformed = 0;          // dropped: see the top of this file
  long no_pose = 0;            // dropped: no pose at the stamp
  long non_finite_points = 0;  // returns dropped from clouds used (an organised cloud's invalid pixels)
  long poses = 0;              // odometry messages, or transforms on /tf and /tf_static
  long bad_poses = 0;          // of those: non-finite, not a unit quaternion, or refused by tf2
  BagCloudCounts& operator+=(const BagCloudCounts& other);
};

// Calls `visit` with each usable cloud of the topic, in the bag's order.
// A non-OK status from `visit` stops the reading and is returned. Errors
// name the bag's path.
core::Status ForEachBagCloud(const BagCloudSource& source, const std::function<core::Status(BagCloud&)>& visit,
                             BagCloudCounts* counts);

// The names and types of a bag's topics, "/topic [pkg/Type]", sorted.
core::Result<std::vector<std::string>> BagTopics(const std::string& path);

// Writes a range sensor's frames as a ROS 1 bag, as a robot's driver and
// state estimator would record them: each frame's returns as a
// sensor_msgs/PointCloud2 (float32 x, y, z; frame sensor_frame) on
// cloud_topic, the vehicle's pose as a nav_msgs/Odometry (world_frame to
// base_frame) on odom_topic, and both transforms (world_frame to
// base_frame, base_frame to sensor_frame) on /tf. Stamps are the given
// times plus `epoch`: a ROS 1 bag holds no message at time zero. The bag
// is written beside `path` and renamed onto it by Close, so that a failed
// run leaves no file.
struct BagTopicsToWrite {
  std::string cloud_topic = "/quadhand/points";
  std::string odom_topic = "/quadhand/odom";
  std::string world_frame = "world";
  std::string base_frame = "base_link";
  std::string sensor_frame = "quadhand_sensor";
  double epoch = 1.0;  // s
};

class BagWriter {
 public:
  static core::Result<std::unique_ptr<BagWriter>> Create(const std::string& path, const BagTopicsToWrite& topics = {});
  ~BagWriter();
  // The vehicle's pose at t: the odometry and both transforms.
  core::Status WritePose(double t, const Pose& base_to_world, const Pose& sensor_to_base);
  // A frame's returns at t, in the sensor's frame.
  core::Status WriteCloud(double t, const std::vector<Vec3>& points);
  // Both, at one time.
  core::Status Write(double t, const Pose& base_to_world, const Pose& sensor_to_base, const std::vector<Vec3>& points);
  // Finishes the bag and renames it onto its path; without it, the
  // destructor removes what was written.
  core::Status Close();

 private:
  struct Impl;
  explicit BagWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace quadhand::scene
