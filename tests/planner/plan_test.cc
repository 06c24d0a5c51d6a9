// The planning pipeline (planner.h) on the default window-and-cup task with
// the coarse link SDFs: the initial guess it optimises from.
#include "quadhand/planner/planner.h"

#include <gtest/gtest.h>

#include <cmath>

#include "quadhand/robot/kinematics.h"
#include "quadhand/solvers/lbfgs_solver.h"
#include "support/window_cup_scene.h"

namespace quadhand::planner {
namespace {

using testing::WindowCup;

// Plan() with no iterations: the decoded trajectory is the initial guess.
PlanResult InitialGuess(PlannerOptions options) {
  options.solver.max_iterations = 0;
  options.max_attempts = 1;
  options.alternative_guesses = 0;
  solvers::LbfgsSolver solver;
  Task task = WindowCup().task;
  task.start.yaw = -2.0;  // far from the goal yaw (pi), the other way round
  auto result = Plan(WindowCup().Scene(), task, options, solver);
  EXPECT_TRUE(result.ok()) << result.status().message();
  EXPECT_TRUE(result->trajectory.has_value());
  return *result;
}

// Times of the piece boundaries (the waypoints) of the initial guess.
std::vector<double> WaypointTimes(const WholeBodyTrajectory& trajectory) {
  std::vector<double> times;
  double t = 0.0;
  for (int i = 0; i + 1 < trajectory.num_pieces(); ++i) {
    t += trajectory.position().durations()[i];
    times.push_back(t);
  }
  return times;
}

// When the stowing (and with it the settled yaw) is complete: `lead` metres
// before the end of the first leg of the shortcut path, in the time of the
// guess without the insertion piece.
double SettleTime(const PlanResult& plan, double lead) {
  const std::vector<Vec3>& legs = plan.path.shortcut;
  double length = 0.0;
  for (size_t i = 1; i < legs.size(); ++i) length += (legs[i] - legs[i - 1]).norm();
  const double first = (legs[1] - legs[0]).norm();
  const WholeBodyTrajectory& trajectory = *plan.trajectory;
  const double transit = trajectory.duration() - trajectory.position().durations()[trajectory.num_pieces() - 1];
  return transit * std::max(0.5 * first, first - lead) / length;
}

TEST(PlanTest, InitialYawSettlesWithTheStowedArmBeforeTheFirstCorner) {
  PlannerOptions options = DefaultPlannerOptions();
  ASSERT_TRUE(options.stow_joints_in_transit && options.settle_yaw_in_transit);
  const PlanResult plan = InitialGuess(options);
  ASSERT_GE(plan.path.shortcut.size(), 4u);  // the stowing needs three legs
  const double goal_yaw = plan.terminal.yaw;
  const double settle = SettleTime(plan, options.stow_lead);
  int settled = 0, turning = 0;
  for (double t : WaypointTimes(*plan.trajectory)) {
    const WholeBodySample s = plan.trajectory->Sample(t);
    if (t >= settle - 1e-9 && t < plan.trajectory->duration() - plan.trajectory->position().durations().tail(1)[0]) {
      EXPECT_NEAR(s.yaw, goal_yaw, 1e-9) << "waypoint at t = " << t;
      ++settled;
    } else if (t < settle) {
      EXPECT_GT(std::abs(s.yaw - goal_yaw), 1e-3) << "waypoint at t = " << t;
      ++turning;
    }
  }
  EXPECT_GE(settled, 3);
  EXPECT_GE(turning, 1);
}

TEST(PlanTest, WithoutSettlingTheInitialYawTurnsLinearlyInTime) {
  PlannerOptions options = DefaultPlannerOptions();
  options.settle_yaw_in_transit = false;
  const PlanResult plan = InitialGuess(options);
  const WholeBodyTrajectory& trajectory = *plan.trajectory;
  const double transit = trajectory.duration() - trajectory.position().durations().tail(1)[0];
  const double start_yaw = -2.0, goal_yaw = plan.terminal.yaw;
  for (double t : WaypointTimes(trajectory)) {
    const double f = std::min(1.0, t / transit);
    EXPECT_NEAR(trajectory.Sample(t).yaw, (1.0 - f) * start_yaw + f * goal_yaw, 1e-9) << "waypoint at t = " << t;
  }
}

// A terminal where the start stands, at another heading (a turn in place,
// what a vehicle at a dead end does to look round): the front end's path is
// one point, the guess takes long enough to make the turn within the yaw
// rate limit, and the plan passes its post-check with the base held where it
// stands.
TEST(PlanTest, ATurnInPlaceIsPlannedAndCertified) {
  Task task = WindowCup().task;
  task.tool.reset();
  task.mission.clear();
  task.vias.clear();
  task.terminal = task.start;
  task.terminal->yaw = task.start.yaw + 2.0;
  const double least = 2.0 / task.limits.yaw_rate_max;

  PlannerOptions guess_only = DefaultPlannerOptions();
  guess_only.solver.max_iterations = 0;
  guess_only.max_attempts = 1;
  guess_only.alternative_guesses = 0;
  solvers::LbfgsSolver solver;
  auto guess = Plan(WindowCup().Scene(), task, guess_only, solver);
  ASSERT_TRUE(guess.ok()) << guess.status().message();
  ASSERT_TRUE(guess->trajectory.has_value());
  EXPECT_GE(guess->trajectory->duration(), least);

  auto result = Plan(WindowCup().Scene(), task, DefaultPlannerOptions(), solver);
  ASSERT_TRUE(result.ok()) << result.status().message();
  ASSERT_TRUE(result->success) << result->message;
  const WholeBodyTrajectory& trajectory = *result->trajectory;
  EXPECT_GE(trajectory.duration(), least);
  double farthest = 0.0;
  for (double t = 0.0; t <= trajectory.duration(); t += 0.01) {
    farthest = std::max(farthest, (trajectory.Sample(t).position - task.start.position).norm());
  }
  EXPECT_LT(farthest, 0.1);
  EXPECT_NEAR(trajectory.Sample(trajectory.duration()).yaw, task.start.yaw + 2.0, 0.01);
}

// The default stopping rule (relative decrease over a window) ends the first
// solve before the iteration cap on the default task, and the plan passes.
TEST(PlanTest, DefaultSolveStopsOnTheRelativeDecreaseBeforeTheCap) {
  const PlannerOptions options = DefaultPlannerOptions();
  solvers::LbfgsSolver solver;
  auto result = Plan(WindowCup().Scene(), WindowCup().task, options, solver);
  ASSERT_TRUE(result.ok()) << result.status().message();
  EXPECT_TRUE(result->success) << result->message;
  ASSERT_FALSE(result->attempts.empty());
  EXPECT_EQ(result->attempts[0].solver_status, opt::SolveStatus::kConverged);
  EXPECT_LT(result->attempts[0].iterations, options.solver.max_iterations);
}

// With 4 samples per piece the first solve lets a link slip past a window
// edge between samples; raising the collision weight alone cannot see that,
// the re-solve with twice the samples does.
TEST(PlanTest, ClearanceFailureResolvesWithMoreSamples) {
  PlannerOptions options = DefaultPlannerOptions();
  options.cost.samples_per_piece = 4;
  options.cost.insertion_samples = 4;
  options.max_attempts = 3;  // up to 16 samples per piece
  solvers::LbfgsSolver solver;
  auto doubled = Plan(WindowCup().Scene(), WindowCup().task, options, solver);
  ASSERT_TRUE(doubled.ok()) << doubled.status().message();
  ASSERT_GE(doubled->attempts.size(), 2u);
  EXPECT_EQ(doubled->attempts[0].post_check_failure.rfind("clearance", 0), 0u)
      << doubled->attempts[0].post_check_failure;
  EXPECT_TRUE(doubled->success) << doubled->message;

  options.resolve_sample_factor = 1;  // weights only
  options.alternative_guesses = 0;
  auto weights_only = Plan(WindowCup().Scene(), WindowCup().task, options, solver);
  ASSERT_TRUE(weights_only.ok());
  EXPECT_FALSE(weights_only->success);
  EXPECT_EQ(weights_only->message.rfind("clearance", 0), 0u) << weights_only->message;
}

// A path of more pieces than section_pieces is optimised in sections from
// the initial guess's state at each junction, joined and post-checked
// whole: the plan passes through those states, and the joined plan is the
// one the report judges. (The default task has ~13 pieces: cut in 8s.)
TEST(PlanTest, ALongPathIsSolvedInSectionsAndCheckedWhole) {
  PlannerOptions options = DefaultPlannerOptions();
  solvers::LbfgsSolver solver;
  auto whole = Plan(WindowCup().Scene(), WindowCup().task, options, solver);
  ASSERT_TRUE(whole.ok()) << whole.status().message();
  ASSERT_TRUE(whole->success) << whole->message;
  EXPECT_EQ(whole->sections, 0);
  const int pieces = whole->num_pieces;
  ASSERT_GT(pieces, 4 + 2);  // more than one section and its overlap

  options.section_pieces = 4;  // 4 kept of a solve over 6, ..., then the rest
  auto cut = Plan(WindowCup().Scene(), WindowCup().task, options, solver);
  ASSERT_TRUE(cut.ok()) << cut.status().message();
  ASSERT_TRUE(cut->success) << cut->message;
  EXPECT_GE(cut->sections, 2);
  EXPECT_EQ(cut->trajectory->num_pieces(), pieces);
  EXPECT_TRUE(cut->post_check.passed);
  EXPECT_TRUE(cut->post_check.certified);
  EXPECT_GE(static_cast<int>(cut->attempts.size()), cut->sections);  // each section's solves
  const WholeBodySample end = cut->trajectory->Sample(cut->trajectory->duration());
  EXPECT_LT((end.position - cut->terminal.position).norm(), 1e-6);
  // The junction after the first 4 pieces: as smooth as the solver's own
  // pieces (position to jerk, yaw and joints with their rates).
  const VecX& durations = cut->trajectory->position().durations();
  const double junction = durations.head(4).sum();
  const WholeBodySample before = cut->trajectory->Sample(junction - 1e-7), after = cut->trajectory->Sample(junction + 1e-7);
  EXPECT_LT((before.position - after.position).norm(), 1e-5);
  EXPECT_LT((before.velocity - after.velocity).norm(), 1e-4);
  EXPECT_LT((before.acceleration - after.acceleration).norm(), 1e-3);
  EXPECT_LT((before.joints - after.joints).norm(), 1e-5);
  // Off: one solve, as before.
  options.section_pieces = 0;
  auto off = Plan(WindowCup().Scene(), WindowCup().task, options, solver);
  ASSERT_TRUE(off.ok());
  EXPECT_EQ(off->sections, 0);
  std::string why;
  options.section_pieces = 1;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("section_pieces"), std::string::npos) << why;
}

// The still and the moving scene's collision terms share one weight, and a
// report may fail a check twice: each weight is raised once per re-solve,
// by the factor, and the samples are multiplied once.
TEST(PlanTest, AFailedCheckRaisesEachWeightOnce) {
  WholeBodyCostOptions cost;
  const double collision = cost.weight_collision, velocity = cost.weight_velocity;
  const int samples = cost.samples_per_piece;
  PostCheckReport report;
  CheckResult failed_clearance;
  failed_clearance.kind = CheckKind::kClearance;
  failed_clearance.passed = false;
  report.checks = {failed_clearance, failed_clearance};
  ASSERT_TRUE(RaiseWeightsOfFailedChecks(report, 5.0, 2, 1000, &cost));
  EXPECT_DOUBLE_EQ(cost.weight_collision, 5.0 * collision);
  EXPECT_DOUBLE_EQ(cost.weight_velocity, velocity);
  EXPECT_EQ(cost.samples_per_piece, 2 * samples);

  // A failed check that no term's weight answers: re-solving cannot help.
  WholeBodyCostOptions untouched;
  CheckResult failed_start;
  failed_start.kind = CheckKind::kStartState;
  failed_start.passed = false;
  report.checks = {failed_start};
  EXPECT_FALSE(RaiseWeightsOfFailedChecks(report, 5.0, 2, 1000, &untouched));
  EXPECT_DOUBLE_EQ(untouched.weight_collision, collision);
}

// A plan whose every solve fails its post-check tries the other initial
// guesses in their fixed order, each with the same solves, and keeps the
// times and attempts of all (here nothing can pass: no collision cost).
TEST(PlanTest, AFailedGuessTriesTheAlternativesInOrder) {
  PlannerOptions options = DefaultPlannerOptions();
  options.cost.weight_collision = 0.0;
  options.max_attempts = 1;
  solvers::LbfgsSolver solver;
  auto result = Plan(WindowCup().Scene(), WindowCup().task, options, solver);
  ASSERT_TRUE(result.ok()) << result.status().message();
  EXPECT_FALSE(result->success);
  EXPECT_EQ(result->status, PlanStatus::kPostCheckFailed) << result->message;
  EXPECT_EQ(result->alternatives_tried, 3);
  EXPECT_EQ(result->attempts.size(), 4u);
  EXPECT_EQ(result->initial_guess, "front_end");
  options.alternative_guesses = 1;
  auto one = Plan(WindowCup().Scene(), WindowCup().task, options, solver);
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->alternatives_tried, 1);
  EXPECT_EQ(one->attempts.size(), 2u);
  options.alternative_guesses = 4;
  EXPECT_FALSE(options.IsValid(nullptr));
}

