// MRC-SDF collision model: penalties and their gradients (link wrench and
// whole-body state gradient through the kinematic chain, mimic battery joint
// included) against finite differences, and clearance against exact distances.
#include "quadhand/env/mrc_sdf_model.h"

#include <gtest/gtest.h>

#include <random>

#include "quadhand/geometry/mesh_to_sdf.h"
#include "quadhand/geometry/primitives.h"
#include "quadhand/opt/penalty.h"
#include "quadhand/robot/link_meshes.h"
#include "support/quadhand_fixture.h"

namespace quadhand::env {
namespace {

using testing::SmoothCentralDifference;
using Fixture = testing::QuadHandFixture;
const Fixture& QuadHand() { return testing::CoarseQuadHand(); }

struct State {
  Vec3 position;
  Vec3 rotation_vector;  // attitude = exp([rotation_vector]x)
  VecX joints;
  Pose BasePose() const { return MakePose(position, ExpSO3(rotation_vector)); }
};

// Obstacle points scattered around the robot's links at `state`, many within
// the threshold, so every link and the mimic battery contribute.
std::vector<Vec3> PointsAroundRobot(const robot::RobotModel& robot, const State& state, int count,
                                    unsigned seed) {
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(robot, state.BasePose(), state.joints, &kinematics);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  std::vector<Vec3> points;
  const std::vector<int> links = robot.CollisionLinks();
  for (int n = 0; n < count; ++n) {
    const int link = links[n % links.size()];
    points.push_back(kinematics.link_poses[link] * Vec3(0.1 + 0.6 * u(rng), u(rng), 0.3 * u(rng)));
  }
  return points;
}

TEST(SmoothedL1Test, ValueAndSlopeMatchThePaperAndFiniteDifferences) {
  const double mu = 0.01;
  double slope;
  EXPECT_EQ(opt::SmoothedL1(-0.1, mu, &slope), 0.0);
  EXPECT_EQ(slope, 0.0);
  EXPECT_NEAR(opt::SmoothedL1(mu, mu, &slope), mu / 2, 1e-15);
  EXPECT_NEAR(opt::SmoothedL1(0.5, mu, &slope), 0.5 - mu / 2, 1e-15);
  EXPECT_NEAR(opt::SmoothedL1(0.004, mu, &slope), (mu - 0.002) * std::pow(0.4, 3), 1e-15);
  for (double x : {-0.005, 0.0005, 0.003, 0.0071, 0.0099, 0.0101, 0.2}) {
    const double h = 1e-8;
    double s0, unused;
    opt::SmoothedL1(x, mu, &s0);
    const double numeric = (opt::SmoothedL1(x + h, mu, &unused) - opt::SmoothedL1(x - h, mu, &unused)) / (2 * h);
    EXPECT_NEAR(s0, numeric, 1e-6) << x;
  }
}

TEST(MrcSdfModelTest, LinkWrenchMatchesFiniteDifferences) {
  const Fixture& fx = QuadHand();
  const State state{Vec3(0.3, -0.2, 1.1), Vec3(0.1, -0.2, 0.3), Vec3(0.7, -0.4, 0.5)};
  auto model = MrcSdfModel::Create(fx.links, fx.grids, PointsAroundRobot(fx.robot, state, 3000, 1));
  ASSERT_TRUE(model.ok()) << model.status().message();
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(fx.robot, state.BasePose(), state.joints, &kinematics);
  const PenaltyParameters parameters{0.03, 0.01};
  int checked = 0, skipped = 0;
  for (int link : fx.links) {
    const Pose X_WL = kinematics.link_poses[link];
    LinkWrench wrench;
    const double cost = (*model)->LinkPenalty(link, X_WL, parameters, {}, &wrench);
    ASSERT_GT(cost, 0.0) << "link " << link << " has no nearby points";
    for (int axis = 0; axis < 6; ++axis) {
      auto moved = [&](double s) {
        Pose X = X_WL;
        if (axis < 3) X.translation() += s * Vec3::Unit(axis);
        else X.linear() = ExpSO3(s * Vec3::Unit(axis - 3)) * X_WL.linear();
        return (*model)->LinkPenalty(link, X, parameters, {}, nullptr);
      };
      double numeric;
      if (!SmoothCentralDifference(moved, 1e-7, &numeric)) {
        ++skipped;
        continue;
      }
      const double analytic = axis < 3 ? wrench.force[axis] : wrench.torque[axis - 3];
      EXPECT_LE(std::abs(analytic - numeric), 1e-5 * std::max(1.0, std::abs(numeric)))
          << "link " << link << " axis " << axis << " analytic " << analytic << " numeric " << numeric;
      ++checked;
    }
  }
  EXPECT_GE(checked, 25);
  EXPECT_LE(skipped, 5);
}

TEST(MrcSdfModelTest, WholeBodyGradientMatchesFiniteDifferences) {
  const Fixture& fx = QuadHand();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  const VecX lower = fx.robot.LowerLimits(), upper = fx.robot.UpperLimits();
  int checked = 0, skipped = 0;
  for (int trial = 0; trial < 4; ++trial) {
    State state{Vec3(u(rng), u(rng), 1 + u(rng)), 0.4 * Vec3(u(rng), u(rng), u(rng)), VecX(3)};
    for (int k = 0; k < 3; ++k) state.joints[k] = lower[k] + (upper[k] - lower[k]) * (0.5 + 0.45 * u(rng));
    auto model = MrcSdfModel::Create(fx.links, fx.grids, PointsAroundRobot(fx.robot, state, 3000, trial));
    ASSERT_TRUE(model.ok());
    robot::KinematicsState kinematics;
    robot::ComputeKinematics(fx.robot, state.BasePose(), state.joints, &kinematics);
    const PenaltyParameters parameters{0.03, 0.01};
    StateGradient gradient;
    gradient.SetZero(3);
    const double cost = WholeBodyPenalty(fx.robot, kinematics, **model, parameters, {}, &gradient);
    ASSERT_GT(cost, 0.0);
    EXPECT_NEAR(WholeBodyPenalty(fx.robot, kinematics, **model, parameters, {}, nullptr), cost, 1e-12);
    for (int coordinate = 0; coordinate < 9; ++coordinate) {
      auto moved = [&](double s) {
        State perturbed = state;
        Pose base = state.BasePose();
        if (coordinate < 3) base.translation() += s * Vec3::Unit(coordinate);
        else if (coordinate < 6) base.linear() = ExpSO3(s * Vec3::Unit(coordinate - 3)) * base.linear();
        else perturbed.joints[coordinate - 6] += s;
        robot::KinematicsState k;
        robot::ComputeKinematics(fx.robot, base, perturbed.joints, &k);
        return WholeBodyPenalty(fx.robot, k, **model, parameters, {}, nullptr);
      };
      double numeric;
      if (!SmoothCentralDifference(moved, 1e-7, &numeric)) {
        ++skipped;
        continue;
      }
      const double analytic = coordinate < 3   ? gradient.position[coordinate]
                              : coordinate < 6 ? gradient.rotation[coordinate - 3]
                                               : gradient.joints[coordinate - 6];
      EXPECT_LE(std::abs(analytic - numeric), 1e-5 * std::max(1.0, std::abs(numeric)))
          << "trial " << trial << " coordinate " << coordinate << " analytic " << analytic << " numeric " << numeric;
      ++checked;
    }
  }
  EXPECT_GE(checked, 30);
  EXPECT_LE(skipped, 6);
}

TEST(MrcSdfModelTest, ASharedIndexGivesTheSamePenaltyAndGradientBitForBit) {
  const Fixture& fx = QuadHand();
  State state{Vec3(0.1, -0.2, 1.0), Vec3(0.1, 0.2, 0.3), VecX(3)};
  state.joints << 0.3, -0.2, 0.1;
  const std::vector<Vec3> points = PointsAroundRobot(fx.robot, state, 3000, 5);
  MrcSdfOptions options;
  auto own = MrcSdfModel::Create(fx.links, fx.grids, points, options);
  auto index = std::make_shared<const scene::PointGrid>(points, options.cell_size);
  auto shared = MrcSdfModel::Create(fx.links, fx.grids, index, options);
  ASSERT_TRUE(own.ok() && shared.ok());
  EXPECT_EQ(&(*shared)->points(), index.get());  // shared, not copied
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(fx.robot, state.BasePose(), state.joints, &kinematics);
  const PenaltyParameters parameters{0.03, 0.01};
  StateGradient a, b;
  a.SetZero(3);
  b.SetZero(3);
  const double cost_own = WholeBodyPenalty(fx.robot, kinematics, **own, parameters, {}, &a);
  const double cost_shared = WholeBodyPenalty(fx.robot, kinematics, **shared, parameters, {}, &b);
  ASSERT_GT(cost_own, 0.0);
  EXPECT_EQ(cost_own, cost_shared);
  EXPECT_EQ(a.position, b.position);
  EXPECT_EQ(a.rotation, b.rotation);
  EXPECT_EQ(a.joints, b.joints);
  EXPECT_FALSE(MrcSdfModel::Create(fx.links, fx.grids, std::shared_ptr<const scene::PointGrid>(), options).ok());
}

TEST(MrcSdfModelTest, ClearanceMatchesExactDistanceToAnOffsetPoint) {
  const Fixture& fx = QuadHand();
  // One obstacle point straight below the battery's bottom face (z = -0.018 in
  // its frame), 25 mm away, at a state where everything is axis aligned.
  const State state{Vec3(0, 0, 1), Vec3::Zero(), VecX::Zero(3)};
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(fx.robot, state.BasePose(), state.joints, &kinematics);
  const int battery = fx.robot.LinkIndex("battery");
  const Vec3 point = kinematics.link_poses[battery] * Vec3(-0.085, 0.0, -0.018 - 0.025);
  auto model = MrcSdfModel::Create(fx.links, fx.grids, {point});
  ASSERT_TRUE(model.ok());
  int closest = -1;
  const double clearance = WholeBodyClearance(kinematics, **model, 0.1, {}, &closest);
  EXPECT_EQ(closest, battery);
  EXPECT_NEAR(clearance, 0.025, 1e-3);
  // Within threshold 0.03 and smoothing 0.01: penalty (0.01 - 0.005/2)... x = 0.005.
  double slope;
  const double expected = opt::SmoothedL1(0.03 - clearance, 0.01, &slope);
  EXPECT_NEAR(WholeBodyPenalty(fx.robot, kinematics, **model, {0.03, 0.01}, {}, nullptr), expected, 1e-9);
  // Far away: nothing within the search radius.
  auto far = MrcSdfModel::Create(fx.links, fx.grids, {Vec3(10, 10, 10)});
  EXPECT_EQ(WholeBodyClearance(kinematics, **far, 0.1, {}), 0.1);
  EXPECT_EQ(WholeBodyPenalty(fx.robot, kinematics, **far, {0.03, 0.01}, {}, nullptr), 0.0);
}

// Reference penalty and wrench of one link: every point, no spatial index,
// no block minima, no far-cell test.
double BruteForcePenalty(const geometry::SdfGrid& grid, const std::vector<Vec3>& points, const Pose& X,
                         const PenaltyParameters& parameters, LinkWrench* wrench) {
  const double reach = parameters.threshold;
  const Vec3 lo = grid.info().geometry_min - Vec3::Constant(reach), hi = grid.info().geometry_max + Vec3::Constant(reach);
  double cost = 0.0;
  for (const Vec3& x : points) {
    const Vec3 local = X.linear().transpose() * (x - X.translation());
    if ((local.array() < lo.array()).any() || (local.array() > hi.array()).any()) continue;
    double d;
    Vec3 g;
    grid.Evaluate(local, &d, &g);
    if (!(d < reach)) continue;
    double slope;
    cost += opt::SmoothedL1(reach - d, parameters.mu, &slope);
    const Vec3 g_world = X.linear() * g;
    wrench->force += slope * g_world;
    wrench->torque -= slope * g_world.cross(x - X.translation());
  }
  return cost;
}

// The shortcuts of LinkPenalty and LinkClearance (spatial index, block
// minima, the coarse distance grid that skips links far from every point)
// change no result: link
// poses near a wall of points, at a few centimetres to a metre from it, and
// outside the coarse grid, with a fine and a very coarse far grid.
TEST(MrcSdfModelTest, PenaltyEqualsBruteForceNearAndFarFromThePoints) {
  const Fixture& fx = QuadHand();
  std::vector<Vec3> wall;
  for (double y = -0.5; y <= 0.5; y += 0.02)
    for (double z = 0.5; z <= 1.5; z += 0.02) wall.emplace_back(0.0, y, z);
  MrcSdfOptions coarse;
  coarse.far_cell_size = 0.4;
  coarse.far_padding = 0.0;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const PenaltyParameters parameters{0.04, 0.01};
  for (const MrcSdfOptions& options : {MrcSdfOptions{}, coarse}) {
    auto model = MrcSdfModel::Create(fx.links, fx.grids, wall, options);
    ASSERT_TRUE(model.ok());
    int touching = 0, free = 0;
    for (int n = 0; n < 400; ++n) {
      // Distances from the wall spread from 0 to about 2.5 m (beyond the padding).
      const double x = 0.1 * std::pow(25.0, 0.5 * (u(rng) + 1.0)) - 0.05;
      const Pose X = MakePose(Vec3(x, 0.6 * u(rng), 1.0 + 0.6 * u(rng)), ExpSO3(Vec3(u(rng), u(rng), u(rng))));
      for (size_t i = 0; i < fx.links.size(); ++i) {
        LinkWrench got, want;
        const double cost = (*model)->LinkPenalty(fx.links[i], X, parameters, {}, &got);
        const double reference = BruteForcePenalty(fx.grids[i], wall, X, parameters, &want);
        EXPECT_NEAR(cost, reference, 1e-12 * std::max(1.0, reference));
        EXPECT_LT((got.force - want.force).norm(), 1e-9 * std::max(1.0, want.force.norm()));
        EXPECT_LT((got.torque - want.torque).norm(), 1e-9 * std::max(1.0, want.torque.norm()));
        (reference > 0.0 ? touching : free) += 1;
        // Clearance within a search radius: the smallest distance of the points in the grown box.
        const double radius = 0.08;
        const Vec3 lo = fx.grids[i].info().geometry_min - Vec3::Constant(radius);
        const Vec3 hi = fx.grids[i].info().geometry_max + Vec3::Constant(radius);
        double nearest = radius;
        for (const Vec3& p : wall) {
          const Vec3 local = X.linear().transpose() * (p - X.translation());
          if ((local.array() < lo.array()).any() || (local.array() > hi.array()).any()) continue;
          double d;
          fx.grids[i].Evaluate(local, &d, nullptr);
          nearest = std::min(nearest, d);
        }
        EXPECT_EQ((*model)->LinkClearance(fx.links[i], X, radius, {}), nearest);
      }
    }
    EXPECT_GT(touching, 100);
    EXPECT_GT(free, 1000);
  }
  MrcSdfOptions bad;
  bad.far_cell_size = 0.0;
  EXPECT_FALSE(bad.IsValid(nullptr));
  bad = MrcSdfOptions{};
  bad.far_padding = -1.0;
  EXPECT_FALSE(bad.IsValid(nullptr));
}

TEST(MrcSdfModelTest, CreateRejectsBadInput) {
  const Fixture& fx = QuadHand();
  EXPECT_FALSE(MrcSdfModel::Create(fx.links, {}, {Vec3::Zero()}).ok());
  EXPECT_FALSE(MrcSdfModel::Create(fx.links, fx.grids, {Vec3(std::nan(""), 0, 0)}).ok());
  MrcSdfOptions bad;
  bad.cell_size = 0;
  EXPECT_FALSE(MrcSdfModel::Create(fx.links, fx.grids, {Vec3::Zero()}, bad).ok());
  auto missing = MrcSdfModel::Create(fx.robot, "/nonexistent/sdf", {Vec3::Zero()});
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("/nonexistent/sdf/base_link.qhsdf"), std::string::npos);
}

}  // namespace
}  // namespace quadhand::env
