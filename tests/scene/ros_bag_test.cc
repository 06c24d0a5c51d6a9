// ROS 1 bags of sensor clouds (scene/ros_bag.h). Bags are written here two
// ways: with QuadHand's BagWriter, and message by message with rosbag
// itself (for the malformed clouds and poses a writer of ours would never
// make). What is read back is judged against exact primitives: the faces
// of a box, placed by known poses.
#include "quadhand/scene/ros_bag.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>

#include "quadhand/scene/scans.h"

namespace quadhand::scene {
namespace {

class RosBagTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("quadhand_bag_test_" + std::to_string(getpid()) + "_" +
                                                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  std::filesystem::path dir_;
};

// Points on the faces of the box [lo, hi], `step` apart.
std::vector<Vec3> BoxFaces(const Vec3& lo, const Vec3& hi, double step) {
  std::vector<Vec3> points;
  for (double u = lo.x(); u <= hi.x() + 1e-9; u += step) {
    for (double v = lo.y(); v <= hi.y() + 1e-9; v += step) {
      points.emplace_back(u, v, lo.z());
      points.emplace_back(u, v, hi.z());
    }
  }
  for (double u = lo.x(); u <= hi.x() + 1e-9; u += step) {
    for (double w = lo.z(); w <= hi.z() + 1e-9; w += step) {
      points.emplace_back(u, lo.y(), w);
      points.emplace_back(u, hi.y(), w);
    }
  }
  return points;
}

Pose PoseOf(const Vec3& position, double yaw, double pitch) {
  return MakePose(position, (Eigen::AngleAxisd(yaw, Vec3::UnitZ()) * Eigen::AngleAxisd(pitch, Vec3::UnitY())).toRotationMatrix());
}

std::vector<Vec3> Moved(const Pose& pose, std::vector<Vec3> points) {
  for (Vec3& p : points) p = pose * p;
  return points;
}

double LargestDistance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  EXPECT_EQ(a.size(), b.size());
  double worst = 0.0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) worst = std::max(worst, (a[i] - b[i]).norm());
  return worst;
}

BagCloudSource Source(const std::string& path) {
  BagCloudSource source;
  source.path = path;
  source.cloud_topic = "/quadhand/points";
  return source;
}

std::vector<BagCloud> ReadAll(const BagCloudSource& source, BagCloudCounts* counts, core::Status* status = nullptr) {
  std::vector<BagCloud> clouds;
  const core::Status s = ForEachBagCloud(
      source,
      [&](BagCloud& cloud) {
        clouds.push_back(cloud);
        return core::Status::Ok();
      },
      counts);
  if (status != nullptr) {
    *status = s;
  } else {
    EXPECT_TRUE(s.ok()) << s.message();
  }
  return clouds;
}

// Three frames of a box seen from three poses of a vehicle whose sensor is
// pitched down and offset from its base.
struct Recording {
  std::vector<Vec3> world = BoxFaces(Vec3(2.0, -0.5, 0.0), Vec3(3.0, 0.5, 1.0), 0.05);
  Pose sensor_to_base = PoseOf(Vec3(0.1, 0.0, -0.05), 0.0, 0.3);
  std::vector<Pose> bases = {PoseOf(Vec3(0.0, 0.0, 1.0), 0.1, 0.02), PoseOf(Vec3(0.5, 0.2, 1.1), -0.2, 0.0),
                             PoseOf(Vec3(1.0, -0.1, 1.2), 0.4, -0.03)};
  std::vector<double> times = {0.0, 0.1, 0.2};

  Pose SensorToWorld(size_t i) const { return bases[i] * sensor_to_base; }
  core::Status Write(const std::string& path) const {
    auto writer = BagWriter::Create(path);
    if (!writer.ok()) return writer.status();
    for (size_t i = 0; i < bases.size(); ++i) {
      QUADHAND_RETURN_IF_ERROR((*writer)->Write(times[i], bases[i], sensor_to_base, Moved(SensorToWorld(i).inverse(), world)));
    }
    return (*writer)->Close();
  }
};

