// Safe-flight-corridor baseline: polytopes contain their seed segment and no
// obstacle point, penalties vanish inside and push back across a face, the
// link wrench and whole-body gradient against finite differences, piece
// assignment, clearance as a lower bound, and bad input.
#include "quadhand/env/sfc_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "quadhand/robot/link_meshes.h"
#include "quadhand/scene/point_cloud.h"
#include "support/quadhand_fixture.h"

namespace quadhand::env {
namespace {

// The corridor penalty is C^2 (SmoothedL1 is, and skipping a face for a
// cluster happens only where it contributes nothing), so plain central
// differences apply everywhere and no coordinate is skipped.
double CentralDifference(const std::function<double(double)>& f, double step = 1e-6) {
  return (f(step) - f(-step)) / (2 * step);
}

const robot::RobotModel& Robot() {
  static const robot::RobotModel robot = *robot::RobotModel::LoadFromUrdfFile(testing::QuadHandUrdfPath());
  return robot;
}

struct State {
  Vec3 position;
  Vec3 rotation_vector;
  VecX joints;
  Pose BasePose() const { return MakePose(position, ExpSO3(rotation_vector)); }
};

// The faces of the box [lo, hi], points every `step`.
std::vector<Vec3> BoxSurface(const Vec3& lo, const Vec3& hi, double step) {
  std::vector<Vec3> points;
  Eigen::Vector3i n;
  for (int a = 0; a < 3; ++a) n[a] = static_cast<int>(std::round((hi[a] - lo[a]) / step));
  for (int i = 0; i <= n.x(); ++i) {
    for (int j = 0; j <= n.y(); ++j) {
      for (int k = 0; k <= n.z(); ++k) {
        if (i != 0 && i != n.x() && j != 0 && j != n.y() && k != 0 && k != n.z()) continue;
        points.push_back(lo + Vec3(i, j, k).cwiseProduct(hi - lo).cwiseQuotient(n.cast<double>()));
      }
    }
  }
  return points;
}

// A wall x = x0 (one face), y, z in [-1, 1], with a 0.6 x 0.45 window at
// (y, z) = (0, z0), points every 0.02 m.
std::vector<Vec3> WallWithWindow(double x0, double z0) {
  std::vector<Vec3> points;
  for (int j = 0; j <= 100; ++j) {
    for (int k = 0; k <= 100; ++k) {
      const double y = -1 + 0.02 * j, z = z0 - 1 + 0.02 * k;
      if (std::abs(y) < 0.3 && std::abs(z - z0) < 0.225) continue;
      points.emplace_back(x0, y, z);
    }
  }
  return points;
}

std::vector<Vec3> WindowScene() {
  std::vector<Vec3> points = WallWithWindow(0.0, 1.0);
  const std::vector<Vec3> second = WallWithWindow(-1.2, 1.4);
  points.insert(points.end(), second.begin(), second.end());
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> ux(-2, 1), uy(-1, 1), uz(0, 2.4);
  for (int n = 0; n < 300; ++n) {  // clutter away from the windows' axis
    const Vec3 p(ux(rng), uy(rng), uz(rng));
    if (std::abs(p.y()) > 0.5) points.push_back(p);
  }
  return points;
}

void ExpectValidPolytope(const Polytope& polytope, const std::vector<Vec3>& points) {
  for (int n = 0; n <= 100; ++n) {
    const Vec3 p = polytope.seed_begin + (polytope.seed_end - polytope.seed_begin) * (n / 100.0);
    EXPECT_GE(polytope.Margin(p), -1e-9) << "seed point " << p.transpose();
  }
  int inside = 0;
  for (const Vec3& p : points) inside += polytope.Margin(p) > 1e-8;
  EXPECT_EQ(inside, 0);
  for (const Vec3& normal : polytope.normals) EXPECT_NEAR(normal.norm(), 1.0, 1e-12);
}

TEST(SfcModelTest, PolytopesContainTheirSeedAndNoObstaclePoint) {
  const std::vector<Vec3> points = WindowScene();
  const std::vector<Vec3> path{Vec3(0.8, 0.1, 1.1), Vec3(0.3, 0, 1.0), Vec3(-0.6, 0, 1.2), Vec3(-1.6, 0.05, 1.4),
                               Vec3(-2.0, 0.3, 0.8)};
  auto model = SfcModel::Create(Robot(), points, path);
  ASSERT_TRUE(model.ok()) << model.status().message();
  ASSERT_EQ((*model)->num_polytopes(), 4);
  EXPECT_GT((*model)->corridor_seconds(), 0.0);
  for (int i = 0; i < 4; ++i) {
    const Polytope& polytope = (*model)->polytopes()[i];
    EXPECT_EQ(polytope.seed_begin, path[i]);
    EXPECT_EQ(polytope.seed_end, path[i + 1]);
    EXPECT_GT(polytope.num_faces(), polytope.num_box_faces);
    ExpectValidPolytope(polytope, points);
  }
  // Through the first window the corridor is about the window's size: the
  // window centre is inside, the wall 10 cm beyond the window's edge is not.
  const Polytope& through = (*model)->polytopes()[1];
  EXPECT_GT(through.Margin(Vec3(0, 0, 1.0)), 0.1);
  EXPECT_LE(through.Margin(Vec3(0, 0.4, 1.0)), 1e-8);
  EXPECT_LE(through.Margin(Vec3(0, 0, 1.3)), 1e-8);
}

TEST(SfcModelTest, RandomSegmentsInRandomCloudsGiveValidPolytopes) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3> points;
  for (int n = 0; n < 2000; ++n) points.emplace_back(u(rng), u(rng), u(rng));
  const scene::PointGrid grid(points, 0.1);
  int tried = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const Vec3 a = 0.8 * Vec3(u(rng), u(rng), u(rng));
    const Vec3 b = a + 0.3 * Vec3(u(rng), u(rng), u(rng));
    SfcOptions options;
    options.local_margin = 0.5;
    auto polytope = InflateSegment(a, b, grid, options);
    ASSERT_TRUE(polytope.ok()) << polytope.status().message();
    ExpectValidPolytope(*polytope, points);
    // The ellipsoid lies inside the polytope.
    for (int n = 0; n < 50; ++n) {
      const Vec3 direction = Vec3(u(rng), u(rng), u(rng)).normalized();
      const Vec3 p = polytope->ellipsoid_center + polytope->ellipsoid_axes * direction * 0.999;
      const Vec3 local = polytope->ellipsoid_axes.inverse() * (p - polytope->ellipsoid_center);
      if (local.norm() <= 1.0) {
        EXPECT_GE(polytope->Margin(p), -1e-9);
      }
    }
    ++tried;
  }
  EXPECT_EQ(tried, 20);
}

