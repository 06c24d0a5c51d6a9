// Self-collision pairs and their certified distance bound, on robots made of
// spheres whose distances are known exactly: which pairs are checked (rigid,
// adjacent, SRDF-disabled and close-at-zero pairs are not), and that the
// bound is never above the true distance and at most the sample spacing
// (plus the spheres' tessellation) below it, and negative for overlaps.
#include "quadhand/env/self_collision.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include <unistd.h>

#include "quadhand/geometry/mesh_to_sdf.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/robot/srdf.h"

namespace quadhand::env {
namespace {

// base: sphere r 0.1 at its origin; guard: a box fixed to the base at y 0.3;
// arm: sphere r 0.05, slides along x from x 0.3; hand: sphere r 0.03 at x 0.1
// of its frame, turns about z at the arm's origin.
constexpr const char* kSphereArm = R"(<robot name="sphere_arm">
  <link name="base"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
  <link name="guard"><collision><geometry><box size="0.05 0.05 0.05"/></geometry></collision></link>
  <link name="arm"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <link name="hand"><collision><origin xyz="0.1 0 0"/><geometry><sphere radius="0.03"/></geometry></collision></link>
  <joint name="guard_mount" type="fixed"><parent link="base"/><child link="guard"/><origin xyz="0 0.3 0"/></joint>
  <joint name="slide" type="prismatic"><parent link="base"/><child link="arm"/><origin xyz="0.3 0 0"/>
    <axis xyz="1 0 0"/><limit lower="-0.5" upper="0.5" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="continuous"><parent link="arm"/><child link="hand"/><axis xyz="0 0 1"/></joint>
</robot>)";

// The same hand joined to the base through a link without collision
// geometry: base and hand are adjacent.
constexpr const char* kThroughMassless = R"(<robot name="through_massless">
  <link name="base"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
  <link name="carriage"/>
  <link name="hand"><collision><origin xyz="0.1 0 0"/><geometry><sphere radius="0.03"/></geometry></collision></link>
  <joint name="slide" type="prismatic"><parent link="base"/><child link="carriage"/><origin xyz="0.3 0 0"/>
    <axis xyz="1 0 0"/><limit lower="-0.5" upper="0.5" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="continuous"><parent link="carriage"/><child link="hand"/><axis xyz="0 0 1"/></joint>
</robot>)";

struct Fixture {
  robot::RobotModel robot;
  std::unique_ptr<ExactMeshModel> exact;
};

Fixture Load(const char* urdf) {
  auto robot = robot::RobotModel::LoadFromUrdfString(urdf, ".");
  EXPECT_TRUE(robot.ok()) << robot.status().message();
  Fixture f{std::move(*robot), nullptr};
  auto exact = ExactMeshModel::Create(f.robot, std::vector<Vec3>{Vec3(100, 100, 100)});
  EXPECT_TRUE(exact.ok()) << exact.status().message();
  f.exact = std::move(*exact);
  return f;
}

std::vector<std::pair<std::string, std::string>> PairNames(const Fixture& f, const SelfCollisionModel& model) {
  std::vector<std::pair<std::string, std::string>> names;
  for (const LinkPair& p : model.pairs()) {
    std::string a = f.robot.link(p.sampled_link).name, b = f.robot.link(p.queried_link).name;
    if (a > b) std::swap(a, b);
    names.emplace_back(a, b);
  }
  std::sort(names.begin(), names.end());
  return names;
}

PairExclusion ExclusionOf(const Fixture& f, const SelfCollisionModel& model, const std::string& a,
                          const std::string& b) {
  for (const ExcludedPair& p : model.excluded()) {
    const std::string x = f.robot.link(p.link_a).name, y = f.robot.link(p.link_b).name;
    if ((x == a && y == b) || (x == b && y == a)) return p.why;
  }
  ADD_FAILURE() << a << " and " << b << " are not excluded";
  return PairExclusion::kAdjacent;
}

