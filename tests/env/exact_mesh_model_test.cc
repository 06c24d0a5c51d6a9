// The exact collision model (link meshes against raw points).
// LinkClearance prunes exact mesh queries (box bounds, sorted candidates, the
// 1-Lipschitz bound from points already queried, inside tests only within
// the bounding box) and must still return exactly the minimum signed
// distance that querying every nearby point would give; LinkPenalty is the
// brute-force sum of penalties, and its wrench matches finite differences.
#include "quadhand/env/exact_mesh_model.h"

#include <gtest/gtest.h>

#include <random>

#include "quadhand/geometry/mesh_distance.h"
#include "quadhand/geometry/mesh_to_sdf.h"
#include "quadhand/robot/link_sdfs.h"
#include "quadhand/opt/penalty.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/scene/point_cloud.h"
#include "support/quadhand_fixture.h"

namespace quadhand::env {
namespace {

struct LinkQuery {
  int link;
  std::unique_ptr<geometry::MeshDistanceQuery> query;
  Vec3 box_min, box_max;
};

// Every point within `reach` of a link's bounding box, queried exactly.
double BruteForce(const std::vector<LinkQuery>& links, const std::vector<Vec3>& points,
                  const robot::KinematicsState& kinematics, double reach, int* closest) {
  double clearance = reach;
  for (const LinkQuery& g : links) {
    const Pose& X = kinematics.link_poses[g.link];
    for (const Vec3& x : points) {
      const Vec3 local = X.inverse() * x;
      if (((g.box_min - local).array() > reach).any() || ((local - g.box_max).array() > reach).any()) continue;
      const double d = g.query->SignedDistance(local);
      if (d < clearance) {
        clearance = d;
        *closest = g.link;
      }
    }
  }
  return clearance;
}

TEST(ExactMeshModelTest, PrunedClearanceIsTheBruteForceMinimum) {
  auto robot = robot::RobotModel::LoadFromUrdfFile(std::string(QUADHAND_SOURCE_DIR) + "/meshes/quadhand/quadhand.urdf");
  ASSERT_TRUE(robot.ok()) << robot.status().message();
  auto cloud = scene::LoadPcd(std::string(QUADHAND_SOURCE_DIR) + "/data/scenes/window_cup.pcd");
  ASSERT_TRUE(cloud.ok()) << cloud.status().message();
  auto exact = ExactMeshModel::Create(*robot, cloud->points);
  ASSERT_TRUE(exact.ok()) << exact.status().message();
  std::vector<LinkQuery> links;
  for (int link : robot->CollisionLinks()) {
    auto mesh = robot::LinkCollisionMesh(*robot, link);
    ASSERT_TRUE(mesh.ok());
    const geometry::AxisAlignedBox box = geometry::BoundingBox(*mesh);
    links.push_back({link, std::move(*geometry::MeshDistanceQuery::Create(*mesh, true)), box.min, box.max});
  }

  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const VecX lower = robot->LowerLimits(), upper = robot->UpperLimits();
  robot::KinematicsState kinematics;
  const double reach = 0.08;
  int close = 0, penetrating = 0;
  for (int trial = 0; trial < 150; ++trial) {
    // The base near a random scene point, so that links come close to (or into) the cloud.
    const Vec3& anchor = cloud->points[rng() % cloud->points.size()];
    const Vec3 position = anchor + 0.25 * Vec3(unit(rng), unit(rng), unit(rng));
    const Mat3 rotation = ExpSO3(Vec3(0.3 * unit(rng), 0.3 * unit(rng), M_PI * unit(rng)));
    VecX joints(robot->num_actuated());
    for (int q = 0; q < joints.size(); ++q) joints[q] = lower[q] + 0.5 * (unit(rng) + 1.0) * (upper[q] - lower[q]);
    robot::ComputeKinematics(*robot, MakePose(position, rotation), joints, &kinematics);
    int link = -1, expected_link = -1;
    const double pruned = WholeBodyClearance(kinematics, **exact, reach, {}, &link);
    // Every link lies within 1.5 m of the base origin: the other points cannot matter.
    std::vector<Vec3> nearby;
    for (const Vec3& x : cloud->points) {
      if ((x - position).norm() < 1.5) nearby.push_back(x);
    }
    const double expected = BruteForce(links, nearby, kinematics, reach, &expected_link);
    ASSERT_NEAR(pruned, expected, 1e-9) << "trial " << trial;
    if (expected < reach) {
      EXPECT_EQ(link, expected_link) << "trial " << trial;
      ++close;
    }
    penetrating += expected < 0.0;
  }
  // The poses exercise both pruning and the inside test.
  EXPECT_GT(close, 40);
  EXPECT_GT(penetrating, 5);
}

// Obstacle points around every collision link at `base` / `joints`, many
// within a few centimetres of the surface and some inside.
std::vector<Vec3> PointsAroundLinks(const robot::RobotModel& robot, const robot::KinematicsState& kinematics,
                                    int count, unsigned seed) {
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

TEST(ExactMeshModelTest, AModelOfSomeLinksMeasuresThoseAsTheWholeModelDoes) {
  const testing::QuadHandFixture& fx = testing::CoarseQuadHand();
  std::vector<Vec3> points;
  for (int i = 0; i < 400; ++i) points.push_back(Vec3(0.002 * i - 0.4, 0.1 * std::sin(0.1 * i), 0.05));
  auto index = std::make_shared<const scene::PointGrid>(points, ExactMeshModel::kIndexCellSize);
  auto all = ExactMeshModel::Create(fx.robot, index);
  ASSERT_TRUE(all.ok());
  const std::vector<int> every = fx.robot.CollisionLinks();
  ASSERT_GE(every.size(), 3u);
  const std::vector<int> some = {every[1], every.back()};
  auto part = ExactMeshModel::Create(fx.robot, index, some);
  ASSERT_TRUE(part.ok()) << part.status().message();
  EXPECT_EQ((*part)->links(), some);
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(fx.robot, Pose::Identity(), VecX::Zero(fx.robot.num_actuated()), &kinematics);
  double least = 1.0;
  for (int link : some) {
    const Pose& X = kinematics.link_poses[link];
    const double d = (*part)->LinkClearance(link, X, 1.0, {});
    EXPECT_DOUBLE_EQ(d, (*all)->LinkClearance(link, X, 1.0, {}));
    least = std::min(least, d);
  }
  int closest = -1;
  EXPECT_DOUBLE_EQ(WholeBodyClearance(kinematics, **part, 1.0, {}, &closest), least);
  EXPECT_TRUE(closest == some[0] || closest == some[1]);
  // Only collision links of the robot.
  EXPECT_FALSE(ExactMeshModel::Create(fx.robot, index, {fx.robot.num_links()}).ok());
  EXPECT_FALSE(ExactMeshModel::Create(fx.robot, index, {-1}).ok());
}

TEST(ExactMeshModelTest, PenaltyIsTheBruteForceSumAndItsWrenchMatchesFiniteDifferences) {
  const testing::QuadHandFixture& fx = testing::CoarseQuadHand();
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(fx.robot, MakePose(Vec3(0.3, -0.2, 1.1), ExpSO3(Vec3(0.1, -0.2, 0.3))),
                           Vec3(0.7, -0.4, 0.5), &kinematics);
  const std::vector<Vec3> points = PointsAroundLinks(fx.robot, kinematics, 1500, 3);
  auto model = ExactMeshModel::Create(fx.robot, points);
  ASSERT_TRUE(model.ok()) << model.status().message();
  const PenaltyParameters parameters{0.03, 0.01};
  int checked = 0, skipped = 0;
  for (int link : (*model)->links()) {
    const Pose X_WL = kinematics.link_poses[link];
    auto mesh = robot::LinkCollisionMesh(fx.robot, link);
    ASSERT_TRUE(mesh.ok());
    auto query = geometry::MeshDistanceQuery::Create(*mesh, true);
    ASSERT_TRUE(query.ok());
    double expected = 0.0, slope;
    for (const Vec3& x : points) {
      expected += opt::SmoothedL1(parameters.threshold - (*query)->SignedDistance(X_WL.inverse() * x), parameters.mu,
                                  &slope);
    }
    LinkWrench wrench;
    const double cost = (*model)->LinkPenalty(link, X_WL, parameters, {}, &wrench);
    ASSERT_GT(cost, 0.0) << "link " << link << " has no nearby points";
    EXPECT_NEAR(cost, expected, 1e-9 * std::max(1.0, expected)) << "link " << link;
    for (int axis = 0; axis < 6; ++axis) {
      auto moved = [&](double s) {
        Pose X = X_WL;
        if (axis < 3) X.translation() += s * Vec3::Unit(axis);
        else X.linear() = ExpSO3(s * Vec3::Unit(axis - 3)) * X_WL.linear();
        return (*model)->LinkPenalty(link, X, parameters, {}, nullptr);
      };
      double numeric;
      if (!testing::SmoothCentralDifference(moved, 1e-7, &numeric)) {
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

TEST(ExactMeshModelTest, ALinkFarFromEveryPointCostsNothing) {
  const testing::QuadHandFixture& fx = testing::CoarseQuadHand();
  auto model = ExactMeshModel::Create(fx.robot, std::vector<Vec3>{Vec3(10, 10, 10)});
  ASSERT_TRUE(model.ok());
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(fx.robot, Pose::Identity(), VecX::Zero(fx.robot.num_actuated()), &kinematics);
  for (int link : (*model)->links()) {
    LinkWrench wrench;
    EXPECT_EQ((*model)->LinkPenalty(link, kinematics.link_poses[link], {0.03, 0.01}, {}, &wrench), 0.0);
    EXPECT_EQ(wrench.force.norm() + wrench.torque.norm(), 0.0);
    EXPECT_EQ((*model)->LinkClearance(link, kinematics.link_poses[link], 0.5, {}), 0.5);
  }
  EXPECT_EQ((*model)->distance_quality(), DistanceQuality::kExact);
}

// Signed distances of the primitives of tests/robot/fixtures/rotor_guards.urdf.
double BoxDistance(const Vec3& p, const Vec3& center, const Vec3& size) {
  const Vec3 q = (p - center).cwiseAbs() - 0.5 * size;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}
double CylinderDistance(const Vec3& p, const Vec3& center, double radius, double length) {
  const Vec3 r = p - center;
  const Eigen::Vector2d q(std::hypot(r.x(), r.y()) - radius, std::abs(r.z()) - 0.5 * length);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}
double RotorGuardsDistance(const Vec3& p) {
  double d = std::min(BoxDistance(p, Vec3::Zero(), Vec3(0.30, 0.30, 0.06)),
                      BoxDistance(p, Vec3(0, 0, 0.055), Vec3(0.10, 0.10, 0.05)));
  for (const double x : {-0.15, 0.15}) {
    for (const double y : {-0.15, 0.15}) d = std::min(d, CylinderDistance(p, Vec3(x, y, 0), 0.08, 0.04));
  }
  return d;
}

// A link of six overlapping primitives, two of them sharing a face: its SDF
// grid and the exact model both give the distance to the union (the minimum
// over the elements), within the cylinders' tessellation tolerance, outside
// it, and a negative value inside.
TEST(ExactMeshModelTest, ALinkOfOverlappingPrimitivesIsTheirUnion) {
  const std::string urdf = std::string(QUADHAND_SOURCE_DIR) + "/tests/robot/fixtures/rotor_guards.urdf";
  auto robot = robot::RobotModel::LoadFromUrdfFile(urdf);
  ASSERT_TRUE(robot.ok()) << robot.status().message();
  const int frame = robot->LinkIndex("frame");
  auto elements = robot::LinkCollisionElements(*robot, frame);
  ASSERT_TRUE(elements.ok()) << elements.status().message();
  EXPECT_EQ(elements->size(), 6u);
  ASSERT_TRUE(robot::LinkCollisionMesh(*robot, frame).ok());  // drawable, union or not

  auto jobs = robot::LinkSdfJobsFromUrdf(urdf, {});
  ASSERT_TRUE(jobs.ok()) << jobs.status().message();
  geometry::SdfGenerationOptions options;
  options.resolution = 0.01;
  options.padding = 0.05;
  ASSERT_TRUE(robot::CheckLinkSdfJobs(*jobs, options).ok());
  auto grid = geometry::GenerateSdf(jobs->front().elements, "frame", urdf, options);
  ASSERT_TRUE(grid.ok()) << grid.status().message();
  EXPECT_TRUE(grid->info().is_signed);

  const double tolerance = 2e-4;  // cylinders are inscribed within 1e-4
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-0.28, 0.28), uz(-0.09, 0.12);
  std::vector<Vec3> probes;
  for (int n = 0; n < 400; ++n) probes.emplace_back(u(rng), u(rng), uz(rng));
  int outside = 0, inside = 0;
  for (const Vec3& p : probes) {
    const double exact = RotorGuardsDistance(p);
    const std::vector<Vec3> one = {p};
    auto model = ExactMeshModel::Create(*robot, one);
    ASSERT_TRUE(model.ok());
    const double measured = (*model)->LinkClearance(frame, Pose::Identity(), 1.0, {});
    if (exact > tolerance) {
      EXPECT_NEAR(measured, exact, tolerance) << p.transpose();
      ++outside;
    } else if (exact < -tolerance) {
      EXPECT_LT(measured, 0.0) << p.transpose();
      EXPECT_GE(measured, exact - tolerance) << p.transpose();  // never deeper than the union's depth
      ++inside;
    }
  }
  EXPECT_GT(outside, 100);
  EXPECT_GT(inside, 20);
  // Grid nodes: exact distances to the tessellated elements.
  const geometry::SdfGridInfo& info = grid->info();
  int nodes = 0;
  for (int k = 0; k < info.dims.z(); k += 3) {
    for (int j = 0; j < info.dims.y(); j += 3) {
      for (int i = 0; i < info.dims.x(); i += 3) {
        const Vec3 p = info.origin + info.resolution * Vec3(i, j, k);
        const double exact = RotorGuardsDistance(p);
        const double value = grid->NodeValue(i, j, k);
        if (exact > tolerance) {
          EXPECT_NEAR(value, exact, tolerance + 1e-6) << p.transpose();
        }
        if (exact < -tolerance) {
          EXPECT_LT(value, 0.0) << p.transpose();
        }
        ++nodes;
      }
    }
  }
  EXPECT_GT(nodes, 1000);
}

}  // namespace
}  // namespace quadhand::env
