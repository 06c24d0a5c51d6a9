// The shipped reference robot (meshes/quadhand/quadhand.urdf) against
// docs/robot.md: names, joint table, mimic battery, tool frame, masses and
// centres of mass, one closed mesh per collision link, and the forward
// kinematics facts the spec states.
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "quadhand/geometry/mesh_io.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/robot/robot_model.h"
#include "robot/robot_test_util.h"

namespace quadhand::robot {
namespace {

using testing::SourcePath;

class QuadhandUrdfTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto model = RobotModel::LoadFromUrdfFile(SourcePath("meshes/quadhand/quadhand.urdf"));
    if (model.ok()) {
      model_ = new RobotModel(std::move(model).value());
    } else {
      load_error_ = new std::string(model.status().message());
    }
  }
  static void TearDownTestSuite() {
    delete model_;
    delete load_error_;
    model_ = nullptr;
    load_error_ = nullptr;
  }
  void SetUp() override { ASSERT_NE(model_, nullptr) << *load_error_; }

  const RobotModel& model() const { return *model_; }
  const Joint& joint(const std::string& name) const {
    const int index = model_->JointIndex(name);
    EXPECT_GE(index, 0) << name;
    return model_->joint(index < 0 ? 0 : index);
  }
  int link(const std::string& name) const {
    const int index = model_->LinkIndex(name);
    EXPECT_GE(index, 0) << name;
    return index;
  }
  // q from named angles, in the model's own actuated order.
  VecX Q(double joint1, double joint2, double joint3) const {
    VecX q(model_->num_actuated());
    q[joint("joint1").q_index] = joint1;
    q[joint("joint2").q_index] = joint2;
    q[joint("joint3").q_index] = joint3;
    return q;
  }

  static RobotModel* model_;
  static std::string* load_error_;
};

RobotModel* QuadhandUrdfTest::model_ = nullptr;
std::string* QuadhandUrdfTest::load_error_ = nullptr;

TEST_F(QuadhandUrdfTest, LinksAndCollisionLinks) {
  EXPECT_EQ(model().link(0).name, "base_link");
  EXPECT_EQ(model().num_links(), 6);
  for (const char* name : {"base_link", "battery", "link1", "link2", "link3", "tool"}) {
    EXPECT_GE(model().LinkIndex(name), 0) << name;
  }
  std::vector<std::string> collision_links;
  for (int l : model().CollisionLinks()) collision_links.push_back(model().link(l).name);
  std::sort(collision_links.begin(), collision_links.end());
  EXPECT_EQ(collision_links,
            (std::vector<std::string>{"base_link", "battery", "link1", "link2", "link3"}));
  // One mesh per collision link (N_l = 5), resolved to an existing file.
  for (int l : model().CollisionLinks()) {
    ASSERT_EQ(model().link(l).collisions.size(), 1u) << model().link(l).name;
    EXPECT_EQ(model().link(l).collisions[0].type, GeometryType::kMesh);
  }
}

TEST_F(QuadhandUrdfTest, ActuatedJointsAreJoint1To3InOrder) {
  EXPECT_EQ(model().ActuatedJointNames(),
            (std::vector<std::string>{"joint1", "joint2", "joint3"}));
  EXPECT_EQ(model().num_joints(), 5);
}

TEST_F(QuadhandUrdfTest, JointTable) {
  struct Row {
    const char* name;
    const char* parent;
    const char* child;
    Vec3 origin;
    Vec3 axis;
    double lower, upper, rate;
  };
  const std::vector<Row> rows = {
      {"joint1", "base_link", "link1", {0.04, 0, -0.045}, {0, 1, 0}, 0.0, 1.57, 2.0},
      {"joint2", "link1", "link2", {0.20, 0, 0}, {0, 1, 0}, -1.5, 1.5, 2.0},
      {"joint3", "link2", "link3", {0.16, 0, 0}, {1, 0, 0}, -3.14, 3.14, 3.0},
      {"battery_joint", "base_link", "battery", {-0.06, 0, -0.045}, {0, 1, 0}, -1.57, 0.0, -1},
  };
  for (const Row& row : rows) {
    SCOPED_TRACE(row.name);
    const Joint& j = joint(row.name);
    EXPECT_EQ(j.type, JointType::kRevolute);
    EXPECT_EQ(model().link(j.parent_link).name, row.parent);
    EXPECT_EQ(model().link(j.child_link).name, row.child);
    EXPECT_LT((j.origin.translation() - row.origin).norm(), 1e-12);
    EXPECT_LT((j.origin.linear() - Mat3::Identity()).norm(), 1e-12);
    EXPECT_LT((j.axis - row.axis).norm(), 1e-12);
    EXPECT_DOUBLE_EQ(j.lower, row.lower);
    EXPECT_DOUBLE_EQ(j.upper, row.upper);
    if (row.rate >= 0) {
      EXPECT_DOUBLE_EQ(j.max_velocity, row.rate);
    }
  }
  EXPECT_EQ(model().LowerLimits(), Eigen::Vector3d(0.0, -1.5, -3.14));
  EXPECT_EQ(model().UpperLimits(), Eigen::Vector3d(1.57, 1.5, 3.14));
  EXPECT_EQ(model().VelocityLimits(), Eigen::Vector3d(2.0, 2.0, 3.0));
}

