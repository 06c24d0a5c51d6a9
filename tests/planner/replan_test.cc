// Warm-started replanning (planner/replan.h) on the default window-and-cup task.
#include "quadhand/planner/replan.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <limits>

#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/solvers/lbfgs_solver.h"
#include "support/window_cup_plan.h"

namespace quadhand::planner {
namespace {

using testing::WindowCup;

const PlanResult& DefaultPlan() { return testing::WindowCupPlan(); }

// The plan's state at t (a measured state with no error).
BoundaryState StateOnPlan(const WholeBodyTrajectory& trajectory, double t) { return trajectory.Sample(t).State(); }

// Exact clearance of the whole robot in `state` (as Replan measures its start).
double StartClearance(const BoundaryState& state) {
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(WindowCup().robot(),
                           MakePose(state.position, Eigen::AngleAxisd(state.yaw, Vec3::UnitZ()).toRotationMatrix()),
                           state.joints, &kinematics);
  return env::WholeBodyClearance(kinematics, *WindowCup().exact, 0.1, {});  // 10 cm: the margins of interest are 3 cm
}

// The same at the attitude the state's trajectory starts with (flatness of
// its acceleration and jerk), as the post-check sees its first sample.
double FlatStartClearance(const BoundaryState& state) {
  const traj::FlatState flat = traj::FlatForward(state.velocity, state.acceleration, state.jerk, state.yaw,
                                                 state.yaw_rate, DefaultPlannerOptions().cost.flatness);
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(WindowCup().robot(), MakePose(state.position, flat.rotation()), state.joints, &kinematics);
  return env::WholeBodyClearance(kinematics, *WindowCup().exact, 0.1, {});
}

// The gradient of `clearance` in the base position (central differences).
Vec3 ClearanceGradient(const BoundaryState& state, double (*clearance)(const BoundaryState&)) {
  Vec3 gradient;
  for (int k = 0; k < 3; ++k) {
    BoundaryState plus = state, minus = state;
    plus.position[k] += 1e-3;
    minus.position[k] -= 1e-3;
    gradient[k] = (clearance(plus) - clearance(minus)) / 2e-3;
  }
  return gradient;
}

// `state` moved (position only) towards the nearest obstacle until its exact
// clearance (by `clearance`) is `target` (bisection along the clearance's
// descent direction).
BoundaryState MovedToClearance(BoundaryState state, double target,
                               double (*clearance)(const BoundaryState&) = StartClearance) {
  const Vec3 towards = -ClearanceGradient(state, clearance).normalized();
  double lo = 0.0, hi = 0.2;  // metres along `towards`: clearance above / below target
  for (int i = 0; i < 40; ++i) {
    BoundaryState mid = state;
    mid.position += 0.5 * (lo + hi) * towards;
    (clearance(mid) > target ? lo : hi) = 0.5 * (lo + hi);
  }
  state.position += lo * towards;
  return state;
}

double InsertionStart(const PlanResult& plan) {
  const VecX& T = plan.trajectory->position().durations();
  return plan.trajectory->duration() - T[T.size() - 1];
}

// 0.3 s before the plan's closest approach to the scene before the
// insertion (next to a window edge): the plan is approaching it there.
double TimeApproachingTheClosestEdge(const PlanResult& plan) {
  double t_close = 0.0, closest = 1e9;
  for (double t = 0.2; t < InsertionStart(plan) - 1.0; t += 0.05) {
    const double d = StartClearance(StateOnPlan(*plan.trajectory, t));
    if (d < closest) closest = d;
    if (d == closest) t_close = t;
  }
  return std::max(0.2, t_close - 0.3);
}

TEST(RemainderGuessTest, KeepsTheRemainingPiecesAndTheirJunctions) {
  const WholeBodyTrajectory& trajectory = *DefaultPlan().trajectory;
  const VecX& T = trajectory.position().durations();
  ASSERT_GE(T.size(), 4);
  // Halfway through piece 1: pieces 1..N-1 remain, the first one halved.
  const double t_from = T[0] + 0.5 * T[1];
  MatX position, aux;
  VecX durations;
  int first = -1;
  ASSERT_TRUE(RemainderGuess(trajectory, t_from, 0.01, &position, &aux, &durations, &first).ok());
  EXPECT_EQ(first, 1);
  ASSERT_EQ(durations.size(), T.size() - 1);
  EXPECT_NEAR(durations[0], 0.5 * T[1], 1e-12);
  EXPECT_NEAR(durations.sum(), trajectory.duration() - t_from, 1e-9);
  ASSERT_EQ(position.cols(), durations.size() - 1);
  ASSERT_EQ(aux.rows(), 1 + WindowCup().robot().num_actuated());
  // Waypoint i is the plan's state at the end of the remaining piece i.
  double t = t_from;
  for (int i = 0; i + 1 < durations.size(); ++i) {
    t += durations[i];
    const WholeBodySample s = trajectory.Sample(t);
    EXPECT_LT((position.col(i) - s.position).norm(), 1e-9) << i;
    EXPECT_NEAR(aux(0, i), s.yaw, 1e-9);
    EXPECT_LT((aux.col(i).tail(aux.rows() - 1) - s.joints).norm(), 1e-9);
  }
}

TEST(RemainderGuessTest, MergesAShortFirstPieceIntoTheNextOnes) {
  const WholeBodyTrajectory& trajectory = *DefaultPlan().trajectory;
  const VecX& T = trajectory.position().durations();
  const double t_from = T[0] + T[1] - 0.05;  // 50 ms before the end of piece 1
  MatX position, aux;
  VecX durations;
  int first = -1;
  ASSERT_TRUE(RemainderGuess(trajectory, t_from, 0.15, &position, &aux, &durations, &first).ok());
  EXPECT_EQ(first, 1);
  ASSERT_EQ(durations.size(), T.size() - 2);  // piece 1's rest folded into piece 2
  EXPECT_NEAR(durations[0], 0.05 + T[2], 1e-9);
  EXPECT_NEAR(durations.sum(), trajectory.duration() - t_from, 1e-9);
  EXPECT_LT((position.col(0) - trajectory.Sample(T[0] + T[1] + T[2]).position).norm(), 1e-9);
  // Several short pieces are merged until the first is long enough.
  const double longer = 0.05 + T[2] + 0.5 * T[3];
  ASSERT_TRUE(RemainderGuess(trajectory, t_from, longer, &position, &aux, &durations, &first).ok());
  ASSERT_EQ(durations.size(), T.size() - 3);  // pieces 2 and 3 folded in
  EXPECT_NEAR(durations[0], 0.05 + T[2] + T[3], 1e-9);
  EXPECT_NEAR(durations.sum(), trajectory.duration() - t_from, 1e-9);
  // Outside the plan: an error, not a guess.
  EXPECT_FALSE(RemainderGuess(trajectory, trajectory.duration(), 0.15, &position, &aux, &durations, &first).ok());
  EXPECT_FALSE(RemainderGuess(trajectory, -0.1, 0.15, &position, &aux, &durations, &first).ok());
}

TEST(ReplanTest, FromAStateOnThePlanKeepsThePlan) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& old = *plan.trajectory;
  const double t_from = 0.3 * InsertionStart(plan);
  solvers::LbfgsSolver solver;
  auto result = Replan(WindowCup().Scene(), WindowCup().task, DefaultPlannerOptions(), DefaultReplanOptions(), solver,
                       plan, t_from, StateOnPlan(old, t_from));
  ASSERT_TRUE(result.ok()) << result.status().message();
  ASSERT_TRUE(result->success) << result->message;
  // Already near a minimum: the remainder barely changes.
  const WholeBodyTrajectory& fresh = *result->trajectory;
  EXPECT_NEAR(fresh.duration(), old.duration() - t_from, 0.1 * old.duration());
  double worst = 0.0;
  for (int k = 0; k <= 50; ++k) {
    const double f = k / 50.0;
    worst = std::max(worst, (fresh.Sample(f * fresh.duration()).position -
                             old.Sample(t_from + f * (old.duration() - t_from)).position).norm());
  }
  EXPECT_LT(worst, 0.15);
}

TEST(ReplanTest, FromAnOffsetStateStartsThereAndReachesTheGoal) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& old = *plan.trajectory;
  solvers::LbfgsSolver solver;
  int successes = 0;
  const Vec3 offsets[] = {Vec3(0.1, 0.0, 0.0), Vec3(0.0, -0.08, 0.05), Vec3(-0.05, 0.05, -0.1)};
  const double fractions[] = {0.2, 0.45, 0.7};
  for (int i = 0; i < 3; ++i) {
    const double t_from = fractions[i] * InsertionStart(plan);
    BoundaryState start = StateOnPlan(old, t_from);
    start.position += offsets[i];
    auto result = Replan(WindowCup().Scene(), WindowCup().task, DefaultPlannerOptions(), DefaultReplanOptions(),
                         solver, plan, t_from, start);
    ASSERT_TRUE(result.ok()) << result.status().message();
    if (result->status == PlanStatus::kStartInCollision) continue;  // the offset pushed a link into the scene
    ASSERT_TRUE(result->trajectory.has_value()) << result->message;
    if (!result->success) {
      ADD_FAILURE() << "t = " << t_from << ": " << result->message;
      continue;
    }
    ++successes;
    const WholeBodySample first = result->trajectory->Sample(0.0), last = result->trajectory->Sample(1e9);
    EXPECT_LT((first.position - start.position).norm(), 1e-6);
    EXPECT_LT((first.velocity - start.velocity).norm(), 1e-6);
    EXPECT_LT((last.position - plan.terminal.position).norm(), 0.01);
    EXPECT_TRUE(result->post_check.passed);
    // A start the offset pushed into the safety margin is judged by the
    // recovery rule (tested below); any other keeps the safety distance.
    if (!result->post_check.recovery) {
      EXPECT_GE(result->post_check.min_clearance_exact, WindowCup().task.safety_distance - 0.002);
    }
  }
  EXPECT_GE(successes, 2);
}

