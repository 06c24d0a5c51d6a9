// Every registered solver back-end on the same problems (Drake's habit): the
// shared problems of support/solver_problems.h, each back-end's status
// mapping, the registry's names and arguments, and a small whole-body
// planning problem. docs/solvers.md describes what is tested here.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/opt/solver_registry.h"
#include "quadhand/planner/whole_body_problem.h"
#include "quadhand/solvers/builtin_solvers.h"
#include "quadhand/solvers/ceres_solver.h"
#include "quadhand/solvers/ipopt_solver.h"
#include "quadhand/solvers/nlopt_solver.h"
#include "support/quadhand_fixture.h"
#include "support/solver_problems.h"

namespace quadhand::solvers {
namespace {

using opt::FunctionObjective;
using opt::SolveResult;
using opt::SolverOptions;
using opt::SolveStatus;
using testing::SolverProblem;

// Every back-end by registry name; each nlopt algorithm is its own back-end.
std::vector<std::string> BackendNames() {
  std::vector<std::string> names = {"lbfgs", "ceres", "ceres:BFGS", "ipopt", "nlopt"};
  for (const std::string& algorithm : NloptSolver::SupportedAlgorithms()) {
    if (algorithm != NloptSolver::kDefaultAlgorithm) names.push_back("nlopt:" + algorithm);
  }
  return names;
}

std::string TestName(std::string name) {
  for (char& c : name)
    if (c == ':') c = '_';
  return name;
}

std::string BackendName(const ::testing::TestParamInfo<std::string>& param) {
  return TestName(param.param);
}

std::unique_ptr<opt::Solver> MakeSolver(const std::string& name) {
  EXPECT_TRUE(RegisterBuiltinSolvers().ok());
  core::Result<std::unique_ptr<opt::Solver>> solver = opt::CreateSolver(name);
  EXPECT_TRUE(solver.ok()) << name << ": " << solver.status().message();
  return solver.ok() ? std::move(*solver) : nullptr;
}

// A back-end built without its library cannot run anything: skip, saying so.
#define QUADHAND_SKIP_IF_UNAVAILABLE(solver) \
  if (!(solver)->available()) GTEST_SKIP() << (solver)->name() << " was built without its library"

// ---------------------------------------------------------------- shared problems

struct BackendProblem {
  std::string solver;
  SolverProblem problem;
};

void PrintTo(const BackendProblem& p, std::ostream* os) {
  *os << p.solver << " / " << p.problem.name;
}

// Where a back-end cannot solve a shared problem as posed, it gets an
// exception here, each with the reason (measured, see docs/solvers.md). The
// accuracy asked of it is always the shared one.
SolverProblem ForBackend(const std::string& solver, SolverProblem p) {
  const bool ccsa = solver == "nlopt:LD_MMA" || solver == "nlopt:LD_CCSAQ";
  if (ccsa && p.name.rfind("rosenbrock", 0) == 0) {
    // MMA and CCSAQ (conservative separable approximations, no curvature
    // pairs) crawl along Rosenbrock's curved valley: they need about 4400 to
    // 5100 iterations (measured) to meet the shared accuracy, more than the
    // shared cap of 2000. The accuracy asked of them is the shared one.
    p.options.max_iterations = 10000;
  }
  if (solver == "nlopt:LD_SLSQP" && p.name == "smoothed_abs_10d") {
    // SLSQP reaches the minimiser (|x - x*|inf ~ 1e-11, measured) but then
    // keeps trying steps that lower nothing (the curvature jumps from ~0 to
    // w/mu = 1e3 there), so it ends with line search failed, as it may on
    // the nonsmooth problem. The accuracy asked of it is the shared one.
    p.nonsmooth = true;
  }
  return p;
}

std::vector<BackendProblem> AllBackendProblems() {
  std::vector<BackendProblem> cases;
  for (const std::string& solver : BackendNames())
    for (const SolverProblem& problem : testing::SharedSolverProblems())
      cases.push_back({solver, ForBackend(solver, problem)});
  return cases;
}

class SharedProblemTest : public ::testing::TestWithParam<BackendProblem> {};

TEST_P(SharedProblemTest, Solves) {
  const std::unique_ptr<opt::Solver> solver = MakeSolver(GetParam().solver);
  ASSERT_NE(solver, nullptr);
  QUADHAND_SKIP_IF_UNAVAILABLE(solver);
  const SolveResult result = testing::ExpectSolves(*solver, GetParam().problem);
  EXPECT_EQ(result.solver, solver->name());
  // The reported cost and gradient norm are those of the reported point.
  double cost = 0.0;
  VecX grad;
  ASSERT_TRUE(GetParam().problem.objective->Evaluate(result.x, &cost, &grad));
  EXPECT_EQ(cost, result.cost);
  EXPECT_EQ(grad.lpNorm<Eigen::Infinity>(), result.gradient_max_norm);
}

std::string BackendProblemName(const ::testing::TestParamInfo<BackendProblem>& param) {
  return TestName(param.param.solver) + "_" + param.param.problem.name;
}

INSTANTIATE_TEST_SUITE_P(EveryBackend, SharedProblemTest, ::testing::ValuesIn(AllBackendProblems()),
                         BackendProblemName);

// ---------------------------------------------------------------- status mapping

class BackendTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    solver_ = MakeSolver(GetParam());
    ASSERT_NE(solver_, nullptr);
    QUADHAND_SKIP_IF_UNAVAILABLE(solver_);
  }
  std::unique_ptr<opt::Solver> solver_;
};

