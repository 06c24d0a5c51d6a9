#include "quadhand/scene/point_grid.h"

#include <gtest/gtest.h>

#include <random>

namespace quadhand::scene {
namespace {

TEST(PointGridTest, BoxQueriesFindExactlyThePointsInTheBox) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2, 2);
  std::vector<Vec3> points(20000);
  for (Vec3& p : points) p = Vec3(u(rng), u(rng), 0.5 * u(rng));
  const PointGrid grid(points, 0.1);
  ASSERT_EQ(grid.num_points(), 20000);
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 center(u(rng), u(rng), u(rng));
    const Vec3 half = Vec3(std::abs(u(rng)), std::abs(u(rng)), std::abs(u(rng))) * 0.3;
    const Vec3 lo = center - half, hi = center + half;
    long inside = 0;
    const long visited = grid.VisitBox(lo, hi, [&](const Vec3& p) {
      inside += (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
    });
    EXPECT_EQ(inside, grid.CountInBoxBruteForce(lo, hi));
    EXPECT_GE(visited, inside);
    // Only the overlapping cells are visited, never the whole cloud.
    EXPECT_LT(visited, 20000 / 4);
  }
}

TEST(PointGridTest, HandlesEmptyCloudsFarBoxesAndOutliers) {
  const PointGrid empty({}, 0.1);
  EXPECT_EQ(empty.VisitBox(Vec3::Constant(-1), Vec3::Constant(1), [](const Vec3&) {}), 0);
  std::vector<Vec3> points = {Vec3(0, 0, 0), Vec3(1e6, 1e6, 1e6)};  // an outlier must not explode memory
  const PointGrid grid(points, 0.01);
  EXPECT_GT(grid.cell_size(), 0.01);
  long count = 0;
  grid.VisitBox(Vec3::Constant(-1e300), Vec3::Constant(1e300), [&](const Vec3&) { ++count; });
  EXPECT_EQ(count, 2);
  EXPECT_EQ(grid.VisitBox(Vec3::Constant(2e6), Vec3::Constant(3e6), [](const Vec3&) {}), 0);
  const double nan = std::nan("");
  EXPECT_EQ(grid.VisitBox(Vec3(nan, 0, 0), Vec3::Constant(1), [](const Vec3&) {}), 0);
}

}  // namespace
}  // namespace quadhand::scene
