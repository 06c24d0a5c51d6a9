// The whole-body objective: its gradient (every term alone, and all together)
// against finite differences at random points, and its bookkeeping.
#include "quadhand/planner/whole_body_problem.h"

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <string>
#include <vector>

#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/env/self_collision.h"
#include "quadhand/planner/cost_term.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/robot/kinematics.h"
#include "support/quadhand_fixture.h"

namespace quadhand::planner {
namespace {

using testing::CoarseQuadHand;
using testing::SmoothCentralDifference;

constexpr int kPieces = 5;

BoundaryState Start() {
  BoundaryState s;
  s.position = Vec3(0.0, 0.0, 1.0);
  s.velocity = Vec3(0.3, 0.0, 0.0);
  s.yaw = 0.2;
  s.joints = Vec3(0.3, -0.2, 0.1);
  return s;
}

BoundaryState Goal() {
  BoundaryState s;
  s.position = Vec3(1.6, 0.3, 1.2);
  s.yaw = 0.5;
  s.joints = Vec3(0.9, 0.6, -0.3);
  return s;
}

// A wall of points at x = 0.8 with a gap, close enough to the straight path
// that the collision term is active at the test points.
std::vector<Vec3> Wall() {
  std::vector<Vec3> points;
  for (double y = -0.6; y <= 0.9; y += 0.02) {
    for (double z = 0.6; z <= 1.6; z += 0.02) {
      if (std::abs(y - 0.15) < 0.22 && std::abs(z - 1.05) < 0.2) continue;  // the gap
      points.emplace_back(0.8, y, z);
    }
  }
  return points;
}

// The reference robot's self-collision pairs, every one of them (an SRDF
// that disables none), penalised in the coarse fixture's SDFs.
const env::SelfCollisionModel& SelfCollision() {
  static const auto model = [] {
    const auto& fx = CoarseQuadHand();
    static const auto exact = std::move(*env::ExactMeshModel::Create(fx.robot, std::vector<Vec3>{Vec3(50, 50, 50)}));
    auto self = std::move(*env::SelfCollisionModel::Create(fx.robot, *exact, std::vector<std::pair<int, int>>{},
                                                           env::SelfCollisionOptions{}));
    EXPECT_TRUE(self->AttachSdfGrids(std::make_shared<const std::vector<geometry::SdfGrid>>(fx.grids)).ok());
    return self;
  }();
  return *model;
}

// A target that moves and turns slowly about a point near the goal, and a
// copy of the wall that moves with it, nearer the start: the robot passes
// its gap while it moves.
struct MovingParts {
  TargetMotion motion = TargetMotion::Constant(Vec3(1.7, 0.3, 1.0), Vec3(0.1, 0.05, 0.02), Vec3(0.02, 0.0, 0.0), 0.02);
  std::unique_ptr<env::MrcSdfModel> model;
  MovingScene scene;
};

struct ProblemSetup {
  std::unique_ptr<env::MrcSdfModel> model;
  std::unique_ptr<MovingParts> moving;
  std::unique_ptr<WholeBodyProblem> problem;
  VecX x0;
};

ProblemSetup MakeSetup(const WholeBodyCostOptions& options, bool insertion, const std::vector<Vec3>& extra_points = {},
                       bool moving = false, bool insertion_begun = false) {
  const auto& fx = CoarseQuadHand();
  ProblemSetup setup;
  std::vector<Vec3> points = Wall();
  points.insert(points.end(), extra_points.begin(), extra_points.end());
  setup.model = std::move(*env::MrcSdfModel::Create(fx.links, fx.grids, points));
  Limits limits;
  limits.v_max = 0.6;  // low bounds so that every feasibility term is active
  limits.a_max = 0.5;
  limits.yaw_rate_max = 0.1;
  limits.body_rate_xy_max = 0.05;
  limits.joint_rate_max = Vec3(0.2, 0.2, 0.2);
  limits.joint_lower = fx.robot.LowerLimits();
  limits.joint_upper = Vec3(0.5, 1.5, 3.14);
  InsertionGoal goal_tool;
  if (insertion) {
    goal_tool.enabled = true;
    goal_tool.tool_link = fx.robot.LinkIndex("tool");
    robot::KinematicsState k;
    const Pose base = MakePose(Goal().position, Eigen::AngleAxisd(Goal().yaw, Vec3::UnitZ()).toRotationMatrix());
    robot::ComputeKinematics(fx.robot, base, Goal().joints, &k);
    goal_tool.tool_position = k.link_poses[goal_tool.tool_link].translation() + Vec3(0.01, 0.0, 0.0);
    goal_tool.tool_orientation = Quat(Eigen::AngleAxisd(0.3, Vec3::UnitY()) * k.link_poses[goal_tool.tool_link].linear());
    goal_tool.direction = Vec3(0.1, 0.0, -1.0);
    goal_tool.length = 0.1;
    goal_tool.begun = insertion_begun;
  }
  auto problem = WholeBodyProblem::Create(fx.robot, *setup.model, Start(), Goal(), limits, goal_tool, options, kPieces,
                                          &SelfCollision());
  EXPECT_TRUE(problem.ok()) << problem.status().message();
  setup.problem = std::move(*problem);
  if (moving) {
    setup.moving = std::make_unique<MovingParts>();
    std::vector<Vec3> moving_points;
    for (const Vec3& p : Wall()) moving_points.push_back(p - Vec3(0.25, 0.0, 0.0));
    setup.moving->model = std::move(*env::MrcSdfModel::Create(fx.links, fx.grids, moving_points));
    setup.moving->scene.motion = &setup.moving->motion;
    setup.moving->scene.collision = setup.moving->model.get();
    EXPECT_TRUE(setup.problem->SetMovingScene(&setup.moving->scene).ok());
  }
  // Straight-line waypoints, perturbed so nothing is symmetric.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  MatX position(3, kPieces - 1), aux(4, kPieces - 1);
  for (int i = 0; i < kPieces - 1; ++i) {
    const double s = (i + 1.0) / kPieces;
    position.col(i) = (1 - s) * Start().position + s * Goal().position + 0.05 * Vec3(u(rng), u(rng), u(rng));
    aux(0, i) = (1 - s) * Start().yaw + s * Goal().yaw + 0.1 * u(rng);
    aux.block(1, i, 3, 1) = (1 - s) * Start().joints + s * Goal().joints + 0.1 * Vec3(u(rng), u(rng), u(rng));
  }
  VecX durations(kPieces);
  for (int i = 0; i < kPieces; ++i) durations[i] = 0.6 + 0.1 * u(rng);
  setup.x0 = setup.problem->Pack(position, aux, durations);
  return setup;
}

// Checks every coordinate of the gradient at x against central differences;
// coordinates whose one-sided slopes disagree (a trilinear cell face crossed
// inside the step) are skipped and counted.
void ExpectGradientMatches(const WholeBodyProblem& problem, const VecX& x, double tolerance, int* skipped,
                           double step = 1e-7) {
  double cost = 0;
  VecX grad;
  ASSERT_TRUE(problem.Evaluate(x, &cost, &grad));
  for (int i = 0; i < x.size(); ++i) {
    auto f = [&](double s) {
      VecX moved = x;
      moved[i] += s;
      double c = 0;
      EXPECT_TRUE(problem.Evaluate(moved, &c, nullptr));
      return c;
    };
    double numeric = 0;
    if (!SmoothCentralDifference(f, step, &numeric)) {
      ++*skipped;
      continue;
    }
    EXPECT_LE(std::abs(grad[i] - numeric), tolerance * std::max(1.0, std::abs(numeric)))
        << "variable " << i << " analytic " << grad[i] << " numeric " << numeric;
  }
}

// Every weight zero but the one of `term` ("time", "energy", or a sampled
// term of CostTermDescriptors()).
WholeBodyCostOptions OnlyTerm(const std::string& term) {
  WholeBodyCostOptions o;
  o.time_weight = term == "time" ? 20.0 : 0.0;
  o.energy_weight_position = term == "energy" ? 1.0 : 0.0;
  o.energy_weight_aux = term == "energy" ? 1.0 : 0.0;
  // Terms may share a weight (the still and the moving scene's collision):
  // all are cleared first, then the named one's set.
  for (const CostTermDescriptor& descriptor : CostTermDescriptors()) o.*(descriptor.weight) = 0.0;
  for (const CostTermDescriptor& descriptor : CostTermDescriptors()) {
    // Geometric terms are steeper per unit of weight than the rate terms.
    const std::string name = descriptor.name;
    const double weight = name == "collision" || name == "moving_collision" || name == "insertion" ? 1e3 : 1e2;
    if (term == name) o.*(descriptor.weight) = weight;
  }
  // The arm's links pass within 15 cm of the battery and the airframe (a
  // lower weight: the term sums many samples, and a larger value leaves
  // more rounding in the differences).
  if (term == "self_collision") {
    o.self_collision_threshold = 0.15;
    o.weight_self_collision = 10.0;
  }
  return o;
}

// "time", "energy" and every registered sampled term: a new term gets its
// finite-difference test here without a line of its own.
std::vector<std::string> EveryTermName() {
  std::vector<std::string> names = {"time", "energy"};
  for (const CostTermDescriptor& descriptor : CostTermDescriptors()) names.push_back(descriptor.name);
  return names;
}

class TermGradientTest : public ::testing::TestWithParam<std::string> {};

// The gradient of `term` alone (OnlyTerm) at the setup's x0, which the term
// must be active at or the check proves nothing.
void ExpectTermGradient(const std::string& term, bool moving, double step) {
  ProblemSetup setup = MakeSetup(OnlyTerm(term), /*insertion=*/true, {}, moving);
  auto breakdown = setup.problem->Breakdown(setup.x0);
  ASSERT_TRUE(breakdown.ok());
  const double value = term == "time" ? breakdown->time : term == "energy" ? breakdown->energy : breakdown->Term(term);
  EXPECT_GT(value, 0.0) << term << " is not active at the test point";
  int skipped = 0;
  ExpectGradientMatches(*setup.problem, setup.x0, 1e-5, &skipped, step);
  EXPECT_LE(skipped, 3);
}

TEST_P(TermGradientTest, MatchesFiniteDifferences) {
  // The moving scene's collision term needs a moving scene.
  ExpectTermGradient(GetParam(), /*moving=*/GetParam() == "moving_collision", 1e-7);
}

INSTANTIATE_TEST_SUITE_P(EveryTerm, TermGradientTest, ::testing::ValuesIn(EveryTermName()));

// With a goal that follows a moving target (WholeBodyProblem::SetMovingScene)
// every term's gradient also reaches the durations through the target's
// clock: the tail (time, energy and every term near the end), the moving
// insertion line and the moving points.
class MovingGoalTermGradientTest : public ::testing::TestWithParam<std::string> {};

TEST_P(MovingGoalTermGradientTest, MatchesFiniteDifferences) {
  // With the tail moving, the body rate (through the jerk) has rounding of
  // 2e-5 at a step of 1e-7 and agrees to 1e-7 at 1e-5 and 1e-6; the
  // geometric terms keep 1e-7, which steps over fewer trilinear cell faces.
  ExpectTermGradient(GetParam(), /*moving=*/true, GetParam() == "body_rate" ? 1e-6 : 1e-7);
}

INSTANTIATE_TEST_SUITE_P(EveryTerm, MovingGoalTermGradientTest, ::testing::ValuesIn(EveryTermName()));

// An insertion that has begun (InsertionGoal::begun, a replan partway down
// the line to a moving target): the line's term on every piece, no back-off
// cost, the same gradient as finite differences.
TEST(WholeBodyProblemTest, AnInsertionThatHasBegunCostsEveryPieceWithItsGradient) {
  ProblemSetup begun = MakeSetup(OnlyTerm("insertion"), /*insertion=*/true, {}, /*moving=*/true, /*begun=*/true);
  ProblemSetup fresh = MakeSetup(OnlyTerm("insertion"), /*insertion=*/true, {}, /*moving=*/true, /*begun=*/false);
  auto begun_cost = begun.problem->Breakdown(begun.x0);
  auto fresh_cost = fresh.problem->Breakdown(fresh.x0);
  ASSERT_TRUE(begun_cost.ok() && fresh_cost.ok());
  // Every piece is on the line: far more of the trajectory is off it.
  EXPECT_GT(begun_cost->Term("insertion"), 2.0 * fresh_cost->Term("insertion"));
  int skipped = 0;
  ExpectGradientMatches(*begun.problem, begun.x0, 1e-5, &skipped);
  EXPECT_LE(skipped, 3);
}


// Weights fixed here (not the defaults, which get tuned): large enough that
// every term matters, moderate enough that a trilinear cell face crossed
// inside the finite-difference step is still detected as a kink.
WholeBodyCostOptions AllTerms() {
  WholeBodyCostOptions o;
  o.weight_collision = 2e4;
  o.weight_insertion = 2e4;
  o.weight_velocity = o.weight_acceleration = o.weight_yaw_rate = o.weight_joint_rate = o.weight_body_rate = 1e3;
  o.weight_joint_limits = 1e4;
  return o;
}

TEST(WholeBodyProblemTest, WholeObjectiveGradientAtRandomPoints) {
  ProblemSetup setup = MakeSetup(AllTerms(), /*insertion=*/true);
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 0.03);
  int skipped = 0;
  for (int trial = 0; trial < 3; ++trial) {
    VecX x = setup.x0;
    for (int i = 0; i < x.size(); ++i) x[i] += noise(rng);
    ExpectGradientMatches(*setup.problem, x, 1e-5, &skipped);
  }
  EXPECT_LE(skipped, 6);
}

TEST(WholeBodyProblemTest, AMovingGoalEndsTheTrajectoryWhereTheTargetTakesTheGoalState) {
  ProblemSetup setup = MakeSetup(AllTerms(), /*insertion=*/true, {}, /*moving=*/true);
  auto trajectory = setup.problem->Trajectory(setup.x0);
  ASSERT_TRUE(trajectory.ok());
  const double T = trajectory->duration();
  const BoundaryState moved = MovedState(Goal(), setup.moving->motion, T);
  const WholeBodySample end = trajectory->Sample(T);
  EXPECT_LT((end.position - moved.position).norm(), 1e-9);
  EXPECT_LT((end.velocity - moved.velocity).norm(), 1e-9);
  EXPECT_LT((end.acceleration - moved.acceleration).norm(), 1e-9);
  EXPECT_NEAR(end.yaw, Goal().yaw + setup.moving->motion.Yaw(T), 1e-9);
  EXPECT_NEAR(end.yaw_rate, 0.02, 1e-9);
  EXPECT_GT((moved.position - Goal().position).norm(), 0.3);  // it did move
}

// The samples are evaluated piece by piece on `threads` workers; the cost,
// every term and the gradient must not depend on how many.
TEST(WholeBodyProblemTest, TheCostAndGradientDoNotDependOnTheThreads) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.03);
  WholeBodyCostOptions options = AllTerms();
  options.threads = 1;
  ProblemSetup one = MakeSetup(options, /*insertion=*/true);
  for (int trial = 0; trial < 3; ++trial) {
    VecX x = one.x0;
    for (int i = 0; i < x.size(); ++i) x[i] += noise(rng);
    double cost_one = 0;
    VecX grad_one;
    ASSERT_TRUE(one.problem->Evaluate(x, &cost_one, &grad_one));
    const CostBreakdown breakdown_one = *one.problem->Breakdown(x);
    for (int threads : {2, 3, 7}) {
      options.threads = threads;
      ProblemSetup many = MakeSetup(options, /*insertion=*/true);
      double cost = 0;
      VecX grad;
      ASSERT_TRUE(many.problem->Evaluate(x, &cost, &grad));
      EXPECT_EQ(cost, cost_one) << threads;
      EXPECT_TRUE(grad == grad_one) << threads << ": largest difference " << (grad - grad_one).cwiseAbs().maxCoeff();
      const CostBreakdown breakdown = *many.problem->Breakdown(x);
      ASSERT_EQ(breakdown.terms.size(), breakdown_one.terms.size());
      for (size_t i = 0; i < breakdown.terms.size(); ++i) {
        EXPECT_EQ(breakdown.terms[i].second, breakdown_one.terms[i].second) << breakdown.terms[i].first << ", " << threads;
      }
    }
  }
  options.threads = -1;
  EXPECT_FALSE(options.IsValid(nullptr));
}