SolverProblem Rosenbrock2d() { return testing::SharedSolverProblems()[0]; }
SolverProblem ConvexQuadratic50d() { return testing::SharedSolverProblems()[2]; }

TEST_P(BackendTest, ReportsMaxIterations) {
  const SolverProblem p = Rosenbrock2d();
  SolverOptions options = p.options;
  options.max_iterations = 5;
  const SolveResult result = solver_->Solve(*p.objective, p.x0, options);
  EXPECT_EQ(result.status, SolveStatus::kMaxIterations) << result.BriefReport();
  EXPECT_EQ(result.iterations, 5) << result.BriefReport();
  double cost = 0.0;
  ASSERT_TRUE(p.objective->Evaluate(result.x, &cost, nullptr));
  EXPECT_EQ(cost, result.cost);
  EXPECT_LT(result.cost, 24.2);  // f(x0) = 24.2

  options.max_iterations = 0;
  const SolveResult none = solver_->Solve(*p.objective, p.x0, options);
  EXPECT_EQ(none.status, SolveStatus::kMaxIterations) << none.BriefReport();
  EXPECT_EQ(none.iterations, 0);
  EXPECT_EQ(none.x, p.x0);
  EXPECT_DOUBLE_EQ(none.cost, 24.2);
}

TEST_P(BackendTest, StopsOnTheRelativeCostTest) {
  const SolverProblem p = Rosenbrock2d();
  SolverOptions options;
  options.gradient_tolerance = 0.0;
  options.relative_cost_tolerance = 1e-6;
  const SolveResult result = solver_->Solve(*p.objective, p.x0, options);
  EXPECT_EQ(result.status, SolveStatus::kConverged) << result.BriefReport();
  EXPECT_NE(result.message.find("relative cost decrease"), std::string::npos) << result.message;
  EXPECT_GE(result.iterations, options.relative_cost_window);
}

TEST_P(BackendTest, StopsOnTheGradientTest) {
  const SolverProblem p = ConvexQuadratic50d();  // MMA and CCSAQ are slow on Rosenbrock
  SolverOptions options;
  options.relative_cost_tolerance = 0.0;  // only the gradient test can stop it
  options.gradient_tolerance = 1e-6;
  const SolveResult result = solver_->Solve(*p.objective, p.x0, options);
  EXPECT_EQ(result.status, SolveStatus::kConverged) << result.BriefReport();
  EXPECT_LE(result.gradient_max_norm, options.gradient_tolerance) << result.BriefReport();
}

