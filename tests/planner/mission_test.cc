// The mission of a task file (planner/mission.h, docs/missions.md): what is
// read, the defaults, and one error line naming the step for each defect.
#include <gtest/gtest.h>

#include <string>

#include "quadhand/planner/task.h"

namespace quadhand::planner {
namespace {

const std::string kHead =
    "robot: r.urdf\nsdf_dir: sdf\nscene: s.pcd\nstart: {position: [0, 0, 1], yaw: 0, joints: [0.1]}\n";

core::Result<Task> Parse(const std::string& mission) {
  return ParseTaskText(kHead + "mission:\n" + mission, "task.yaml", "/base", TaskSources{});
}

// A reach that puts the tool at (1, 0, 0.5) from above, with an insertion.
const std::string kReachDown =
    "  - reach:\n"
    "      tool:\n"
    "        position: [1, 0, 0.5]\n"
    "        orientation: [1, 0, 0, 0]\n"
    "        insertion: {direction: [0, 0, -1], length: 0.1}\n";
const std::string kGraspCup =
    "  - grasp:\n"
    "      object:\n"
    "        shape: {cylinder: {radius: 0.04, length: 0.1}}\n"
    "        pose: {position: [1, 0, 0.47], orientation: [1, 0, 0, 0]}\n"
    "        mass: 0.08\n";

TEST(MissionTest, EveryStepKindIsReadWithItsDefaults) {
  auto task = Parse(kReachDown + kGraspCup +
                    "  - move: {length: 0.15}\n"
                    "  - via: {position: [0, 0, 1.3]}\n"
                    "  - reach: {position: [0, 1, 1.2], yaw: 0, joints: [0.2]}\n"
                    "  - release:\n"
                    "  - move: {direction: [1, 0, 0], length: 0.2, max_speed: 0.3}\n"
                    "  - hold: {duration: 1.5}\n");
  ASSERT_TRUE(task.ok()) << task.status().message();
  const std::vector<MissionStep>& m = task->mission;
  ASSERT_EQ(m.size(), 8u);
  const StepKind kinds[] = {StepKind::kReach,  StepKind::kGrasp,   StepKind::kMove, StepKind::kVia,
                            StepKind::kReach,  StepKind::kRelease, StepKind::kMove, StepKind::kHold};
  for (size_t i = 0; i < m.size(); ++i) EXPECT_EQ(m[i].kind, kinds[i]) << i;
  ASSERT_TRUE(m[0].reach_tool.has_value());
  EXPECT_TRUE(m[0].reach_tool->has_insertion);
  EXPECT_FALSE(m[0].reach_state.has_value());
  EXPECT_EQ(m[1].object.shape.kind, ObjectShape::Kind::kCylinder);
  EXPECT_DOUBLE_EQ(m[1].object.shape.radius, 0.04);
  EXPECT_DOUBLE_EQ(m[1].object.mass, 0.08);
  EXPECT_DOUBLE_EQ(m[1].scene_margin, 0.01);
  EXPECT_DOUBLE_EQ(m[1].close_time, 0.5);
  EXPECT_FALSE(m[1].held_at_start);
  EXPECT_FALSE(m[2].move_direction.has_value());  // backs out along the insertion
  EXPECT_DOUBLE_EQ(m[2].move_length, 0.15);
  EXPECT_DOUBLE_EQ(m[3].via_tolerance, 0.05);
  ASSERT_TRUE(m[4].reach_state.has_value());
  EXPECT_DOUBLE_EQ(m[5].open_time, 0.5);
  ASSERT_TRUE(m[6].move_direction.has_value());
  EXPECT_TRUE(m[6].move_direction->isApprox(Vec3::UnitX()));
  ASSERT_TRUE(m[6].move_max_speed.has_value());
  EXPECT_DOUBLE_EQ(*m[6].move_max_speed, 0.3);
  EXPECT_DOUBLE_EQ(m[7].hold_duration, 1.5);
}

TEST(MissionTest, AMissionOfOneReachIsThatGoal) {
  auto task = Parse("  - reach: {position: [0, 1, 1.2], yaw: 0.5, joints: [0.2]}\n");
  ASSERT_TRUE(task.ok()) << task.status().message();
  auto goal = ParseTaskText(kHead + "goal: {position: [0, 1, 1.2], yaw: 0.5, joints: [0.2]}\n", "task.yaml", "/base",
                            TaskSources{});
  ASSERT_TRUE(goal.ok());
  ASSERT_TRUE(task->terminal.has_value());
  EXPECT_EQ(task->terminal->position, goal->terminal->position);
  EXPECT_EQ(task->terminal->yaw, goal->terminal->yaw);
  EXPECT_EQ(task->terminal->joints, goal->terminal->joints);
  EXPECT_FALSE(task->tool.has_value());
}

TEST(MissionTest, AGraspFirstIsAnObjectHeldAtTheStart) {
  auto task = Parse(
      "  - grasp:\n"
      "      object: {shape: {box: {size: [0.2, 0.02, 0.05]}}, pose: {position: [0, 0, 0.1], orientation: [1, 0, 0, 0]}}\n"
      "  - reach: {position: [0, 1, 1.2], yaw: 0, joints: [0.2]}\n"
      "  - release: {open_time: 0.2}\n");
  ASSERT_TRUE(task.ok()) << task.status().message();
  EXPECT_TRUE(task->mission[0].held_at_start);
  EXPECT_DOUBLE_EQ(task->mission[2].open_time, 0.2);
}

void ExpectRefused(const std::string& mission, const std::string& fragment) {
  auto task = Parse(mission);
  ASSERT_FALSE(task.ok()) << "accepted: " << mission;
  EXPECT_EQ(task.status().message().find("task.yaml: "), 0u) << task.status().message();
  EXPECT_NE(task.status().message().find(fragment), std::string::npos) << task.status().message();
  EXPECT_EQ(task.status().message().find('\n'), std::string::npos);
}

TEST(MissionTest, EachDefectIsOneLineNamingTheStep) {
  ExpectRefused("  - grab: {}\n", "mission[0]: unknown step kind 'grab'");
  ExpectRefused("  - {hold: {duration: 1}, release: {}}\n", "mission[0]: expected one step kind as the only key");
  ExpectRefused("  - hold: {duration: 1, speed: 2}\n", "mission[0].hold.speed: unknown key");
  ExpectRefused("  - hold: {}\n", "mission[0].hold.duration: missing");
  ExpectRefused("  - release: {}\n", "mission[0].release: nothing is held");
  ExpectRefused(kReachDown + kGraspCup + "  - release: {}\n  - release: {}\n", "mission[3].release: nothing is held");
  ExpectRefused(kReachDown + kGraspCup + kGraspCup, "mission[2].grasp: a second grasp while the object of mission[1] "
                                                    "(grasp) is held");
  ExpectRefused(kReachDown + "  - move: {direction: [0, 0, 1], length: 0}\n",
                "mission[1].move.length: must be positive (a zero or negative move)");
  ExpectRefused(kReachDown + "  - move: {direction: [0, 0, 1], length: -0.1}\n", "mission[1].move.length: must be positive");
  ExpectRefused(kReachDown + "  - move: {direction: [0, 0, 0], length: 0.1}\n", "mission[1].move.direction: must not be zero");
  ExpectRefused(kReachDown + "  - move: {length: 0.1}\n",
                "mission[1].move.direction: missing: it may be left out only right after a grasp or a release");
  // After a grasp, but the reach before it has no insertion to back out along.
  ExpectRefused(
      "  - reach: {tool: {position: [1, 0, 0.5], orientation: [1, 0, 0, 0]}}\n" + kGraspCup + "  - move: {length: 0.1}\n",
      "mission[2].move.direction: missing, and no insertion to back out along");
  // The cup's surface is 0.5 m below the tool.
  ExpectRefused(kReachDown +
                    "  - grasp:\n"
                    "      object: {shape: {sphere: {radius: 0.03}}, pose: {position: [1, 0, 0.0], orientation: [1, 0, 0, 0]}}\n",
                "mission[1] (grasp): the object is not within reach of the tool: its surface is 0.470 m");
  // A move after the reach takes the tool to the object: in reach.
  EXPECT_TRUE(Parse(kReachDown + "  - move: {direction: [0, 0, -1], length: 0.47}\n" +
                    "  - grasp:\n"
                    "      object: {shape: {sphere: {radius: 0.03}}, pose: {position: [1, 0, 0.0], orientation: [1, 0, 0, 0]}}\n")
                  .ok());
  ExpectRefused("  - grasp: {object: {shape: {cone: {radius: 1}}, pose: {position: [0, 0, 0], orientation: [1, 0, 0, 0]}}}\n",
                "mission[0].grasp.object.shape.cone: unknown key");
  ExpectRefused("  - grasp: {object: {shape: {box: {size: [0.1, 0, 0.1]}}, pose: {position: [0, 0, 0], orientation: [1, 0, 0, 0]}}}\n",
                "mission[0].grasp.object.shape.box.size: every edge must be in (0, 5] m");
  ExpectRefused("  - grasp: {object: {shape: {sphere: {radius: 0.1}}}}\n", "mission[0].grasp.object.pose: missing");
  ExpectRefused("  - grasp: {object: {shape: {sphere: {radius: 0.1}}, pose: {position: [0, 0, 0], orientation: [1, 0, 0, 0]}, "
                "mass: -1}}\n",
                "mission[0].grasp.object.mass: must be in [0, 100] kg");
  ExpectRefused("  - via: {position: [0, 0, 1], tolerance: 0}\n", "mission[0].via.tolerance: must be in [0.001, 1] m");
  ExpectRefused("  - reach: {}\n", "mission[0].reach: needs a terminal state");
  ExpectRefused("  []\n", "mission: expected a non-empty list of steps");

  auto both = ParseTaskText(kHead + "goal: {position: [0, 1, 1.2], yaw: 0, joints: [0.2]}\nmission:\n" + kReachDown,
                            "task.yaml", "/base", TaskSources{});
  ASSERT_FALSE(both.ok());
  EXPECT_NE(both.status().message().find("task.yaml: mission: a task has goal or mission, not both"), std::string::npos);
  auto neither = ParseTaskText(kHead, "task.yaml", "/base", TaskSources{});
  ASSERT_FALSE(neither.ok());
  EXPECT_NE(neither.status().message().find("task.yaml: goal: missing"), std::string::npos) << neither.status().message();
}

// A longer mission's moving target (docs/moving_targets.md, "In a mission"):
// one, reached with nothing held, then grasped (or the mission's end), and
// after the grasp a move, a reach or a via; the object on it inside its box.
TEST(MissionTest, AMovingReachIsReadAndItsLimitsAreOneLineEach) {
  const std::string moving_reach =
      "  - reach:\n"
      "      tool:\n"
      "        position: [1, 0, 0.5]\n"
      "        orientation: [1, 0, 0, 0]\n"
      "        insertion: {direction: [0, 0, -1], length: 0.1}\n"
      "        motion: {velocity: [0, 0.1, 0], moving_points: {min: [0.8, -0.2, 0], max: [1.2, 0.2, 0.6]}}\n";
  const std::string lift = "  - move: {length: 0.15}\n";
  auto task = Parse(moving_reach + kGraspCup + lift + "  - hold: {duration: 1}\n");
  ASSERT_TRUE(task.ok()) << task.status().message();
  ASSERT_NE(MovingToolGoal(*task), nullptr);
  EXPECT_EQ(MovingToolGoal(*task), &*task->mission[0].reach_tool);
  EXPECT_FALSE(task->tool.has_value());
  // As the last step, or after a still part of the mission.
  EXPECT_TRUE(Parse("  - hold: {duration: 1}\n" + moving_reach).ok());
  EXPECT_TRUE(Parse(moving_reach + kGraspCup + "  - reach: {position: [0, 0, 1], yaw: 0, joints: [0.1]}\n").ok());

  ExpectRefused(moving_reach + kGraspCup + lift + "  - release: {}\n" + moving_reach,
                "mission[4].reach.tool.motion: a mission has one moving target at most; mission[0] (reach) moves");
  ExpectRefused(moving_reach + "  - hold: {duration: 1}\n",
                "mission[0].reach.tool.motion: a moving reach is followed by a grasp, or ends the mission");
  ExpectRefused(moving_reach + kGraspCup + "  - hold: {duration: 1}\n",
                "mission[2]: after the grasp of a moving target the vehicle moves with it");
  ExpectRefused(moving_reach + kGraspCup, "mission[1]: after the grasp of a moving target the vehicle moves with it");
  ExpectRefused(kReachDown + kGraspCup + lift + moving_reach,
                "mission[3].reach.tool.motion: a moving reach while an object is held");
  // The box above the cup's centre.
  std::string above = moving_reach;
  above.replace(above.find("min: [0.8, -0.2, 0]"), 19, "min: [0.8, -0.2, 0.5]");
  ExpectRefused(above + kGraspCup + lift,
                "mission[1].grasp.object.pose: the object of a moving target moves with it");
}

}  // namespace
}  // namespace quadhand::planner