// Points on a vertical ring of radius `radius` around the robot's tool at the goal.
std::vector<Vec3> RingAroundGoalTool(double radius) {
  const auto& fx = CoarseQuadHand();
  robot::KinematicsState k;
  const Pose base = MakePose(Goal().position, Eigen::AngleAxisd(Goal().yaw, Vec3::UnitZ()).toRotationMatrix());
  robot::ComputeKinematics(fx.robot, base, Goal().joints, &k);
  const Vec3 center = k.link_poses[fx.robot.LinkIndex("tool")].translation();
  std::vector<Vec3> ring;
  for (int i = 0; i < 24; ++i) {
    const double a = 2.0 * M_PI * i / 24;
    ring.push_back(center + radius * Vec3(std::cos(a), std::sin(a), 0.0));
  }
  return ring;
}

TEST(WholeBodyProblemTest, InsertionCollisionThresholdActsOnTheInsertionPieceOnly) {
  WholeBodyCostOptions o = OnlyTerm("collision");
  auto collision_with = [&](double insertion_threshold, bool insertion, const std::vector<Vec3>& extra) {
    o.insertion_collision_threshold = insertion_threshold;
    ProblemSetup setup = MakeSetup(o, insertion, extra);
    auto breakdown = setup.problem->Breakdown(setup.x0);
    EXPECT_TRUE(breakdown.ok());
    return breakdown.ok() ? breakdown->Term("collision") : -1.0;
  };
  // The wall is passed in the middle pieces: the insertion threshold does not touch it.
  const double wall = collision_with(0.0, true, {});
  ASSERT_GT(wall, 0.0);
  EXPECT_EQ(collision_with(1e-3, true, {}), wall);
  // Points around the goal are reached on the last piece only.
  const std::vector<Vec3> ring = RingAroundGoalTool(0.05);
  const double both = collision_with(0.0, true, ring);
  ASSERT_GT(both, wall);
  EXPECT_EQ(collision_with(o.collision_threshold, true, ring), both);  // non-positive means the same
  const double relaxed = collision_with(1e-3, true, ring);
  EXPECT_LT(relaxed, both);
  EXPECT_GE(relaxed, wall);
  // Without an insertion there is no insertion piece.
  EXPECT_EQ(collision_with(1e-3, false, ring), collision_with(0.0, false, ring));
}