TEST_F(RosBagTest, CloudsPlacedByTfComeBackWhereTheyWere) {
  const Recording recording;
  ASSERT_TRUE(recording.Write(Path("box.bag")).ok());
  BagCloudCounts counts;
  const std::vector<BagCloud> clouds = ReadAll(Source(Path("box.bag")), &counts);
  ASSERT_EQ(clouds.size(), 3u);
  EXPECT_EQ(counts.messages, 3);
  EXPECT_EQ(counts.used, 3);
  EXPECT_EQ(counts.poses, 6);  // two transforms per pose
  EXPECT_EQ(counts.bad_poses, 0);
  for (size_t i = 0; i < clouds.size(); ++i) {
    EXPECT_NEAR(clouds[i].t, 1.0 + recording.times[i], 1e-9);  // the writer's epoch: 1 s
    // float32 returns a few metres out: a few micrometres
    EXPECT_LT(LargestDistance(Moved(clouds[i].sensor_to_world, clouds[i].points), recording.world), 1e-5);
  }
}

TEST_F(RosBagTest, CloudsPlacedByOdometryUseTheExtrinsic) {
  const Recording recording;
  ASSERT_TRUE(recording.Write(Path("box.bag")).ok());
  BagCloudSource source = Source(Path("box.bag"));
  source.odom_topic = "/quadhand/odom";
  source.extrinsic = recording.sensor_to_base;
  BagCloudCounts counts;
  const std::vector<BagCloud> clouds = ReadAll(source, &counts);
  ASSERT_EQ(clouds.size(), 3u);
  for (const BagCloud& cloud : clouds) {
    EXPECT_LT(LargestDistance(Moved(cloud.sensor_to_world, cloud.points), recording.world), 1e-5);
  }
  // Without the extrinsic the clouds are placed at the base: off by its offset.
  source.extrinsic = Pose::Identity();
  const std::vector<BagCloud> at_base = ReadAll(source, &counts);
  ASSERT_EQ(at_base.size(), 3u);
  EXPECT_GT(LargestDistance(Moved(at_base[0].sensor_to_world, at_base[0].points), recording.world), 0.1);
}

TEST_F(RosBagTest, OdometryIsInterpolatedBetweenItsMessagesAndNotAcrossAGap) {
  auto writer = BagWriter::Create(Path("odom.bag"));
  ASSERT_TRUE(writer.ok());
  const Pose a = PoseOf(Vec3(0.0, 0.0, 1.0), 0.0, 0.0), b = PoseOf(Vec3(1.0, 2.0, 1.0), 0.8, 0.0);
  const Pose c = PoseOf(Vec3(5.0, 2.0, 1.0), 0.8, 0.0);
  ASSERT_TRUE((*writer)->WritePose(0.0, a, Pose::Identity()).ok());
  ASSERT_TRUE((*writer)->WritePose(0.2, b, Pose::Identity()).ok());
  ASSERT_TRUE((*writer)->WritePose(2.2, c, Pose::Identity()).ok());  // 2 s later: a gap
  const std::vector<Vec3> one = {Vec3(1.0, 0.0, 0.0)};
  ASSERT_TRUE((*writer)->WriteCloud(0.05, one).ok());  // a quarter of the way from a to b
  ASSERT_TRUE((*writer)->WriteCloud(1.0, one).ok());   // in the gap
  ASSERT_TRUE((*writer)->WriteCloud(3.0, one).ok());   // after the last pose
  ASSERT_TRUE((*writer)->Close().ok());
  BagCloudSource source = Source(Path("odom.bag"));
  source.odom_topic = "/quadhand/odom";
  BagCloudCounts counts;
  const std::vector<BagCloud> clouds = ReadAll(source, &counts);
  ASSERT_EQ(clouds.size(), 1u);
  EXPECT_EQ(counts.no_pose, 2);
  EXPECT_LT((clouds[0].sensor_to_world.translation() - Vec3(0.25, 0.5, 1.0)).norm(), 1e-9);
  const double yaw = std::atan2(clouds[0].sensor_to_world.linear()(1, 0), clouds[0].sensor_to_world.linear()(0, 0));
  EXPECT_NEAR(yaw, 0.2, 1e-9);
  // tf2 interpolates the same way, and refuses the stamp after the last transform.
  const std::vector<BagCloud> by_tf = ReadAll(Source(Path("odom.bag")), &counts);
  ASSERT_GE(by_tf.size(), 1u);
  EXPECT_LT((by_tf[0].sensor_to_world.translation() - Vec3(0.25, 0.5, 1.0)).norm(), 1e-6);
  EXPECT_GE(counts.no_pose, 1);
}

