// Scans in the sensor's frame: moved by their pose, cropped in the world
// frame and voxel-filtered with PCL, the unfiltered points kept for the
// post-check; bad poses, boxes and leaves are errors naming the scan's file.
#include "quadhand/scene/scans.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "quadhand/scene/point_cloud.h"

namespace quadhand::scene {
namespace {

namespace fs = std::filesystem;

class ScansTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("quadhand_scans_" + std::to_string(getpid()));
    fs::create_directories(dir_);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < 2000; ++i) points_.emplace_back(u(rng), u(rng), u(rng));  // the unit cube
    ASSERT_TRUE(WritePcd(Path("cube.pcd"), points_).ok());
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) { return (dir_ / name).string(); }
  fs::path dir_;
  std::vector<Vec3> points_;
};

TEST_F(ScansTest, APoseMovesTheScanIntoTheWorld) {
  ScanSource source;
  source.path = Path("cube.pcd");
  source.sensor_to_world = MakePose(Vec3(10, 0, 2), ExpSO3(Vec3(0, 0, M_PI / 2)));
  auto scans = LoadScans({source});
  ASSERT_TRUE(scans.ok()) << scans.status().message();
  ASSERT_EQ(scans->points.size(), points_.size());
  EXPECT_TRUE(scans->unfiltered_points.empty());  // no voxel filter: the same points
  for (size_t i = 0; i < points_.size(); ++i) {
    // float32 in the file
    EXPECT_LT((scans->points[i] - source.sensor_to_world * points_[i]).norm(), 1e-6);
  }
}

TEST_F(ScansTest, CropAndVoxelKeepTheUnfilteredPointsForThePostCheck) {
  ScanSource a, b;
  a.path = b.path = Path("cube.pcd");
  a.crop = CropBox{Vec3(0, 0, 0), Vec3(0.5, 1, 1)};  // about half the cube
  b.sensor_to_world = MakePose(Vec3(5, 0, 0), Mat3::Identity());
  b.voxel = 0.25;  // at most 4 x 4 x 4 centroids
  auto scans = LoadScans({a, b});
  ASSERT_TRUE(scans.ok()) << scans.status().message();
  long cropped = 0;
  for (const Vec3& p : points_) cropped += p.x() > 0.5;
  EXPECT_NEAR(static_cast<double>(scans->cropped_away), static_cast<double>(cropped), 2.0);  // float32 at the edge
  const size_t kept = points_.size() - scans->cropped_away;
  EXPECT_LE(scans->points.size(), kept + 64);
  EXPECT_GT(scans->points.size(), kept);
  // The post-check sees every cropped point of both scans, unreduced.
  EXPECT_EQ(scans->unfiltered_points.size(), kept + points_.size());
  for (const Vec3& p : scans->points) EXPECT_TRUE(p.x() <= 0.5 + 1e-6 || p.x() >= 5.0 - 1e-6);
}

TEST_F(ScansTest, BadSourcesAreErrorsNamingTheFile) {
  ScanSource source;
  source.path = Path("cube.pcd");
  source.sensor_to_world.linear() = 2.0 * Mat3::Identity();  // not a rotation
  auto scaled = LoadScans({source});
  ASSERT_FALSE(scaled.ok());
  EXPECT_NE(scaled.status().message().find("cube.pcd: pose"), std::string::npos) << scaled.status().message();

  source.sensor_to_world = Pose::Identity();
  source.crop = CropBox{Vec3(1, 0, 0), Vec3(0, 1, 1)};
  EXPECT_FALSE(LoadScans({source}).ok());
  source.crop = CropBox{Vec3(5, 5, 5), Vec3(6, 6, 6)};  // nothing inside
  auto empty = LoadScans({source});
  ASSERT_FALSE(empty.ok());
  EXPECT_NE(empty.status().message().find("crop"), std::string::npos) << empty.status().message();
  source.crop.reset();
  source.voxel = 1e-9;  // 1e27 voxels
  auto tiny = LoadScans({source});
  ASSERT_FALSE(tiny.ok());
  EXPECT_NE(tiny.status().message().find("overflow"), std::string::npos) << tiny.status().message();
  EXPECT_FALSE(LoadScans({}).ok());
}