TEST_P(BackendTest, ReportsTimeout) {
  // Every evaluation sleeps 2 ms, so a 10 ms limit is hit after a few
  // evaluations however fast the machine is; the problem needs many more.
  const SolverProblem p = Rosenbrock2d();
  const FunctionObjective slow(2, [&p](const VecX& x, double* cost, VecX* grad) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    return p.objective->Evaluate(x, cost, grad);
  });
  SolverOptions options = p.options;
  options.max_time_seconds = 0.01;
  const SolveResult result = solver_->Solve(slow, p.x0, options);
  EXPECT_EQ(result.status, SolveStatus::kTimeout) << result.BriefReport();
  EXPECT_GE(result.wall_time_seconds, 0.01);
  EXPECT_LT(result.wall_time_seconds, 1.0) << "the limit is checked at least once per iteration";
  EXPECT_TRUE(std::isfinite(result.cost));
}

TEST_P(BackendTest, ReportsAFailingEvaluation) {
  const FunctionObjective never(2, [](const VecX&, double*, VecX*) { return false; });
  SolveResult result = solver_->Solve(never, VecX::Zero(2), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kEvaluationFailed) << result.BriefReport();
  EXPECT_EQ(result.evaluations, 1) << result.BriefReport();
  EXPECT_TRUE(std::isnan(result.cost));
  EXPECT_EQ(result.x, VecX::Zero(2));

  const FunctionObjective nan_cost(1, [](const VecX&, double* cost, VecX* grad) {
    *cost = std::numeric_limits<double>::quiet_NaN();
    if (grad != nullptr) grad->setZero();
    return true;
  });
  result = solver_->Solve(nan_cost, VecX::Zero(1), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kEvaluationFailed) << result.BriefReport();

  const FunctionObjective throws(1, [](const VecX&, double*, VecX*) -> bool {
    throw std::runtime_error("boom");
  });
  result = solver_->Solve(throws, VecX::Zero(1), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kEvaluationFailed) << result.BriefReport();
  EXPECT_NE(result.message.find("boom"), std::string::npos) << result.message;

  // Works at x0, fails everywhere else: every trial step fails.
  const FunctionObjective only_at_start(1, [](const VecX& x, double* cost, VecX* grad) {
    *cost = (x[0] - 3.0) * (x[0] - 3.0);
    if (grad != nullptr) (*grad)[0] = 2.0 * (x[0] - 3.0);
    return x[0] == 0.0;
  });
  result = solver_->Solve(only_at_start, VecX::Zero(1), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kEvaluationFailed) << result.BriefReport();
  EXPECT_EQ(result.x[0], 0.0);
  EXPECT_EQ(result.cost, 9.0);
  EXPECT_EQ(result.iterations, 0);
}

TEST_P(BackendTest, BacktracksOutOfAFailingRegion) {
  // -log(x) + x, minimum at 1, undefined for x <= 0: long steps fail and the
  // line search must shrink them.
  const FunctionObjective barrier(1, [](const VecX& x, double* cost, VecX* grad) {
    if (x[0] <= 0.0) return false;
    *cost = -std::log(x[0]) + x[0];
    if (grad != nullptr) (*grad)[0] = -1.0 / x[0] + 1.0;
    return true;
  });
  const SolveResult result = solver_->Solve(barrier, VecX::Constant(1, 5.0), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kConverged) << result.BriefReport();
  EXPECT_NEAR(result.x[0], 1.0, 1e-5) << result.BriefReport();
}

TEST_P(BackendTest, RejectsBadInputWithoutEvaluating) {
  const SolverProblem p = Rosenbrock2d();
  SolveResult result = solver_->Solve(*p.objective, VecX::Zero(3), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kInvalidInput);
  EXPECT_EQ(result.evaluations, 0);
  SolverOptions options;
  options.memory_size = 0;
  result = solver_->Solve(*p.objective, p.x0, options);
  EXPECT_EQ(result.status, SolveStatus::kInvalidInput);
  EXPECT_EQ(result.evaluations, 0);
}

INSTANTIATE_TEST_SUITE_P(EveryBackend, BackendTest, ::testing::ValuesIn(BackendNames()),
                         BackendName);

// ---------------------------------------------------------------- registry