TEST(SelfCollisionTest, RigidAndAdjacentPairsAreNotChecked) {
  const Fixture f = Load(kSphereArm);
  auto model = SelfCollisionModel::Create(f.robot, *f.exact, std::nullopt, SelfCollisionOptions{});
  ASSERT_TRUE(model.ok()) << model.status().message();
  using Names = std::vector<std::pair<std::string, std::string>>;
  EXPECT_EQ(PairNames(f, **model), (Names{{"base", "hand"}, {"guard", "hand"}}));
  EXPECT_EQ(ExclusionOf(f, **model, "base", "guard"), PairExclusion::kRigid);
  EXPECT_EQ(ExclusionOf(f, **model, "base", "arm"), PairExclusion::kAdjacent);
  EXPECT_EQ(ExclusionOf(f, **model, "guard", "arm"), PairExclusion::kAdjacent);  // rigid with the base
  EXPECT_EQ(ExclusionOf(f, **model, "arm", "hand"), PairExclusion::kAdjacent);
}

TEST(SelfCollisionTest, AdjacencyPassesThroughALinkWithoutGeometry) {
  const Fixture f = Load(kThroughMassless);
  auto model = SelfCollisionModel::Create(f.robot, *f.exact, std::nullopt, SelfCollisionOptions{});
  ASSERT_TRUE(model.ok()) << model.status().message();
  EXPECT_TRUE((*model)->pairs().empty());
  EXPECT_EQ(ExclusionOf(f, **model, "base", "hand"), PairExclusion::kAdjacent);
}

TEST(SelfCollisionTest, SrdfAndZeroConfigurationDisablePairs) {
  const Fixture f = Load(kSphereArm);
  const int base = f.robot.LinkIndex("base"), hand = f.robot.LinkIndex("hand");
  auto srdf = SelfCollisionModel::Create(f.robot, *f.exact, std::vector<std::pair<int, int>>{{base, hand}},
                                         SelfCollisionOptions{});
  ASSERT_TRUE(srdf.ok());
  EXPECT_EQ((*srdf)->pairs().size(), 1u);
  EXPECT_EQ(ExclusionOf(f, **srdf, "base", "hand"), PairExclusion::kSrdf);
  // At zero the hand's sphere is 0.4 - 0.13 = 0.27 m from the base's, and
  // sqrt(0.4^2 + 0.3^2) - 0.03 - 0.025 > 0.44 m from the guard's box.
  SelfCollisionOptions wide;
  wide.safety_distance = 0.3;
  auto close = SelfCollisionModel::Create(f.robot, *f.exact, std::nullopt, wide);
  ASSERT_TRUE(close.ok());
  EXPECT_EQ(ExclusionOf(f, **close, "base", "hand"), PairExclusion::kCloseAtZero);
  EXPECT_EQ((*close)->pairs().size(), 1u);  // guard and hand
  // With an SRDF the zero configuration disables nothing.
  auto given = SelfCollisionModel::Create(f.robot, *f.exact, std::vector<std::pair<int, int>>{}, wide);
  ASSERT_TRUE(given.ok());
  EXPECT_EQ((*given)->pairs().size(), 2u);
}

