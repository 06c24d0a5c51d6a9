// The rolling map (perception/rolling_map.h) against exact primitives: a
// wall seen from a known origin, what is free in front of it, occupied at
// it, unknown behind it; the window forgetting; a voxel freed by later
// frames; the bad inputs.
#include "quadhand/perception/rolling_map.h"

#include "quadhand/geometry/primitives.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <tuple>

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

// Two maps compared at the points centre + (x, y, z), each of x, y, z from
// `from` in steps of `step` while below `to`: where their states differ,
// and where `a` knows a state (and an occupied one).
struct StateComparison {
  int differ = 0, known = 0, occupied = 0;
};
StateComparison CompareStates(const RollingMap& a, const RollingMap& b, const Vec3& centre, const Vec3& from,
                              const Vec3& to, double step) {
  StateComparison c;
  for (double x = from.x(); x < to.x(); x += step) {
    for (double y = from.y(); y < to.y(); y += step) {
      for (double z = from.z(); z < to.z(); z += step) {
        const Vec3 p = centre + Vec3(x, y, z);
        const VoxelState state = a.State(p);
        c.differ += state != b.State(p) ? 1 : 0;
        c.known += state != VoxelState::kUnknown ? 1 : 0;
        c.occupied += state == VoxelState::kOccupied ? 1 : 0;
      }
    }
  }
  return c;
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

// A new obstacle in space seen free is reported once, by the frame that
// turns its voxels occupied; one where nothing had been seen is not (it was
// an obstacle to every plan already), nor one seen again.
// With OctoMap's model alone a voxel seen free changes its mind in a few
// frames; by default (returns_stay_occupied) the first return does it.
void ExpectNewlyBlockedOnce(bool returns_stay_occupied) {
  RollingMapOptions options;
  options.returns_stay_occupied = returns_stay_occupied;
  auto map = Map(options);
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(map->Insert(Wall(3.0), Vec3::Zero()).ok());
  EXPECT_TRUE(map->NewlyBlocked().empty());  // the wall was unknown before its first frame
  ASSERT_EQ(map->State(Vec3(1.55, 0.05, 0.05)), VoxelState::kFree);
  // A post appears at x = 1.55 where the rays had passed: free until enough
  // frames hit it, then occupied, and reported by that frame alone.
  const std::vector<Vec3> post = {Vec3(1.55, 0.05, 0.05), Vec3(1.55, 0.07, 0.02)};
  std::vector<Vec3> seen = Wall(3.0);
  seen.insert(seen.end(), post.begin(), post.end());
  int reported_at = -1;
  for (int k = 0; k < 10; ++k) {
    ASSERT_TRUE(map->Insert(seen, Vec3::Zero()).ok());
    if (map->NewlyBlocked().empty()) continue;
    EXPECT_EQ(reported_at, -1) << "reported twice";
    reported_at = k;
    ASSERT_EQ(map->NewlyBlocked().size(), 1u);  // the two returns share a voxel
    const Vec3 centre = map->NewlyBlocked()[0];
    EXPECT_NEAR((centre - Vec3(1.55, 0.05, 0.05)).norm(), 0.0, 0.5 * std::sqrt(3.0) * 0.1 + 1e-12);
    EXPECT_EQ(map->State(centre), VoxelState::kOccupied);
  }
  if (returns_stay_occupied) {
    EXPECT_EQ(reported_at, 0);
  } else {
    EXPECT_GE(reported_at, 1);  // a free voxel changes its mind in a few frames, not one
  }
}

TEST(RollingMapTest, NewlyBlockedAreTheVoxelsThatTurnFromFreeToOccupied) {
  ExpectNewlyBlockedOnce(true);
  ExpectNewlyBlockedOnce(false);
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

// OctoMap's model alone (returns_stay_occupied off): an obstacle that has
// gone is freed by the rays that now pass through it.
TEST(RollingMapTest, LaterFramesFreeAVoxelThatWasOccupiedUnderOctoMapsModel) {
  RollingMapOptions options;
  options.returns_stay_occupied = false;
  auto map = Map(options);
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

// By default a voxel a return has ended in stays occupied: rays passing
// a surface's edge through the edge's voxel would otherwise free it, and
// the edge would lie in "free" space. Here the rays pass a wall's edge,
// inside its voxels, for twenty frames, and the edge's voxels stay
// occupied; the same with OctoMap's model alone frees them.
TEST(RollingMapTest, RaysPastAnEdgeDoNotFreeTheEdgesVoxels) {
  // A wall at x = 3.02 that ends at y = 0.03, inside the voxel [0, 0.1) of y;
  // beyond it a far wall at 5 m, which the rays past the edge reach.
  std::vector<Vec3> edge_frame;
  for (double y = -1.0; y <= 0.03 + 1e-9; y += 0.01) {
    for (double z = -0.2; z <= 0.2 + 1e-9; z += 0.01) edge_frame.emplace_back(3.02, y, z);
  }
  std::vector<Vec3> past_frame;  // the rays that pass the edge, inside its voxels
  for (double y = 0.04; y <= 1.0 + 1e-9; y += 0.01) {
    for (double z = -0.2; z <= 0.2 + 1e-9; z += 0.01) past_frame.emplace_back(5.0, y * 5.0 / 3.02, z * 5.0 / 3.02);
  }
  for (bool sticky : {true, false}) {
    RollingMapOptions options;
    options.returns_stay_occupied = sticky;
    auto map = Map(options);
    ASSERT_TRUE(map->Insert(edge_frame, Vec3::Zero()).ok());
    const Vec3 edge(3.02, 0.03, 0.0);
    ASSERT_EQ(map->State(edge), VoxelState::kOccupied);
    for (int k = 0; k < 20; ++k) ASSERT_TRUE(map->Insert(past_frame, Vec3::Zero()).ok());
    EXPECT_EQ(map->State(edge), sticky ? VoxelState::kOccupied : VoxelState::kFree) << "sticky " << sticky;
    // A voxel seen free first is occupied at its first return.
    const Vec3 later(4.0, 0.5, 0.0);
    ASSERT_EQ(map->State(later), VoxelState::kFree);
    ASSERT_TRUE(map->Insert({later}, Vec3::Zero()).ok());
    EXPECT_EQ(map->State(later), sticky ? VoxelState::kOccupied : VoxelState::kFree) << "sticky " << sticky;
  }
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

// The certificate a local plan leans on: from any point of a free voxel of
// the box, the distance to everything not seen free (the not-free voxels of
// the box and all space outside it, measured exactly as boxes) is at least
// the distance to the nearest boundary centre less the ball radius.
TEST(RollingMapTest, TheObstacleBoundaryBoundsTheDistanceToEverythingNotSeenFree) {
  RollingMapOptions options;
  options.resolution = 0.1;
  auto map = Map(options);
  // A wall with a square hole seen from the origin: free before it and
  // through the hole, occupied at it, unknown behind it and outside the view.
  std::vector<Vec3> wall;
  for (const Vec3& p : Wall(1.5, 1.0, 0.02)) {
    if (std::abs(p.y()) > 0.25 || std::abs(p.z()) > 0.25) wall.push_back(p);
  }
  for (const Vec3& p : Wall(2.4, 0.4, 0.02)) wall.push_back(p);  // seen through the hole
  ASSERT_TRUE(map->Insert(wall, Vec3::Zero()).ok());
  const Vec3 lo(-0.45, -0.75, -0.55), hi(2.55, 0.75, 0.55);
  const std::vector<Vec3> boundary = map->ObstacleBoundary(lo, hi);
  ASSERT_FALSE(boundary.empty());
  const double ball = map->BoundaryBallRadius();
  EXPECT_DOUBLE_EQ(ball, 0.05 * std::sqrt(3.0));
  // The box in whole voxels, as ObstacleBoundary takes it.
  const double res = options.resolution;
  const Eigen::Vector3i first = (lo / res).array().floor().cast<int>(), last = (hi / res).array().floor().cast<int>();
  const Vec3 box_lo = first.cast<double>() * res, box_hi = (last + Eigen::Vector3i::Ones()).cast<double>() * res;
  std::vector<geometry::Box> not_free;
  for (int i = first.x(); i <= last.x(); ++i) {
    for (int j = first.y(); j <= last.y(); ++j) {
      for (int k = first.z(); k <= last.z(); ++k) {
        const Vec3 c = (Eigen::Vector3i(i, j, k).cast<double>().array() + 0.5).matrix() * res;
        if (map->State(c) == VoxelState::kFree) continue;
        geometry::Box box;
        box.pose = MakePose(c, Mat3::Identity());
        box.size = Vec3::Constant(res);
        not_free.push_back(box);
      }
    }
  }
  ASSERT_FALSE(not_free.empty());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(box_lo.x(), box_hi.x()), y(box_lo.y(), box_hi.y()), z(box_lo.z(), box_hi.z());
  int checked = 0, through_the_hole = 0;
  for (int n = 0; n < 20000 && checked < 400; ++n) {
    const Vec3 p(x(rng), y(rng), z(rng));
    if (map->State(p) != VoxelState::kFree) continue;
    ++checked;
    if (p.x() > 1.5) ++through_the_hole;
    // Exactly: to the nearest not-free voxel, and to the box's faces.
    double exact = std::numeric_limits<double>::infinity();
    for (const geometry::Box& box : not_free) exact = std::min(exact, geometry::SignedDistance(box, p));
    for (int a = 0; a < 3; ++a) exact = std::min({exact, p[a] - box_lo[a], box_hi[a] - p[a]});
    double nearest = std::numeric_limits<double>::infinity();
    for (const Vec3& c : boundary) nearest = std::min(nearest, (c - p).norm());
    EXPECT_GE(exact, nearest - ball - 1e-12) << p.transpose();
    // And the bound is not loose by more than a voxel's diagonal.
    EXPECT_LE(nearest - ball, exact + 1e-12) << p.transpose();
    EXPECT_LE(exact, nearest + 1e-12) << p.transpose();
  }
  EXPECT_GE(checked, 300);
  EXPECT_GT(through_the_hole, 0);
  // Every centre is of a voxel that is not free, or outside the box.
  int outside = 0;
  for (const Vec3& c : boundary) {
    if (((c - box_lo).array() < 0.0).any() || ((box_hi - c).array() < 0.0).any()) {
      ++outside;
      continue;
    }
    EXPECT_NE(map->State(c), VoxelState::kFree) << c.transpose();
  }
  EXPECT_GT(outside, 0);  // the free cone reaches the box's faces
}

// The boundary is exactly its definition, in its order: every not-free voxel
// (occupied, unknown, outside the window or the box) sharing a face with a
// free voxel of the box, once, walked box voxel by box voxel (x, then y,
// then z) and face by face. Read through State() alone, including boxes
// that reach past the window's edge and a window that has rolled.
TEST(RollingMapTest, TheObstacleBoundaryIsItsDefinitionVoxelByVoxel) {
  RollingMapOptions options;
  options.resolution = 0.1;
  options.window_half_extent = Vec3(2.0, 2.0, 1.0);
  auto map = Map(options);
  std::vector<Vec3> wall;
  for (const Vec3& p : Wall(1.2, 1.5, 0.02)) {
    if (std::abs(p.y() - 0.3) > 0.2 || std::abs(p.z()) > 0.3) wall.push_back(p);
  }
  ASSERT_TRUE(map->Insert(wall, Vec3(0.05, 0.02, 0.01)).ok());
  map->MoveWindow(Vec3(0.73, -0.41, 0.12));  // rolled: the ring's cells wrap
  ASSERT_TRUE(map->Insert(wall, Vec3(0.3, -0.2, 0.1)).ok());
  const double res = options.resolution;
  auto reference = [&](const Vec3& lo, const Vec3& hi) {
    const Eigen::Vector3i first = (lo / res).array().floor().cast<int>(), last = (hi / res).array().floor().cast<int>();
    auto centre = [&](const Eigen::Vector3i& v) { return Vec3((v.cast<double>().array() + 0.5).matrix() * res); };
    auto in_box = [&](const Eigen::Vector3i& v) { return (v.array() >= first.array()).all() && (v.array() <= last.array()).all(); };
    auto free = [&](const Eigen::Vector3i& v) { return in_box(v) && map->State(centre(v)) == VoxelState::kFree; };
    std::vector<Vec3> out;
    std::set<std::tuple<int, int, int>> listed;
    const int faces[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int i = first.x(); i <= last.x(); ++i) {
      for (int j = first.y(); j <= last.y(); ++j) {
        for (int k = first.z(); k <= last.z(); ++k) {
          if (!free(Eigen::Vector3i(i, j, k))) continue;
          for (const auto& f : faces) {
            const Eigen::Vector3i u(i + f[0], j + f[1], k + f[2]);
            if (free(u)) continue;
            if (in_box(u) && !listed.insert({u.x(), u.y(), u.z()}).second) continue;
            out.push_back(centre(u));
          }
        }
      }
    }
    return out;
  };
  const std::pair<Vec3, Vec3> boxes[] = {
      {Vec3(-0.45, -0.75, -0.55), Vec3(2.55, 0.75, 0.55)},
      {Vec3(-3.0, -3.0, -2.0), Vec3(3.0, 3.0, 2.0)},      // past the window on every side
      {Vec3(0.31, -0.02, -0.07), Vec3(0.33, 0.01, 0.04)},  // one column of voxels
  };
  for (const auto& [lo, hi] : boxes) {
    const std::vector<Vec3> got = map->ObstacleBoundary(lo, hi), want = reference(lo, hi);
    ASSERT_EQ(got.size(), want.size()) << lo.transpose();
    ASSERT_FALSE(got.empty());
    for (size_t n = 0; n < got.size(); ++n) ASSERT_LT((got[n] - want[n]).norm(), 1e-9) << n;
  }
}

// ConnectedFree: the free voxels a chain of free voxels (face to face,
// inside the box) joins to the start's; none from a voxel that is not free.
TEST(RollingMapTest, ConnectedFreeIsWhatAChainOfFreeVoxelsReaches) {
  auto map = Map();
  map->MarkFree(Vec3(0.0, 0.0, 0.0), 0.5);
  map->MarkFree(Vec3(2.0, 0.0, 0.0), 0.5);
  const Vec3 lo(-1.0, -1.0, -1.0), hi(3.0, 1.0, 1.0);
  const FreeRegion apart = map->ConnectedFree(lo, hi, Vec3(0.01, 0.01, 0.01));
  EXPECT_TRUE(apart.Contains(Vec3(0.3, 0.0, 0.0)));
  EXPECT_FALSE(apart.Contains(Vec3(2.0, 0.0, 0.0)));
  EXPECT_FALSE(apart.Contains(Vec3(1.0, 0.0, 0.0)));  // unknown between them
  EXPECT_FALSE(apart.Contains(Vec3(5.0, 0.0, 0.0)));  // outside the box
  // A corridor joins them.
  for (double x = 0.0; x <= 2.0 + 1e-9; x += 0.1) map->MarkFree(Vec3(x, 0.0, 0.0), 0.12);
  const FreeRegion joined = map->ConnectedFree(lo, hi, Vec3(0.01, 0.01, 0.01));
  EXPECT_TRUE(joined.Contains(Vec3(2.0, 0.0, 0.0)));
  EXPECT_TRUE(joined.Contains(Vec3(1.0, 0.0, 0.0)));
  // ...but not through the box's outside: the same two balls, the box cut
  // between them.
  EXPECT_FALSE(map->ConnectedFree(lo, Vec3(1.0, 1.0, 1.0), Vec3(0.01, 0.01, 0.01)).Contains(Vec3(2.0, 0.0, 0.0)));
  // From a voxel that is not free: nothing.
  const FreeRegion none = map->ConnectedFree(lo, hi, Vec3(0.0, 0.9, 0.9));
  EXPECT_FALSE(none.Contains(Vec3(0.0, 0.9, 0.9)));
  EXPECT_FALSE(none.Contains(Vec3(0.0, 0.0, 0.0)));
}

TEST(RollingMapTest, MarkFreeFreesABallAndMissesFreeTheirRaysOccupyingNothing) {
  auto map = Map();
  map->MarkFree(Vec3(0.0, 0.0, 0.0), 0.35);
  EXPECT_EQ(map->State(Vec3(0.2, 0.1, -0.1)), VoxelState::kFree);
  EXPECT_EQ(map->State(Vec3(0.0, 0.0, 0.5)), VoxelState::kUnknown);
  map->MarkFree(Vec3(std::nan(""), 0.0, 0.0), 1.0);  // nothing
  map->MarkFree(Vec3(3.0, 0.0, 0.0), -1.0);           // nothing
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kUnknown);

  // A miss 4 m out: free along it, nothing occupied at its end; one beyond
  // max_range frees only up to it.
  ASSERT_TRUE(map->Insert({}, Vec3::Zero(), {Vec3(0.0, 4.0, 0.0), Vec3(0.0, -9.0, 0.0), Vec3(std::nan(""), 0, 0)}).ok());
  for (double y : {1.0, 2.5, 3.85}) EXPECT_EQ(map->State(Vec3(0.05, y, 0.05)), VoxelState::kFree) << y;
  EXPECT_NE(map->State(Vec3(0.05, 4.05, 0.05)), VoxelState::kOccupied);
  EXPECT_EQ(map->State(Vec3(0.05, -5.5, 0.05)), VoxelState::kFree);
  EXPECT_EQ(map->State(Vec3(0.05, -6.5, 0.05)), VoxelState::kUnknown);
  EXPECT_TRUE(map->OccupiedPoints().empty());
  EXPECT_EQ(map->dropped_points(), 1);
}

}  // namespace
}  // namespace quadhand::perception

namespace quadhand::perception {
namespace {

// Rays that stop after voxels earlier rays of the frame crossed (opt-in)
// free a subset of what whole rays free, frame after frame, as
// obstacles come and go, with one thread or four, with either sensor model:
// every voxel they hold free is free with whole rays, and every voxel whole
// rays hold occupied is occupied or unknown. And they free nearly all of it
// (99.7-99.9 % here; stopping at the first crossed voxel frees 87 %).
TEST(RollingMapTest, RaysStoppedAfterCrossedVoxelsFreeASubsetOfWhatWholeRaysFree) {
  for (const bool stay : {true, false}) {
    RollingMapOptions whole_options, stopped_options;
    whole_options.window_half_extent = stopped_options.window_half_extent = Vec3(5.0, 5.0, 3.0);
    whole_options.returns_stay_occupied = stopped_options.returns_stay_occupied = stay;
    whole_options.stop_ray_after_crossed = 0;
    stopped_options.stop_ray_after_crossed = 8;
    RollingMapOptions threaded = stopped_options;
    threaded.ray_threads = 4;
    auto whole = Map(whole_options), stopped = Map(stopped_options), parallel = Map(threaded);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> angle(-0.7, 0.7), depth(0.5, 7.0);
    for (int frame = 0; frame < 12; ++frame) {
      const Vec3 origin(0.05 * frame, 0.01 * frame, 0.0);
      std::vector<Vec3> points, misses;
      for (int k = 0; k < 12000; ++k) {
        const double a = angle(rng), e = angle(rng), d = depth(rng);
        const Vec3 p = origin + d * Vec3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
        (k % 7 == 0 ? misses : points).push_back(p);
      }
      if (frame == 6 || frame == 9) points = Wall(2.0, 1.0, 0.02);  // what was seen free is hit
      for (RollingMap* map : {whole.get(), stopped.get(), parallel.get()}) {
        map->MoveWindow(origin);
        ASSERT_TRUE(map->Insert(points, origin, misses).ok());
      }
      for (const RollingMap* map : {stopped.get(), parallel.get()}) {
        long free_whole = 0, free_stopped = 0, freed_more = 0, occupied_less = 0;
        for (double x = -4.95; x < 5.0; x += 0.1) {
          for (double y = -4.95; y < 5.0; y += 0.1) {
            for (double z = -2.95; z < 3.0; z += 0.1) {
              const Vec3 p = origin + Vec3(x, y, z);
              const VoxelState w = whole->State(p), s = map->State(p);
              free_whole += w == VoxelState::kFree;
              free_stopped += s == VoxelState::kFree;
              freed_more += s == VoxelState::kFree && w != VoxelState::kFree;
              occupied_less += w == VoxelState::kOccupied && s == VoxelState::kFree;
            }
          }
        }
        EXPECT_EQ(freed_more, 0) << "frame " << frame << (stay ? "" : ", log-odds alone");
        EXPECT_EQ(occupied_less, 0) << frame;
        EXPECT_GT(free_whole, 20000) << frame;
        EXPECT_GE(free_stopped, 0.995 * free_whole) << frame << ": " << free_stopped << " of " << free_whole;
      }
    }
  }
}

// Rays walked by several threads give the map one thread gives: the same
// state in every voxel, frame after frame, as obstacles come and go (each
// voxel is still updated once per frame, whichever thread reaches it).
TEST(RollingMapTest, SeveralRayThreadsBuildTheMapOneThreadBuilds) {
  RollingMapOptions one, four;
  one.window_half_extent = four.window_half_extent = Vec3(5.0, 5.0, 3.0);
  one.stop_ray_after_crossed = four.stop_ray_after_crossed = 0;  // whole rays: the same map for any order
  four.ray_threads = 4;
  auto serial = Map(one), parallel = Map(four);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(-0.7, 0.7), depth(0.5, 7.0);
  for (int frame = 0; frame < 12; ++frame) {
    const Vec3 origin(0.05 * frame, 0.01 * frame, 0.0);
    std::vector<Vec3> points, misses;
    for (int k = 0; k < 12000; ++k) {  // enough rays for 4 threads
      const double a = angle(rng), e = angle(rng), d = depth(rng);
      const Vec3 p = origin + d * Vec3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      (k % 7 == 0 ? misses : points).push_back(p);
    }
    if (frame == 6) points = Wall(2.0, 1.0, 0.02);  // the scene changes: what was seen free is hit
    for (RollingMap* map : {serial.get(), parallel.get()}) {
      map->MoveWindow(origin);
      ASSERT_TRUE(map->Insert(points, origin, misses).ok());
    }
    EXPECT_EQ(parallel->NewlyBlocked().size(), serial->NewlyBlocked().size()) << frame;
    EXPECT_EQ(parallel->num_known_voxels(), serial->num_known_voxels()) << frame;
  }
  const StateComparison c =
      CompareStates(*serial, *parallel, Vec3::Zero(), Vec3(-4.95, -4.95, -2.95), Vec3(5.0, 5.0, 3.0), 0.1);
  EXPECT_EQ(c.differ, 0);
  EXPECT_GT(c.known, 10000);
  EXPECT_EQ(serial->OccupiedPoints().size(), parallel->OccupiedPoints().size());
  RollingMapOptions bad;
  bad.ray_threads = 0;
  EXPECT_FALSE(RollingMap::Create(bad).ok());
}

// Rays from a sensor a voxel or more inside the window to ends as deep in
// it are walked without a bounds test a step; the others with one. Both
// must mark the same voxels: a window whose first layer holds the sensor
// (every ray walked with the test) holds what a window the rays lie deep
// inside holds (walked without), frame after frame, with the sensor moving
// and the scene changing.
TEST(RollingMapTest, RaysWalkedWithAndWithoutTheBoundsTestMarkTheSameVoxels) {
  RollingMapOptions edge_options, wide;
  // Whole rays: the interior walks (back from the end) and the tested ones
  // (out from the sensor) must mark the same voxels.
  edge_options.stop_ray_after_crossed = wide.stop_ray_after_crossed = 0;
  edge_options.window_half_extent = Vec3(3.0, 3.0, 2.0);
  wide.window_half_extent = Vec3(20.0, 20.0, 10.0);
  auto edge = Map(edge_options), deep = Map(wide);
  edge->MoveWindow(Vec3(3.0, 0.0, 0.0));  // voxels x in [0, 6.1): the sensor at x = 0.05 is in its first layer
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-1.2, 1.2), depth(0.3, 6.0);
  for (int frame = 0; frame < 10; ++frame) {
    const Vec3 origin(0.05, -0.03 * frame, 0.02 * frame);
    std::vector<Vec3> points, misses;
    for (int k = 0; k < 1500; ++k) {
      const double a = angle(rng), e = 0.6 * angle(rng), d = depth(rng);
      const Vec3 p = origin + d * Vec3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      (k % 5 == 0 ? misses : points).push_back(p);
    }
    if (frame == 5) points = Wall(1.5, 1.0, 0.02);
    ASSERT_TRUE(edge->Insert(points, origin, misses).ok());
    ASSERT_TRUE(deep->Insert(points, origin, misses).ok());
  }
  const StateComparison c = CompareStates(*edge, *deep, Vec3::Zero(), Vec3(0.05, -2.95, -1.95), Vec3(6.0, 3.0, 2.0), 0.1);
  EXPECT_EQ(c.differ, 0);
  EXPECT_GT(c.known, 3000);
}

// A small window about a place the sensor looks at from outside it (the
// grasp map about an object) holds there what a window holding the sensor
// holds: rays are walked from where they enter it, and a return beyond it
// frees what its ray crossed in it.
TEST(RollingMapTest, ASmallWindowAwayFromTheSensorHoldsWhatALargeOneHoldsThere) {
  RollingMapOptions large, small;
  large.resolution = small.resolution = 0.02;
  large.stop_ray_after_crossed = small.stop_ray_after_crossed = 0;  // whole rays in both
  large.window_half_extent = Vec3(4.0, 4.0, 2.0);
  small.window_half_extent = Vec3(0.3, 0.4, 0.25);
  auto whole = Map(large), part = Map(small);
  const Vec3 centre(2.5, 0.3, 0.1);
  part->MoveWindow(centre);
  // A post in the small window, a wall behind it, seen from three origins.
  std::vector<Vec3> scene = Wall(3.6, 1.5, 0.015);
  for (double z = -0.5; z <= 0.5; z += 0.008) {
    for (int k = 0; k < 64; ++k) {
      const double a = 2.0 * M_PI * k / 64.0;
      scene.emplace_back(2.5 + 0.05 * std::cos(a), 0.3 + 0.05 * std::sin(a), z);
    }
  }
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-0.6, 0.6);
  long skipped_rays = 0;
  for (const Vec3& origin : {Vec3(0.0, 0.0, 0.0), Vec3(0.5, -0.6, 0.3), Vec3(1.0, 1.0, -0.2)}) {
    std::vector<Vec3> points;
    // Each ray's return: the nearest scene point within 1 cm of the ray.
    for (int k = 0; k < 4000; ++k) {
      const double a = angle(rng), e = angle(rng);
      const Vec3 u(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      double best = std::numeric_limits<double>::infinity();
      for (const Vec3& q : scene) {
        const double along = (q - origin).dot(u);
        if (along > 0.0 && along < best && ((q - origin) - along * u).norm() < 0.01) best = along;
      }
      if (std::isfinite(best)) points.push_back(origin + best * u);
    }
    ASSERT_TRUE(whole->Insert(points, origin).ok());
    for (const Vec3& p : points) skipped_rays += ((p - centre).cwiseAbs().array() > 0.5).any() ? 1 : 0;
    ASSERT_TRUE(part->Insert(points, origin).ok());
  }
  EXPECT_GT(skipped_rays, 1000);
  const StateComparison c =
      CompareStates(*part, *whole, centre, Vec3(-0.27, -0.37, -0.23), Vec3(0.28, 0.38, 0.24), 0.02);
  EXPECT_EQ(c.differ, 0);
  EXPECT_GT(c.known, 1000);
  EXPECT_GT(c.occupied, 20);
}

// A prior map adds obstacles where the sensor has seen nothing, and never
// frees anything: the space before a prior wall stays unknown, and a prior
// point inside space already seen free is ignored.
TEST(RollingMapTest, APriorOccupiesOnlyUnseenVoxelsAndFreesNothing) {
  auto map = Map();
  map->MarkFree(Vec3::Zero(), 0.5);
  std::vector<Vec3> prior = Wall(3.0, 0.5);
  prior.emplace_back(0.1, 0.05, 0.05);  // where the vehicle stands, seen free
  prior.emplace_back(std::nan(""), 0.0, 0.0);
  ASSERT_TRUE(map->SetPrior(prior).ok());
  EXPECT_EQ(map->prior_points(), prior.size() - 1);
  EXPECT_EQ(map->dropped_points(), 1);
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kOccupied);
  EXPECT_EQ(map->State(Vec3(3.0, 0.45, -0.45)), VoxelState::kOccupied);
  EXPECT_EQ(map->State(Vec3(0.1, 0.05, 0.05)), VoxelState::kFree);
  for (double x : {1.0, 2.0, 2.8, 3.5}) EXPECT_EQ(map->State(Vec3(x, 0.0, 0.0)), VoxelState::kUnknown) << x;
  // The prior's own points are what its voxels keep, for the exact checks.
  const std::vector<Vec3> kept = map->OccupiedPoints();
  ASSERT_FALSE(kept.empty());
  for (const Vec3& p : kept) EXPECT_DOUBLE_EQ(p.x(), 3.0);
  EXPECT_TRUE(map->NewlyBlocked().empty());
  EXPECT_FALSE(map->SetPrior(Wall(4.0)).ok());
}

// What the sensor sees wins over the prior: rays through a prior wall that
// is not there free it (the returns_stay_occupied rule keeps only the
// sensor's own returns), and a prior voxel a return ends in becomes the
// sensor's, which later rays through it no longer free.
TEST(RollingMapTest, TheSensorFreesAPriorWallThatIsNotThereAndKeepsOneItSees) {
  auto map = Map();
  std::vector<Vec3> prior = Wall(2.0, 0.4);  // gone since the prior was made
  const std::vector<Vec3> seen = Wall(3.0, 0.4);
  prior.insert(prior.end(), seen.begin(), seen.end());
  ASSERT_TRUE(map->SetPrior(prior).ok());
  ASSERT_EQ(map->State(Vec3(2.0, 0.0, 0.0)), VoxelState::kOccupied);
  ASSERT_TRUE(map->Insert(Wall(3.0), Vec3::Zero()).ok());
  EXPECT_EQ(map->State(Vec3(2.0, 0.0, 0.0)), VoxelState::kFree);
  EXPECT_EQ(map->State(Vec3(2.0, 0.2, -0.1)), VoxelState::kFree);
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kOccupied);
  EXPECT_TRUE(map->NewlyBlocked().empty());  // the prior's voxels were obstacles already
  // The sensor now sees past x = 3 (the wall at 3 moved away): its voxels
  // had returns, so they stay occupied, as any voxel with returns does.
  ASSERT_TRUE(map->Insert(Wall(5.0), Vec3::Zero()).ok());
  EXPECT_EQ(map->State(Vec3(3.0, 0.0, 0.0)), VoxelState::kOccupied);
  for (const Vec3& p : map->OccupiedPoints()) EXPECT_GT(p.x(), 2.5);
}