TEST(ReplanTest, RefusesInsideTheInsertionAndFromACollidingState) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& old = *plan.trajectory;
  solvers::LbfgsSolver solver;
  const double t_insertion = 0.5 * (InsertionStart(plan) + old.duration());
  auto inserting = Replan(WindowCup().Scene(), WindowCup().task, DefaultPlannerOptions(), DefaultReplanOptions(),
                          solver, plan, t_insertion, StateOnPlan(old, t_insertion));
  ASSERT_TRUE(inserting.ok());
  EXPECT_FALSE(inserting->success);
  EXPECT_EQ(inserting->status, PlanStatus::kInsertionInProgress);

  // The base moved onto a scene point.
  const double t_from = 0.5 * InsertionStart(plan);
  BoundaryState start = StateOnPlan(old, t_from);
  const Vec3 nearest = *std::min_element(WindowCup().points.begin(), WindowCup().points.end(),
                                         [&](const Vec3& a, const Vec3& b) {
                                           return (a - start.position).norm() < (b - start.position).norm();
                                         });
  start.position = nearest;
  auto colliding = Replan(WindowCup().Scene(), WindowCup().task, DefaultPlannerOptions(), DefaultReplanOptions(),
                          solver, plan, t_from, start);
  ASSERT_TRUE(colliding.ok());
  EXPECT_FALSE(colliding->success);
  EXPECT_EQ(colliding->status, PlanStatus::kStartInCollision) << colliding->message;
  EXPECT_LT(StartClearance(start), -DefaultReplanOptions().max_start_penetration);
  EXPECT_FALSE(colliding->trajectory.has_value());

  // A braking vehicle is tilted: the start is judged at the attitude its
  // trajectory starts with, as the post-check judges the first sample. Here
  // the tilt takes it past the recovery limit while a level body would not be.
  const double limit = DefaultReplanOptions().max_start_penetration;
  bool tried = false;
  for (const Vec3& acceleration : {Vec3(4, 0, 0), Vec3(-4, 0, 0), Vec3(0, 4, 0), Vec3(0, -4, 0)}) {
    BoundaryState tilted = StateOnPlan(old, t_from);
    tilted.acceleration = acceleration;
    tilted.jerk.setZero();
    tilted = MovedToClearance(tilted, -limit - 0.001, FlatStartClearance);
    if (!(StartClearance(tilted) > -limit)) continue;  // the tilt does not matter in this direction
    tried = true;
    ASSERT_NEAR(FlatStartClearance(tilted), -limit - 0.001, 1e-4);
    auto refused = Replan(WindowCup().Scene(), WindowCup().task, DefaultPlannerOptions(), DefaultReplanOptions(),
                          solver, plan, t_from, tilted);
    ASSERT_TRUE(refused.ok());
    EXPECT_EQ(refused->status, PlanStatus::kStartInCollision) << acceleration.transpose() << ": " << refused->message;
  }
  EXPECT_TRUE(tried) << "no acceleration tilted the body further into the scene";

  // Inconsistent input is an error.
  BoundaryState wrong = StateOnPlan(old, t_from);
  wrong.joints = VecX::Zero(1);
  EXPECT_FALSE(Replan(WindowCup().Scene(), WindowCup().task, DefaultPlannerOptions(), DefaultReplanOptions(), solver,
                      plan, t_from, wrong).ok());
  PlanResult empty;
  EXPECT_FALSE(Replan(WindowCup().Scene(), WindowCup().task, DefaultPlannerOptions(), DefaultReplanOptions(), solver,
                      empty, t_from, StateOnPlan(old, t_from)).ok());
}

