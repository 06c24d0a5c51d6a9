#include "quadhand/planner/front_end.h"

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "quadhand/scene/point_cloud.h"

namespace quadhand::planner {
namespace {

using core::StatusCode;

// A wall in the plane x = x0 (two faces 0.05 apart), y, z in [-half, half]
// around (y0, z0), points every 0.02 m, with an optional rectangular hole.
std::vector<Vec3> Wall(double x0, double half, bool hole, double hole_half_y = 0.3, double hole_half_z = 0.25,
                       double hole_z = 0.5) {
  std::vector<Vec3> points;
  for (double x : {x0 - 0.025, x0 + 0.025}) {
    for (int a = 0; a <= static_cast<int>(std::round(2 * half / 0.02)); ++a) {
      for (int b = 0; b <= static_cast<int>(std::round(2 * half / 0.02)); ++b) {
        const double y = -half + 0.02 * a, z = -half + 0.02 * b;
        if (hole && std::abs(y) < hole_half_y && std::abs(z - hole_z) < hole_half_z) continue;
        points.emplace_back(x, y, z);
      }
    }
  }
  return points;
}

// Smallest distance from the segment [a, b], sampled every `step`, to the
// points, by brute force over every point near the segment's box.
double SampledClearance(const std::vector<Vec3>& points, const Vec3& a, const Vec3& b, double reach,
                        double step = 0.002) {
  std::vector<Vec3> near;
  const Vec3 lo = a.cwiseMin(b) - Vec3::Constant(reach), hi = a.cwiseMax(b) + Vec3::Constant(reach);
  for (const Vec3& p : points) {
    if ((p.array() >= lo.array()).all() && (p.array() <= hi.array()).all()) near.push_back(p);
  }
  double best = reach;
  const int samples = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
  for (int n = 0; n <= samples; ++n) {
    const Vec3 q = a + (b - a) * (static_cast<double>(n) / samples);
    for (const Vec3& p : near) best = std::min(best, (p - q).norm());
  }
  return best;
}

double PolylineClearance(const std::vector<Vec3>& points, const std::vector<Vec3>& path, double reach) {
  double best = reach;
  for (size_t n = 1; n < path.size(); ++n) best = std::min(best, SampledClearance(points, path[n - 1], path[n], reach));
  return best;
}

// Where the polyline crosses the plane x = x0 (every crossing).
std::vector<Vec3> Crossings(const std::vector<Vec3>& path, double x0) {
  std::vector<Vec3> out;
  for (size_t n = 1; n < path.size(); ++n) {
    const Vec3 &a = path[n - 1], &b = path[n];
    if ((a.x() - x0) * (b.x() - x0) <= 0.0 && a.x() != b.x()) {
      const Vec3 c = a + (b - a) * ((x0 - a.x()) / (b.x() - a.x()));
      if (out.empty() || (c - out.back()).norm() > 1e-9) out.push_back(c);  // a vertex on the plane: once
    }
  }
  return out;
}

TEST(FrontEndOptions, DefaultsAreValidAndBadValuesAreRejected) {
  {
    FrontEndOptions o;
    o.inflation_height = -0.1;
    EXPECT_FALSE(o.IsValid(nullptr));
    o.inflation_height = 0.05;
    o.tight_cost_factor = 0.5;
    EXPECT_FALSE(o.IsValid(nullptr));
    o.tight_cost_factor = 5.0;
    EXPECT_TRUE(o.IsValid(nullptr));
  }
  std::string why;
  EXPECT_TRUE(FrontEndOptions().IsValid(&why)) << why;
  EXPECT_TRUE(FrontEndOptions().IsValid(nullptr));
  auto rejects = [](auto mutate, const std::string& word) {
    FrontEndOptions o;
    mutate(o);
    std::string reason;
    EXPECT_FALSE(o.IsValid(&reason)) << word;
    EXPECT_NE(reason.find(word), std::string::npos) << reason;
  };
  rejects([](FrontEndOptions& o) { o.voxel_size = 0.0; }, "voxel_size");
  rejects([](FrontEndOptions& o) { o.voxel_size = std::nan(""); }, "voxel_size");
  rejects([](FrontEndOptions& o) { o.inflation_radius = -0.1; }, "inflation_radius");
  rejects([](FrontEndOptions& o) { o.shortcut_clearance = 0.2; }, "shortcut_clearance");
  rejects([](FrontEndOptions& o) { o.bounds_margin.y() = -1.0; }, "bounds_margin");
  rejects([](FrontEndOptions& o) { o.max_escape_distance = -1.0; }, "max_escape_distance");
  rejects([](FrontEndOptions& o) { o.heuristic_weight = 0.9; }, "heuristic_weight");
  rejects([](FrontEndOptions& o) { o.max_expansions = 0; }, "max_expansions");
  rejects([](FrontEndOptions& o) { o.max_seconds = 0.0; }, "max_seconds");
  rejects([](FrontEndOptions& o) { o.max_voxels = 1; }, "max_voxels");
  rejects([](FrontEndOptions& o) { o.max_voxels = 1L << 40; }, "max_voxels");

  FrontEndOptions bad;
  bad.voxel_size = -1.0;
  auto result = FindBasePath({Vec3(1, 1, 1)}, Vec3::Zero(), Vec3::Ones(), bad);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(result.status().message().find("voxel_size"), std::string::npos);
}

TEST(FrontEnd, BadInputIsInvalidArgument) {
  const FrontEndOptions options;
  const std::vector<Vec3> cloud{Vec3(0, 0, -1)};
  auto empty = FindBasePath({}, Vec3::Zero(), Vec3::Ones(), options);
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(empty.status().message().find("empty"), std::string::npos);

  auto nan_start = FindBasePath(cloud, Vec3(std::nan(""), 0, 0), Vec3::Ones(), options);
  ASSERT_FALSE(nan_start.ok());
  EXPECT_EQ(nan_start.status().code(), StatusCode::kInvalidArgument);

  auto nan_point = FindBasePath({Vec3(0, std::nan(""), 0)}, Vec3::Zero(), Vec3::Ones(), options);
  ASSERT_FALSE(nan_point.ok());
  EXPECT_EQ(nan_point.status().code(), StatusCode::kInvalidArgument);

  auto map = FrontEndMap::Build(cloud, options, {Vec3(1, 1, 1)});
  ASSERT_TRUE(map.ok()) << map.status().message();
  auto outside = map->FindPath(Vec3(5, 0, 0), Vec3(1, 1, 1));
  ASSERT_FALSE(outside.ok());
  EXPECT_EQ(outside.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(outside.status().message().find("start"), std::string::npos);
  EXPECT_NE(outside.status().message().find("outside"), std::string::npos);
  auto goal_outside = map->FindPath(Vec3(1, 1, 1), Vec3(0, -3, 0));
  ASSERT_FALSE(goal_outside.ok());
  EXPECT_EQ(goal_outside.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(goal_outside.status().message().find("goal"), std::string::npos);

  FrontEndOptions tiny = options;
  tiny.max_voxels = 1000;
  auto too_big = FrontEndMap::Build(cloud, tiny, {Vec3(5, 5, 5)});
  ASSERT_FALSE(too_big.ok());
  EXPECT_EQ(too_big.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(too_big.status().message().find("max_voxels"), std::string::npos);
}

TEST(FrontEnd, EmptySpaceGivesTheStraightSegment) {
  const Vec3 start(0.0, 0.0, 0.0), goal(3.0, 1.0, 0.5);
  auto result = FindBasePath({Vec3(1.0, 0.0, -2.0)}, start, goal, FrontEndOptions());
  ASSERT_TRUE(result.ok()) << result.status().message();
  ASSERT_EQ(result->shortcut.size(), 2u);
  EXPECT_EQ(result->shortcut.front(), start);
  EXPECT_EQ(result->shortcut.back(), goal);
  EXPECT_EQ(result->raw.front(), start);
  EXPECT_EQ(result->raw.back(), goal);
  EXPECT_GT(result->raw.size(), 2u);
  EXPECT_GT(result->expansions, 0);
  EXPECT_FALSE(result->start_escaped);
  EXPECT_FALSE(result->goal_escaped);
  // Octile A* on an empty grid expands only nodes along the way.
  EXPECT_LT(result->expansions, 200);
}

TEST(FrontEnd, WallWithHoleIsPassedThroughTheHole) {
  const std::vector<Vec3> wall = Wall(1.0, 1.5, true);
  FrontEndOptions options;
  options.bounds_margin = Vec3::Constant(0.1);  // too little to fly around the wall
  const Vec3 start(0.0, 0.8, -0.5), goal(2.0, -0.6, 1.0);
  auto result = FindBasePath(wall, start, goal, options);
  ASSERT_TRUE(result.ok()) << result.status().message();
  const std::vector<Vec3>& path = result->shortcut;
  EXPECT_EQ(path.front(), start);
  EXPECT_EQ(path.back(), goal);
  EXPECT_GE(path.size(), 3u);
  for (double x : {0.975, 1.0, 1.025}) {
    const std::vector<Vec3> crossings = Crossings(path, x);
    ASSERT_EQ(crossings.size(), 1u);
    EXPECT_LT(std::abs(crossings[0].y()), 0.3);
    EXPECT_LT(std::abs(crossings[0].z() - 0.5), 0.25);
  }
  EXPECT_GE(PolylineClearance(wall, path, 0.3), options.inflation_radius - 1e-9);
  EXPECT_GE(PolylineClearance(wall, result->raw, 0.3), options.inflation_radius - 1e-9);
}

TEST(FrontEnd, ClosedWallIsInfeasible) {
  FrontEndOptions options;
  options.bounds_margin = Vec3::Constant(0.1);
  auto result = FindBasePath(Wall(1.0, 1.5, false), Vec3(0.0, 0.0, 0.0), Vec3(2.0, 0.0, 0.0), options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), StatusCode::kInfeasible);
  EXPECT_NE(result.status().message().find("no collision-free path"), std::string::npos)
      << result.status().message();

  // A hole narrower than twice the radius is closed too.
  auto narrow = FindBasePath(Wall(1.0, 1.5, true, 0.3, 0.12), Vec3(0.0, 0.0, 0.5), Vec3(2.0, 0.0, 0.5), options);
  ASSERT_FALSE(narrow.ok());
  EXPECT_EQ(narrow.status().code(), StatusCode::kInfeasible);

  // With room to fly around the wall, there is a path.
  options.bounds_margin = Vec3::Constant(0.5);
  EXPECT_TRUE(FindBasePath(Wall(1.0, 1.5, false), Vec3(0.0, 0.0, 0.0), Vec3(2.0, 0.0, 0.0), options).ok());
}

// A slot 0.24 m high and 0.6 m wide: closed to the sphere of the default
// radius (0.15), open to a flat base (height 0.05: the ellipsoid's half
// height with the voxel allowance, 0.06, leaves voxel centres free), which
// crosses inside it and keeps its ellipsoid clear of every point.
TEST(FrontEnd, AFlatBasePassesASlotLowerThanItsWidth) {
  const std::vector<Vec3> wall = Wall(1.0, 1.5, true, 0.3, 0.12);
  FrontEndOptions options;
  options.bounds_margin = Vec3::Constant(0.1);  // no way round
  const Vec3 start(0.0, 0.0, 0.5), goal(2.0, 0.0, 0.5);
  ASSERT_FALSE(FindBasePath(wall, start, goal, options).ok());
  options.inflation_height = 0.05;
  auto result = FindBasePath(wall, start, goal, options);
  ASSERT_TRUE(result.ok()) << result.status().message();
  for (const std::vector<Vec3>* path : {&result->raw, &result->shortcut}) {
    const std::vector<Vec3> crossings = Crossings(*path, 1.0);
    ASSERT_EQ(crossings.size(), 1u);
    EXPECT_LT(std::abs(crossings[0].y()), 0.3);
    EXPECT_LT(std::abs(crossings[0].z() - 0.5), 0.12);
  }
  // Every raw voxel centre keeps the ellipsoid (its axes scaled to a unit
  // sphere) clear of every point.
  for (const Vec3& c : std::vector<Vec3>(result->raw.begin() + 1, result->raw.end() - 1)) {
    for (const Vec3& p : wall) {
      const Vec3 d = p - c;
      const double r = options.inflation_radius, h = options.inflation_height;
      EXPECT_GE((d.x() * d.x() + d.y() * d.y()) / (r * r) + d.z() * d.z() / (h * h), 1.0) << c.transpose();
    }
  }
}

// With a roomy way round (a wall 1 m wide, 0.4 m of margin each side) the
// tight slot costs tight_cost_factor times its length and the path goes
// round; at factor 1 the slot is as good as open space, and the path
// crosses in it.
TEST(FrontEnd, TightVoxelsAreTakenOnlyWhenNoRoomierWayIsShorter) {
  const std::vector<Vec3> wall = Wall(1.0, 0.5, true, 0.3, 0.12, 0.0);
  FrontEndOptions options;
  options.bounds_margin = Vec3(0.1, 0.45, 0.45);
  options.inflation_height = 0.05;
  const Vec3 start(0.0, 0.0, 0.0), goal(2.0, 0.0, 0.0);
  auto detour = FindBasePath(wall, start, goal, options);
  ASSERT_TRUE(detour.ok()) << detour.status().message();
  std::vector<Vec3> crossings = Crossings(detour->raw, 1.0);
  ASSERT_EQ(crossings.size(), 1u);
  EXPECT_GT(std::max(std::abs(crossings[0].y()), std::abs(crossings[0].z())), 0.5) << crossings[0].transpose();
  options.tight_cost_factor = 1.0;
  auto slot = FindBasePath(wall, start, goal, options);
  ASSERT_TRUE(slot.ok()) << slot.status().message();
  crossings = Crossings(slot->raw, 1.0);
  ASSERT_EQ(crossings.size(), 1u);
  EXPECT_LT(std::abs(crossings[0].y()), 0.3);
  EXPECT_LT(std::abs(crossings[0].z()), 0.12);
}

TEST(FrontEnd, SearchBudgetIsInfeasibleWithAReason) {
  FrontEndOptions options;
  options.bounds_margin = Vec3::Constant(0.1);
  options.max_expansions = 10;
  auto result = FindBasePath(Wall(1.0, 1.5, true), Vec3(0.0, 0.8, -0.5), Vec3(2.0, -0.6, 1.0), options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), StatusCode::kInfeasible);
  EXPECT_NE(result.status().message().find("max_expansions"), std::string::npos);
}

TEST(FrontEnd, StartAndGoalInsideTheInflatedRegionEscape) {
  const std::vector<Vec3> wall = Wall(1.0, 1.5, true);
  FrontEndOptions options;
  options.bounds_margin = Vec3::Constant(0.1);
  options.bounds_margin.x() = 0.5;
  const Vec3 start(0.9, 0.8, -0.5), goal(1.08, -0.6, 1.0);  // 0.075 and 0.055 m from the wall faces
  auto result = FindBasePath(wall, start, goal, options);
  ASSERT_TRUE(result.ok()) << result.status().message();
  EXPECT_TRUE(result->start_escaped);
  EXPECT_TRUE(result->goal_escaped);
  EXPECT_EQ(result->shortcut.front(), start);
  EXPECT_EQ(result->shortcut.back(), goal);
  // Apart from the first and last segment, the path keeps the radius.
  const std::vector<Vec3> inner(result->shortcut.begin() + 1, result->shortcut.end() - 1);
  EXPECT_GE(PolylineClearance(wall, inner, 0.3), options.inflation_radius - 1e-9);

  options.max_escape_distance = 0.0;
  auto stuck = FindBasePath(wall, start, goal, options);
  ASSERT_FALSE(stuck.ok());
  EXPECT_EQ(stuck.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(stuck.status().message().find("max_escape_distance"), std::string::npos);
}

TEST(FrontEnd, SegmentIsClearMatchesBruteForce) {
  const std::vector<Vec3> wall = Wall(1.0, 1.0, true);
  FrontEndOptions options;
  auto map = FrontEndMap::Build(wall, options);
  ASSERT_TRUE(map.ok()) << map.status().message();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(0.5, 1.5), uyz(-0.8, 0.8);
  int clear = 0, blocked = 0;
  for (int n = 0; n < 200; ++n) {
    const Vec3 a(ux(rng), uyz(rng), uyz(rng)), b(ux(rng), uyz(rng), uyz(rng));
    const double exact = SampledClearance(wall, a, b, 0.3, 0.002);
    const bool says_clear = map->SegmentIsClear(a, b);
    // Sampling every 2 mm overstates the distance by at most (1 mm)^2 / (2 r).
    if (says_clear) {
      EXPECT_GE(exact, options.shortcut_clearance - 1e-6);
    } else {
      EXPECT_LT(exact, options.shortcut_clearance + 1e-5);
    }
    (says_clear ? clear : blocked)++;
  }
  EXPECT_GT(clear, 20);
  EXPECT_GT(blocked, 20);
  EXPECT_FALSE(map->SegmentIsClear(Vec3(0.5, 0, 0), Vec3(100, 0, 0)));
}

class WindowCup : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto cloud = scene::LoadPcd(std::string(QUADHAND_SOURCE_DIR) + "/data/scenes/window_cup.pcd");
    ASSERT_TRUE(cloud.ok()) << cloud.status().message();
    points_ = new std::vector<Vec3>(std::move(cloud->points));
  }
  static void TearDownTestSuite() {
    delete points_;
    points_ = nullptr;
  }
  static std::vector<Vec3> Starts() {
    std::vector<Vec3> starts{Vec3(0.5, 0.2, 1.2)};
    for (double x : {0.0, 1.0}) {
      for (double y : {-1.0, 1.0}) {
        for (double z : {0.8, 1.8}) starts.emplace_back(x, y, z);
      }
    }
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> ux(0.0, 1.0), uy(-1.0, 1.0), uz(0.8, 1.8);
    for (int n = 0; n < 6; ++n) starts.emplace_back(ux(rng), uy(rng), uz(rng));
    return starts;
  }
  static inline const Vec3 kGoal{-2.995, 0.0, 1.29};
  static inline std::vector<Vec3>* points_ = nullptr;
};

class WindowCupWeights : public WindowCup, public ::testing::WithParamInterface<double> {};

TEST_P(WindowCupWeights, PathsKeepTheRadiusAndPassBothWindows) {
  FrontEndOptions options;
  options.heuristic_weight = GetParam();
  auto map = FrontEndMap::Build(*points_, options, {Vec3(0, -1, 0.8), Vec3(1, 1, 1.8), kGoal});
  ASSERT_TRUE(map.ok()) << map.status().message();
  for (const Vec3& start : Starts()) {
    SCOPED_TRACE("start " + std::to_string(start.x()) + " " + std::to_string(start.y()) + " " +
                 std::to_string(start.z()));
    auto result = map->FindPath(start, kGoal);
    ASSERT_TRUE(result.ok()) << result.status().message();
    const std::vector<Vec3>& path = result->shortcut;
    EXPECT_EQ(path.front(), start);
    EXPECT_EQ(path.back(), kGoal);
    EXPECT_FALSE(result->start_escaped);
    EXPECT_FALSE(result->goal_escaped);
    EXPECT_GE(PolylineClearance(*points_, path, 0.5), options.inflation_radius - 1e-9);
    // Both wall faces of both walls are crossed once, inside the opening.
    for (const auto& [wall_x, window_z] : {std::pair{-1.0, 0.9}, std::pair{-2.2, 1.6}}) {
      for (double x : {wall_x - 0.025, wall_x + 0.025}) {
        const std::vector<Vec3> crossings = Crossings(path, x);
        ASSERT_EQ(crossings.size(), 1u) << "wall at x = " << wall_x;
        EXPECT_LT(std::abs(crossings[0].y()), 0.3) << "wall at x = " << wall_x;
        EXPECT_LT(std::abs(crossings[0].z() - window_z), 0.225) << "wall at x = " << wall_x;
      }
    }
    // Far shorter than the raw staircase, and no longer than a detour needs.
    EXPECT_LE(PathLength(path), PathLength(result->raw) + 1e-9);
    EXPECT_LT(PathLength(path), 1.3 * ((start - Vec3(-1, 0, 0.9)).norm() + 1.4 + 0.9));
  }
}

INSTANTIATE_TEST_SUITE_P(Weights, WindowCupWeights, ::testing::Values(1.0, 1.5, 3.0));

TEST_F(WindowCup, OptimalSearchIsNoLongerThanWeighted) {
  FrontEndOptions optimal, weighted;
  optimal.heuristic_weight = 1.0;
  weighted.heuristic_weight = 2.0;
  const Vec3 start(1.0, -1.0, 1.8);
  auto a = FindBasePath(*points_, start, kGoal, optimal);
  auto b = FindBasePath(*points_, start, kGoal, weighted);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_LE(PathLength(a->raw), PathLength(b->raw) + 1e-9);
  EXPECT_LE(PathLength(b->raw), 2.0 * PathLength(a->raw));
  EXPECT_GT(a->expansions, b->expansions);
}

TEST_F(WindowCup, RawPathKeepsTheRadiusToo) {
  const FrontEndOptions options;
  auto result = FindBasePath(*points_, Vec3(0.5, 0.2, 1.2), kGoal, options);
  ASSERT_TRUE(result.ok()) << result.status().message();
  EXPECT_GE(PolylineClearance(*points_, result->raw, 0.5), options.inflation_radius - 1e-9);
}

TEST_F(WindowCup, SameInputGivesTheSamePath) {
  const FrontEndOptions options;
  const Vec3 start(0.7, -0.6, 1.7);
  auto a = FindBasePath(*points_, start, kGoal, options);
  auto b = FindBasePath(*points_, start, kGoal, options);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->raw, b->raw);
  EXPECT_EQ(a->shortcut, b->shortcut);
  EXPECT_EQ(a->expansions, b->expansions);
  // A map reused across queries answers the same as a fresh one.
  auto map = FrontEndMap::Build(*points_, options, {start, kGoal});
  ASSERT_TRUE(map.ok());
  ASSERT_TRUE(map->FindPath(Vec3(0.1, 0.9, 0.9), kGoal).ok());
  auto c = map->FindPath(start, kGoal);
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(a->shortcut, c->shortcut);
}

TEST(InitialGuess, KeepsEveryCornerAndTimesATrapezoid) {
  const std::vector<Vec3> path{Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 0.1, 0), Vec3(2, 0.1, 3)};
  const int pieces = PieceCountForPath(path, 0.5);
  EXPECT_EQ(pieces, static_cast<int>(std::ceil(5.1 / 0.5)));
  MatX waypoints;
  VecX durations;
  ASSERT_TRUE(InitialGuessFromPath(path, pieces, 2.0, 4.0, &waypoints, &durations).ok());
  ASSERT_EQ(waypoints.rows(), 3);
  ASSERT_EQ(waypoints.cols(), pieces - 1);
  ASSERT_EQ(durations.size(), pieces);
  // Corners are waypoints.
  for (int corner : {1, 2}) {
    bool found = false;
    for (int n = 0; n < waypoints.cols(); ++n) found |= (waypoints.col(n) - path[corner]).norm() < 1e-12;
    EXPECT_TRUE(found) << "corner " << corner;
  }
  // Waypoints run along the path in order, piece lengths as even as the corners allow.
  std::vector<Vec3> knots{path.front()};
  for (int n = 0; n < waypoints.cols(); ++n) knots.push_back(waypoints.col(n));
  knots.push_back(path.back());
  EXPECT_NEAR(PathLength(knots), PathLength(path), 1e-12);
  for (size_t n = 1; n < knots.size(); ++n) {
    const double piece = (knots[n] - knots[n - 1]).norm();
    EXPECT_GT(piece, 0.0);
    EXPECT_LE(piece, 0.5 + 1e-12);
  }
  // Trapezoid: 2 m/s cruise, 4 m/s^2: 0.5 s ramps over 0.5 m each, 4.1 m at cruise.
  EXPECT_NEAR(durations.sum(), 2 * 0.5 + 4.1 / 2.0, 1e-9);
  EXPECT_GT(durations.minCoeff(), 0.0);
  EXPECT_NEAR(durations[0], std::sqrt(2 * 0.5 / 4.0), 1e-9);  // first 0.5 m from rest