// A PointCloud2 of `points` with the given field layout.
sensor_msgs::PointCloud2 RawCloud(const std::vector<Vec3>& points, bool doubles, const std::string& frame) {
  sensor_msgs::PointCloud2 cloud;
  cloud.header.stamp = ros::Time(1.0);
  cloud.header.frame_id = frame;
  cloud.height = 1;
  cloud.width = static_cast<uint32_t>(points.size());
  const uint32_t size = doubles ? 8 : 4;
  const char* axes[3] = {"x", "y", "z"};
  for (uint32_t axis = 0; axis < 3; ++axis) {
    sensor_msgs::PointField field;
    field.name = axes[axis];
    field.offset = 4 + axis * size;  // after an intensity-like float
    field.datatype = doubles ? sensor_msgs::PointField::FLOAT64 : sensor_msgs::PointField::FLOAT32;
    field.count = 1;
    cloud.fields.push_back(field);
  }
  cloud.point_step = 4 + 3 * size;
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.data.assign(cloud.row_step, 0);
  for (size_t i = 0; i < points.size(); ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      uint8_t* at = cloud.data.data() + i * cloud.point_step + 4 + axis * size;
      if (doubles) {
        const double v = points[i][axis];
        std::memcpy(at, &v, 8);
      } else {
        const float v = static_cast<float>(points[i][axis]);
        std::memcpy(at, &v, 4);
      }
    }
  }
  return cloud;
}

