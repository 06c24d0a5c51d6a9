#include "quadhand/opt/numeric_diff.h"

#include <gtest/gtest.h>

#include <cmath>

#include "support/solver_problems.h"

namespace quadhand::opt {
namespace {

// f = sum_i sin(x_i) x_{i+1} + exp(x_0); `wrong_index` >= 0 perturbs that gradient entry.
FunctionObjective Wavy(int n, int wrong_index = -1) {
  return FunctionObjective(n, [n, wrong_index](const VecX& x, double* cost, VecX* grad) {
    *cost = std::exp(x[0]);
    if (grad != nullptr) {
      grad->setZero();
      (*grad)[0] = std::exp(x[0]);
    }
    for (int i = 0; i + 1 < n; ++i) {
      *cost += std::sin(x[i]) * x[i + 1];
      if (grad != nullptr) {
        (*grad)[i] += std::cos(x[i]) * x[i + 1];
        (*grad)[i + 1] += std::sin(x[i]);
      }
    }
    if (grad != nullptr && wrong_index >= 0) (*grad)[wrong_index] *= 1.01;
    return true;
  });
}

TEST(NumericGradientTest, MatchesAnalyticGradientAtRandomPoints) {
  const FunctionObjective f = Wavy(6);
  testing::PortableRandom random(7);
  for (int trial = 0; trial < 5; ++trial) {
    const VecX x = 3.0 * random.Vector(6);
    const core::Result<VecX> numeric = NumericGradient(f, x);
    ASSERT_TRUE(numeric.ok()) << numeric.status().message();
    VecX analytic;
    double cost = 0.0;
    ASSERT_TRUE(f.Evaluate(x, &cost, &analytic));
    EXPECT_LE((*numeric - analytic).lpNorm<Eigen::Infinity>(), 1e-8);
  }
}

TEST(NumericGradientTest, ReportsBadInputAndFailedEvaluations) {
  const FunctionObjective f = Wavy(3);
  EXPECT_EQ(NumericGradient(f, VecX::Zero(2)).status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(NumericGradient(f, VecX::Zero(3), 0.0).status().code(),
            core::StatusCode::kInvalidArgument);
  const FunctionObjective positive_only(1, [](const VecX& x, double* cost, VecX*) {
    *cost = std::log(x[0]);
    return x[0] > 0.0;
  });
  EXPECT_EQ(NumericGradient(positive_only, VecX::Zero(1)).status().code(),
            core::StatusCode::kInternal);
  EXPECT_TRUE(NumericGradient(positive_only, VecX::Ones(1)).ok());
}

TEST(NumericJacobianTest, MatchesAnalyticJacobian) {
  // F(x) = (x0 x1, sin(x2), x0 + 2 x2)
  const VectorFunction f = [](const VecX& x, VecX* y) {
    *y = (VecX(3) << x[0] * x[1], std::sin(x[2]), x[0] + 2.0 * x[2]).finished();
    return true;
  };
  const VecX x = (VecX(3) << 0.5, -1.5, 2.0).finished();
  MatX expected(3, 3);
  expected << x[1], x[0], 0.0, 0.0, 0.0, std::cos(x[2]), 1.0, 0.0, 2.0;
  const core::Result<MatX> jacobian = NumericJacobian(f, x);
  ASSERT_TRUE(jacobian.ok()) << jacobian.status().message();
  EXPECT_LE((*jacobian - expected).cwiseAbs().maxCoeff(), 1e-8);

  const VectorFunction varies = [](const VecX& v, VecX* y) {
    *y = VecX::Zero(v[0] > 0.0 ? 2 : 1);
    return true;
  };
  EXPECT_EQ(NumericJacobian(varies, VecX::Zero(1)).status().code(), core::StatusCode::kInternal);
}

TEST(GradientCheckTest, PassesACorrectGradient) {
  const core::Result<GradientCheckReport> report =
      GradientCheck(Wavy(5), (VecX(5) << 0.1, -0.7, 1.3, 2.0, -2.5).finished());
  ASSERT_TRUE(report.ok()) << report.status().message();
  EXPECT_TRUE(report->passed) << report->Describe();
  EXPECT_LE(report->max_relative_error, 1e-7);
  EXPECT_EQ(report->relative_error.size(), 5);
}

TEST(GradientCheckTest, FindsTheWrongComponent) {
  const VecX x = (VecX(5) << 0.1, -0.7, 1.3, 2.0, -2.5).finished();
  const core::Result<GradientCheckReport> report = GradientCheck(Wavy(5, /*wrong_index=*/3), x);
  ASSERT_TRUE(report.ok()) << report.status().message();
  EXPECT_FALSE(report->passed);
  EXPECT_EQ(report->worst_index, 3);
  EXPECT_GT(report->max_relative_error, 1e-3);
  EXPECT_NE(report->Describe().find("index 3"), std::string::npos) << report->Describe();
}

TEST(GradientCheckTest, SharedProblemsHaveCorrectGradients) {
  testing::PortableRandom random(11);
  for (const testing::SolverProblem& problem : testing::SharedSolverProblems()) {
    // Random points, away from the kinks of the nonsmooth problem.
    const VecX x = problem.x0 + 0.5 * random.Vector(static_cast<int>(problem.x0.size()));
    const core::Result<GradientCheckReport> report = GradientCheck(*problem.objective, x);
    ASSERT_TRUE(report.ok()) << problem.name << ": " << report.status().message();
    EXPECT_TRUE(report->passed) << problem.name << ": " << report->Describe();
  }
}

}  // namespace
}  // namespace quadhand::opt