TEST(WholeBodyProblemTest, GradientWithAnInsertionCollisionThreshold) {
  WholeBodyCostOptions o = AllTerms();
  o.insertion_collision_threshold = 0.75 * o.collision_threshold;
  ProblemSetup setup = MakeSetup(o, /*insertion=*/true, RingAroundGoalTool(0.045));
  // The ring must be within the insertion threshold on the last piece.
  ProblemSetup without_ring = MakeSetup(o, /*insertion=*/true);
  ASSERT_GT(setup.problem->Breakdown(setup.x0)->Term("collision"),
            without_ring.problem->Breakdown(without_ring.x0)->Term("collision"));
  int skipped = 0;
  ExpectGradientMatches(*setup.problem, setup.x0, 1e-5, &skipped);
  EXPECT_LE(skipped, 3);
}

TEST(WholeBodyProblemTest, InsertionPieceHasItsOwnSampleCount) {
  auto breakdown_with = [](int samples, int insertion_samples) {
    WholeBodyCostOptions o = AllTerms();
    o.samples_per_piece = samples;
    o.insertion_samples = insertion_samples;
    ProblemSetup setup = MakeSetup(o, /*insertion=*/true, RingAroundGoalTool(0.05));
    auto breakdown = setup.problem->Breakdown(setup.x0);
    EXPECT_TRUE(breakdown.ok());
    return *breakdown;
  };
  // 0 means samples_per_piece.
  EXPECT_EQ(breakdown_with(16, 0).total, breakdown_with(16, 16).total);
  // Only the last piece's quadrature changes: the insertion term (on that
  // piece alone) moves, the energy and time do not.
  const CostBreakdown coarse = breakdown_with(16, 4), fine = breakdown_with(16, 16);
  EXPECT_NE(coarse.Term("insertion"), fine.Term("insertion"));
  EXPECT_EQ(coarse.energy, fine.energy);
  EXPECT_EQ(coarse.time, fine.time);
  // The defaults' gradient tests above run with insertion_samples = 8 against
  // 16 per piece; here also a count that does not divide the other.
  WholeBodyCostOptions o = AllTerms();
  o.insertion_samples = 5;
  ProblemSetup setup = MakeSetup(o, /*insertion=*/true, RingAroundGoalTool(0.05));
  int skipped = 0;
  ExpectGradientMatches(*setup.problem, setup.x0, 1e-5, &skipped);
  EXPECT_LE(skipped, 3);
  o.insertion_samples = -1;
  EXPECT_FALSE(o.IsValid(nullptr));
}