TEST_F(RosBagTest, MalformedCloudsAndPosesAreDroppedAndCounted) {
  const std::vector<Vec3> points = {Vec3(1.0, 0.0, 0.0), Vec3(2.0, 0.5, -0.5),
                                    Vec3(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0)};
  {
    rosbag::Bag bag(Path("raw.bag"), rosbag::bagmode::Write);
    tf2_msgs::TFMessage tf;
    geometry_msgs::TransformStamped t;
    t.header.frame_id = "world";
    t.child_frame_id = "cam";
    t.transform.translation.z = 1.0;
    t.transform.rotation.w = 1.0;
    t.header.stamp = ros::Time(1.0);
    tf.transforms.push_back(t);
    t.header.stamp = ros::Time(2.0);
    tf.transforms.push_back(t);
    t.transform.rotation.w = 0.5;  // not a unit quaternion: refused
    tf.transforms.push_back(t);
    bag.write("/tf", ros::Time(1.0), tf);
    bag.write("/quadhand/points", ros::Time(1.0), RawCloud(points, false, "cam"));   // good, one NaN return
    bag.write("/quadhand/points", ros::Time(1.0), RawCloud(points, true, "/cam"));   // good (float64, a leading slash)
    sensor_msgs::PointCloud2 big_endian = RawCloud(points, false, "cam");
    big_endian.is_bigendian = true;
    bag.write("/quadhand/points", ros::Time(1.0), big_endian);
    sensor_msgs::PointCloud2 no_z = RawCloud(points, false, "cam");
    no_z.fields.pop_back();
    bag.write("/quadhand/points", ros::Time(1.0), no_z);
    sensor_msgs::PointCloud2 short_data = RawCloud(points, false, "cam");
    short_data.data.resize(short_data.data.size() - 1);
    bag.write("/quadhand/points", ros::Time(1.0), short_data);
    sensor_msgs::PointCloud2 huge = RawCloud(points, false, "cam");
    huge.width = 4000000000u;  // declares 48 GB it does not hold
    huge.row_step = huge.point_step;
    bag.write("/quadhand/points", ros::Time(1.0), huge);
    sensor_msgs::PointCloud2 int_field = RawCloud(points, false, "cam");
    int_field.fields[1].datatype = sensor_msgs::PointField::INT16;
    bag.write("/quadhand/points", ros::Time(1.0), int_field);
    bag.write("/quadhand/points", ros::Time(1.0), RawCloud(points, false, "elsewhere"));  // no such frame in /tf
    sensor_msgs::PointCloud2 late = RawCloud(points, false, "cam");
    late.header.stamp = ros::Time(9.0);  // after the last transform
    bag.write("/quadhand/points", ros::Time(1.0), late);
    bag.write("/quadhand/odom", ros::Time(1.0), nav_msgs::Odometry());  // all zero: not a unit quaternion
  }
  BagCloudCounts counts;
  const std::vector<BagCloud> clouds = ReadAll(Source(Path("raw.bag")), &counts);
  ASSERT_EQ(clouds.size(), 2u);
  EXPECT_EQ(counts.messages, 9);
  EXPECT_EQ(counts.malformed, 5);
  EXPECT_EQ(counts.no_pose, 2);
  EXPECT_EQ(counts.non_finite_points, 2);
  EXPECT_EQ(counts.poses, 3);
  EXPECT_EQ(counts.bad_poses, 1);
  for (const BagCloud& cloud : clouds) {
    ASSERT_EQ(cloud.points.size(), 2u);
    EXPECT_LT((cloud.sensor_to_world * cloud.points[1] - Vec3(2.0, 0.5, 0.5)).norm(), 1e-6);
  }
  BagCloudSource by_odom = Source(Path("raw.bag"));
  by_odom.odom_topic = "/quadhand/odom";
  const std::vector<BagCloud> none = ReadAll(by_odom, &counts);
  EXPECT_TRUE(none.empty());
  EXPECT_EQ(counts.bad_poses, 1);
  EXPECT_EQ(counts.no_pose, 4);
}

TEST_F(RosBagTest, AMissingTopicListsTheTopicsTheBagHas) {
  const Recording recording;
  ASSERT_TRUE(recording.Write(Path("box.bag")).ok());
  BagCloudSource source = Source(Path("box.bag"));
  source.cloud_topic = "/camera/depth/points";
  BagCloudCounts counts;
  core::Status status;
  ReadAll(source, &counts, &status);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find(Path("box.bag")), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("no topic /camera/depth/points"), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("/quadhand/points [sensor_msgs/PointCloud2]"), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("/quadhand/odom [nav_msgs/Odometry]"), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("/tf [tf2_msgs/TFMessage]"), std::string::npos) << status.message();
  // A topic of another type.
  source.cloud_topic = "/quadhand/odom";
  ReadAll(source, &counts, &status);
  EXPECT_NE(status.message().find("/quadhand/odom is nav_msgs/Odometry, not sensor_msgs/PointCloud2"), std::string::npos)
      << status.message();
  auto topics = BagTopics(Path("box.bag"));
  ASSERT_TRUE(topics.ok());
  EXPECT_EQ(topics->size(), 3u);
}