// A gust pushed the vehicle 2 cm into the 3 cm margin of a window edge: the
// replan is attempted, moves away without getting closer than it started,
// keeps the safety distance after the recovery time, and reaches the goal.
// The same trajectory fails Plan()'s ordinary post-check (no recovery).
TEST(ReplanTest, FromAStartInsideTheSafetyMarginRecoversAndReachesTheGoal) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& old = *plan.trajectory;
  const Task& task = WindowCup().task;
  const double t_from = TimeApproachingTheClosestEdge(plan);
  const BoundaryState start = MovedToClearance(StateOnPlan(old, t_from), 0.01);
  const double start_clearance = StartClearance(start);
  ASSERT_NEAR(start_clearance, 0.01, 1e-3);
  solvers::LbfgsSolver solver;
  const ReplanOptions replan = DefaultReplanOptions();
  auto result = Replan(WindowCup().Scene(), task, DefaultPlannerOptions(), replan, solver, plan, t_from, start);
  ASSERT_TRUE(result.ok()) << result.status().message();
  ASSERT_TRUE(result->success) << PlanStatusName(result->status) << ": " << result->message;
  EXPECT_TRUE(result->post_check.recovery);
  // (The trajectory's first sample tilts the body with its acceleration.)
  EXPECT_NEAR(result->post_check.start_clearance_exact, start_clearance, 1e-3);
  const WholeBodyTrajectory& fresh = *result->trajectory;
  EXPECT_LT((fresh.Sample(0.0).position - start.position).norm(), 1e-6);
  EXPECT_LT((fresh.Sample(fresh.duration()).position - plan.terminal.position).norm(), 0.01);
  // The rule, checked independently of the post-check on a finer time grid.
  const double tolerance = DefaultPlannerOptions().post_check.clearance_tolerance;
  for (double t = 0.0; t <= fresh.duration(); t += 0.005) {
    const double d = StartClearance(StateOnPlan(fresh, t));
    if (t < replan.recovery_time) {
      ASSERT_GE(d, start_clearance - tolerance - 5e-4) << "t = " << t;
    } else {
      ASSERT_GE(d, task.safety_distance - tolerance - 5e-4) << "t = " << t;
    }
  }
  // Plan()'s check (no recovery stretch) refuses it: nothing was weakened there.
  const PostCheckReport plain = PostCheck(fresh, WindowCup().robot(), task, plan.terminal, plan.insertion,
                                          *WindowCup().model, *WindowCup().exact, nullptr, DefaultPlannerOptions().post_check);
  EXPECT_FALSE(plain.passed);
  EXPECT_FALSE(plain.recovery);
  // Nor does a recovery stretch too short to get out of the margin (2 cm in
  // 50 ms would take 16 m/s^2 from rest, four times a_max).
  PostCheckOptions short_stretch = DefaultPlannerOptions().post_check;
  short_stretch.recovery_time = 0.05;
  const PostCheckReport hurried = PostCheck(fresh, WindowCup().robot(), task, plan.terminal, plan.insertion,
                                            *WindowCup().model, *WindowCup().exact, nullptr, short_stretch);
  EXPECT_TRUE(hurried.recovery);
  EXPECT_FALSE(hurried.passed);
  EXPECT_NE(hurried.FirstFailure().find("clearance: recovery"), std::string::npos) << hurried.FirstFailure();
}