  // A short path never reaches cruise: a triangle profile.
  ASSERT_TRUE(InitialGuessFromPath({Vec3::Zero(), Vec3(0.4, 0, 0)}, 3, 2.0, 4.0, &waypoints, &durations).ok());
  EXPECT_NEAR(durations.sum(), 2 * std::sqrt(0.4 / 4.0), 1e-9);
  EXPECT_NEAR(durations[0], durations[2], 1e-12);
}

TEST(InitialGuess, RejectsBadInputAndHandlesDegeneratePaths) {
  MatX waypoints;
  VecX durations;
  const std::vector<Vec3> path{Vec3::Zero(), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(2, 1, 0)};
  auto code = [&](const std::vector<Vec3>& p, int n, double v, double a, MatX* q, VecX* t) {
    return InitialGuessFromPath(p, n, v, a, q, t).code();
  };
  EXPECT_EQ(code(path, 2, 2.0, 4.0, &waypoints, &durations), StatusCode::kInvalidArgument);  // 3 segments
  EXPECT_EQ(code(path, 3, 2.0, 4.0, &waypoints, &durations), StatusCode::kOk);
  EXPECT_EQ(code(path, 3, 0.0, 4.0, &waypoints, &durations), StatusCode::kInvalidArgument);
  EXPECT_EQ(code(path, 3, 2.0, -1.0, &waypoints, &durations), StatusCode::kInvalidArgument);
  EXPECT_EQ(code(path, 3, 2.0, 4.0, nullptr, &durations), StatusCode::kInvalidArgument);
  EXPECT_EQ(code({Vec3::Zero()}, 3, 2.0, 4.0, &waypoints, &durations), StatusCode::kInvalidArgument);
  EXPECT_EQ(code({Vec3::Zero(), Vec3(std::nan(""), 0, 0)}, 3, 2.0, 4.0, &waypoints, &durations),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(PieceCountForPath(path, 10.0), 3);
  EXPECT_EQ(PieceCountForPath({Vec3::Zero(), Vec3(0.1, 0, 0)}, 0.5), 3);
  EXPECT_EQ(PieceCountForPath(path, 0.5, 1), 6);

  // Repeated points are not segments; a zero-length path gets 0.1 s pieces.
  ASSERT_TRUE(InitialGuessFromPath({Vec3::Zero(), Vec3::Zero(), Vec3(1, 0, 0)}, 1, 2.0, 4.0, &waypoints,
                                   &durations)
                  .ok());
  EXPECT_EQ(waypoints.cols(), 0);
  EXPECT_EQ(durations.size(), 1);
  ASSERT_TRUE(InitialGuessFromPath({Vec3::Ones(), Vec3::Ones()}, 3, 2.0, 4.0, &waypoints, &durations).ok());
  EXPECT_EQ(waypoints.cols(), 2);
  EXPECT_EQ(waypoints.col(1), Vec3::Ones());
  EXPECT_EQ(durations, VecX::Constant(3, 0.1));
}

TEST_F(WindowCup, InitialGuessKeepsTheWindowCorners) {
  auto result = FindBasePath(*points_, Vec3(0.5, 0.2, 1.2), kGoal, FrontEndOptions());
  ASSERT_TRUE(result.ok());
  const std::vector<Vec3>& path = result->shortcut;
  const int pieces = PieceCountForPath(path);
  MatX waypoints;
  VecX durations;
  ASSERT_TRUE(InitialGuessFromPath(path, pieces, 2.0, 4.0, &waypoints, &durations).ok());
  std::vector<Vec3> knots{path.front()};
  for (int n = 0; n < waypoints.cols(); ++n) knots.push_back(waypoints.col(n));
  knots.push_back(path.back());
  // The piecewise-linear interpolation of the waypoints is the path itself.
  EXPECT_NEAR(PathLength(knots), PathLength(path), 1e-9);
  EXPECT_GE(PolylineClearance(*points_, knots, 0.5), 0.15 - 1e-9);
  EXPECT_GT(durations.minCoeff(), 0.0);
}

}  // namespace
}  // namespace quadhand::planner