// The weights-only re-solves of ClearanceFailureResolvesWithMoreSamples
// fail from the front end's guess; another guess passes.
TEST(PlanTest, AnAlternativeGuessPassesWhereTheFirstFails) {
  PlannerOptions options = DefaultPlannerOptions();
  options.cost.samples_per_piece = 4;
  options.cost.insertion_samples = 4;
  options.max_attempts = 3;
  options.resolve_sample_factor = 1;
  solvers::LbfgsSolver solver;
  auto result = Plan(WindowCup().Scene(), WindowCup().task, options, solver);
  ASSERT_TRUE(result.ok()) << result.status().message();
  EXPECT_TRUE(result->success) << result->message;
  EXPECT_NE(result->initial_guess, "front_end");
  EXPECT_GE(result->alternatives_tried, 1);
  EXPECT_GT(result->attempts.size(), 3u);
  EXPECT_TRUE(result->post_check.certified);
}

// The end effector is the link the task names: the default task with the
// tool pose and insertion given for `link3` (the parent of `tool`) instead,
// at link3's pose in the same terminal state, plans and puts link3 there.
TEST(PlanTest, TheInsertionMovesTheLinkTheTaskNames) {
  const robot::RobotModel& robot = WindowCup().robot();
  Task task = WindowCup().task;
  task.tool_link = "link3";
  task.tool_link_given = true;
  ASSERT_TRUE(ApplyRobot(robot, &task).ok());
  const int link3 = robot.LinkIndex("link3");
  const BoundaryState& terminal = *task.terminal;
  const Pose hover = MakePose(terminal.position, Eigen::AngleAxisd(terminal.yaw, Vec3::UnitZ()).toRotationMatrix());
  const Pose goal = robot::LinkPose(robot, hover, terminal.joints, link3);
  ASSERT_GT((goal.translation() - task.tool->position).norm(), 0.05);  // a different frame from `tool`
  task.tool->position = goal.translation();
  task.tool->orientation = Quat(goal.linear());
  solvers::LbfgsSolver solver;
  auto result = Plan(WindowCup().Scene(), task, PlannerOptions{}, solver);
  ASSERT_TRUE(result.ok()) << result.status().message();
  EXPECT_EQ(result->insertion.tool_link, link3);
  EXPECT_TRUE(result->success) << result->message;
  const WholeBodySample end = result->trajectory->Sample(result->trajectory->duration());
  const Pose reached = robot::LinkPose(robot, end.BasePose(), end.joints, link3);
  EXPECT_LT((reached.translation() - goal.translation()).norm(), 0.01);

  task.tool_link = "no_such_link";
  EXPECT_EQ(ApplyRobot(robot, &task).code(), core::StatusCode::kInvalidArgument);
}

TEST(PlanTest, RejectsANegativeStowLead) {
  PlannerOptions options = DefaultPlannerOptions();
  options.stow_lead = -0.1;
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("stow_lead"), std::string::npos);
}

}  // namespace
}  // namespace quadhand::planner
