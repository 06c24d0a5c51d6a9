// Forward kinematics and Jacobians on the arm2 fixture (revolute, prismatic,
// continuous, fixed, mimic and mimic-of-mimic joints, rotated joint frames).
// Jacobians are checked against central differences (step 1e-6) with the
// per-column relative bound kJacobianRelativeTolerance = 1e-6, at the
// identity, near it and at random states.
#include "quadhand/robot/kinematics.h"

#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "robot/robot_test_util.h"
#include "support/allocation_counter.h"

namespace quadhand::robot {
namespace {

using testing::JacobianError;
using testing::kJacobianRelativeTolerance;
using testing::kPi;
using testing::NumericLinkJacobian;
using testing::NumericPointJacobian;
using testing::State;

class KinematicsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto model = RobotModel::LoadFromUrdfFile(testing::Arm2Path());
    ASSERT_TRUE(model.ok()) << model.status().message();
    model_ = std::move(model).value();
    wrist_ = model_.joint(model_.JointIndex("wrist")).q_index;
    slider_ = model_.joint(model_.JointIndex("slider")).q_index;
    shoulder_ = model_.joint(model_.JointIndex("shoulder")).q_index;
  }

  State Zero() const {
    State state;
    state.q = VecX::Zero(model_.num_actuated());
    return state;
  }

  // The identity, a state near it, and random states (fixed seed).
  std::vector<State> TestStates() const {
    std::vector<State> states = {Zero()};
    State near = Zero();
    near.X_WB = MakePose(Vec3(1e-3, -2e-3, 1e-3), ExpSO3(Vec3(1e-3, -1e-3, 2e-3)));
    near.q << 1e-3, 2e-3, -1e-3;
    states.push_back(near);
    std::mt19937 rng(12345);
    for (int i = 0; i < 20; ++i) {
      State random;
      random.X_WB = testing::RandomPose(&rng, 3.0);
      random.q = testing::RandomConfiguration(model_, &rng);
      states.push_back(random);
    }
    // Beyond +-pi on the continuous joint.
    State wound = states.back();
    wound.q[wrist_] = 7.5;
    states.push_back(wound);
    return states;
  }

  RobotModel model_;
  int wrist_ = -1, slider_ = -1, shoulder_ = -1;
};

TEST_F(KinematicsTest, StateHasOneEntryPerLinkAndJoint) {
  KinematicsState state;
  const State zero = Zero();
  ComputeKinematics(model_, zero.X_WB, zero.q, &state);
  EXPECT_EQ(state.link_poses.size(), 7u);
  EXPECT_EQ(state.joint_axes.size(), 6u);
  EXPECT_EQ(state.joint_origins.size(), 6u);
  EXPECT_EQ(state.joint_positions.size(), 6u);
  EXPECT_TRUE(state.link_poses[0].isApprox(Pose::Identity()));
}

TEST_F(KinematicsTest, LinkPoseMatchesComputeKinematics) {
  KinematicsState state;
  for (const State& s : TestStates()) {
    ComputeKinematics(model_, s.X_WB, s.q, &state);
    for (int l = 0; l < model_.num_links(); ++l) {
      const Pose X_WL = LinkPose(model_, s.X_WB, s.q, l);
      EXPECT_LT((X_WL.matrix() - state.link_poses[l].matrix()).cwiseAbs().maxCoeff(), 1e-14);
    }
  }
}

TEST_F(KinematicsTest, HandComputedPosesAtZero) {
  const State zero = Zero();
  KinematicsState state;
  ComputeKinematics(model_, zero.X_WB, zero.q, &state);
  // upper = shoulder frame: (0, 0, 0.1) rotated by rpy (0.1, -0.2, 0.3).
  const Mat3 R_upper = (Eigen::AngleAxisd(0.3, Vec3::UnitZ()) *
                        Eigen::AngleAxisd(-0.2, Vec3::UnitY()) *
                        Eigen::AngleAxisd(0.1, Vec3::UnitX()))
                           .toRotationMatrix();
  const int upper = model_.LinkIndex("upper");
  EXPECT_TRUE(state.link_poses[upper].translation().isApprox(Vec3(0, 0, 0.1)));
  EXPECT_TRUE(state.link_poses[upper].linear().isApprox(R_upper, 1e-14));
  // The flap joint at zero wrist sits at its mimic offset, 0.1 rad about y.
  const int flap_joint = model_.JointIndex("flap_joint");
  EXPECT_DOUBLE_EQ(state.joint_positions[flap_joint], 0.1);
  const Mat3 R_flap = R_upper * Eigen::AngleAxisd(0.1, Vec3::UnitY()).toRotationMatrix();
  EXPECT_TRUE(state.link_poses[model_.LinkIndex("flap")].linear().isApprox(R_flap, 1e-14));
  EXPECT_TRUE(state.link_poses[model_.LinkIndex("flap")].translation().isApprox(
      Vec3(0, 0, 0.1) + R_upper * Vec3(0.1, 0, 0.04), 1e-14));
  EXPECT_TRUE(state.joint_axes[flap_joint].isApprox(R_upper * Vec3::UnitY(), 1e-14));
  EXPECT_EQ(state.joint_positions[model_.JointIndex("tool_joint")], 0.0);
}

