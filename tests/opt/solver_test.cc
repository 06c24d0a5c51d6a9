// SolverOptions, SolveResult, the checks of Solver::Solve and the registry.
#include "quadhand/opt/solver.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include "quadhand/opt/solver_registry.h"

namespace quadhand::opt {
namespace {

TEST(SolverOptionsTest, DefaultsAreValidAndBadFieldsAreNamed) {
  std::string why;
  EXPECT_TRUE(SolverOptions().IsValid(&why)) << why;
  EXPECT_TRUE(SolverOptions().IsValid(nullptr));

  SolverOptions options;
  options.line_search_c2 = options.line_search_c1 / 2.0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("line_search_c2"), std::string::npos) << why;

  options = SolverOptions();
  options.max_time_seconds = 0.0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("max_time_seconds"), std::string::npos) << why;

  options = SolverOptions();
  options.memory_size = 0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("memory_size"), std::string::npos) << why;

  options = SolverOptions();
  options.relative_cost_tolerance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(options.IsValid(nullptr));
}

TEST(SolveResultTest, NamesEveryStatusAndReportsOnOneLine) {
  for (SolveStatus status :
       {SolveStatus::kConverged, SolveStatus::kMaxIterations, SolveStatus::kTimeout,
        SolveStatus::kLineSearchFailed, SolveStatus::kEvaluationFailed,
        SolveStatus::kNotAvailable, SolveStatus::kInvalidInput}) {
    EXPECT_STRNE(SolveStatusName(status), "unknown");
  }
  SolveResult result;
  result.solver = "demo";
  result.status = SolveStatus::kTimeout;
  result.iterations = 7;
  result.evaluations = 9;
  result.message = "out of time";
  const std::string report = result.BriefReport();
  EXPECT_NE(report.find("demo: timeout"), std::string::npos) << report;
  EXPECT_NE(report.find("7 iterations, 9 evaluations"), std::string::npos) << report;
  EXPECT_NE(report.find("(out of time)"), std::string::npos) << report;
  EXPECT_EQ(report.find('\n'), std::string::npos);
}

// Evaluates x0 once and reports convergence; checks what reaches DoSolve.
class OneStepSolver final : public Solver {
 public:
  explicit OneStepSolver(bool is_available = true) : available_(is_available) {}
  std::string name() const override { return "one_step"; }
  bool available() const override { return available_; }
  mutable bool called = false;

 protected:
  void DoSolve(const Objective& objective, const VecX& x0, const SolverOptions&,
               SolveResult* result) const override {
    called = true;
    EXPECT_EQ(result->x, x0);
    VecX grad;
    if (!objective.Evaluate(x0, &result->cost, &grad)) {
      result->status = SolveStatus::kEvaluationFailed;
      return;
    }
    result->status = SolveStatus::kConverged;
  }

 private:
  bool available_;
};

FunctionObjective Quadratic(int n) {
  return FunctionObjective(n, [](const VecX& x, double* cost, VecX* grad) {
    *cost = x.squaredNorm();
    if (grad != nullptr) *grad = 2.0 * x;
    return true;
  });
}

TEST(SolverTest, RejectsBadInputWithoutEvaluating) {
  const OneStepSolver solver;
  const FunctionObjective f = Quadratic(2);
  SolveResult result = solver.Solve(f, VecX::Zero(3), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kInvalidInput);
  EXPECT_NE(result.message.find("x0 has 3 entries"), std::string::npos) << result.message;

  result = solver.Solve(f, (VecX(2) << 1.0, std::nan("")).finished(), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kInvalidInput);

  SolverOptions bad;
  bad.max_iterations = -1;
  result = solver.Solve(f, VecX::Zero(2), bad);
  EXPECT_EQ(result.status, SolveStatus::kInvalidInput);
  EXPECT_NE(result.message.find("max_iterations"), std::string::npos) << result.message;
  EXPECT_EQ(result.evaluations, 0);
  EXPECT_FALSE(solver.called);

  result = OneStepSolver(/*is_available=*/false).Solve(f, VecX::Zero(2), SolverOptions());
  EXPECT_EQ(result.status, SolveStatus::kNotAvailable);
  EXPECT_EQ(result.solver, "one_step");
}