TEST(SfcModelTest, WindowCupCorridorExcludesEveryScenePointAndTheCup) {
  auto cloud = scene::LoadPcd(std::string(QUADHAND_SOURCE_DIR) + "/data/scenes/window_cup.pcd");
  ASSERT_TRUE(cloud.ok()) << cloud.status().message();
  // Through the centres of both windows to the point above the base goal.
  const std::vector<Vec3> path{Vec3(0.5, 0.2, 1.2), Vec3(-1.0, 0, 0.9), Vec3(-2.2, 0, 1.6), Vec3(-2.995, 0, 1.388)};
  auto model = SfcModel::Create(Robot(), cloud->points, path);
  ASSERT_TRUE(model.ok()) << model.status().message();
  ASSERT_EQ((*model)->num_polytopes(), 3);
  for (const Polytope& polytope : (*model)->polytopes()) ExpectValidPolytope(polytope, cloud->points);
  // The cup (top at z = 0.9 on the pedestal at (-3.2, 0)) is an obstacle: the
  // space the open fingers need around it is outside the last polytope.
  const Polytope& last = (*model)->polytopes().back();
  EXPECT_LT(last.Margin(Vec3(-3.2 + 0.075, 0, 0.86)), 0.0);
}

// A room 3 x 3 x 2.4 m (x in [-1.5, 1.5], y in [-1.5, 1.5], z in [0, 2.4])
// with the corridor along its middle; the local box (margin 2 m) holds the
// whole room, so the polytope is the room.
struct Room {
  Room() { options.local_margin = 2.0; }
  std::vector<Vec3> points = BoxSurface(Vec3(-1.5, -1.5, 0), Vec3(1.5, 1.5, 2.4), 0.05);
  std::vector<Vec3> path{Vec3(-0.8, 0, 1.2), Vec3(0.8, 0, 1.2)};
  SfcOptions options;
};