TEST_F(KinematicsTest, PrismaticJointTranslatesAlongItsAxis) {
  State s = Zero();
  s.X_WB = MakePose(Vec3(1, 2, 3), ExpSO3(Vec3(0.3, -0.2, 0.5)));
  s.q[shoulder_] = 0.7;
  const int forearm = model_.LinkIndex("forearm");
  const Pose before = LinkPose(model_, s.X_WB, s.q, forearm);
  s.q[slider_] = 0.15;
  const Pose after = LinkPose(model_, s.X_WB, s.q, forearm);
  // Along the slider's x axis, which is the forearm's x axis; no rotation.
  EXPECT_TRUE((after.translation() - before.translation())
                  .isApprox(0.15 * before.linear().col(0), 1e-14));
  EXPECT_TRUE(after.linear().isApprox(before.linear(), 1e-14));
}

TEST_F(KinematicsTest, ContinuousJointIsPeriodic) {
  State s = Zero();
  s.q[wrist_] = 0.4;
  const int hand = model_.LinkIndex("hand");
  const Pose a = LinkPose(model_, s.X_WB, s.q, hand);
  s.q[wrist_] = 0.4 + 2.0 * kPi;
  const Pose b = LinkPose(model_, s.X_WB, s.q, hand);
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), 1e-14);
}

TEST_F(KinematicsTest, MimicJointsFollowTheirSource) {
  State s = Zero();
  s.q[wrist_] = 0.6;
  KinematicsState state;
  ComputeKinematics(model_, s.X_WB, s.q, &state);
  EXPECT_DOUBLE_EQ(state.joint_positions[model_.JointIndex("flap_joint")], 0.5 * 0.6 + 0.1);
  EXPECT_DOUBLE_EQ(state.joint_positions[model_.JointIndex("flap2_joint")], -0.6 - 0.15);
  // flap2 slides along the flap's y axis by its position.
  const Pose& flap = state.link_poses[model_.LinkIndex("flap")];
  const Pose& flap2 = state.link_poses[model_.LinkIndex("flap2")];
  EXPECT_TRUE(flap2.translation().isApprox(flap * Vec3(0, 0.05 + (-0.75), 0), 1e-14));
}

TEST_F(KinematicsTest, PointJacobianMatchesFiniteDifferences) {
  KinematicsState state;
  Jacobian J;
  double worst = 0.0;
  for (const State& s : TestStates()) {
    ComputeKinematics(model_, s.X_WB, s.q, &state);
    for (int l = 0; l < model_.num_links(); ++l) {
      for (const Vec3& p_L : {Vec3(0, 0, 0), Vec3(0.1, -0.05, 0.2), Vec3(-0.3, 0.2, -0.1)}) {
        const Vec3 p_W = state.link_poses[l] * p_L;
        PointJacobian(model_, state, l, p_W, &J);
        ASSERT_EQ(J.rows(), 3);
        ASSERT_EQ(J.cols(), 6 + model_.num_actuated());
        const double error = JacobianError(NumericPointJacobian(model_, s, l, p_L), J);
        EXPECT_LT(error, kJacobianRelativeTolerance) << "link " << model_.link(l).name;
        worst = std::max(worst, error);
      }
    }
  }
  RecordProperty("worst_relative_error", ::testing::PrintToString(worst));
}

TEST_F(KinematicsTest, LinkJacobianMatchesFiniteDifferences) {
  KinematicsState state;
  Jacobian J;
  double worst = 0.0;
  for (const State& s : TestStates()) {
    ComputeKinematics(model_, s.X_WB, s.q, &state);
    for (int l = 0; l < model_.num_links(); ++l) {
      LinkJacobian(model_, state, l, &J);
      ASSERT_EQ(J.rows(), 6);
      ASSERT_EQ(J.cols(), 6 + model_.num_actuated());
      const double error = JacobianError(NumericLinkJacobian(model_, s, l), J);
      EXPECT_LT(error, kJacobianRelativeTolerance) << "link " << model_.link(l).name;
      worst = std::max(worst, error);
    }
  }
  RecordProperty("worst_relative_error", ::testing::PrintToString(worst));
}

