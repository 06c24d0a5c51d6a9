// The shared unconstrained test problems that every opt::Solver back-end runs
// (Drake's habit: one list, one parameterised test per back-end). Each has a
// known minimiser, a standard start and the accuracy a back-end must reach.
//
// A back-end's test does:
//   class MySolverTest : public ::testing::TestWithParam<SolverProblem> {};
//   TEST_P(MySolverTest, SolvesSharedProblem) { ExpectSolves(MySolver(), GetParam()); }
//   INSTANTIATE_TEST_SUITE_P(Shared, MySolverTest, ::testing::ValuesIn(SharedSolverProblems()),
//                            SolverProblemName);
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <memory>
#include <ostream>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>

#include "quadhand/core/types.h"
#include "quadhand/opt/objective.h"
#include "quadhand/opt/solver.h"

namespace quadhand::testing {

struct SolverProblem {
  std::string name;  // [A-Za-z0-9_], used as the gtest parameter name
  std::shared_ptr<const opt::Objective> objective;
  VecX x0;
  VecX x_star;      // the (unique) minimiser
  double f_star;    // the minimum
  // Accuracy required of |x - x*|_inf and |f - f*|.
  double x_tolerance;
  double cost_tolerance;
  // Nonsmooth problems may also end with kLineSearchFailed at the kink.
  bool nonsmooth = false;
  // Options for this problem; back-ends map them as well as they can.
  opt::SolverOptions options;
};

// Deterministic uniform numbers in [-1, 1] on every platform (std::
// distributions are not portable; mt19937 itself is).
class PortableRandom {
 public:
  explicit PortableRandom(std::uint32_t seed) : engine_(seed) {}
  double Uniform() { return 2.0 * (static_cast<double>(engine_()) / 4294967295.0) - 1.0; }
  MatX Matrix(int rows, int cols) {
    MatX m(rows, cols);
    for (int j = 0; j < cols; ++j)
      for (int i = 0; i < rows; ++i) m(i, j) = Uniform();
    return m;
  }
  VecX Vector(int n) { return Matrix(n, 1); }

 private:
  std::mt19937 engine_;
};

// Extended Rosenbrock: sum over pairs of 100 (x_{2i+1} - x_{2i}^2)^2 + (1 - x_{2i})^2
// (n even; n = 2 is the classic function). Minimiser 1, minimum 0.
class ExtendedRosenbrock final : public opt::Objective {
 public:
  explicit ExtendedRosenbrock(int n) : n_(n) {}
  int num_variables() const override { return n_; }

 protected:
  bool DoEvaluate(const VecX& x, double* cost, VecX* grad) const override {
    *cost = 0.0;
    for (int i = 0; i + 1 < n_; i += 2) {
      const double a = x[i + 1] - x[i] * x[i];
      const double b = 1.0 - x[i];
      *cost += 100.0 * a * a + b * b;
      if (grad != nullptr) {
        (*grad)[i] = -400.0 * x[i] * a - 2.0 * b;
        (*grad)[i + 1] = 200.0 * a;
      }
    }
    return true;
  }

 private:
  int n_;
};

// 0.5 x'Ax - b'x with A symmetric positive definite.
class ConvexQuadratic final : public opt::Objective {
 public:
  ConvexQuadratic(MatX a, VecX b) : a_(std::move(a)), b_(std::move(b)) {}
  int num_variables() const override { return static_cast<int>(b_.size()); }
  const MatX& a() const { return a_; }
  const VecX& b() const { return b_; }

 protected:
  bool DoEvaluate(const VecX& x, double* cost, VecX* grad) const override {
    const VecX ax = a_ * x;
    *cost = 0.5 * x.dot(ax) - b_.dot(x);
    if (grad != nullptr) *grad = ax - b_;
    return true;
  }

 private:
  MatX a_;
  VecX b_;
};

// sum_i w_i sqrt(((Bx)_i - c_i)^2 + mu^2): a smoothed weighted L1 distance,
// curvature ~ w/mu at the minimiser x* = B^-1 c and ~ 0 away from it.
class SmoothedAbs final : public opt::Objective {
 public:
  SmoothedAbs(MatX b, VecX c, VecX w, double mu)
      : b_(std::move(b)), c_(std::move(c)), w_(std::move(w)), mu_(mu) {}
  int num_variables() const override { return static_cast<int>(c_.size()); }

 protected:
  bool DoEvaluate(const VecX& x, double* cost, VecX* grad) const override {
    const VecX r = b_ * x - c_;
    VecX dr(r.size());
    *cost = 0.0;
    for (int i = 0; i < r.size(); ++i) {
      const double root = std::sqrt(r[i] * r[i] + mu_ * mu_);
      *cost += w_[i] * root;
      dr[i] = w_[i] * r[i] / root;
    }
    if (grad != nullptr) *grad = b_.transpose() * dr;
    return true;
  }

 private:
  MatX b_;
  VecX c_;
  VecX w_;
  double mu_;
};

// max_j |x - a_j|^2 over a_j = +-e_i, which equals |x|^2 + 1 + 2 |x|_inf:
// nonsmooth at its minimiser 0 (minimum 1). The gradient returned at a tie is
// that of the first active piece.
class MaxOfQuadratics final : public opt::Objective {
 public:
  explicit MaxOfQuadratics(int n) : n_(n) {}
  int num_variables() const override { return n_; }

 protected:
  bool DoEvaluate(const VecX& x, double* cost, VecX* grad) const override {
    double best = -1.0;
    VecX best_center = VecX::Zero(n_);
    VecX center = VecX::Zero(n_);
    for (int i = 0; i < n_; ++i) {
      for (double sign : {1.0, -1.0}) {
        center.setZero();
        center[i] = sign;
        const double value = (x - center).squaredNorm();
        if (value > best) {
          best = value;
          best_center = center;
        }
      }
    }
    *cost = best;
    if (grad != nullptr) *grad = 2.0 * (x - best_center);
    return true;
  }