TEST(SelfCollisionTest, TheBoundIsBelowTheExactSphereDistanceByAtMostTheSpacing) {
  const Fixture f = Load(kSphereArm);
  SelfCollisionOptions options;
  options.sample_spacing = 0.004;
  auto model = SelfCollisionModel::Create(f.robot, *f.exact, std::nullopt, options);
  ASSERT_TRUE(model.ok());
  int pair = -1;
  for (size_t i = 0; i < (*model)->pairs().size(); ++i) {
    const LinkPair& p = (*model)->pairs()[i];
    if (f.robot.link(p.sampled_link).name == "hand" && f.robot.link(p.queried_link).name == "base") pair = i;
  }
  ASSERT_GE(pair, 0) << "the hand (fewer samples) is sampled, the base queried";
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> slide(-0.5, 0.2), angle(-M_PI, M_PI);
  robot::KinematicsState kinematics;
  int overlaps = 0;
  for (int trial = 0; trial < 200; ++trial) {
    VecX q(2);
    q << slide(rng), angle(rng);
    const Pose X_WB = Pose(Eigen::AngleAxisd(angle(rng), Vec3(0.3, -0.2, 1.0).normalized())) *
                      Eigen::Translation3d(0.5, -1.0, 2.0);
    robot::ComputeKinematics(f.robot, X_WB, q, &kinematics);
    const Vec3 hand_in_base = X_WB.inverse() * (kinematics.link_poses[f.robot.LinkIndex("hand")] * Vec3(0.1, 0, 0));
    const double truth = hand_in_base.norm() - 0.13;
    const double bound = (*model)->PairDistanceLowerBound(pair, kinematics, 1.0);
    // Tessellated spheres are inscribed: within 1e-4 of the true surface.
    // Overlapping solids have no distance: any negative bound says so.
    if (truth >= 0.0) {
      EXPECT_LE(bound, truth + 3e-4) << "q = " << q.transpose();
      EXPECT_GE(bound, truth - options.sample_spacing - 3e-4) << "q = " << q.transpose();
    } else {
      ++overlaps;
      EXPECT_LT(bound, 0.0) << "q = " << q.transpose();
    }
    EXPECT_LE((*model)->MinDistanceLowerBound(kinematics, 1.0), bound);
  }
  EXPECT_GT(overlaps, 10);
  // Beyond `reach` the bound is reach.
  VecX q(2);
  q << 0.5, 0.0;
  robot::ComputeKinematics(f.robot, Pose::Identity(), q, &kinematics);
  EXPECT_EQ((*model)->PairDistanceLowerBound(pair, kinematics, 0.05), 0.05);
}

// The penalty's gradient w.r.t. the base pose and both joints against
// central differences, with the hand's sphere a few millimetres to a few
// centimetres from the base's (both links move, through their chains).
TEST(SelfCollisionTest, PenaltyGradientMatchesFiniteDifferences) {
  const Fixture f = Load(kSphereArm);
  auto model = SelfCollisionModel::Create(f.robot, *f.exact, std::nullopt, SelfCollisionOptions{});
  ASSERT_TRUE(model.ok());
  geometry::SdfGenerationOptions sdf_options;
  sdf_options.resolution = 0.004;
  auto grids = std::make_shared<std::vector<geometry::SdfGrid>>();
  for (int link : f.robot.CollisionLinks()) {
    auto elements = robot::LinkCollisionElements(f.robot, link);
    ASSERT_TRUE(elements.ok());
    auto grid = geometry::GenerateSdf(*elements, f.robot.link(link).name, "test", sdf_options);
    ASSERT_TRUE(grid.ok()) << grid.status().message();
    grids->push_back(std::move(*grid));
  }
  EXPECT_FALSE((*model)->has_penalty());
  ASSERT_TRUE((*model)->AttachSdfGrids(grids).ok());
  EXPECT_TRUE((*model)->has_penalty());
  const PenaltyParameters parameters{0.03, 0.01};
  const Pose X_WB = Pose(Eigen::AngleAxisd(0.4, Vec3(1, 2, 3).normalized())) * Eigen::Translation3d(0.2, -0.1, 1.0);
  auto penalty = [&](const Pose& base, const VecX& q, StateGradient* gradient) {
    robot::KinematicsState kinematics;
    robot::ComputeKinematics(f.robot, base, q, &kinematics);
    return (*model)->Penalty(f.robot, kinematics, parameters, gradient);
  };
  int checked = 0;
  // Hand centre at (0.3 + slide + 0.1 cos(wrist), 0.1 sin(wrist)) from the
  // base's: spheres 1 cm apart, 2.5 cm apart, 1 cm deep, touching.
  for (const auto& [slide, wrist] : {std::pair{-0.25, 0.8}, std::pair{-0.24, 0.5}, std::pair{-0.26, 1.2},
                                     std::pair{-0.27, 0.0}}) {
    VecX q(2);
    q << slide, wrist;
    StateGradient gradient;
    gradient.SetZero(2);
    const double value = penalty(X_WB, q, &gradient);
    if (value <= 0.0) continue;
    ++checked;
    const double h = 1e-6;
    for (int axis = 0; axis < 3; ++axis) {
      Pose plus = X_WB, minus = X_WB;
      plus.translation()[axis] += h;
      minus.translation()[axis] -= h;
      const double fd = (penalty(plus, q, nullptr) - penalty(minus, q, nullptr)) / (2 * h);
      EXPECT_NEAR(gradient.position[axis], fd, 1e-5 + 1e-4 * std::abs(fd)) << "translation " << axis;
      Pose turned_plus = X_WB, turned_minus = X_WB;
      turned_plus.linear() = Eigen::AngleAxisd(h, Vec3::Unit(axis)).toRotationMatrix() * X_WB.linear();
      turned_minus.linear() = Eigen::AngleAxisd(-h, Vec3::Unit(axis)).toRotationMatrix() * X_WB.linear();
      const double fd_rotation = (penalty(turned_plus, q, nullptr) - penalty(turned_minus, q, nullptr)) / (2 * h);
      EXPECT_NEAR(gradient.rotation[axis], fd_rotation, 1e-5 + 1e-4 * std::abs(fd_rotation)) << "rotation " << axis;
    }
    for (int j = 0; j < 2; ++j) {
      VecX plus = q, minus = q;
      plus[j] += h;
      minus[j] -= h;
      const double fd = (penalty(X_WB, plus, nullptr) - penalty(X_WB, minus, nullptr)) / (2 * h);
      EXPECT_NEAR(gradient.joints[j], fd, 1e-5 + 1e-4 * std::abs(fd)) << "joint " << j;
    }
  }
  EXPECT_EQ(checked, 4);
  VecX far(2);
  far << 0.5, 0.0;
  EXPECT_EQ(penalty(X_WB, far, nullptr), 0.0);
}

