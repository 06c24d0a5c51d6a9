// Moving targets (planner/target_motion.h): the displacement, the point
// derivatives against finite differences, the path file's checks, and the
// task keys of goal.tool.motion with their errors.
#include "quadhand/planner/target_motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "quadhand/planner/task.h"

namespace quadhand::planner {
namespace {

// Central differences of PointDerivatives' order `order - 1` at t.
Vec3 DifferenceOf(const TargetMotion& motion, const Vec3& x0, double t, int order) {
  const double h = 1e-5;
  Vec3 ahead[5], behind[5];
  motion.PointDerivatives(x0, t + h, ahead);
  motion.PointDerivatives(x0, t - h, behind);
  return (ahead[order - 1] - behind[order - 1]) / (2.0 * h);
}

TEST(TargetMotionTest, AConstantMotionMovesTheTargetAndTurnsAboutItsOwnVerticalAxis) {
  const Vec3 origin(1.0, 2.0, 0.8);
  const TargetMotion motion = TargetMotion::Constant(origin, Vec3(0.3, 0.0, 0.0), Vec3(0.0, 0.1, 0.0), 0.5);
  EXPECT_TRUE(motion.Displacement(0.0).isApprox(Pose::Identity()));
  // The target's own point follows c(t) = origin + v t + a t^2 / 2.
  EXPECT_TRUE((motion.Displacement(2.0) * origin).isApprox(Vec3(1.6, 2.2, 0.8), 1e-12));
  // A point 0.1 m beside it turns with it: 1 rad after 2 s.
  const Vec3 beside = motion.Displacement(2.0) * (origin + Vec3(0.1, 0.0, 0.0));
  EXPECT_TRUE((beside - Vec3(1.6, 2.2, 0.8)).isApprox(0.1 * Vec3(std::cos(1.0), std::sin(1.0), 0.0), 1e-12));
  EXPECT_DOUBLE_EQ(motion.Yaw(2.0), 1.0);
}

TEST(TargetMotionTest, PointDerivativesMatchFiniteDifferences) {
  const Vec3 x0(0.4, -0.3, 1.1);
  const TargetMotion constant = TargetMotion::Constant(Vec3(0.1, 0.2, 1.0), Vec3(0.3, -0.2, 0.05),
                                                       Vec3(0.2, 0.1, -0.1), 0.7);
  const TargetMotion sampled = TargetMotion::Sampled({{0.0, Vec3(0, 0, 1), 0.0}, {2.0, Vec3(1, 0.5, 1), 0.8},
                                                      {4.0, Vec3(1.5, 1.5, 1.2), 0.2}});
  for (const TargetMotion* motion : {&constant, &sampled}) {
    for (double t : {0.3, 1.1, 2.7, 3.5}) {
      Vec3 d[5];
      motion->PointDerivatives(x0, t, d);
      for (int order = 1; order <= 4; ++order) {
        EXPECT_LT((d[order] - DifferenceOf(*motion, x0, t, order)).norm(), 1e-6 * (1.0 + d[order].norm()))
            << "order " << order << " at t = " << t << (motion->sampled() ? " (sampled)" : " (constant)");
      }
      EXPECT_TRUE(d[1].isApprox(motion->PointVelocity(d[0], t), 1e-12));
    }
  }
}

// A mission's leg that starts at s sees the target on the mission's clock:
// the shifted motion at t is the motion at s + t, its displacement still
// from the mission's t = 0, and its speed bound over [s, s + horizon].
TEST(TargetMotionTest, AShiftedMotionRunsOnTheLaterClock) {
  const TargetMotion constant = TargetMotion::Constant(Vec3(0.1, 0.2, 1.0), Vec3(0.3, -0.2, 0.0),
                                                       Vec3(0.2, 0.0, 0.0), 0.4);
  const TargetMotion sampled = TargetMotion::Sampled({{0.0, Vec3(0, 0, 1), 0.0}, {2.0, Vec3(1, 0.5, 1), 0.8},
                                                      {4.0, Vec3(1.5, 1.5, 1.2), 0.2}});
  const Vec3 x0(0.4, -0.3, 1.1);
  for (const TargetMotion* motion : {&constant, &sampled}) {
    const TargetMotion later = motion->Shifted(1.5);
    EXPECT_DOUBLE_EQ(later.time_offset(), 1.5);
    EXPECT_DOUBLE_EQ(later.Shifted(0.5).time_offset(), 2.0);
    for (double t : {0.0, 0.7, 2.1}) {
      EXPECT_TRUE(later.Displacement(t).isApprox(motion->Displacement(1.5 + t), 1e-12)) << t;
      EXPECT_TRUE(later.Center(t).isApprox(motion->Center(1.5 + t), 1e-12));
      EXPECT_DOUBLE_EQ(later.Yaw(t), motion->Yaw(1.5 + t));
      EXPECT_DOUBLE_EQ(later.YawRate(t), motion->YawRate(1.5 + t));
      Vec3 a[5], b[5];
      later.PointDerivatives(x0, t, a);
      motion->PointDerivatives(x0, 1.5 + t, b);
      for (int k = 0; k < 5; ++k) EXPECT_TRUE(a[k].isApprox(b[k], 1e-12) || (a[k] - b[k]).norm() < 1e-12) << k;
    }
  }
  // The constant motion speeds up at 0.2 m/s^2: over [1.5, 2.5] its centre
  // goes from |(0.6, -0.2)| to |(0.8, -0.2)|; a point 0.5 m out adds 0.2.
  EXPECT_NEAR(constant.Shifted(1.5).MaxSpeed(0.5, 1.0), std::hypot(0.8, 0.2) + 0.2, 1e-12);
  EXPECT_NEAR(constant.MaxSpeed(0.5, 1.0), std::hypot(0.5, 0.2) + 0.2, 1e-12);
  // The path's first interval is over by 2 s: from 2.5 s only the second counts.
  EXPECT_NEAR(sampled.Shifted(2.5).MaxYawRate(1.0), 0.3, 1e-12);
  EXPECT_NEAR(sampled.MaxYawRate(1.0), 0.4, 1e-12);
}

TEST(TargetMotionTest, ASampledPathHoldsItsEndsAndBoundsItsSpeed) {
  const TargetMotion sampled =
      TargetMotion::Sampled({{0.0, Vec3(0, 0, 1), 0.0}, {2.0, Vec3(1, 0, 1), 0.0}, {3.0, Vec3(1, 2, 1), 1.0}});
  EXPECT_TRUE((sampled.Displacement(10.0) * Vec3(0, 0, 1)).isApprox(Vec3(1, 2, 1)));
  EXPECT_TRUE(sampled.PointVelocity(Vec3(1, 2, 1), 10.0).isZero());
  EXPECT_DOUBLE_EQ(sampled.MaxSpeed(0.0, 2.5), 2.0);        // the second leg: 2 m in 1 s
  EXPECT_DOUBLE_EQ(sampled.MaxSpeed(0.5, 1.0), 0.5);        // only the first leg
  EXPECT_DOUBLE_EQ(sampled.MaxSpeed(0.5, 2.5), 2.0 + 0.5);  // 1 rad/s at 0.5 m
}

TEST(TargetPathTest, AFileIsReadByColumnNameAndItsTurnsAreUnwrapped) {
  // A half turn per row, about z: the yaw grows past pi without jumping back.
  const std::string text =
      "qw,qx,qy,qz,t,x,y,z\n"
      "1,0,0,0,0,0,0,1\n"
      "0.7071068,0,0,0.7071068,1,0.5,0,1\n"
      "0,0,0,1,2,1,0,1\n"
      "-0.7071068,0,0,0.7071068,3,1.5,0,1\n";
  auto path = ParseTargetPath(text, "belt.csv");
  ASSERT_TRUE(path.ok()) << path.status().message();
  ASSERT_EQ(path->size(), 4u);
  EXPECT_NEAR((*path)[3].yaw, 1.5 * M_PI, 1e-6);
  EXPECT_TRUE((*path)[1].position.isApprox(Vec3(0.5, 0, 1)));
}

TEST(TargetPathTest, EachBadFileIsNamedWithItsLine) {
  struct Case {
    const char* text;
    const char* expected;
  };
  const Case cases[] = {
      {"", "belt.csv: empty target path"},
      {"t,x,y,z,qw,qx,qy\n0,0,0,0,1,0,0\n", "belt.csv:1: missing column 'qz'"},
      {"t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,nan,0,0,1,0,0,0\n", "belt.csv:3: column x: expected a finite number"},
      {"t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0,1,0,0,1,0,0,0\n", "belt.csv:3: time 0 does not increase"},
      {"t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,1,0,0,0.9,0,0,0\n", "belt.csv:3: the quaternion"},
      {"t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,1,0,0,0.9950042,0.0998334,0,0\n", "belt.csv:3: the orientation tilts"},
      {"t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n", "belt.csv: a target path needs at least 2 rows"},
      {"t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0,0\n", "belt.csv:3: expected 8 values, got 3"},
  };
  for (const Case& c : cases) {
    auto path = ParseTargetPath(c.text, "belt.csv");
    ASSERT_FALSE(path.ok()) << c.text;
    EXPECT_EQ(path.status().message().rfind(c.expected, 0), 0u) << path.status().message();
  }
}

// The default task's shape with a moving cup: `motion` is the text of
// goal.tool's motion keys, `extra` more keys of goal.tool.
std::string MovingTask(const std::string& motion, const std::string& extra = "",
                       const std::string& limits = "") {
  return "robot: r.urdf\nsdf_dir: sdf\nscene: s.pcd\n"
         "start: {position: [0, 0, 1], yaw: 0, joints: [0, 0, 0]}\n"
         "goal:\n  tool:\n    position: [-3.2, 0.0, 0.86]\n    orientation: [0, -0.7071068, 0, 0.7071068]\n"
         "    insertion: {direction: [0, 0, -1], length: 0.1}\n"
         "    motion: " + motion + "\n" + extra + limits;
}

TEST(MovingTargetTaskTest, AConstantMotionAndItsMovingPointsAreRead) {
  auto task = ParseTaskText(MovingTask("{velocity: [0.3, 0, 0], yaw_rate: 0.2, moving_points: {min: [-3.3, -0.1, "
                                       "0.7], max: [-3.1, 0.1, 0.9]}}",
                                       "    max_relative_speed: 0.05\n"),
                            "task.yaml", "/base", TaskSources{});
  ASSERT_TRUE(task.ok()) << task.status().message();
  ASSERT_TRUE(task->tool && task->tool->moving);
  const MovingTarget& moving = *task->tool->moving;
  EXPECT_TRUE((moving.motion.Displacement(1.0) * Vec3(-3.2, 0.0, 0.86)).isApprox(Vec3(-2.9, 0.0, 0.86)));
  ASSERT_TRUE(moving.moving_box.has_value());
  EXPECT_TRUE(moving.moving_box->Contains(Vec3(-3.2, 0.0, 0.8)));
  EXPECT_DOUBLE_EQ(*moving.max_relative_speed, 0.05);
}

TEST(MovingTargetTaskTest, EachBadMotionIsNamedByItsKey) {
  const std::string dir = ::testing::TempDir();
  const std::string backwards = dir + "/backwards.csv";
  std::ofstream(backwards) << "t,x,y,z,qw,qx,qy,qz\n0,0,0,1,1,0,0,0\n2,1,0,1,1,0,0,0\n1,2,0,1,1,0,0,0\n";
  const std::string fast = dir + "/fast.csv";
  std::ofstream(fast) << "t,x,y,z,qw,qx,qy,qz\n0,0,0,1,1,0,0,0\n0.1,1,0,1,1,0,0,0\n";
  struct Case {
    std::string text;
    std::string expected;
  };
  const Case cases[] = {
      {MovingTask("{file: missing.csv}"), "task.yaml: goal.tool.motion.file: "},
      {MovingTask("{file: " + backwards + "}"), "task.yaml: goal.tool.motion.file: " + backwards +
                                                    ":4: time 1 does not increase"},
      {MovingTask("{file: " + fast + "}"), "task.yaml: goal.tool.motion.file: the target moves at 10.000 m/s, above "
                                           "limits.v_max (2.000 m/s)"},
      {MovingTask("{velocity: [0.3, 0, .nan]}"), "task.yaml: goal.tool.motion.velocity[2]: must be a finite number"},
      {MovingTask("{velocity: [3, 0, 0]}"), "task.yaml: goal.tool.motion.velocity: the target moves at 3.000 m/s"},
      {MovingTask("{velocity: [0.3, 0, 0], moving_points: {min: [0, 0, 1], max: [1, 1, 0]}}"),
       "task.yaml: goal.tool.motion.moving_points: not a box"},
      {MovingTask("{yaw_rate: 0.3}"), "task.yaml: goal.tool.motion.velocity: missing"},
      {MovingTask("{velocity: [0.3, 0, 0], file: a.csv}"), "task.yaml: goal.tool.motion.velocity: give a constant"},
      {MovingTask("{velocity: [0.3, 0, 0], spin: 1}"), "task.yaml: goal.tool.motion.spin: unknown key"},
      {MovingTask("{velocity: [0.3, 0, 0]}", "    max_relative_speed: -1\n"),
       "task.yaml: goal.tool.max_relative_speed: must be a positive speed"},
      {MovingTask("{velocity: [0.3, 0, 0], yaw_rate: -3}"),
       "task.yaml: goal.tool.motion.yaw_rate: the target turns at 3.000 rad/s, above limits.yaw_rate_max (1.500 rad/s)"},
  };
  for (const Case& c : cases) {
    auto task = ParseTaskText(c.text, "task.yaml", dir, TaskSources{});
    ASSERT_FALSE(task.ok()) << c.text;
    EXPECT_EQ(task.status().message().rfind(c.expected, 0), 0u) << task.status().message();
  }
}

}  // namespace
}  // namespace quadhand::planner