TEST_F(RosBagTest, WhatIsNotABagIsOneErrorNamingIt) {
  BagCloudCounts counts;
  core::Status status;
  ReadAll(Source(Path("missing.bag")), &counts, &status);
  EXPECT_EQ(status.message(), Path("missing.bag") + ": no such file");
  { std::ofstream(Path("text.bag")) << "#ROSBAG V2.0\nnot really\n"; }
  ReadAll(Source(Path("text.bag")), &counts, &status);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.message().rfind(Path("text.bag") + ": not a readable ROS 1 bag", 0), 0u) << status.message();
  // A record declaring a 4 GB header in a file of 30 bytes: refused before
  // rosbag would allocate it (found by fuzz_ros_bag).
  {
    std::ofstream huge(Path("huge.bag"), std::ios::binary);
    huge << "#ROSBAG V2.0\n";
    const uint32_t lengths[3] = {0xF0000000u, 0u, 0u};
    huge.write(reinterpret_cast<const char*>(lengths), sizeof(lengths));
  }
  ReadAll(Source(Path("huge.bag")), &counts, &status);
  EXPECT_EQ(status.message(), Path("huge.bag") + ": not a readable ROS 1 bag (a record's header runs past the end)");
  ReadAll(Source(dir_.string()), &counts, &status);
  EXPECT_EQ(status.message(), dir_.string() + ": not a regular file");
  // A bag cut short anywhere: an error naming it, or the clouds before the cut; never a crash.
  const Recording recording;
  ASSERT_TRUE(recording.Write(Path("box.bag")).ok());
  std::ifstream in(Path("box.bag"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const double fraction : {0.02, 0.3, 0.6, 0.97}) {
    { std::ofstream(Path("cut.bag"), std::ios::binary) << bytes.substr(0, static_cast<size_t>(fraction * bytes.size())); }
    const std::vector<BagCloud> clouds = ReadAll(Source(Path("cut.bag")), &counts, &status);
    if (!status.ok()) {
      EXPECT_EQ(status.message().rfind(Path("cut.bag") + ": ", 0), 0u) << status.message();
    } else {
      EXPECT_LE(clouds.size(), 3u);
    }
  }
}

TEST_F(RosBagTest, CompressedChunksReadAsPlainOnes) {
  const std::vector<Vec3> points = {Vec3(1.0, 0.0, 0.0), Vec3(2.0, 0.5, -0.5)};
  for (const auto compression : {rosbag::compression::BZ2, rosbag::compression::LZ4}) {
    const std::string path = Path(compression == rosbag::compression::BZ2 ? "bz2.bag" : "lz4.bag");
    {
      rosbag::Bag bag(path, rosbag::bagmode::Write);
      bag.setCompression(compression);
      tf2_msgs::TFMessage tf;
      geometry_msgs::TransformStamped t;
      t.header.frame_id = "world";
      t.child_frame_id = "cam";
      t.header.stamp = ros::Time(1.0);
      t.transform.translation.z = 1.0;
      t.transform.rotation.w = 1.0;
      tf.transforms.push_back(t);
      bag.write("/tf", ros::Time(1.0), tf);
      for (int i = 0; i < 50; ++i) bag.write("/quadhand/points", ros::Time(1.0), RawCloud(points, false, "cam"));
    }
    BagCloudCounts counts;
    const std::vector<BagCloud> clouds = ReadAll(Source(path), &counts);
    ASSERT_EQ(clouds.size(), 50u) << path;
    EXPECT_LT((clouds[49].sensor_to_world * clouds[49].points[1] - Vec3(2.0, 0.5, 0.5)).norm(), 1e-6);
  }
}

// What fuzz_ros_bag found (tests/fuzz/corpus/ros_bag/: a connection record
// declaring a 4 GB header; an index entry pointing into the middle of a
// chunk, and a connection header's field longer than the header, each of
// which made rosbag read outside its buffer; a cloud declaring 3 GB of data
// in a short message) and the seed bags:
// each is read or refused with one error naming it.
TEST_F(RosBagTest, TheFuzzersFindingsAreRefusedNotCrashedOn) {
  const std::string corpus = std::string(QUADHAND_SOURCE_DIR) + "/tests/fuzz/corpus/ros_bag";
  int refused = 0, read = 0;
  for (const auto& entry : std::filesystem::directory_iterator(corpus)) {
    BagCloudCounts counts;
    core::Status status;
    ReadAll(Source(entry.path().string()), &counts, &status);
    if (status.ok()) {
      ++read;
    } else {
      ++refused;
      EXPECT_EQ(status.message().rfind(entry.path().string() + ": not a readable ROS 1 bag (", 0), 0u) << status.message();
    }
  }
  EXPECT_GE(read, 4);     // the seeds: plain, bz2 and lz4 with /tf_static, many chunks
  EXPECT_GE(refused, 3);  // three of the findings
}