// A start 2 cm from a window edge (1 cm inside the margin) flying at it:
// the recovery rule allows the braking that speed needs, v^2 / (2 a_max),
// but never a bound below -max_start_penetration (less the tolerance)
// however fast the start moves: deeper is contact. Checked independently of
// the post-check on a 5 ms grid wherever a replan claims success.
TEST(ReplanTest, TheRecoveryRuleNeverAcceptsContactHoweverFastTheStart) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& old = *plan.trajectory;
  const Task& task = WindowCup().task;
  const double t_from = TimeApproachingTheClosestEdge(plan);
  const ReplanOptions replan = DefaultReplanOptions();
  const double a_max = task.limits.a_max;
  const double tolerance = DefaultPlannerOptions().post_check.clearance_tolerance;
  solvers::LbfgsSolver solver;
  int successes = 0;
  for (double speed : {0.0, 0.3, 1.5}) {
    BoundaryState start = StateOnPlan(old, t_from);
    start.velocity.setZero();
    start.acceleration.setZero();
    start.jerk.setZero();
    start = MovedToClearance(start, 0.02, FlatStartClearance);
    // Towards the obstacle: down the clearance's gradient.
    start.velocity = -speed * ClearanceGradient(start, FlatStartClearance).normalized();
    auto result = Replan(WindowCup().Scene(), task, DefaultPlannerOptions(), replan, solver, plan, t_from, start);
    ASSERT_TRUE(result.ok()) << result.status().message();
    ASSERT_TRUE(result->trajectory.has_value()) << speed << ": " << result->message;
    const PostCheckReport& report = result->post_check;
    const double braking = speed * speed / (2.0 * a_max);  // the clearance closes at about `speed`
    EXPECT_TRUE(report.recovery) << speed;
    EXPECT_NEAR(report.recovery_braking_allowance, braking, 0.5 * braking + 1e-4) << speed;
    if (!result->success) continue;
    ++successes;
    const WholeBodyTrajectory& fresh = *result->trajectory;
    const double floor =
        std::max(-replan.max_start_penetration, report.start_clearance_exact - report.recovery_braking_allowance);
    for (double t = 0.0; t <= fresh.duration(); t += 0.005) {
      const double d = FlatStartClearance(StateOnPlan(fresh, t));
      if (t < replan.recovery_time) {
        ASSERT_GE(d, floor - tolerance - 5e-4) << "speed " << speed << ", t = " << t;
      } else {
        ASSERT_GE(d, task.safety_distance - tolerance - 5e-4) << "speed " << speed << ", t = " << t;
      }
    }
  }
  EXPECT_GE(successes, 1) << "no start was certified by the recovery rule";
}

// The post-check's samples are measured on several workers and reduced in
// time order: the report is the same to the last bit for any count.
TEST(ReplanTest, ThePostCheckVerdictDoesNotDependOnItsThreads) {
  const PlanResult& plan = DefaultPlan();
  PostCheckOptions options = DefaultPlannerOptions().post_check;
  auto check = [&](int threads) {
    options.threads = threads;
    return PostCheck(*plan.trajectory, WindowCup().robot(), WindowCup().task, plan.terminal, plan.insertion,
                     *WindowCup().model, *WindowCup().exact, nullptr, options);
  };
  const PostCheckReport one = check(1);
  ASSERT_TRUE(one.passed) << one.FirstFailure();
  for (int threads : {2, 3, 7}) {
    const PostCheckReport many = check(threads);
    EXPECT_EQ(many.min_clearance_exact, one.min_clearance_exact) << threads;
    EXPECT_EQ(many.min_clearance_model, one.min_clearance_model) << threads;
    EXPECT_EQ(many.closest_link, one.closest_link) << threads;
    ASSERT_EQ(many.checks.size(), one.checks.size());
    for (size_t i = 0; i < one.checks.size(); ++i) {
      EXPECT_EQ(many.checks[i].value, one.checks[i].value) << one.checks[i].name << ", " << threads;
      EXPECT_EQ(many.checks[i].time, one.checks[i].time) << one.checks[i].name << ", " << threads;
      EXPECT_EQ(many.checks[i].passed, one.checks[i].passed) << one.checks[i].name << ", " << threads;
    }
  }
  options.threads = -1;
  EXPECT_FALSE(options.IsValid(nullptr));
  options.threads = 0;
  EXPECT_TRUE(options.IsValid(nullptr));
  for (double floor : {0.001, std::numeric_limits<double>::quiet_NaN(), -std::numeric_limits<double>::infinity()}) {
    options.recovery_min_clearance = floor;
    EXPECT_FALSE(options.IsValid(nullptr)) << floor;
  }
}

// A trajectory that would need more than a million samples is a failed
// check, never hours of sampling (or an overflowing count).
TEST(ReplanTest, APostCheckThatWouldNeverEndFailsInstead) {
  const PlanResult& plan = DefaultPlan();
  PostCheckOptions options = DefaultPlannerOptions().post_check;
  options.dt = 1e-9;  // IsValid refuses it; PostCheck must not trust that
  EXPECT_FALSE(options.IsValid(nullptr));
  const PostCheckReport report = PostCheck(*plan.trajectory, WindowCup().robot(), WindowCup().task, plan.terminal,
                                           plan.insertion, *WindowCup().model, *WindowCup().exact, nullptr, options);
  EXPECT_FALSE(report.passed);
  ASSERT_EQ(report.checks.size(), 1u);
  EXPECT_EQ(report.checks[0].kind, CheckKind::kSampling);
  EXPECT_NE(report.FirstFailure().find("samples"), std::string::npos) << report.FirstFailure();
}

// The recovery rule changes nothing for a start outside the margin.
TEST(ReplanTest, TheRecoveryRuleKeepsTheVerdictOfAStartOutsideTheMargin) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& old = *plan.trajectory;
  PostCheckOptions options = DefaultPlannerOptions().post_check;
  options.recovery_time = 1.0;
  Task task = WindowCup().task;
  task.start = StateOnPlan(old, 0.0);
  const PostCheckReport report =
      PostCheck(old, WindowCup().robot(), task, plan.terminal, plan.insertion, *WindowCup().model, *WindowCup().exact, nullptr,
                options);
  EXPECT_TRUE(report.passed) << report.FirstFailure();
  EXPECT_FALSE(report.recovery);
  EXPECT_EQ(report.FirstFailure(), "");
  EXPECT_EQ(report.min_clearance_exact, plan.post_check.min_clearance_exact);
}


// The least exact clearance of `trajectory` over samples every `step` s.
double BruteForceClearance(const WholeBodyTrajectory& trajectory, double step) {
  const int n = static_cast<int>(std::ceil(trajectory.duration() / step));
  robot::KinematicsState kinematics;
  double least = 1e9;
  for (int i = 0; i <= n; ++i) {
    const WholeBodySample s = trajectory.Sample(std::min(trajectory.duration(), i * trajectory.duration() / n));
    robot::ComputeKinematics(WindowCup().robot(), s.BasePose(), s.joints, &kinematics);
    least = std::min(least, env::WholeBodyClearance(kinematics, *WindowCup().exact, 0.2, {}));
  }
  return least;
}

