// The simulated range sensors (sim/sensor.h): what a depth camera and a
// LiDAR return from exact primitives of points (a wall, a box behind it, a
// post), their limits, occlusion and seeded noise.
#include "quadhand/sim/sensor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace quadhand::sim {
namespace {

// A wall of points in the plane x = `x`, spanning |y|, |z - 1| <= half, every `step`.
std::vector<Vec3> Wall(double x, double half, double step, double z_centre = 1.0) {
  std::vector<Vec3> points;
  for (double y = -half; y <= half + 1e-9; y += step) {
    for (double z = z_centre - half; z <= z_centre + half + 1e-9; z += step) points.emplace_back(x, y, z);
  }
  return points;
}

// The camera at (0, 0, 1) looking along +x (the default mount's rotation).
Pose CameraAlongX() { return MakePose(Vec3(0, 0, 1), DefaultMount(SensorKind::kDepth).linear()); }

SensorConfig Depth(double noise = 0.0) {
  SensorConfig config;
  config.kind = SensorKind::kDepth;
  config.depth.width = 160;
  config.depth.height = 120;
  config.depth.noise_at_1m = noise;
  config.splat_radius = 0.02;
  return config;
}

TEST(SensorTest, ADepthCameraSeesAWallAtItsDistanceAndFillsItsImage) {
  auto renderer = SensorRenderer::Create(Wall(3.0, 4.0, 0.01), Depth(), 1);
  ASSERT_TRUE(renderer.ok()) << renderer.status().message();
  const Pose camera = CameraAlongX();
  const std::vector<Vec3> points = (*renderer)->Render(camera);
  // The wall fills the whole image (it is 8 m wide at 3 m: wider than the
  // 87 x 58 degree view): one return per pixel, each at depth 3 m, each on
  // the wall in the world.
  EXPECT_EQ(points.size(), 160u * 120u);
  for (const Vec3& p : points) {
    EXPECT_NEAR(p.z(), 3.0, 1e-6);
    EXPECT_NEAR((camera * p).x(), 3.0, 1e-6);
  }
}

// A wall sampled every 4 cm: PointSpacing measures 0.04 m (duplicates are
// not neighbours), and that is what decides whether the camera sees
// through it: discs of 0.02 m leave holes (the holes of a 4 cm grid are
// 0.028 m from its points), discs of 0.029 m (what quadhand-explore's
// warning asks) fill the image.
TEST(SensorTest, ThePointSpacingSaysWhenTheDiscsLeaveHoles) {
  std::vector<Vec3> wall = Wall(3.0, 4.0, 0.04);
  EXPECT_NEAR(PointSpacing(wall), 0.04, 1e-9);
  EXPECT_NEAR(PointSpacing(wall, 0.5), 0.04, 1e-9);
  const size_t n = wall.size();
  for (size_t i = 0; i < n; i += 2) wall.push_back(wall[i]);  // duplicates
  EXPECT_NEAR(PointSpacing(wall), 0.04, 1e-9);
  // Nine in ten on a 1 cm grid, a tenth alone 0.5 m away: the 0.9 quantile
  // is the grid's, the largest the lone points'.
  std::vector<Vec3> mixed = Wall(3.0, 0.5, 0.01);
  const size_t dense = mixed.size();
  for (size_t k = 0; k < dense / 9 + 20; ++k) mixed.emplace_back(10.0 + 0.5 * static_cast<double>(k), 0.0, 0.0);
  EXPECT_NEAR(PointSpacing(mixed, 0.8), 0.01, 1e-9);
  EXPECT_NEAR(PointSpacing(mixed, 1.0), 0.5, 1e-9);
  EXPECT_EQ(PointSpacing({}), 0.0);
  EXPECT_EQ(PointSpacing({Vec3(0, 0, 0), Vec3(0, 0, 0)}), 0.0);
  EXPECT_EQ(PointSpacing({Vec3(0, 0, 0), Vec3(5, 0, 0)}), 0.0);  // none within 2 m

  SensorConfig thin = Depth();
  thin.splat_radius = 0.02;
  auto holes = SensorRenderer::Create(Wall(3.0, 4.0, 0.04), thin, 1);
  ASSERT_TRUE(holes.ok());
  EXPECT_LT((*holes)->Render(CameraAlongX()).size(), 160u * 120u);
  SensorConfig covering = Depth();
  covering.splat_radius = 0.029;
  auto filled = SensorRenderer::Create(Wall(3.0, 4.0, 0.04), covering, 1);
  ASSERT_TRUE(filled.ok());
  EXPECT_EQ((*filled)->Render(CameraAlongX()).size(), 160u * 120u);
}

TEST(SensorTest, TheNearestSurfaceOccludesWhatIsBehindIt) {
  // A 1 m wide panel at 2 m in front of a wall at 4 m.
  std::vector<Vec3> world = Wall(4.0, 4.0, 0.01);
  for (const Vec3& p : Wall(2.0, 0.5, 0.01)) world.push_back(p);
  auto renderer = SensorRenderer::Create(world, Depth(), 1);
  ASSERT_TRUE(renderer.ok());
  const std::vector<Vec3> points = (*renderer)->Render(CameraAlongX());
  int panel = 0, wall = 0;
  for (const Vec3& p : points) {
    const double z = p.z();
    ASSERT_TRUE(std::abs(z - 2.0) < 1e-6 || std::abs(z - 4.0) < 1e-6) << z;
    if (z < 3.0) {
      ++panel;
      // Seen only where the panel is, give or take the splat.
      EXPECT_LE(std::abs(p.x()), 0.5 + 0.03);
      EXPECT_LE(std::abs(p.y()), 0.5 + 0.03);
    } else {
      ++wall;
      // No wall point where the panel hides it.
      const Vec3 on_panel = p * (2.0 / 4.0);
      EXPECT_FALSE(std::abs(on_panel.x()) < 0.45 && std::abs(on_panel.y()) < 0.45) << p.transpose();
    }
  }
  EXPECT_GT(panel, 0);
  EXPECT_GT(wall, 0);
  EXPECT_EQ(panel + wall, 160 * 120);
}

TEST(SensorTest, NothingBeyondTheRangesOrBehindTheCamera) {
  auto far = SensorRenderer::Create(Wall(7.0, 4.0, 0.02), Depth(), 1);  // beyond 6 m
  ASSERT_TRUE(far.ok());
  EXPECT_TRUE((*far)->Render(CameraAlongX()).empty());
  auto behind = SensorRenderer::Create(Wall(-2.0, 4.0, 0.02), Depth(), 1);
  ASSERT_TRUE(behind.ok());
  EXPECT_TRUE((*behind)->Render(CameraAlongX()).empty());
  auto near = SensorRenderer::Create(Wall(0.1, 4.0, 0.02), Depth(), 1);  // nearer than 0.2 m
  ASSERT_TRUE(near.ok());
  EXPECT_TRUE((*near)->Render(CameraAlongX()).empty());
}

// A miss is a pixel that saw nothing in range: its far end lies on the
// ray at the camera's range; a pixel a too-near point covers is no miss
// (the point hides what is behind it), and neither is one with a return.
TEST(SensorTest, MissesAreThePixelsThatSawNothingAndNotThoseANearPointHides) {
  // A wall at 3 m filling the left half of the image (y > 0 in the world is
  // the image's left: x to the right), and a post 0.1 m before the camera.
  std::vector<Vec3> world;
  for (const Vec3& p : Wall(3.0, 4.0, 0.01)) {
    if (p.y() > 0.0) world.push_back(p);
  }
  for (double z = 0.5; z <= 1.5; z += 0.005) world.emplace_back(0.1, -0.02, z);
  auto renderer = SensorRenderer::Create(world, Depth(), 1);
  ASSERT_TRUE(renderer.ok());
  const Pose camera = CameraAlongX();
  const std::vector<Vec3> points = (*renderer)->Render(camera);
  ASSERT_FALSE(points.empty());
  for (const Vec3& p : points) EXPECT_NEAR(p.z(), 3.0, 1e-6);  // only the wall: the post is too near
  const std::vector<Vec3> misses = (*renderer)->LastMisses(1);
  const std::vector<Vec3> coarse = (*renderer)->LastMisses(4);
  ASSERT_FALSE(misses.empty());
  EXPECT_NEAR(static_cast<double>(coarse.size()), misses.size() / 16.0, misses.size() / 16.0 * 0.1 + 2.0);
  for (const Vec3& m : misses) {
    EXPECT_NEAR(m.z(), 6.0, 1e-9);       // at the camera's range
    EXPECT_GT(m.x(), -1e-9) << m.transpose();  // the image's right half: no wall there
    // Not behind the post: its pixels (0.12 m right of the axis at 0.1 m,
    // 0.02 m wide with the splat) hide their rays.
    const Vec3 at_post = m * (0.1 / m.z());
    EXPECT_FALSE(std::abs(at_post.x() - 0.02) < 0.015 && std::abs(at_post.y()) < 0.03) << m.transpose();
  }
  // Every pixel is a return, a miss or hidden by the post.
  EXPECT_LT(points.size() + misses.size(), 160u * 120u);
  EXPECT_GT(points.size() + misses.size(), 160u * 120u * 7 / 10);
}

TEST(SensorTest, DepthNoiseIsSeededAndGrowsWithTheSquareOfTheDepth) {
  const std::vector<Vec3> wall = Wall(4.0, 4.0, 0.01);
  auto a = SensorRenderer::Create(wall, Depth(0.01), 7), b = SensorRenderer::Create(wall, Depth(0.01), 7);
  ASSERT_TRUE(a.ok() && b.ok());
  const std::vector<Vec3> first = (*a)->Render(CameraAlongX()), second = (*b)->Render(CameraAlongX());
  ASSERT_EQ(first.size(), second.size());
  double sum = 0.0, squares = 0.0;
  for (size_t i = 0; i < first.size(); ++i) {
    EXPECT_EQ(first[i], second[i]);
    sum += first[i].z() - 4.0;
    squares += (first[i].z() - 4.0) * (first[i].z() - 4.0);
  }
  const double n = static_cast<double>(first.size());
  const double sigma = std::sqrt(squares / n - (sum / n) * (sum / n));
  EXPECT_NEAR(sigma, 0.01 * 16.0, 0.01);  // 0.01 m at 1 m, times 4^2
  EXPECT_NEAR(sum / n, 0.0, 0.01);
}

TEST(SensorTest, ALidarRingMeetsAPostAtItsRange) {
  // A post (vertical cylinder of radius 0.2 m) 5 m ahead, from z = 0 to 2.
  std::vector<Vec3> post;
  for (double z = 0.0; z <= 2.0; z += 0.02) {
    for (int k = 0; k < 63; ++k) {
      const double a = 2.0 * M_PI * k / 63;
      post.emplace_back(5.0 + 0.2 * std::cos(a), 0.2 * std::sin(a), z);
    }
  }
  SensorConfig config;
  config.kind = SensorKind::kLidar;
  config.lidar.noise = 0.0;
  config.mount = DefaultMount(SensorKind::kLidar);
  auto renderer = SensorRenderer::Create(post, config, 3);
  ASSERT_TRUE(renderer.ok()) << renderer.status().message();
  const Pose lidar = MakePose(Vec3(0, 0, 1), Mat3::Identity());
  const std::vector<Vec3> points = (*renderer)->Render(lidar);
  ASSERT_FALSE(points.empty());
  for (const Vec3& p : points) {
    const Vec3 world = lidar * p;
    // On the post's near side, within the splat.
    const double from_axis = std::hypot(world.x() - 5.0, world.y());
    EXPECT_NEAR(from_axis, 0.2, 0.03) << world.transpose();
    EXPECT_LT(world.x(), 5.0 + 0.03);
    EXPECT_GE(world.z(), -0.03);
    EXPECT_LE(world.z(), 2.03);
  }
  // Every beam that points at the post's axis from within its height
  // returns: 16 channels over +-15 degrees, the post spans -11.3 to +11.3
  // degrees of elevation from 1 m up at 5 m: 12 channels.
  int straight_ahead = 0;
  for (const Vec3& p : points) straight_ahead += std::abs(std::atan2(p.y(), p.x())) < 1e-9 ? 1 : 0;
  EXPECT_EQ(straight_ahead, 12);
}

TEST(SensorTest, BadOptionsAndAnEmptyWorldAreRefused) {
  SensorConfig config = Depth();
  config.depth.max_range = 0.1;  // below min_range
  auto bad = SensorRenderer::Create(Wall(3.0, 1.0, 0.1), config, 1);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("depth.min_range"), std::string::npos) << bad.status().message();
  config = Depth();
  config.splat_radius = 0.0;
  EXPECT_FALSE(SensorRenderer::Create(Wall(3.0, 1.0, 0.1), config, 1).ok());
  EXPECT_FALSE(SensorRenderer::Create({}, Depth(), 1).ok());
  EXPECT_FALSE(SensorRenderer::Create({Vec3(1, std::nan(""), 0)}, Depth(), 1).ok());
  EXPECT_FALSE(ParseSensorKind("radar").ok());
}

}  // namespace
}  // namespace quadhand::sim