TEST(SfcModelTest, PenaltyIsZeroInsideAndPushesBackAcrossAFace) {
  const Room room;
  auto model = SfcModel::Create(Robot(), room.points, room.path, room.options);
  ASSERT_TRUE(model.ok()) << model.status().message();
  const Polytope& polytope = (*model)->polytopes()[0];
  ExpectValidPolytope(polytope, room.points);
  // The polytope is the room (its faces touch the walls' nearest points).
  EXPECT_NEAR(polytope.Margin(Vec3(0, 0, 1.2)), 1.2, 1e-6);
  State state{Vec3(0, 0, 1.2), Vec3(0, 0, 0.3), Vec3(0.5, 0.2, 0.1)};
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(Robot(), state.BasePose(), state.joints, &kinematics);
  const PenaltyParameters parameters{0.03, 0.01};
  StateGradient gradient;
  gradient.SetZero(3);
  EXPECT_EQ(WholeBodyPenalty(Robot(), kinematics, **model, parameters, {0, 0.0}, &gradient), 0.0);
  EXPECT_EQ(gradient.position.norm(), 0.0);
  const double clearance = WholeBodyClearance(kinematics, **model, 10.0, {0, 0.0});
  EXPECT_GT(clearance, 0.5);
  // The polytope is the room, so the clearance is the distance of the link
  // surfaces to the walls (reached at mesh vertices, which are samples), and
  // the wall points are no closer than the walls.
  double nearest_wall = 1e300;
  for (int link : (*model)->links()) {
    for (const Vec3& s : (*model)->samples_of_link(link).points) {
      const Vec3 p = kinematics.link_poses[link] * s;
      nearest_wall = std::min({nearest_wall, 1.5 - std::abs(p.x()), 1.5 - std::abs(p.y()), p.z(), 2.4 - p.z()});
    }
  }
  EXPECT_NEAR(clearance, nearest_wall, 1e-9);

  // The base pushed up against the ceiling (z = 2.4): positive penalty, and
  // the gradient points up (descent moves the robot back down).
  state.position.z() = 2.4 - 0.03;
  robot::ComputeKinematics(Robot(), state.BasePose(), state.joints, &kinematics);
  gradient.SetZero(3);
  const double cost = WholeBodyPenalty(Robot(), kinematics, **model, parameters, {0, 0.0}, &gradient);
  EXPECT_GT(cost, 0.0);
  EXPECT_GT(gradient.position.z(), 0.0);
  EXPECT_LT(std::abs(gradient.position.x()) + std::abs(gradient.position.y()), 0.1 * gradient.position.z());
  EXPECT_LT(WholeBodyClearance(kinematics, **model, 10.0, {0, 0.0}), 0.0);
}

