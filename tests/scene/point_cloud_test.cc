#include "quadhand/scene/point_cloud.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

namespace quadhand::scene {
namespace {

namespace fs = std::filesystem;

class PointCloudTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("quadhand_pcd_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) { return (dir_ / name).string(); }
  void WriteText(const std::string& name, const std::string& text) { std::ofstream(Path(name)) << text; }
  fs::path dir_;
};

std::vector<Vec3> RandomPoints(int n) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-3, 3);
  std::vector<Vec3> points(n);
  for (Vec3& p : points) p = Vec3(u(rng), u(rng), u(rng));
  return points;
}

TEST_F(PointCloudTest, RoundTripsEveryEncoding) {
  const std::vector<Vec3> points = RandomPoints(1000);
  for (PcdEncoding encoding : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    const std::string path = Path("cloud.pcd");
    ASSERT_TRUE(WritePcd(path, points, encoding).ok());
    auto cloud = LoadPcd(path);
    ASSERT_TRUE(cloud.ok()) << cloud.status().message();
    ASSERT_EQ(cloud->points.size(), points.size());
    EXPECT_EQ(cloud->dropped_non_finite, 0);
    for (size_t i = 0; i < points.size(); ++i) {
      EXPECT_LT((cloud->points[i] - points[i]).norm(), 1e-6);  // float32 storage
    }
  }
}

TEST_F(PointCloudTest, DropsAndCountsNonFinitePoints) {
  WriteText("nan.pcd",
            "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
            "WIDTH 4\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA ascii\n"
            "1 2 3\nnan 0 0\n4 5 6\n0 inf 0\n");
  auto cloud = LoadPcd(Path("nan.pcd"));
  ASSERT_TRUE(cloud.ok()) << cloud.status().message();
  EXPECT_EQ(cloud->points.size(), 2u);
  EXPECT_EQ(cloud->dropped_non_finite, 2);
}

TEST_F(PointCloudTest, ReportsBadFilesWithTheirName) {
  auto expect_error = [](const std::string& path, const std::string& fragment) {
    auto cloud = LoadPcd(path);
    ASSERT_FALSE(cloud.ok());
    EXPECT_NE(cloud.status().message().find(path), std::string::npos) << cloud.status().message();
    EXPECT_NE(cloud.status().message().find(fragment), std::string::npos) << cloud.status().message();
  };
  expect_error(Path("missing.pcd"), "cannot open");
  WriteText("garbage.pcd", "hello world\n1 2 3\n");
  expect_error(Path("garbage.pcd"), "PCD");
  WriteText("empty.pcd",
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 0\nHEIGHT 1\n"
            "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 0\nDATA ascii\n");
  expect_error(Path("empty.pcd"), "no finite points");
  WriteText("all_nan.pcd",
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
            "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\nnan nan nan\n");
  expect_error(Path("all_nan.pcd"), "no finite points");
  WriteText("no_xyz.pcd",
            "VERSION 0.7\nFIELDS intensity\nSIZE 4\nTYPE F\nCOUNT 1\nWIDTH 1\nHEIGHT 1\n"
            "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n5\n");
  expect_error(Path("no_xyz.pcd"), "x, y, z fields");
  WriteText("short.pcd",
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 100\nHEIGHT 1\n"
            "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 100\nDATA binary\nabc");
  expect_error(Path("short.pcd"), "PCD");
}

}  // namespace
}  // namespace quadhand::scene