TEST_F(KinematicsTest, MimicContributesToItsSourceColumn) {
  // flap2 is moved by the wrist only through two mimic joints (it is not
  // below the wrist), so its wrist column is exactly their contributions.
  State s = Zero();
  s.q << 0.3, 0.1, -0.4;
  KinematicsState state;
  ComputeKinematics(model_, s.X_WB, s.q, &state);
  const int flap2 = model_.LinkIndex("flap2");
  const int flap_joint = model_.JointIndex("flap_joint");
  const int flap2_joint = model_.JointIndex("flap2_joint");
  Jacobian J;
  LinkJacobian(model_, state, flap2, &J);
  const Vec3 p = state.link_poses[flap2].translation();
  const Vec3 expected_linear =
      0.5 * state.joint_axes[flap_joint].cross(p - state.joint_origins[flap_joint]) +
      -1.0 * state.joint_axes[flap2_joint];
  EXPECT_TRUE((J.block<3, 1>(0, 6 + wrist_).isApprox(expected_linear, 1e-14)));
  const Vec3 expected_angular = 0.5 * state.joint_axes[flap_joint];
  EXPECT_TRUE((J.block<3, 1>(3, 6 + wrist_).isApprox(expected_angular, 1e-14)));
  EXPECT_TRUE(J.col(6 + slider_).isZero());  // the slider is on another branch
  EXPECT_LT(JacobianError(NumericLinkJacobian(model_, s, flap2), J), kJacobianRelativeTolerance);
}

TEST_F(KinematicsTest, BaseColumns) {
  State s = Zero();
  s.X_WB = MakePose(Vec3(0.5, -1, 2), ExpSO3(Vec3(0.1, 0.2, -0.3)));
  KinematicsState state;
  ComputeKinematics(model_, s.X_WB, s.q, &state);
  Jacobian J;
  LinkJacobian(model_, state, model_.LinkIndex("hand"), &J);
  EXPECT_TRUE((J.block<3, 3>(0, 0).isIdentity()));
  EXPECT_TRUE((J.block<3, 3>(3, 0).isZero()));
  EXPECT_TRUE((J.block<3, 3>(3, 3).isIdentity()));
  LinkJacobian(model_, state, 0, &J);  // the base itself: no joint columns
  EXPECT_TRUE(J.block(0, 6, 6, model_.num_actuated()).isZero());
  EXPECT_TRUE((J.block<3, 3>(0, 3).isZero()));
}

TEST_F(KinematicsTest, SteadyStateDoesNotAllocate) {
  std::mt19937 rng(7);
  const State a{testing::RandomPose(&rng, 1.0), testing::RandomConfiguration(model_, &rng)};
  const State b{testing::RandomPose(&rng, 1.0), testing::RandomConfiguration(model_, &rng)};
  KinematicsState state;
  Jacobian J_point, J_link;
  ComputeKinematics(model_, a.X_WB, a.q, &state);  // first call sizes the buffers
  PointJacobian(model_, state, 3, Vec3(1, 2, 3), &J_point);
  LinkJacobian(model_, state, 6, &J_link);
  const long before = quadhand::testing::AllocationCount();
  for (int i = 0; i < 10; ++i) {
    ComputeKinematics(model_, (i % 2 ? a : b).X_WB, (i % 2 ? a : b).q, &state);
    PointJacobian(model_, state, i % model_.num_links(), Vec3(1, 2, 3), &J_point);
    LinkJacobian(model_, state, i % model_.num_links(), &J_link);
  }
  EXPECT_EQ(quadhand::testing::AllocationCount() - before, 0);
}

}  // namespace
}  // namespace quadhand::robot

namespace quadhand::robot {
namespace {

// LinkOriginReach bounds every link origin's distance from the root over
// joint values within the limits (and is infinite below a prismatic joint
// driven by a joint without limits); at the joint values that stretch the
// reference arm along its chain it is nearly attained.
TEST(LinkOriginReachTest, BoundsEveryLinkOriginOverTheJointRange) {
  for (const std::string& path :
       {testing::Arm2Path(), testing::SourcePath("meshes/quadhand/quadhand.urdf")}) {
    auto model = RobotModel::LoadFromUrdfFile(path);
    ASSERT_TRUE(model.ok()) << model.status().message();
    const std::vector<double> reach = LinkOriginReach(*model);
    ASSERT_EQ(static_cast<int>(reach.size()), model->num_links());
    EXPECT_EQ(reach[0], 0.0);
    std::mt19937 rng(5);
    KinematicsState state;
    double largest_tool = 0.0;
    for (int trial = 0; trial < 2000; ++trial) {
      ComputeKinematics(*model, Pose::Identity(), testing::RandomConfiguration(*model, &rng), &state);
      for (int l = 0; l < model->num_links(); ++l) {
        EXPECT_LE(state.link_poses[l].translation().norm(), reach[l] + 1e-12) << path << " link " << l;
      }
      if (const int tool = model->LinkIndex("tool"); tool >= 0) {
        largest_tool = std::max(largest_tool, state.link_poses[tool].translation().norm());
      }
    }
    if (const int tool = model->LinkIndex("tool"); tool >= 0) {
      EXPECT_GT(largest_tool, 0.6 * reach[tool]) << path;  // a bound, not a gross overestimate
    }
  }
  // arm2's flap2 is a prismatic mimic of the continuous wrist: no finite bound.
  auto arm2 = RobotModel::LoadFromUrdfFile(testing::Arm2Path());
  EXPECT_TRUE(std::isinf(LinkOriginReach(*arm2)[arm2->LinkIndex("flap2")]));
}

}  // namespace
}  // namespace quadhand::robot