TEST(SfcModelTest, LinkWrenchAndWholeBodyGradientMatchFiniteDifferences) {
  const Room room;
  auto model = SfcModel::Create(Robot(), room.points, room.path, room.options);
  ASSERT_TRUE(model.ok());
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  const VecX lower = Robot().LowerLimits(), upper = Robot().UpperLimits();
  const PenaltyParameters parameters{0.03, 0.01};
  int checked = 0;
  for (int trial = 0; trial < 4; ++trial) {
    // Near a corner of the room, so several faces are crossed.
    State state{Vec3(1.3 + 0.1 * u(rng), 1.3 + 0.1 * u(rng), 2.2 + 0.1 * u(rng)), 0.5 * Vec3(u(rng), u(rng), u(rng)),
                VecX(3)};
    for (int k = 0; k < 3; ++k) state.joints[k] = lower[k] + (upper[k] - lower[k]) * (0.5 + 0.45 * u(rng));
    robot::KinematicsState kinematics;
    robot::ComputeKinematics(Robot(), state.BasePose(), state.joints, &kinematics);
    const QueryContext context{0, 0.0};
    for (int link : (*model)->links()) {
      const Pose X_WL = kinematics.link_poses[link];
      LinkWrench wrench;
      if ((*model)->LinkPenalty(link, X_WL, parameters, context, &wrench) == 0.0) continue;
      for (int axis = 0; axis < 6; ++axis) {
        auto moved = [&](double s) {
          Pose X = X_WL;
          if (axis < 3) X.translation() += s * Vec3::Unit(axis);
          else X.linear() = ExpSO3(s * Vec3::Unit(axis - 3)) * X_WL.linear();
          return (*model)->LinkPenalty(link, X, parameters, context, nullptr);
        };
        const double numeric = CentralDifference(moved);
        const double analytic = axis < 3 ? wrench.force[axis] : wrench.torque[axis - 3];
        EXPECT_LE(std::abs(analytic - numeric), 1e-5 * std::max(1.0, std::abs(numeric)))
            << "link " << link << " axis " << axis << " analytic " << analytic << " numeric " << numeric;
        ++checked;
      }
    }
    StateGradient gradient;
    gradient.SetZero(3);
    ASSERT_GT(WholeBodyPenalty(Robot(), kinematics, **model, parameters, context, &gradient), 0.0);
    for (int coordinate = 0; coordinate < 9; ++coordinate) {
      auto moved = [&](double s) {
        State perturbed = state;
        Pose base = state.BasePose();
        if (coordinate < 3) base.translation() += s * Vec3::Unit(coordinate);
        else if (coordinate < 6) base.linear() = ExpSO3(s * Vec3::Unit(coordinate - 3)) * base.linear();
        else perturbed.joints[coordinate - 6] += s;
        robot::KinematicsState k;
        robot::ComputeKinematics(Robot(), base, perturbed.joints, &k);
        return WholeBodyPenalty(Robot(), k, **model, parameters, context, nullptr);
      };
      const double numeric = CentralDifference(moved);
      const double analytic = coordinate < 3   ? gradient.position[coordinate]
                              : coordinate < 6 ? gradient.rotation[coordinate - 3]
                                               : gradient.joints[coordinate - 6];
      EXPECT_LE(std::abs(analytic - numeric), 1e-5 * std::max(1.0, std::abs(numeric)))
          << "trial " << trial << " coordinate " << coordinate << " analytic " << analytic << " numeric " << numeric;
      ++checked;
    }
  }
  EXPECT_GE(checked, 60);
}