TEST_F(QuadhandUrdfTest, BatteryMimicsJoint1Inverted) {
  const Joint& battery = joint("battery_joint");
  EXPECT_TRUE(battery.is_mimic);
  EXPECT_EQ(battery.q_index, joint("joint1").q_index);
  EXPECT_DOUBLE_EQ(battery.mimic_multiplier, -1.0);
  EXPECT_DOUBLE_EQ(battery.mimic_offset, 0.0);
}

TEST_F(QuadhandUrdfTest, ToolFrameIsFixedToLink3) {
  const Joint& tool = joint("tool_joint");
  EXPECT_EQ(tool.type, JointType::kFixed);
  EXPECT_EQ(model().link(tool.parent_link).name, "link3");
  EXPECT_EQ(model().link(tool.child_link).name, "tool");
  EXPECT_LT((tool.origin.translation() - Vec3(0.11, 0, 0)).norm(), 1e-12);
  EXPECT_LT((tool.origin.linear() - Mat3::Identity()).norm(), 1e-12);
}

TEST_F(QuadhandUrdfTest, MassesAndCentresOfMass) {
  struct Row {
    const char* name;
    double mass;
    Vec3 com;
  };
  const std::vector<Row> rows = {{"base_link", 1.12, {0, 0, 0}},
                                 {"battery", 0.25, {-0.085, 0, 0}},
                                 {"link1", 0.10, {0.10, 0, 0}},
                                 {"link2", 0.08, {0.08, 0, 0}},
                                 {"link3", 0.15, {0.05, 0, 0}}};
  for (const Row& row : rows) {
    SCOPED_TRACE(row.name);
    const Link& l = model().link(link(row.name));
    EXPECT_NEAR(l.mass, row.mass, 1e-12);
    EXPECT_LT((l.center_of_mass - row.com).norm(), 1e-12);
    // A physical inertia: symmetric, positive definite, triangle inequality.
    EXPECT_LT((l.inertia - l.inertia.transpose()).norm(), 1e-15);
    const Vec3 principal = Eigen::SelfAdjointEigenSolver<Mat3>(l.inertia).eigenvalues();
    EXPECT_GT(principal.minCoeff(), 0.0);
    EXPECT_LE(principal.maxCoeff(), principal.sum() - principal.maxCoeff() + 1e-15);
  }
  EXPECT_NEAR(model().TotalMass(), 1.12 + 0.25 + 0.10 + 0.08 + 0.15, 1e-12);
}

TEST_F(QuadhandUrdfTest, ToolAtZeroJointsIsStraightAhead) {
  std::mt19937 rng(3);
  for (int i = 0; i < 5; ++i) {
    const Pose X_WB = i == 0 ? Pose::Identity() : testing::RandomPose(&rng, 5.0);
    const Pose X_WT = LinkPose(model(), X_WB, Q(0, 0, 0), link("tool"));
    const Vec3 expected = X_WB * Vec3(0.04 + 0.20 + 0.16 + 0.11, 0.0, -0.045);
    EXPECT_LT((X_WT.translation() - expected).norm(), 1e-12);
    EXPECT_LT((X_WT.linear() - X_WB.linear()).norm(), 1e-12);
  }
}