TEST(WholeBodyProblemTest, PackUnpackAndTrajectoryMeetTheBoundaryStates) {
  ProblemSetup setup = MakeSetup(WholeBodyCostOptions{}, false);
  MatX position, aux;
  VecX durations;
  setup.problem->Unpack(setup.x0, &position, &aux, &durations);
  EXPECT_LT((setup.problem->Pack(position, aux, durations) - setup.x0).norm(), 1e-9);
  auto trajectory = setup.problem->Trajectory(setup.x0);
  ASSERT_TRUE(trajectory.ok());
  EXPECT_NEAR(trajectory->duration(), durations.sum(), 1e-12);
  const WholeBodySample first = trajectory->Sample(0.0), last = trajectory->Sample(trajectory->duration());
  EXPECT_LT((first.position - Start().position).norm(), 1e-9);
  EXPECT_LT((first.velocity - Start().velocity).norm(), 1e-9);
  EXPECT_LT((first.joints - Start().joints).norm(), 1e-9);
  EXPECT_LT((last.position - Goal().position).norm(), 1e-9);
  EXPECT_LT(last.velocity.norm(), 1e-9);
  EXPECT_NEAR(last.yaw, Goal().yaw, 1e-9);
  // Hover at the goal: the attitude is the yaw rotation alone.
  EXPECT_LT(last.attitude.angularDistance(Quat(Eigen::AngleAxisd(Goal().yaw, Vec3::UnitZ()))), 1e-9);
  EXPECT_NEAR(last.thrust, 9.81, 1e-9);
}