// A folder of recorded frames: each frame's cloud, in its sensor's frame,
// lands where frames.csv places it; an empty frame adds nothing; a row or a
// cloud that cannot be used is an error naming the folder unless the
// scan skips the unusable.
TEST_F(ScansTest, AFramesFolderPlacesEachFrameAtItsPose) {
  const fs::path folder = dir_ / "frames";
  fs::create_directories(folder);
  ASSERT_TRUE(WritePcd((folder / "a.pcd").string(), points_).ok());
  ASSERT_TRUE(WritePcd((folder / "empty.pcd").string(), {}).ok());
  const Pose a = MakePose(Vec3(3, -1, 2), Quat(0.8, 0.2, -0.1, 0.5).normalized().toRotationMatrix());
  const Pose b = MakePose(Vec3(-4, 0, 0.5), ExpSO3(Vec3(0, 0, -M_PI / 3)));
  auto row = [](int i, double t, const std::string& file, const Pose& pose) {
    const Quat q(pose.linear());
    const Vec3 p = pose.translation();
    std::ostringstream out;
    out.precision(17);
    out << i << "," << t << "," << file << "," << p.x() << "," << p.y() << "," << p.z() << "," << q.w() << "," << q.x()
        << "," << q.y() << "," << q.z() << "\n";
    return out.str();
  };
  const std::string header = "index,t,file,x,y,z,qw,qx,qy,qz\n";
  std::ofstream(folder / "frames.csv") << header << row(0, 0.0, "a.pcd", a) << row(1, 0.1, "empty.pcd", a)
                                       << row(2, 0.2, (folder / "a.pcd").string(), b);
  ScanSource source;
  source.path = folder.string();
  source.frame_folder = true;
  auto scans = LoadScans({source});
  ASSERT_TRUE(scans.ok()) << scans.status().message();
  ASSERT_EQ(scans->points.size(), 2 * points_.size());
  for (size_t i = 0; i < points_.size(); ++i) {
    ASSERT_LT((scans->points[i] - a * points_[i]).norm(), 1e-5);
    ASSERT_LT((scans->points[points_.size() + i] - b * points_[i]).norm(), 1e-5);
  }
  EXPECT_EQ(scans->frame_clouds.rows, 3);
  EXPECT_EQ(scans->frame_clouds.used, 2);
  EXPECT_EQ(scans->frame_clouds.empty_clouds, 1);

  // Cropped as each frame is read.
  source.crop = CropBox{Vec3(-10, -10, -10), Vec3(0, 10, 10)};  // frame b's side alone
  auto cropped = LoadScans({source});
  ASSERT_TRUE(cropped.ok()) << cropped.status().message();
  EXPECT_EQ(cropped->points.size(), points_.size());
  EXPECT_EQ(cropped->cropped_away, static_cast<long>(points_.size()));
  source.crop.reset();

  // A malformed row and a missing cloud: refused, then skipped when asked.
  std::ofstream(folder / "frames.csv", std::ios::app) << "3,0.3,a.pcd,0,0,nan,1,0,0,0\n" << row(4, 0.4, "gone.pcd", a);
  auto refused = LoadScans({source});
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find(folder.string() + ": 2 of the 5 frames could not be used (1 rows"),
            std::string::npos)
      << refused.status().message();
  source.skip_unusable_clouds = true;
  auto skipped = LoadScans({source});
  ASSERT_TRUE(skipped.ok()) << skipped.status().message();
  EXPECT_EQ(skipped->points.size(), 2 * points_.size());
  EXPECT_EQ(skipped->frame_clouds.dropped_rows, 1);
  EXPECT_EQ(skipped->frame_clouds.unreadable_clouds, 1);

  // Nothing usable, and no index at all.
  std::ofstream(folder / "frames.csv", std::ios::trunc) << header << row(0, 0.0, "empty.pcd", a);
  auto nothing = LoadScans({source});
  ASSERT_FALSE(nothing.ok());
  EXPECT_NE(nothing.status().message().find("no frame with a return could be used"), std::string::npos)
      << nothing.status().message();
  fs::remove(folder / "frames.csv");
  auto no_index = LoadScans({source});
  ASSERT_FALSE(no_index.ok());
  EXPECT_NE(no_index.status().message().find((folder / "frames.csv").string()), std::string::npos)
      << no_index.status().message();
}

}  // namespace
}  // namespace quadhand::scene