TEST_F(RosBagTest, AFailedWriterLeavesNoFile) {
  {
    auto writer = BagWriter::Create(Path("unfinished.bag"));
    ASSERT_TRUE(writer.ok());
    ASSERT_TRUE((*writer)->Write(0.0, Pose::Identity(), Pose::Identity(), {Vec3(1, 2, 3)}).ok());
    EXPECT_FALSE((*writer)->Write(std::numeric_limits<double>::quiet_NaN(), Pose::Identity(), Pose::Identity(), {}).ok());
  }  // never closed
  EXPECT_TRUE(std::filesystem::is_empty(dir_));
  EXPECT_FALSE(BagWriter::Create(Path("no/such/folder/x.bag")).ok());
}

TEST_F(RosBagTest, ATaskSceneListsABagLikeAScan) {
  const Recording recording;
  ASSERT_TRUE(recording.Write(Path("box.bag")).ok());
  ScanSource scan;
  scan.path = Path("box.bag");
  scan.bag = Source(scan.path);
  scan.crop = CropBox{Vec3(1.9, -1.0, 0.525), Vec3(3.1, 1.0, 1.5)};  // the box's upper half (between its rows)
  auto loaded = LoadScans({scan});
  ASSERT_TRUE(loaded.ok()) << loaded.status().message();
  size_t upper = 0;
  for (const Vec3& p : recording.world) upper += p.z() >= 0.525 ? 1 : 0;
  EXPECT_EQ(loaded->points.size(), 3 * upper);  // three frames of it
  EXPECT_EQ(loaded->bag_clouds.used, 3);
  for (const Vec3& p : loaded->points) EXPECT_GE(p.z(), 0.525);
  // A bag with a cloud that cannot be placed: the scene would miss what it
  // saw, so it is an error unless the task says to plan without it.
  {
    auto partial = BagWriter::Create(Path("partial.bag"));
    ASSERT_TRUE(partial.ok());
    ASSERT_TRUE((*partial)->WritePose(0.0, Pose::Identity(), Pose::Identity()).ok());
    ASSERT_TRUE((*partial)->WritePose(0.2, Pose::Identity(), Pose::Identity()).ok());
    ASSERT_TRUE((*partial)->WriteCloud(0.1, recording.world).ok());
    ASSERT_TRUE((*partial)->WriteCloud(5.0, recording.world).ok());  // after the last pose
    ASSERT_TRUE((*partial)->Close().ok());
  }
  ScanSource partial;
  partial.path = Path("partial.bag");
  partial.bag = Source(partial.path);
  auto strict = LoadScans({partial});
  ASSERT_FALSE(strict.ok());
  EXPECT_EQ(strict.status().message(),
            Path("partial.bag") + ": 1 of the 2 clouds on /quadhand/points could not be used (0 malformed, 1 without a "
                                  "pose at their stamp): the scene would miss what they saw (skip_unusable: true plans "
                                  "without them)");
  partial.skip_unusable_clouds = true;
  auto skipping = LoadScans({partial});
  ASSERT_TRUE(skipping.ok()) << skipping.status().message();
  EXPECT_EQ(skipping->points.size(), recording.world.size());
  EXPECT_EQ(skipping->bag_clouds.no_pose, 1);
  // A bag none of whose clouds has a pose is an error naming it.
  scan.bag->odom_topic = "/quadhand/odom";
  auto writer = BagWriter::Create(Path("posed_late.bag"));
  ASSERT_TRUE(writer.ok());
  ASSERT_TRUE((*writer)->WritePose(5.0, Pose::Identity(), Pose::Identity()).ok());
  ASSERT_TRUE((*writer)->WriteCloud(0.0, recording.world).ok());
  ASSERT_TRUE((*writer)->Close().ok());
  scan.path = scan.bag->path = Path("posed_late.bag");
  auto refused = LoadScans({scan});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().message(),
            Path("posed_late.bag") + ": no cloud on /quadhand/points could be used (1 messages: 0 malformed, 1 without "
                                     "a pose at their stamp)");
}

}  // namespace
}  // namespace quadhand::scene