// A waypoint held in a ball (a mission's via): the whole gradient through
// the ball map matches finite differences, the waypoint stays in its ball
// wherever the variables go, and Pack inverts Unpack.
TEST(WholeBodyProblemTest, AWaypointInABallHasTheRightGradientAndNeverLeavesIt) {
  ProblemSetup setup = MakeSetup(AllTerms(), /*insertion=*/false);
  MatX position, aux;
  VecX durations;
  setup.problem->Unpack(setup.x0, &position, &aux, &durations);
  const Vec3 center = position.col(1) + Vec3(0.02, -0.01, 0.03);
  const double radius = 0.05;
  ASSERT_TRUE(setup.problem->SetWaypointBalls({{1, center, radius}}).ok());
  const VecX x0 = setup.problem->Pack(position, aux, durations);
  MatX unpacked, unused_aux;
  VecX unused_durations;
  setup.problem->Unpack(x0, &unpacked, &unused_aux, &unused_durations);
  EXPECT_LT((unpacked - position).norm(), 1e-12);  // the guess is inside the ball: kept as it is
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.03), far(0.0, 5.0);
  int skipped = 0;
  for (int trial = 0; trial < 3; ++trial) {
    VecX x = x0;
    for (int i = 0; i < x.size(); ++i) x[i] += noise(rng);
    // (Looser than the other gradient tests' 1e-5: at these points two of
    // the other variables' differences are 1.2e-5 off, as without a ball;
    // a wrong chain rule through the map would be off by order one.)
    ExpectGradientMatches(*setup.problem, x, 3e-5, &skipped);
    for (int i = 0; i < 3; ++i) x[kPieces + 3 + i] = far(rng);
    setup.problem->Unpack(x, &unpacked, &unused_aux, &unused_durations);
    EXPECT_LE((unpacked.col(1) - center).norm(), radius * (1.0 + 1e-12));
  }
  EXPECT_LE(skipped, 6);
  // A guess outside the ball starts on its sphere, on the guess's side.
  position.col(1) = center + Vec3(0.3, 0.0, 0.0);
  setup.problem->Unpack(setup.problem->Pack(position, aux, durations), &unpacked, &unused_aux, &unused_durations);
  EXPECT_LT((unpacked.col(1) - (center + Vec3(radius, 0.0, 0.0))).norm(), 1e-12);
}

