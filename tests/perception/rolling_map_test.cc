// The rolling map (perception/rolling_map.h) against exact primitives: a
// wall seen from a known origin, what is free in front of it, occupied at
// it, unknown behind it; the window forgetting; a voxel freed by later
// frames; the bad inputs.
#include "quadhand/perception/rolling_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace quadhand::perception {
namespace {

// A wall in the plane x = `x`, |y| <= half, |z| <= half, every `step`.
std::vector<Vec3> Wall(double x, double half = 1.0, double step = 0.05) {
  std::vector<Vec3> points;
  for (double y = -half; y <= half + 1e-9; y += step) {
    for (double z = -half; z <= half + 1e-9; z += step) points.emplace_back(x, y, z);
  }
  return points;
}

std::unique_ptr<RollingMap> Map(RollingMapOptions options = {}) {
  auto map = RollingMap::Create(options);
  EXPECT_TRUE(map.ok()) << map.status().message();
  return std::move(*map);
}

TEST(RollingMapTest, AWallIsOccupiedTheSpaceBeforeItFreeAndBehindItUnknown) {
  auto map = Map();
  ASSERT_TRUE(map->Insert(Wall(3.0), Vec3::Zero()).ok());
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kOccupied);
  EXPECT_EQ(map->State(Vec3(3.0, 0.52, -0.31)), VoxelState::kOccupied);
  for (double x : {0.3, 1.0, 2.0, 2.8}) EXPECT_EQ(map->State(Vec3(x, 0.1, 0.05)), VoxelState::kFree) << x;
  EXPECT_EQ(map->State(Vec3(3.5, 0.0, 0.0)), VoxelState::kUnknown);   // behind the wall
  EXPECT_EQ(map->State(Vec3(0.0, 4.0, 0.0)), VoxelState::kUnknown);   // never looked at
  EXPECT_EQ(map->State(Vec3(-1.0, 0.0, 0.0)), VoxelState::kUnknown);  // behind the sensor
  // The raw returns, a few per voxel, all on the wall.
  const std::vector<Vec3> kept = map->OccupiedPoints();
  ASSERT_FALSE(kept.empty());
  for (const Vec3& p : kept) EXPECT_DOUBLE_EQ(p.x(), 3.0);
  EXPECT_LE(kept.size(), Wall(3.0).size());
  EXPECT_EQ(map->frames(), 1);
}

TEST(RollingMapTest, UnknownVoxelsAreTheOnesNoRayCrossed) {
  auto map = Map();
  ASSERT_TRUE(map->Insert(Wall(3.0), Vec3::Zero()).ok());
  // (From 1.5 m on: nearer the sensor, the rays to the wall span less than the box.)
  const std::vector<Vec3> unknown = map->UnknownVoxelCentres(Vec3(1.5, -0.2, -0.2), Vec3(4.0, 0.2, 0.2));
  ASSERT_FALSE(unknown.empty());
  for (const Vec3& c : unknown) {
    EXPECT_EQ(map->State(c), VoxelState::kUnknown) << c.transpose();
    EXPECT_GT(c.x(), 3.0) << c.transpose();  // only behind the wall, in this box straight ahead
  }
  // Behind the wall, every voxel of the box is in the list: 10 voxels deep
  // (3.0 to 4.0 m; the wall's own voxel is known), 4 x 4 across.
  EXPECT_GE(unknown.size(), 9u * 4u * 4u);
}

TEST(RollingMapTest, AReturnBeyondTheRangeFreesTheRayButOccupiesNothing) {
  RollingMapOptions options;
  options.max_range = 2.0;
  auto map = Map(options);
  ASSERT_TRUE(map->Insert(Wall(3.0, 0.2), Vec3::Zero()).ok());
  EXPECT_EQ(map->State(Vec3(1.5, 0.0, 0.0)), VoxelState::kFree);
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kUnknown);
  EXPECT_TRUE(map->OccupiedPoints().empty());
}

TEST(RollingMapTest, LaterFramesFreeAVoxelThatWasOccupied) {
  auto map = Map();
  ASSERT_TRUE(map->Insert(Wall(3.0, 0.3), Vec3::Zero()).ok());
  ASSERT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kOccupied);
  // The panel has gone: the rays now reach a wall at 5 m through it. One
  // miss does not outweigh one hit (OctoMap's 0.7 / 0.4); three do.
  ASSERT_TRUE(map->Insert(Wall(5.0, 1.0), Vec3::Zero()).ok());
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kOccupied);
  ASSERT_TRUE(map->Insert(Wall(5.0, 1.0), Vec3::Zero()).ok());
  ASSERT_TRUE(map->Insert(Wall(5.0, 1.0), Vec3::Zero()).ok());
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kFree);
  EXPECT_EQ(map->State(Vec3(5.0, 0.0, 0.0)), VoxelState::kOccupied);
  for (const Vec3& p : map->OccupiedPoints()) EXPECT_DOUBLE_EQ(p.x(), 5.0);
}

TEST(RollingMapTest, WhatLeavesTheWindowIsForgotten) {
  RollingMapOptions options;
  options.window_half_extent = Vec3(5.0, 5.0, 3.0);
  auto map = Map(options);
  ASSERT_TRUE(map->Insert(Wall(3.0), Vec3::Zero()).ok());
  const size_t before = map->memory_bytes();
  ASSERT_GT(map->num_known_voxels(), 0u);
  map->MoveWindow(Vec3(20.0, 0.0, 0.0));  // the wall and the ray are 17 m and more behind
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kUnknown);
  EXPECT_EQ(map->State(Vec3(1.0, 0.0, 0.0)), VoxelState::kUnknown);
  EXPECT_EQ(map->num_known_voxels(), 0u);
  EXPECT_TRUE(map->OccupiedPoints().empty());
  EXPECT_LT(map->memory_bytes(), before);
  // Moved back, nothing returns: it was forgotten, not hidden.
  map->MoveWindow(Vec3::Zero());
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kUnknown);
}

TEST(RollingMapTest, BadReturnsAreDroppedAndBadInputRefused) {
  auto map = Map();
  std::vector<Vec3> wall = Wall(3.0, 0.2);
  wall.emplace_back(std::nan(""), 0.0, 0.0);
  wall.emplace_back(1.0, std::numeric_limits<double>::infinity(), 0.0);
  ASSERT_TRUE(map->Insert(wall, Vec3::Zero()).ok());
  EXPECT_EQ(map->dropped_points(), 2);
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kOccupied);
  EXPECT_FALSE(map->Insert(Wall(3.0), Vec3(0.0, std::nan(""), 0.0)).ok());
  EXPECT_EQ(map->frames(), 1);
  RollingMapOptions bad;
  bad.resolution = 0.0;
  EXPECT_FALSE(RollingMap::Create(bad).ok());
  bad = RollingMapOptions{};
  bad.probability_miss = 0.6;
  EXPECT_FALSE(RollingMap::Create(bad).ok());
  bad = RollingMapOptions{};
  bad.window_half_extent = Vec3(1.0, -1.0, 1.0);
  EXPECT_FALSE(RollingMap::Create(bad).ok());
}

}  // namespace
}  // namespace quadhand::perception