class SrdfFile {
 public:
  explicit SrdfFile(const std::string& text)
      : path_((std::filesystem::temp_directory_path() / ("qh_srdf_" + std::to_string(::getpid()) + ".srdf")).string()) {
    std::ofstream(path_) << text;
  }
  ~SrdfFile() { std::remove(path_.c_str()); }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

TEST(SrdfTest, ReadsDisabledPairsAndNamesTheFileInErrors) {
  const Fixture f = Load(kSphereArm);
  {
    SrdfFile srdf(R"(<?xml version="1.0"?><robot name="sphere_arm">
      <group name="arm"><chain base_link="base" tip_link="hand"/></group>
      <disable_collisions link1="hand" link2="base" reason="Never"/>
      <disable_collisions link1="base" link2="hand" reason="Duplicate"/></robot>)");
    auto pairs = robot::LoadSrdfDisabledPairs(srdf.path(), f.robot);
    ASSERT_TRUE(pairs.ok()) << pairs.status().message();
    ASSERT_EQ(pairs->size(), 1u);
    EXPECT_EQ((*pairs)[0], std::make_pair(f.robot.LinkIndex("base"), f.robot.LinkIndex("hand")));
  }
  for (const char* bad : {R"(<robot><disable_collisions link1="base" link2="wing"/></robot>)",
                          R"(<robot><disable_collisions link1="base"/></robot>)", R"(<robot><disable_collisions)",
                          R"(<model/>)",
                          R"(<!DOCTYPE robot [<!ENTITY b "base">]><robot><disable_collisions link1="&b;" link2="hand"/></robot>)"}) {
    SrdfFile srdf(bad);
    auto pairs = robot::LoadSrdfDisabledPairs(srdf.path(), f.robot);
    ASSERT_FALSE(pairs.ok()) << bad;
    EXPECT_NE(pairs.status().message().find(srdf.path()), std::string::npos) << pairs.status().message();
  }
  EXPECT_FALSE(robot::LoadSrdfDisabledPairs("/nonexistent/robot.srdf", f.robot).ok());
}

}  // namespace
}  // namespace quadhand::env
