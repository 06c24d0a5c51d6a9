// A scene made of one or more scans, each as its sensor wrote it: a point
// cloud file (scene/point_cloud.h) and the sensor's pose in the world, a
// ROS 1 bag's clouds at their recorded poses (scene/ros_bag.h), or a folder
// of recorded frames at theirs (scene/frame_folder.h); then an
// optional crop box (world frame) and an optional voxel filter, both PCL's
// filters. The task file's `scene:` (docs/task_format.md) is a list of these.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/scene/ros_bag.h"

namespace quadhand::scene {

struct CropBox {
  Vec3 min, max;  // world frame, metres; min < max on every axis
};

struct ScanSource {
  std::string path;               // PCD or PLY, or the bag
  Pose sensor_to_world = Pose::Identity();
  // A bag instead of one cloud (bag->path == path): every usable cloud of
  // its topic at its own pose; sensor_to_world stays the identity.
  std::optional<BagCloudSource> bag;
  // A folder of recorded frames instead of one cloud (path is the folder):
  // every usable frame's cloud at its pose; sensor_to_world stays the
  // identity.
  bool frame_folder = false;
  // A bag or a frames folder with clouds that cannot be used (malformed, or
  // without a pose) is an error unless this is set: the scene would miss
  // what they saw. Set, the usable clouds are the scan.
  bool skip_unusable_clouds = false;
  std::optional<CropBox> crop;    // applied in the world frame, after the pose
  double voxel = 0.0;             // leaf size, metres; 0: no voxel filter
};

// What a frames folder held, summed over the folders of a scene.
struct FrameFolderCounts {
  long rows = 0;               // of frames.csv, kept or dropped
  long used = 0;               // frames whose clouds joined the scene
  long dropped_rows = 0;       // malformed, bad pose or out of order (scene/frame_folder.h)
  long unreadable_clouds = 0;  // a frame's cloud missing, truncated or malformed
  long empty_clouds = 0;       // the sensor saw nothing in range: nothing to add, not an error
  FrameFolderCounts& operator+=(const FrameFolderCounts& other);
};

struct LoadedScans {
  // What planning optimises against: every scan moved into the world,
  // cropped, and voxel-filtered where asked (a voxel's points become their
  // centroid).
  std::vector<Vec3> points;
  // The cropped points before any voxel filter: what the post-check must
  // keep the robot clear of. Empty when no scan has a voxel filter (then
  // they are `points`).
  std::vector<Vec3> unfiltered_points;
  long dropped_non_finite = 0;  // over all scans
  BagCloudCounts bag_clouds;    // summed over the bags
  FrameFolderCounts frame_clouds;  // summed over the frames folders
  long cropped_away = 0;        // finite points outside their scan's crop box
  double load_seconds = 0.0;    // reading, moving and filtering every scan
};

// Errors name the scan's file: unreadable or malformed (LoadPointCloud; a
// bag: ForEachBagCloud, or no cloud of its topic with a pose; a frames
// folder: ReadFrameIndex, or no frame that could be used), unusable clouds
// without skip_unusable_clouds, a
// pose that is not a rigid motion, a crop box with min >= max, a voxel leaf
// that is not positive and finite or so small for the scan's extent that
// PCL's voxel indices would overflow, and a scene with no point left.
core::Result<LoadedScans> LoadScans(const std::vector<ScanSource>& sources);

}  // namespace quadhand::scene