// A replan from an offset state early in the plan solves only the next
// `horizon` seconds and keeps the rest of the plan as it is: the kept part is
// the plan's own, the seam is continuous up to the jerk (and the joint
// rates), and the report's certificate - the new part's and the kept part's
// - holds at every millisecond of the joined trajectory.
TEST(ReplanTest, RejoinsThePlanAfterTheHorizonAndKeepsItsCertificate) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& old = *plan.trajectory;
  const Task& task = WindowCup().task;
  solvers::LbfgsSolver solver;
  const double t_from = 0.15 * InsertionStart(plan);
  BoundaryState start = StateOnPlan(old, t_from);
  start.position += Vec3(0.06, -0.04, 0.03);
  const ReplanOptions replan = DefaultReplanOptions();
  ASSERT_GT(replan.horizon, 0.0);
  auto result = Replan(WindowCup().Scene(), task, DefaultPlannerOptions(), replan, solver, plan, t_from, start);
  ASSERT_TRUE(result.ok()) << result.status().message();
  ASSERT_TRUE(result->success) << result->message;
  ASSERT_GT(result->rejoined_at, 0.0) << "not rejoined";
  const WholeBodyTrajectory& fresh = *result->trajectory;
  EXPECT_LT(result->rejoined_at, fresh.duration());
  EXPECT_LT(fresh.num_pieces(), old.num_pieces() + 1);

  // The kept part is the plan's own.
  const double kept = fresh.duration() - result->rejoined_at;
  const double old_join = old.duration() - kept;
  EXPECT_GE(old_join, t_from + 0.5 * replan.horizon);
  for (int k = 0; k <= 40; ++k) {
    const double tau = kept * k / 40.0;
    const WholeBodySample a = fresh.Sample(result->rejoined_at + tau), b = old.Sample(old_join + tau);
    EXPECT_LT((a.position - b.position).norm(), 1e-9) << tau;
    EXPECT_LT((a.joints - b.joints).cwiseAbs().maxCoeff(), 1e-9) << tau;
  }
  // The seam.
  const WholeBodySample before = fresh.Sample(result->rejoined_at - 1e-7), after = fresh.Sample(result->rejoined_at + 1e-7);
  EXPECT_LT((before.position - after.position).norm(), 1e-5);
  EXPECT_LT((before.velocity - after.velocity).norm(), 1e-4);
  EXPECT_LT((before.acceleration - after.acceleration).norm(), 1e-3);
  EXPECT_LT((before.jerk - after.jerk).norm(), 1e-2);
  EXPECT_LT(std::abs(before.yaw_rate - after.yaw_rate), 1e-4);
  EXPECT_LT((before.joint_rates - after.joint_rates).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_LT((before.body_rate - after.body_rate).norm(), 1e-2);

  // The joined report: the stretches tile [0, duration], and the certified
  // clearance holds at every millisecond.
  const PostCheckReport& report = result->post_check;
  EXPECT_TRUE(report.certified) << report.FirstFailure();
  ASSERT_FALSE(report.certified_intervals.empty());
  EXPECT_EQ(report.certified_intervals.front().t0, 0.0);
  EXPECT_NEAR(report.certified_intervals.back().t1, fresh.duration(), 1e-9);
  const double truth = BruteForceClearance(fresh, 0.001);
  EXPECT_LE(report.certified_clearance, truth);
  EXPECT_GE(truth, task.safety_distance - DefaultPlannerOptions().post_check.clearance_tolerance);
  EXPECT_LE(report.min_clearance_exact, plan.post_check.min_clearance_exact + 1e-12);  // the grasp is in the kept part
  bool end_checked = false;
  for (const CheckResult& check : report.checks) {
    if (check.kind == CheckKind::kEndState) end_checked = check.passed && std::abs(check.time - fresh.duration()) < 1e-6;
  }
  EXPECT_TRUE(end_checked) << "the kept end-state check, moved to the new clock";
  const WholeBodySample last = fresh.Sample(1e9);
  EXPECT_LT((last.position - plan.terminal.position).norm(), 0.01);

  // A replan of the joined plan rejoins it in turn.
  const double t_next = 0.5 * result->rejoined_at;
  BoundaryState next = StateOnPlan(fresh, t_next);
  next.position += Vec3(-0.03, 0.03, 0.0);
  auto again = Replan(WindowCup().Scene(), task, DefaultPlannerOptions(), replan, solver, *result, t_next, next);
  ASSERT_TRUE(again.ok()) << again.status().message();
  ASSERT_TRUE(again->success) << again->message;
  EXPECT_GT(again->rejoined_at, 0.0);
  EXPECT_LE(again->post_check.certified_clearance, BruteForceClearance(*again->trajectory, 0.002));
}