core::Status CreateStatus(const std::string& name) {
  EXPECT_TRUE(RegisterBuiltinSolvers().ok());
  const core::Result<std::unique_ptr<opt::Solver>> solver = opt::CreateSolver(name);
  return solver.ok() ? core::Status::Ok() : solver.status();
}

TEST(SolverRegistryTest, EveryBackendIsRegisteredByItsName) {
  ASSERT_TRUE(RegisterBuiltinSolvers().ok());
  ASSERT_TRUE(RegisterBuiltinSolvers().ok());  // idempotent
  for (const char* name : {"lbfgs", "ceres", "ipopt", "nlopt"}) {
    EXPECT_TRUE(opt::IsSolverRegistered(name)) << name;
  }
  for (const std::string& name : BackendNames()) {
    core::Result<std::unique_ptr<opt::Solver>> solver = opt::CreateSolver(name);
    ASSERT_TRUE(solver.ok()) << name << ": " << solver.status().message();
    std::cout << "[ backend  ] " << (*solver)->name()
              << ((*solver)->available() ? "" : " (built without its library)") << "\n";
  }
  EXPECT_EQ((*opt::CreateSolver("nlopt"))->name(), "nlopt:LD_LBFGS");
  EXPECT_EQ((*opt::CreateSolver("nlopt:LD_MMA"))->name(), "nlopt:LD_MMA");
  EXPECT_EQ((*opt::CreateSolver("ceres:LBFGS"))->name(), "ceres");
  EXPECT_EQ((*opt::CreateSolver("ceres:BFGS"))->name(), "ceres:BFGS");
}