TEST(WholeBodyProblemTest, RejectsWaypointBallsThatDoNotFit) {
  ProblemSetup setup = MakeSetup(WholeBodyCostOptions{}, false);
  EXPECT_FALSE(setup.problem->SetWaypointBalls({{kPieces - 1, Vec3::Zero(), 0.1}}).ok());  // no such waypoint
  EXPECT_FALSE(setup.problem->SetWaypointBalls({{-1, Vec3::Zero(), 0.1}}).ok());
  EXPECT_FALSE(setup.problem->SetWaypointBalls({{0, Vec3::Zero(), 0.0}}).ok());
  EXPECT_FALSE(setup.problem->SetWaypointBalls({{0, Vec3::Zero(), 0.1}, {0, Vec3::Ones(), 0.1}}).ok());
  EXPECT_FALSE(setup.problem->SetWaypointBalls({{0, Vec3::Constant(NAN), 0.1}}).ok());
  EXPECT_TRUE(setup.problem->waypoint_balls().empty());
}

TEST(WholeBodyProblemTest, RejectsInconsistentInput) {
  const auto& fx = CoarseQuadHand();
  auto model = env::MrcSdfModel::Create(fx.links, fx.grids, Wall());
  Limits limits;
  limits.joint_rate_max = Vec3::Constant(2.0);
  limits.joint_lower = fx.robot.LowerLimits();
  limits.joint_upper = fx.robot.UpperLimits();
  BoundaryState bad = Start();
  bad.joints = VecX::Zero(2);
  EXPECT_FALSE(WholeBodyProblem::Create(fx.robot, **model, bad, Goal(), limits, {}, {}, 3).ok());
  EXPECT_FALSE(WholeBodyProblem::Create(fx.robot, **model, Start(), Goal(), limits, {}, {}, 0).ok());
  WholeBodyCostOptions options;
  options.collision_mu = 0.0;
  EXPECT_FALSE(WholeBodyProblem::Create(fx.robot, **model, Start(), Goal(), limits, {}, options, 3).ok());
  auto ok = WholeBodyProblem::Create(fx.robot, **model, Start(), Goal(), limits, {}, {}, 3);
  ASSERT_TRUE(ok.ok());
  double cost;
  VecX x = VecX::Zero((*ok)->num_variables());
  x[0] = std::nan("");
  EXPECT_FALSE((*ok)->Evaluate(x, &cost, nullptr));
}

}  // namespace
}  // namespace quadhand::planner