// Less than the horizon before the insertion there is no junction a full
// horizon ahead: the replan rejoins at the last junction, the insertion's
// start, and keeps the insertion piece with its certificate and its
// insertion check (a replan of the whole remainder re-solved and re-checked
// the insertion at the cup, the costliest stretch to check).
TEST(ReplanTest, RejoinsAtTheLastJunctionWhenNoneIsAHorizonAhead) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& old = *plan.trajectory;
  const Task& task = WindowCup().task;
  ASSERT_TRUE(plan.insertion.enabled);
  solvers::LbfgsSolver solver;
  const ReplanOptions replan = DefaultReplanOptions();
  const double t_from = InsertionStart(plan) - 0.5 * replan.horizon;
  // 1 cm off: 4 cm off, the single new piece meets the junction's state only
  // by a detour, which is refused (RefusesARejoinThatDetours...).
  BoundaryState start = StateOnPlan(old, t_from);
  start.position += Vec3(0.008, 0.005, -0.004);
  auto result = Replan(WindowCup().Scene(), task, DefaultPlannerOptions(), replan, solver, plan, t_from, start);
  ASSERT_TRUE(result.ok()) << result.status().message();
  ASSERT_TRUE(result->success) << result->message;
  ASSERT_GT(result->rejoined_at, 0.0) << "not rejoined";
  const WholeBodyTrajectory& fresh = *result->trajectory;
  EXPECT_LT(fresh.duration(), old.duration() - t_from + 0.1) << "no detour";
  const double insertion = old.position().durations()[old.num_pieces() - 1];
  EXPECT_NEAR(fresh.duration() - result->rejoined_at, insertion, 1e-9) << "the kept part is the insertion piece";
  for (int k = 0; k <= 20; ++k) {
    const double tau = insertion * k / 20.0;
    const WholeBodySample a = fresh.Sample(result->rejoined_at + tau), b = old.Sample(InsertionStart(plan) + tau);
    EXPECT_LT((a.position - b.position).norm(), 1e-9) << tau;
    EXPECT_LT((a.joints - b.joints).cwiseAbs().maxCoeff(), 1e-9) << tau;
  }
  const PostCheckReport& report = result->post_check;
  EXPECT_TRUE(report.certified) << report.FirstFailure();
  bool insertion_checked = false;
  for (const CheckResult& check : report.checks) {
    if (check.kind == CheckKind::kInsertion) insertion_checked = check.passed;
  }
  EXPECT_TRUE(insertion_checked) << "the kept insertion check";
  const double truth = BruteForceClearance(fresh, 0.001);
  EXPECT_LE(report.certified_clearance, truth);
  EXPECT_GE(truth, task.safety_distance - DefaultPlannerOptions().post_check.clearance_tolerance);
}

// The kept part must carry the full safety distance in the current plan's
// certificate; where it does not (here: a stretch marked below it), or with
// the horizon off, the whole remainder is replanned and checked.
TEST(ReplanTest, ReplansTheWholeRemainderWhereTheKeptPartIsNotCertified) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& old = *plan.trajectory;
  solvers::LbfgsSolver solver;
  const double t_from = 0.15 * InsertionStart(plan);
  BoundaryState start = StateOnPlan(old, t_from);
  start.position += Vec3(0.06, -0.04, 0.03);
  PlanResult weak = plan;
  ASSERT_FALSE(weak.post_check.certified_intervals.empty());
  weak.post_check.certified_intervals.back().clearance_lower = 0.0;
  auto result = Replan(WindowCup().Scene(), WindowCup().task, DefaultPlannerOptions(), DefaultReplanOptions(), solver,
                       weak, t_from, start);
  ASSERT_TRUE(result.ok()) << result.status().message();
  EXPECT_TRUE(result->success) << result->message;
  EXPECT_LT(result->rejoined_at, 0.0);

  ReplanOptions no_horizon = DefaultReplanOptions();
  no_horizon.horizon = 0.0;
  auto whole = Replan(WindowCup().Scene(), WindowCup().task, DefaultPlannerOptions(), no_horizon, solver, plan, t_from,
                      start);
  ASSERT_TRUE(whole.ok()) << whole.status().message();
  EXPECT_TRUE(whole->success) << whole->message;
  EXPECT_LT(whole->rejoined_at, 0.0);
  EXPECT_EQ(whole->trajectory->duration() > 0.0, true);
}

// A replan of the default plan with `replan`'s options, from `start` at
// t_from on the plan's clock.
core::Result<PlanResult> ReplanDefault(const ReplanOptions& replan, double t_from, const BoundaryState& start) {
  solvers::LbfgsSolver solver;
  return Replan(WindowCup().Scene(), WindowCup().task, DefaultPlannerOptions(), replan, solver, DefaultPlan(), t_from,
                start);
}

// The default options without the detour rule: any certified rejoin is kept.
ReplanOptions WithoutTheDetourRule() {
  ReplanOptions replan = DefaultReplanOptions();
  replan.max_rejoin_stretch = 1e6;
  return replan;
}

// Certified, and the clearance kept at every 2 ms.
void ExpectCertifiedAndClear(const PlanResult& result) {
  EXPECT_TRUE(result.post_check.certified) << result.post_check.FirstFailure();
  EXPECT_GE(BruteForceClearance(*result.trajectory, 0.002),
            WindowCup().task.safety_distance - DefaultPlannerOptions().post_check.clearance_tolerance);
}

// A vehicle ahead of its plan (the reference lags it) less than a horizon
// before the insertion: the only rejoin junction is the insertion's start,
// which it nearly has reached. Meeting that junction's state from there is a
// detour: on past it, turn and come back through the window, certified but
// three times as long as the plan left. It is refused, and the whole
// remainder is replanned instead.
TEST(ReplanTest, RefusesARejoinThatDetoursAndReplansTheWholeRemainder) {
  const PlanResult& plan = DefaultPlan();
  const double t_from = InsertionStart(plan) - 0.4;
  const BoundaryState start = StateOnPlan(*plan.trajectory, t_from + 0.2);
  const double remaining = plan.trajectory->duration() - t_from;

  // Without the rule, the rejoin is the detour this test is about.
  auto detour = ReplanDefault(WithoutTheDetourRule(), t_from, start);
  ASSERT_TRUE(detour.ok()) << detour.status().message();
  ASSERT_TRUE(detour->success) << detour->message;
  ASSERT_GT(detour->rejoined_at, 0.0);
  ASSERT_GT(detour->trajectory->duration(), 2.0 * remaining) << "the scenario no longer detours";

  auto result = ReplanDefault(DefaultReplanOptions(), t_from, start);
  ASSERT_TRUE(result.ok()) << result.status().message();
  ASSERT_TRUE(result->success) << result->message;
  EXPECT_TRUE(result->rejoin_refused_as_detour);
  EXPECT_LT(result->rejoined_at, 0.0);
  EXPECT_LT(result->trajectory->duration(), remaining + 0.5);
  ExpectCertifiedAndClear(*result);
  EXPECT_LT((result->trajectory->Sample(1e9).position - plan.terminal.position).norm(), 0.01);

  ReplanOptions invalid = DefaultReplanOptions();
  invalid.max_rejoin_stretch = 0.9;
  EXPECT_FALSE(invalid.IsValid(nullptr));
}