 private:
  int n_;
};

// Tight defaults for the shared problems: they ask for accurate minimisers.
inline opt::SolverOptions SharedProblemOptions() {
  opt::SolverOptions options;
  options.max_iterations = 2000;
  options.gradient_tolerance = 1e-9;
  options.relative_cost_tolerance = 1e-15;
  options.max_time_seconds = 60.0;  // a guard against hangs, never reached
  return options;
}

inline std::vector<SolverProblem> SharedSolverProblems() {
  std::vector<SolverProblem> problems;

  {
    SolverProblem p;
    p.name = "rosenbrock_2d";
    p.objective = std::make_shared<ExtendedRosenbrock>(2);
    p.x0 = (VecX(2) << -1.2, 1.0).finished();
    p.x_star = VecX::Ones(2);
    p.f_star = 0.0;
    p.x_tolerance = 1e-5;
    p.cost_tolerance = 1e-10;
    p.options = SharedProblemOptions();
    problems.push_back(p);
  }
  {
    SolverProblem p;
    const int n = 100;
    p.name = "rosenbrock_100d";
    p.objective = std::make_shared<ExtendedRosenbrock>(n);
    p.x0.resize(n);
    for (int i = 0; i < n; ++i) p.x0[i] = i % 2 == 0 ? -1.2 : 1.0;
    p.x_star = VecX::Ones(n);
    p.f_star = 0.0;
    p.x_tolerance = 1e-5;
    p.cost_tolerance = 1e-9;
    p.options = SharedProblemOptions();
    problems.push_back(p);
  }
  {
    SolverProblem p;
    const int n = 50;
    PortableRandom random(20240611);
    const MatX m = random.Matrix(n, n);
    // Eigenvalues in about [0.10, 1.32]: condition number ~ 13.
    const MatX a = m * m.transpose() / n + 0.1 * MatX::Identity(n, n);
    const VecX b = random.Vector(n);
    p.name = "convex_quadratic_50d";
    p.objective = std::make_shared<ConvexQuadratic>(a, b);
    p.x0 = VecX::Zero(n);
    p.x_star = a.ldlt().solve(b);
    p.f_star = -0.5 * b.dot(p.x_star);
    p.x_tolerance = 1e-6;
    p.cost_tolerance = 1e-10;
    p.options = SharedProblemOptions();
    problems.push_back(p);
  }
  {
    SolverProblem p;
    const int n = 10;
    MatX b = MatX::Identity(n, n);
    for (int i = 0; i + 1 < n; ++i) b(i, i + 1) = 0.5;
    VecX c(n);
    VecX w(n);
    for (int i = 0; i < n; ++i) {
      c[i] = 0.3 * (i + 1) * (i % 2 == 0 ? 1.0 : -1.0);
      w[i] = 1.0 + 0.2 * i;
    }
    const double mu = 1e-3;
    p.name = "smoothed_abs_10d";
    p.objective = std::make_shared<SmoothedAbs>(b, c, w, mu);
    p.x0 = VecX::Constant(n, 2.0);
    p.x_star = b.triangularView<Eigen::Upper>().solve(c);
    p.f_star = w.sum() * mu;
    p.x_tolerance = 1e-5;
    p.cost_tolerance = 1e-8;
    p.options = SharedProblemOptions();
    problems.push_back(p);
  }
  {
    SolverProblem p;
    const int n = 5;
    p.name = "max_of_quadratics_5d";
    p.objective = std::make_shared<MaxOfQuadratics>(n);
    p.x0 = (VecX(n) << 0.9, -0.4, 0.3, 0.7, -0.8).finished();
    p.x_star = VecX::Zero(n);
    p.f_star = 1.0;
    p.x_tolerance = 1e-4;
    p.cost_tolerance = 1e-4;
    p.nonsmooth = true;
    p.options = SharedProblemOptions();
    problems.push_back(p);
  }
  return problems;
}

// gtest parameter names.
inline std::string SolverProblemName(const ::testing::TestParamInfo<SolverProblem>& info) {
  return info.param.name;
}
inline void PrintTo(const SolverProblem& problem, std::ostream* os) { *os << problem.name; }

// Solves `problem` with its options and checks status and accuracy; returns
// the result (also printed as one line) for further checks.
inline opt::SolveResult ExpectSolves(const opt::Solver& solver, const SolverProblem& problem) {
  const opt::SolveResult result = solver.Solve(*problem.objective, problem.x0, problem.options);
  std::cout << "[ shared   ] " << problem.name << ": " << result.BriefReport();
  if (result.x.size() == problem.x_star.size())
    std::cout << " |x-x*|inf " << (result.x - problem.x_star).lpNorm<Eigen::Infinity>();
  std::cout << "\n";
  const bool acceptable_status =
      result.status == opt::SolveStatus::kConverged ||
      (problem.nonsmooth && result.status == opt::SolveStatus::kLineSearchFailed);
  EXPECT_TRUE(acceptable_status) << result.BriefReport();
  EXPECT_EQ(result.x.size(), problem.x_star.size());
  if (result.x.size() == problem.x_star.size()) {
    EXPECT_LE((result.x - problem.x_star).lpNorm<Eigen::Infinity>(), problem.x_tolerance)
        << result.BriefReport();
  }
  EXPECT_NEAR(result.cost, problem.f_star, problem.cost_tolerance) << result.BriefReport();
  EXPECT_GT(result.evaluations, 0);
  EXPECT_GE(result.evaluations, result.iterations);
  return result;
}

}  // namespace quadhand::testing