TEST(SfcModelTest, PiecesSelectTheirPolytope) {
  // An L-shaped path in the room: two polytopes.
  const Room room;
  const std::vector<Vec3> path{Vec3(-0.8, -0.8, 1.2), Vec3(0.8, -0.8, 1.2), Vec3(0.8, 0.8, 1.2)};
  auto model = SfcModel::Create(Robot(), room.points, path, room.options);
  ASSERT_TRUE(model.ok());
  ASSERT_EQ((*model)->num_polytopes(), 2);
  EXPECT_EQ((*model)->PolytopeOf({1, 0.0}), 1);
  EXPECT_EQ((*model)->PolytopeOf({2, 0.0}), -1);
  EXPECT_EQ((*model)->PolytopeOf({-1, 0.0}), -1);
  // Three pieces on the first segment, two on the second (corner kept).
  const std::vector<Vec3> boundaries{path[0], Vec3(-0.3, -0.8, 1.2), Vec3(0.3, -0.8, 1.2), path[1],
                                     Vec3(0.8, 0, 1.2), path[2]};
  const std::vector<int> assignment = AssignPiecesToSegments(path, boundaries);
  EXPECT_EQ(assignment, (std::vector<int>{0, 0, 0, 1, 1}));
  ASSERT_TRUE((*model)->SetPieceAssignment(assignment).ok());
  EXPECT_EQ((*model)->PolytopeOf({3, 0.0}), 1);
  EXPECT_EQ((*model)->PolytopeOf({5, 0.0}), -1);
  EXPECT_FALSE((*model)->SetPieceAssignment({0, 2}).ok());
  EXPECT_FALSE((*model)->SetPieceAssignment({-1}).ok());
  EXPECT_EQ((*model)->piece_assignment(), assignment);

  // Without a valid piece, the best polytope counts: min penalty, max clearance.
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(Robot(), MakePose(Vec3(1.3, 0.0, 1.2), Mat3::Identity()), VecX::Zero(3), &kinematics);
  const int base = Robot().LinkIndex("base_link");
  const Pose& X = kinematics.link_poses[base];
  const PenaltyParameters parameters{0.03, 0.01};
  const double p0 = (*model)->LinkPenalty(base, X, parameters, {0, 0.0}, nullptr);
  const double p1 = (*model)->LinkPenalty(base, X, parameters, {3, 0.0}, nullptr);
  EXPECT_NEAR((*model)->LinkPenalty(base, X, parameters, {-1, 0.0}, nullptr), std::min(p0, p1), 1e-12);
  const double c0 = (*model)->LinkClearance(base, X, 10.0, {0, 0.0});
  const double c1 = (*model)->LinkClearance(base, X, 10.0, {3, 0.0});
  EXPECT_NEAR((*model)->LinkClearance(base, X, 10.0, {-1, 0.0}), std::max(c0, c1), 1e-12);
}

TEST(SfcModelTest, CreateRejectsBadInput) {
  const Room room;
  std::string why;
  SfcOptions bad;
  bad.local_margin = 0;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_FALSE(SfcModel::Create(Robot(), room.points, room.path, bad).ok());
  bad = SfcOptions();
  bad.surface_spacing = -1;
  EXPECT_FALSE(bad.IsValid(&why));
  bad = SfcOptions();
  bad.max_faces = 0;
  EXPECT_FALSE(bad.IsValid(&why));
  bad = SfcOptions();
  bad.cell_size = std::nan("");
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_TRUE(SfcOptions().IsValid(&why));
  EXPECT_FALSE(SfcModel::Create(Robot(), room.points, {Vec3::Zero()}).ok());
  EXPECT_FALSE(SfcModel::Create(Robot(), room.points, {Vec3::Zero(), Vec3::Zero()}).ok());
  EXPECT_FALSE(SfcModel::Create(Robot(), {}, room.path).ok());
  EXPECT_FALSE(SfcModel::Create(Robot(), {Vec3(0, std::nan(""), 0)}, room.path).ok());
  auto blocked = SfcModel::Create(Robot(), {Vec3(0, 0, 1.2)}, room.path);  // a point on the segment
  ASSERT_FALSE(blocked.ok());
  EXPECT_NE(blocked.status().message().find("on the seed segment"), std::string::npos);
  bad = SfcOptions();
  bad.max_faces = 1;  // the room needs six
  auto capped = SfcModel::Create(Robot(), room.points, room.path, bad);
  ASSERT_FALSE(capped.ok());
  EXPECT_EQ(capped.status().code(), core::StatusCode::kInfeasible);
}

}  // namespace
}  // namespace quadhand::env