// Earlier in the flight a detour's refusal is met one junction later: a
// vehicle 0.35 s ahead of its plan rejoins it past one more junction, the
// new part absorbing the offset in two pieces, and keeps the rest of the
// plan. With one try only, the whole remainder is replanned instead.
TEST(ReplanTest, AfterADetourRejoinsAtALaterJunction) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& old = *plan.trajectory;
  const double t_from = 0.3 * InsertionStart(plan);
  const BoundaryState start = StateOnPlan(old, t_from + 0.35);
  const double left = old.duration() - t_from;

  auto detour = ReplanDefault(WithoutTheDetourRule(), t_from, start);
  ASSERT_TRUE(detour.ok()) << detour.status().message();
  ASSERT_TRUE(detour->success) << detour->message;
  ASSERT_GT(detour->trajectory->duration(), left + 1.0) << "the first junction no longer gives a detour";

  auto result = ReplanDefault(DefaultReplanOptions(), t_from, start);
  ASSERT_TRUE(result.ok()) << result.status().message();
  ASSERT_TRUE(result->success) << result->message;
  EXPECT_TRUE(result->rejoin_refused_as_detour);
  ASSERT_GT(result->rejoined_at, 0.0) << "not rejoined";
  const WholeBodyTrajectory& fresh = *result->trajectory;
  EXPECT_LT(fresh.duration(), left + 0.3);
  const double kept = fresh.duration() - result->rejoined_at;
  for (int k = 0; k <= 20; ++k) {
    const double tau = kept * k / 20.0;
    EXPECT_LT((fresh.Sample(result->rejoined_at + tau).position - old.Sample(old.duration() - kept + tau).position).norm(),
              1e-9)
        << tau;
  }
  ExpectCertifiedAndClear(*result);

  ReplanOptions one_try = DefaultReplanOptions();
  one_try.max_rejoin_tries = 1;
  auto whole = ReplanDefault(one_try, t_from, start);
  ASSERT_TRUE(whole.ok()) << whole.status().message();
  EXPECT_TRUE(whole->rejoin_refused_as_detour);
  EXPECT_LT(whole->rejoined_at, 0.0);
}

// The default scene split as a moving target's task splits it: the cup and
// its pedestal (data/tasks/moving_cup.yaml's box) move, the rest stands.
struct MovingCupScene {
  std::vector<Vec3> still, cup;
  std::unique_ptr<env::MrcSdfModel> still_model;
  std::unique_ptr<env::ExactMeshModel> still_exact;
  std::unique_ptr<FrontEndMap> front_end;
  Task task;

  // The moving part for a motion, its points placed by `placement` (as
  // PlanningContext::MovingSceneFor makes it).
  struct Part {
    TargetMotion motion;
    std::unique_ptr<env::MrcSdfModel> model;
    std::unique_ptr<env::ExactMeshModel> exact;
    MovingScene scene;
  };
  std::unique_ptr<Part> MakePart(const TargetMotion& motion, const Pose& placement) const {
    const auto& fx = quadhand::testing::CoarseQuadHand();
    auto part = std::make_unique<Part>();
    part->motion = motion;
    std::vector<Vec3> placed;
    for (const Vec3& p : cup) placed.push_back(placement * p);
    part->model = std::move(*env::MrcSdfModel::Create(fx.links, fx.grids, placed));
    part->exact = std::move(*env::ExactMeshModel::Create(fx.robot, placed));
    part->scene.motion = &part->motion;
    part->scene.collision = part->model.get();
    part->scene.exact = part->exact.get();
    const Vec3 center = motion.Center(0.0);
    for (const Vec3& p : placed) part->scene.radius = std::max(part->scene.radius, (p - center).head<2>().norm());
    part->scene.target_at_zero = placement * MakePose(task.tool->position, task.tool->orientation.toRotationMatrix());
    return part;
  }
  PlanningScene Scene(const Part& part) const {
    PlanningScene scene{WindowCup().robot(), *still_model, *still_exact, *front_end};
    scene.moving = &part.scene;
    return scene;
  }
};

const MovingCupScene& MovingCup() {
  static const MovingCupScene scene = [] {
    const auto& fx = quadhand::testing::CoarseQuadHand();
    MovingCupScene s;
    const TargetBox box{Vec3(-3.36, -0.16, 0.49), Vec3(-3.04, 0.16, 0.91)};
    for (const Vec3& p : WindowCup().points) (box.Contains(p) ? s.cup : s.still).push_back(p);
    s.still_model = std::move(*env::MrcSdfModel::Create(fx.links, fx.grids, s.still));
    s.still_exact = std::move(*env::ExactMeshModel::Create(fx.robot, s.still));
    s.task = WindowCup().task;
    s.task.terminal.reset();  // the terminal state is the planner's to find
    MovingTarget moving;
    moving.motion = TargetMotion::Constant(s.task.tool->position, Vec3(0.0, 0.15, 0.0), Vec3::Zero(), 0.0);
    moving.moving_box = box;
    s.task.tool->moving = moving;
    // The front end's map covers where the cup goes.
    std::vector<Vec3> contain = {s.task.start.position, s.task.tool->position + Vec3(0.0, 1.5, 0.5),
                                 s.task.tool->position - Vec3(0.5, 0.5, 0.0)};
    s.front_end = std::make_unique<FrontEndMap>(std::move(*FrontEndMap::Build(s.still, FrontEndOptions{}, contain)));
    return s;
  }();
  return scene;
}