TEST(SolverTest, CountsEvaluationsAndCatchesExceptions) {
  const OneStepSolver solver;
  const SolveResult ok = solver.Solve(Quadratic(2), VecX::Ones(2), SolverOptions());
  EXPECT_EQ(ok.status, SolveStatus::kConverged);
  EXPECT_EQ(ok.evaluations, 1);
  EXPECT_DOUBLE_EQ(ok.cost, 2.0);
  EXPECT_GE(ok.wall_time_seconds, 0.0);

  const FunctionObjective throws(1, [](const VecX&, double*, VecX*) -> bool {
    throw std::runtime_error("boom");
  });
  const SolveResult thrown = solver.Solve(throws, VecX::Zero(1), SolverOptions());
  EXPECT_EQ(thrown.status, SolveStatus::kEvaluationFailed);
  EXPECT_NE(thrown.message.find("boom"), std::string::npos) << thrown.message;
}

// The registry is process-wide: names here start with "test_" to stay apart
// from the built-in solvers.
TEST(SolverRegistryTest, CreatesByNameAndPassesTheArgument) {
  std::string seen_argument = "unset";
  ASSERT_TRUE(RegisterSolver("test_one_step", [&seen_argument](const std::string& argument)
                                                  -> core::Result<std::unique_ptr<Solver>> {
                seen_argument = argument;
                if (argument == "bad") return core::Status::InvalidArgument("bad argument");
                return std::unique_ptr<Solver>(std::make_unique<OneStepSolver>());
              }).ok());
  EXPECT_TRUE(IsSolverRegistered("test_one_step"));

  core::Result<std::unique_ptr<Solver>> solver = CreateSolver("test_one_step");
  ASSERT_TRUE(solver.ok()) << solver.status().message();
  EXPECT_EQ((*solver)->name(), "one_step");
  EXPECT_EQ(seen_argument, "");

  EXPECT_TRUE(CreateSolver("test_one_step:LD_MMA").ok());
  EXPECT_EQ(seen_argument, "LD_MMA");

  const core::Result<std::unique_ptr<Solver>> rejected = CreateSolver("test_one_step:bad");
  EXPECT_EQ(rejected.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(rejected.status().message().find("test_one_step:bad"), std::string::npos);

  const std::vector<std::string> names = SolverNames();
  EXPECT_NE(std::find(names.begin(), names.end(), "test_one_step"), names.end());
}

TEST(SolverRegistryTest, UnknownNamesListTheKnownOnes) {
  ASSERT_TRUE(RegisterSolver("test_listed", [](const std::string&)
                                                -> core::Result<std::unique_ptr<Solver>> {
                return std::unique_ptr<Solver>(std::make_unique<OneStepSolver>());
              }).ok());
  const core::Result<std::unique_ptr<Solver>> missing = CreateSolver("no_such_solver:x");
  EXPECT_EQ(missing.status().code(), core::StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find("unknown solver 'no_such_solver:x'"),
            std::string::npos)
      << missing.status().message();
  EXPECT_NE(missing.status().message().find("test_listed"), std::string::npos)
      << missing.status().message();
}

TEST(SolverRegistryTest, RejectsBadNamesAndDuplicates) {
  const SolverFactory factory = [](const std::string&) -> core::Result<std::unique_ptr<Solver>> {
    return std::unique_ptr<Solver>(std::make_unique<OneStepSolver>());
  };
  EXPECT_FALSE(RegisterSolver("", factory).ok());
  EXPECT_FALSE(RegisterSolver("a:b", factory).ok());
  EXPECT_FALSE(RegisterSolver("test_null", nullptr).ok());
  ASSERT_TRUE(RegisterSolver("test_duplicate", factory).ok());
  const core::Status again = RegisterSolver("test_duplicate", factory);
  EXPECT_EQ(again.code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(again.message().find("already registered"), std::string::npos);
}

}  // namespace
}  // namespace quadhand::opt