// The window brings the prior back wherever it moves: after any sequence
// of moves the map holds what a map whose prior was set at the last place
// holds, voxel by voxel and point by point (the slabs a move brings in are
// seeded once each, whatever the moves' directions).
TEST(RollingMapTest, TheWindowBringsThePriorBackWhereverItMoves) {
  RollingMapOptions options;
  options.window_half_extent = Vec3(4.0, 3.0, 2.0);
  std::vector<Vec3> prior;
  std::mt19937 random(5);
  std::uniform_real_distribution<double> along(-12.0, 12.0), across(-6.0, 6.0), up(-3.0, 3.0);
  for (int k = 0; k < 4000; ++k) prior.emplace_back(along(random), across(random), up(random));
  auto moved = Map(options);
  ASSERT_TRUE(moved->SetPrior(prior).ok());
  EXPECT_EQ(moved->State(Vec3(10.0, 0.0, 0.0)), VoxelState::kUnknown);
  const std::vector<Vec3> centres = {Vec3(0.35, 0.0, 0.0), Vec3(3.0, 1.1, -0.4), Vec3(9.7, 2.5, 0.3),
                                     Vec3(9.0, -4.2, 1.9), Vec3(-2.0, -1.0, 0.0), Vec3(-30.0, 0.0, 0.0),
                                     Vec3(-9.5, 0.8, -0.3), Vec3(1.2, 0.1, 0.05)};
  for (const Vec3& centre : centres) {
    moved->MoveWindow(centre);
    auto fresh = Map(options);
    fresh->MoveWindow(centre);
    ASSERT_TRUE(fresh->SetPrior(prior).ok());
    const StateComparison c =
        CompareStates(*moved, *fresh, centre, Vec3(-4.5, -3.5, -2.5), Vec3(4.5, 3.5, 2.5), 0.1);
    EXPECT_EQ(c.differ, 0) << centre.transpose();
    EXPECT_EQ(moved->OccupiedPoints().size(), fresh->OccupiedPoints().size()) << centre.transpose();
    if (centre.x() > -20.0) {
      EXPECT_GT(c.occupied, 100) << centre.transpose();
    }
  }
}

}  // namespace
}  // namespace quadhand::perception