// The tool's distance at the plan's end from the target's pose there.
double ToolToTarget(const PlanResult& plan, const MovingScene& moving, const Pose& target_at_zero) {
  const WholeBodySample end = plan.trajectory->Sample(plan.trajectory->duration());
  const Vec3 tool = robot::LinkPose(WindowCup().robot(), end.BasePose(), end.joints,
                                    WindowCup().robot().LinkIndex("tool"))
                        .translation();
  return (tool - moving.motion->Displacement(plan.trajectory->duration()) * target_at_zero.translation()).norm();
}

// The cup is measured moving faster than first predicted: a replan from the
// flown state against the new prediction, warm-started from the current
// plan, meets the cup where the new prediction has it, certified.
TEST(ReplanTest, AMovingTargetIsMetWhereItsNewPredictionHasIt) {
  const MovingCupScene& world = MovingCup();
  solvers::LbfgsSolver solver;
  const auto first = world.MakePart(world.task.tool->moving->motion, Pose::Identity());
  auto plan = Plan(world.Scene(*first), world.task, DefaultPlannerOptions(), solver);
  ASSERT_TRUE(plan.ok()) << plan.status().message();
  ASSERT_TRUE(plan->success) << plan->message;
  ASSERT_TRUE(plan->moving_target);
  EXPECT_LT(ToolToTarget(*plan, first->scene, first->scene.target_at_zero), 0.002);

  std::vector<double> replan_ms;
  for (double t_from : {1.0, 2.0, 3.0, 4.0}) {
    SCOPED_TRACE(t_from);
    // The new prediction at t_from: the cup where the old one had it then,
    // now at 0.25 m/s, its clock starting at t_from.
    const Pose moved = first->motion.Displacement(t_from);
    const TargetMotion faster =
        TargetMotion::Constant(moved * world.task.tool->position, Vec3(0.0, 0.25, 0.0), Vec3::Zero(), 0.0);
    const auto next = world.MakePart(faster, moved);
    const BoundaryState start = StateOnPlan(*plan->trajectory, t_from);
    const auto begin = std::chrono::steady_clock::now();
    auto replanned = Replan(world.Scene(*next), world.task, DefaultPlannerOptions(), DefaultReplanOptions(), solver,
                            *plan, t_from, start);
    replan_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count());
    ASSERT_TRUE(replanned.ok()) << replanned.status().message();
    ASSERT_TRUE(replanned->success) << replanned->message;
    EXPECT_TRUE(replanned->post_check.certified);
    EXPECT_LT(replanned->rejoined_at, 0.0);  // nothing kept: the goal moved
    EXPECT_LT(ToolToTarget(*replanned, next->scene, next->scene.target_at_zero), 0.002);
    // It starts where the vehicle is.
    EXPECT_LT((replanned->trajectory->Sample(0.0).position - start.position).norm(), 1e-6);
    // The cup is farther along than the old prediction had it at the new arrival.
    const double arrival = replanned->trajectory->duration();
    EXPECT_GT((faster.Displacement(arrival) * moved * world.task.tool->position).y(),
              (first->motion.Displacement(t_from + arrival) * world.task.tool->position).y() + 0.05);
  }
  // Partway down the insertion (0.5 s before the arrival, the fingers
  // around the cup) the rest of the approach is replanned along the line as
  // it now moves, for a prediction 0.02 m/s faster (a tracker's error by
  // then; a 0.1 m/s change there would push the cup into the fingers before
  // the vehicle could follow): the tool stays on the line from the first
  // sample and meets the cup.
  {
    const double t_from = plan->trajectory->duration() - 0.5;
    const Pose moved = first->motion.Displacement(t_from);
    const TargetMotion faster =
        TargetMotion::Constant(moved * world.task.tool->position, Vec3(0.0, 0.17, 0.0), Vec3::Zero(), 0.0);
    const auto next = world.MakePart(faster, moved);
    auto replanned = Replan(world.Scene(*next), world.task, DefaultPlannerOptions(), DefaultReplanOptions(), solver,
                            *plan, t_from, StateOnPlan(*plan->trajectory, t_from));
    ASSERT_TRUE(replanned.ok()) << replanned.status().message();
    ASSERT_TRUE(replanned->success) << replanned->message;
    EXPECT_TRUE(replanned->post_check.certified);
    EXPECT_TRUE(replanned->insertion_at_zero.begun);
    EXPECT_EQ(replanned->trajectory->num_pieces(), 2);
    EXPECT_LT(ToolToTarget(*replanned, next->scene, next->scene.target_at_zero), 0.002);
    bool insertion_checked = false;
    for (const CheckResult& check : replanned->post_check.checks) {
      if (check.kind != CheckKind::kInsertion) continue;
      insertion_checked = true;
      EXPECT_TRUE(check.passed) << check.detail;
      EXPECT_NE(check.detail.find("over the approach from t = 0.00 s"), std::string::npos) << check.detail;
    }
    EXPECT_TRUE(insertion_checked);
    // Too late (less than min_piece_duration left) it is not replanned.
    const double late = plan->trajectory->duration() - 0.05;
    auto refused = Replan(world.Scene(*next), world.task, DefaultPlannerOptions(), DefaultReplanOptions(), solver,
                          *plan, late, StateOnPlan(*plan->trajectory, late));
    ASSERT_TRUE(refused.ok());
    EXPECT_EQ(refused->status, PlanStatus::kInsertionInProgress);
  }
  std::sort(replan_ms.begin(), replan_ms.end());
  std::printf("moving-target replans: %.1f, %.1f, %.1f, %.1f ms\n", replan_ms[0], replan_ms[1], replan_ms[2],
              replan_ms[3]);

  // Without a prediction to plan against it is refused, not planned to a still goal.
  PlanningScene still{WindowCup().robot(), *world.still_model, *world.still_exact, *world.front_end};
  EXPECT_FALSE(Replan(still, world.task, DefaultPlannerOptions(), DefaultReplanOptions(), solver, *plan, 2.0,
                      StateOnPlan(*plan->trajectory, 2.0))
                   .ok());
}

}  // namespace
}  // namespace quadhand::planner
