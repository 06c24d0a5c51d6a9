#include "quadhand/solvers/lbfgs_solver.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

#include "quadhand/opt/solver_registry.h"
#include "quadhand/solvers/builtin_solvers.h"
#include "support/solver_problems.h"

namespace quadhand::solvers {
namespace {

using opt::FunctionObjective;
using opt::SolveResult;
using opt::SolverOptions;
using opt::SolveStatus;
using testing::SolverProblem;

class LbfgsSharedProblemTest : public ::testing::TestWithParam<SolverProblem> {};

TEST_P(LbfgsSharedProblemTest, Solves) {
  const SolveResult result = testing::ExpectSolves(LbfgsSolver(), GetParam());
  EXPECT_EQ(result.solver, "lbfgs");
}

INSTANTIATE_TEST_SUITE_P(Shared, LbfgsSharedProblemTest,
                         ::testing::ValuesIn(testing::SharedSolverProblems()),
                         testing::SolverProblemName);

SolverProblem Rosenbrock2d() { return testing::SharedSolverProblems().front(); }

TEST(LbfgsSolverTest, ConvergesOnTheGradientTestWithDefaultOptions) {
  const SolverProblem p = Rosenbrock2d();
  SolverOptions options;
  options.relative_cost_tolerance = 0.0;  // only the gradient test can stop it
  const SolveResult result = LbfgsSolver().Solve(*p.objective, p.x0, options);
  EXPECT_EQ(result.status, SolveStatus::kConverged) << result.BriefReport();
  EXPECT_LE(result.gradient_max_norm, options.gradient_tolerance);
  EXPECT_NE(result.message.find("gradient"), std::string::npos) << result.message;
}

TEST(LbfgsSolverTest, StopsOnTheRelativeCostTest) {
  const SolverProblem p = Rosenbrock2d();
  SolverOptions options;
  options.gradient_tolerance = 0.0;
  options.relative_cost_tolerance = 1e-6;
  const SolveResult result = LbfgsSolver().Solve(*p.objective, p.x0, options);
  EXPECT_EQ(result.status, SolveStatus::kConverged) << result.BriefReport();
  EXPECT_NE(result.message.find("relative cost decrease"), std::string::npos) << result.message;
  EXPECT_GE(result.iterations, options.relative_cost_window);
}

TEST(LbfgsSolverTest, ReportsMaxIterations) {
  const SolverProblem p = Rosenbrock2d();
  SolverOptions options = p.options;
  options.max_iterations = 5;
  const SolveResult result = LbfgsSolver().Solve(*p.objective, p.x0, options);
  EXPECT_EQ(result.status, SolveStatus::kMaxIterations) << result.BriefReport();
  EXPECT_EQ(result.iterations, 5);
  // The result is the last (best) iterate, with its cost.
  double cost = 0.0;
  ASSERT_TRUE(p.objective->Evaluate(result.x, &cost, nullptr));
  EXPECT_DOUBLE_EQ(cost, result.cost);
  EXPECT_LT(result.cost, 24.2);  // f(x0) = 24.2

  options.max_iterations = 0;
  const SolveResult none = LbfgsSolver().Solve(*p.objective, p.x0, options);
  EXPECT_EQ(none.status, SolveStatus::kMaxIterations);
  EXPECT_EQ(none.evaluations, 1);
  EXPECT_EQ(none.x, p.x0);
}

TEST(LbfgsSolverTest, ReportsTimeout) {
  // Every evaluation sleeps 2 ms, so a 10 ms limit is hit after a few
  // evaluations however fast the machine is; the problem needs many more.
  const SolverProblem p = Rosenbrock2d();
  const FunctionObjective slow(2, [&p](const VecX& x, double* cost, VecX* grad) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    return p.objective->Evaluate(x, cost, grad);
  });
  SolverOptions options = p.options;
  options.max_time_seconds = 0.01;
  const SolveResult result = LbfgsSolver().Solve(slow, p.x0, options);
  EXPECT_EQ(result.status, SolveStatus::kTimeout) << result.BriefReport();
  EXPECT_GE(result.wall_time_seconds, 0.01);
  EXPECT_TRUE(std::isfinite(result.cost));
}

TEST(LbfgsSolverTest, ReportsEvaluationFailure) {
  const FunctionObjective never(2, [](const VecX&, double*, VecX*) { return false; });
  SolveResult result = LbfgsSolver().Solve(never, VecX::Zero(2), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kEvaluationFailed) << result.BriefReport();
  EXPECT_EQ(result.evaluations, 1);

  const FunctionObjective nan_cost(1, [](const VecX&, double* cost, VecX* grad) {
    *cost = std::numeric_limits<double>::quiet_NaN();
    if (grad != nullptr) grad->setZero();
    return true;
  });
  result = LbfgsSolver().Solve(nan_cost, VecX::Zero(1), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kEvaluationFailed) << result.BriefReport();

  // Works at x0, fails everywhere else: every trial step fails.
  const FunctionObjective only_at_start(1, [](const VecX& x, double* cost, VecX* grad) {
    *cost = (x[0] - 3.0) * (x[0] - 3.0);
    if (grad != nullptr) (*grad)[0] = 2.0 * (x[0] - 3.0);
    return x[0] == 0.0;
  });
  result = LbfgsSolver().Solve(only_at_start, VecX::Zero(1), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kEvaluationFailed) << result.BriefReport();
  EXPECT_EQ(result.x[0], 0.0);
}

TEST(LbfgsSolverTest, BacktracksOutOfAFailingRegion) {
  // -log(x) + x, minimum at 1, undefined for x <= 0: long steps fail and the
  // line search must shrink them.
  const FunctionObjective barrier(1, [](const VecX& x, double* cost, VecX* grad) {
    if (x[0] <= 0.0) return false;
    *cost = -std::log(x[0]) + x[0];
    if (grad != nullptr) (*grad)[0] = -1.0 / x[0] + 1.0;
    return true;
  });
  const SolveResult result =
      LbfgsSolver().Solve(barrier, VecX::Constant(1, 5.0), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kConverged) << result.BriefReport();
  EXPECT_NEAR(result.x[0], 1.0, 1e-5);
}

TEST(LbfgsSolverTest, RejectsNonFiniteStart) {
  const SolverProblem p = Rosenbrock2d();
  const VecX x0 = (VecX(2) << std::numeric_limits<double>::quiet_NaN(), 1.0).finished();
  const SolveResult result = LbfgsSolver().Solve(*p.objective, x0, SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kInvalidInput) << result.BriefReport();
  EXPECT_EQ(result.evaluations, 0);
}

TEST(LbfgsSolverTest, ReportsLineSearchFailureOnAnUnreachableKink) {
  // |x|: from x0 = 1 it reaches the kink at 0 up to rounding; then no step
  // decreases the cost, which is a line search failure (or convergence when
  // the relative cost test stops it first, which is disabled here).
  const FunctionObjective abs(1, [](const VecX& x, double* cost, VecX* grad) {
    *cost = std::abs(x[0]);
    if (grad != nullptr) (*grad)[0] = x[0] >= 0.0 ? 1.0 : -1.0;
    return true;
  });
  SolverOptions options;
  options.relative_cost_tolerance = 0.0;
  options.gradient_tolerance = 0.0;
  const SolveResult result = LbfgsSolver().Solve(abs, VecX::Constant(1, 1.0), options);
  EXPECT_EQ(result.status, SolveStatus::kLineSearchFailed) << result.BriefReport();
  EXPECT_LE(std::abs(result.x[0]), 1e-6);
}

TEST(LbfgsSolverTest, IsRegisteredAndRejectsAnArgument) {
  ASSERT_TRUE(RegisterBuiltinSolvers().ok());
  ASSERT_TRUE(RegisterBuiltinSolvers().ok());  // idempotent
  core::Result<std::unique_ptr<opt::Solver>> solver = opt::CreateSolver("lbfgs");
  ASSERT_TRUE(solver.ok()) << solver.status().message();
  EXPECT_EQ((*solver)->name(), "lbfgs");
  EXPECT_TRUE((*solver)->available());
  EXPECT_FALSE(opt::CreateSolver("lbfgs:fast").ok());
  const core::Result<std::unique_ptr<opt::Solver>> unknown = opt::CreateSolver("lbgfs");
  EXPECT_EQ(unknown.status().code(), core::StatusCode::kNotFound);
  EXPECT_NE(unknown.status().message().find("lbfgs"), std::string::npos);
}

}  // namespace
}  // namespace quadhand::solvers