TEST(SolverRegistryTest, RejectsUnknownNloptAlgorithms) {
  const core::Status unknown = CreateStatus("nlopt:LD_FOO");
  EXPECT_EQ(unknown.code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(unknown.message().find("unknown NLopt algorithm 'LD_FOO'"), std::string::npos)
      << unknown.message();
  EXPECT_NE(unknown.message().find("LD_MMA"), std::string::npos) << unknown.message();

  const core::Status prefixed = CreateStatus("nlopt:NLOPT_LD_MMA");
  EXPECT_FALSE(prefixed.ok());
  EXPECT_NE(prefixed.message().find("nlopt:LD_MMA"), std::string::npos) << prefixed.message();

  EXPECT_FALSE(CreateStatus("nlopt:ld_lbfgs").ok());  // names are case-sensitive, as NLopt's
}

TEST(SolverRegistryTest, RejectsDerivativeFreeAndUnsuitableNloptAlgorithms) {
  for (const char* name : {"nlopt:LN_COBYLA", "nlopt:LN_BOBYQA", "nlopt:GN_DIRECT_L",
                           "nlopt:GN_ISRES", "nlopt:LN_NELDERMEAD"}) {
    const core::Status status = CreateStatus(name);
    EXPECT_EQ(status.code(), core::StatusCode::kInvalidArgument) << name;
    EXPECT_NE(status.message().find("derivative-free"), std::string::npos) << status.message();
  }
  EXPECT_NE(CreateStatus("nlopt:GD_STOGO").message().find("finite bounds"), std::string::npos);
  EXPECT_NE(CreateStatus("nlopt:LD_AUGLAG").message().find("subsidiary"), std::string::npos);
  EXPECT_NE(CreateStatus("nlopt:LD_LBFGS_NOCEDAL").message().find("not compiled"),
            std::string::npos);
}

TEST(SolverRegistryTest, RejectsUnknownArgumentsOfTheOtherBackends) {
  EXPECT_EQ(CreateStatus("ceres:TRUST_REGION").code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(CreateStatus("ipopt:mumps").code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(CreateStatus("lbfgs:x").code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(CreateStatus("knitro").code(), core::StatusCode::kNotFound);
}

// ---------------------------------------------------------------- whole-body problem

// A 5-piece whole-body problem through a gap in a wall of points (the
// planner's cost with its default weights, coarse link SDFs), from a
// perturbed straight line that collides with the wall and breaks the limits.
struct WholeBodySetup {
  std::unique_ptr<env::MrcSdfModel> model;
  std::unique_ptr<planner::WholeBodyProblem> problem;
  VecX x0;
};

const WholeBodySetup& SmallWholeBodyProblem() {
  static const WholeBodySetup setup = [] {
    const auto& fx = testing::CoarseQuadHand();
    std::vector<Vec3> wall;
    for (double y = -0.6; y <= 0.9; y += 0.02)
      for (double z = 0.6; z <= 1.6; z += 0.02)
        if (std::abs(y - 0.15) >= 0.25 || std::abs(z - 1.05) >= 0.22) wall.emplace_back(0.8, y, z);
    WholeBodySetup s;
    s.model = std::move(*env::MrcSdfModel::Create(fx.links, fx.grids, wall));
    planner::BoundaryState start, goal;
    start.position = Vec3(0.0, 0.0, 1.0);
    start.yaw = 0.2;
    start.joints = Vec3(0.3, -0.2, 0.1);
    goal.position = Vec3(1.6, 0.3, 1.2);
    goal.yaw = 0.5;
    goal.joints = Vec3(0.9, 0.6, -0.3);
    planner::Limits limits;
    limits.v_max = 1.0;
    limits.a_max = 2.0;
    limits.yaw_rate_max = 1.0;
    limits.body_rate_xy_max = 1.0;
    limits.joint_rate_max = Vec3(1.0, 1.0, 1.0);
    limits.joint_lower = fx.robot.LowerLimits();
    limits.joint_upper = fx.robot.UpperLimits();
    constexpr int kPieces = 5;
    auto problem = planner::WholeBodyProblem::Create(fx.robot, *s.model, start, goal, limits, {},
                                                     planner::WholeBodyCostOptions{}, kPieces);
    EXPECT_TRUE(problem.ok()) << problem.status().message();
    s.problem = std::move(*problem);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1, 1);
    MatX position(3, kPieces - 1), aux(4, kPieces - 1);
    for (int i = 0; i < kPieces - 1; ++i) {
      const double f = (i + 1.0) / kPieces;
      position.col(i) = (1 - f) * start.position + f * goal.position +
                        0.05 * Vec3(u(rng), u(rng), u(rng));
      aux(0, i) = (1 - f) * start.yaw + f * goal.yaw;
      aux.block(1, i, 3, 1) = (1 - f) * start.joints + f * goal.joints;
    }
    s.x0 = s.problem->Pack(position, aux, VecX::Constant(kPieces, 0.4));
    return s;
  }();
  return setup;
}

class WholeBodyTest : public BackendTest {};

TEST_P(WholeBodyTest, ReducesTheCostSubstantially) {
  const WholeBodySetup& s = SmallWholeBodyProblem();
  double initial = 0.0;
  ASSERT_TRUE(s.problem->Evaluate(s.x0, &initial, nullptr));
  // The planner's settings (planner.cc), with a longer time cap.
  SolverOptions options;
  options.max_iterations = 400;
  options.relative_cost_tolerance = 1e-5;
  options.relative_cost_window = 3;
  options.gradient_tolerance = 1e-5;
  options.max_time_seconds = 60.0;
  const SolveResult result = solver_->Solve(*s.problem, s.x0, options);
  std::cout << "[ wholebody] initial cost " << initial << "; " << result.BriefReport() << "\n";
  // Every back-end ends near 96-222 (measured), from 8.3e5. NLopt's Luksan
  // codes (LD_LBFGS, VAR1/2, TNEWTON*) start only because the wrapper scales
  // the cost by 1 / |g(x0)|inf (|g|inf is 4.4e6 here; their first trial step
  // is of unit length along -g).
  EXPECT_TRUE(result.status == SolveStatus::kConverged ||
              result.status == SolveStatus::kMaxIterations)
      << result.BriefReport();
  EXPECT_LT(result.cost, 1e-3 * initial) << result.BriefReport();
}

INSTANTIATE_TEST_SUITE_P(EveryBackend, WholeBodyTest, ::testing::ValuesIn(BackendNames()),
                         BackendName);

}  // namespace
}  // namespace quadhand::solvers
