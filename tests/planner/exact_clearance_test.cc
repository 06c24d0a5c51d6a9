// ExactClearance::WholeBody prunes exact mesh queries (box bounds, sorted
// candidates, the 1-Lipschitz bound from points already queried, inside tests
// only within the bounding box). It must still return exactly the minimum
// signed distance that querying every nearby point would give.
#include <gtest/gtest.h>

#include <random>

#include "quadhand/geometry/mesh_distance.h"
#include "quadhand/planner/post_check.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/scene/point_cloud.h"

namespace quadhand::planner {
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

TEST(ExactClearanceTest, PrunedQueriesGiveTheBruteForceMinimum) {
  auto robot = robot::RobotModel::LoadFromUrdfFile(std::string(QUADHAND_SOURCE_DIR) + "/meshes/quadhand/quadhand.urdf");
  ASSERT_TRUE(robot.ok()) << robot.status().message();
  auto cloud = scene::LoadPcd(std::string(QUADHAND_SOURCE_DIR) + "/data/scenes/window_cup.pcd");
  ASSERT_TRUE(cloud.ok()) << cloud.status().message();
  auto exact = ExactClearance::Create(*robot, cloud->points);
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
    const double pruned = (*exact)->WholeBody(kinematics, reach, &link);
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

}  // namespace
}  // namespace quadhand::planner