TEST_F(QuadhandUrdfTest, PositiveJoint1TurnsArmAndBatteryDown) {
  const Pose X_WB = Pose::Identity();
  const int tool = link("tool"), battery = link("battery");
  const Vec3 battery_com = model().link(battery).center_of_mass;
  const double tool_z0 = LinkPose(model(), X_WB, Q(0, 0, 0), tool).translation().z();
  const double battery_z0 = (LinkPose(model(), X_WB, Q(0, 0, 0), battery) * battery_com).z();
  EXPECT_NEAR(battery_z0, -0.045, 1e-12);  // straight back at zero
  for (double joint1 : {0.3, 0.8, 1.57}) {
    SCOPED_TRACE(joint1);
    const Pose X_WT = LinkPose(model(), X_WB, Q(joint1, 0, 0), tool);
    const Vec3 battery_W = LinkPose(model(), X_WB, Q(joint1, 0, 0), battery) * battery_com;
    EXPECT_LT(X_WT.translation().z(), tool_z0 - 0.1 * joint1);
    EXPECT_LT(battery_W.z(), battery_z0 - 0.01 * joint1);
    // Mirror images about the vertical through the joints' common height:
    // both drop by the same angle, the battery backwards, the arm forwards.
    EXPECT_LT(battery_W.x(), -0.06);
    EXPECT_NEAR(battery_W.z(), -0.045 - 0.085 * std::sin(joint1), 1e-12);
    EXPECT_GT(X_WT.translation().x(), 0.04);
  }
}

TEST_F(QuadhandUrdfTest, Joint3RollsTheGripperAboutTheApproachAxis) {
  const Pose X_WB = Pose::Identity();
  const Pose a = LinkPose(model(), X_WB, Q(0.4, -0.6, 0.0), link("tool"));
  const Pose b = LinkPose(model(), X_WB, Q(0.4, -0.6, 1.2), link("tool"));
  EXPECT_LT((a.translation() - b.translation()).norm(), 1e-12);     // tool on the roll axis
  EXPECT_LT((a.linear().col(0) - b.linear().col(0)).norm(), 1e-12);  // approach unchanged
  EXPECT_GT((a.linear().col(1) - b.linear().col(1)).norm(), 0.5);    // fingers rolled
}

TEST_F(QuadhandUrdfTest, JacobiansMatchFiniteDifferences) {
  std::mt19937 rng(11);
  KinematicsState state;
  Jacobian J;
  for (int i = 0; i < 10; ++i) {
    testing::State s;
    s.X_WB = testing::RandomPose(&rng, 3.0);
    s.q = testing::RandomConfiguration(model(), &rng);
    ComputeKinematics(model(), s.X_WB, s.q, &state);
    for (int l = 0; l < model().num_links(); ++l) {
      LinkJacobian(model(), state, l, &J);
      EXPECT_LT(testing::JacobianError(testing::NumericLinkJacobian(model(), s, l), J),
                testing::kJacobianRelativeTolerance)
          << model().link(l).name;
    }
  }
}

TEST_F(QuadhandUrdfTest, CollisionMeshesAreClosedAndInTheLinkFrame) {
  for (int l : model().CollisionLinks()) {
    SCOPED_TRACE(model().link(l).name);
    auto mesh = LinkCollisionMesh(model(), l);
    ASSERT_TRUE(mesh.ok()) << mesh.status().message();
    const geometry::MeshCheck check = geometry::CheckMesh(*mesh);
    EXPECT_TRUE(check.bounds_volume) << check.problem;
    EXPECT_TRUE(check.outward) << check.problem;
  }
  // Two links that are single boxes in robot.md: their exact extents.
  auto battery = LinkCollisionMesh(model(), link("battery"));
  ASSERT_TRUE(battery.ok()) << battery.status().message();
  const geometry::AxisAlignedBox b = geometry::BoundingBox(*battery);
  EXPECT_LT((b.min - Vec3(-0.15, -0.025, -0.018)).norm(), 1e-6);
  EXPECT_LT((b.max - Vec3(-0.02, 0.025, 0.018)).norm(), 1e-6);
  EXPECT_NEAR(geometry::SignedVolume(*battery), 0.13 * 0.05 * 0.036, 1e-9);
  auto gripper = LinkCollisionMesh(model(), link("link3"));
  ASSERT_TRUE(gripper.ok()) << gripper.status().message();
  const geometry::AxisAlignedBox g = geometry::BoundingBox(*gripper);
  EXPECT_LT((g.min - Vec3(0.0, -0.095, -0.015)).norm(), 1e-6);
  EXPECT_LT((g.max - Vec3(0.11, 0.095, 0.015)).norm(), 1e-6);
}

}  // namespace
}  // namespace quadhand::robot
