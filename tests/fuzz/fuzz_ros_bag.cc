// ROS 1 bags (scene/ros_bag.h): the input is the bag file, read as a task's
// bag scene or quadhand-map --bag reads it, its poses from /tf and then from
// an odometry topic. Every input must give clouds or an error; every cloud
// handed on holds finite returns at a rigid pose.
#include "fuzz_support.h"
#include "quadhand/scene/ros_bag.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = quadhand::fuzz::WriteInput(data, size, "recording.bag");
  (void)quadhand::scene::BagTopics(path);
  quadhand::scene::BagCloudSource source;
  source.path = path;
  source.cloud_topic = "/quadhand/points";
  auto check = [](quadhand::scene::BagCloud& cloud) {
    if (!cloud.sensor_to_world.matrix().allFinite()) __builtin_trap();
    for (const auto& p : cloud.points) {
      if (!p.allFinite()) __builtin_trap();
    }
    return quadhand::core::Status::Ok();
  };
  quadhand::scene::BagCloudCounts counts;
  (void)quadhand::scene::ForEachBagCloud(source, check, &counts);
  source.odom_topic = "/quadhand/odom";
  (void)quadhand::scene::ForEachBagCloud(source, check, &counts);
  return 0;
}
