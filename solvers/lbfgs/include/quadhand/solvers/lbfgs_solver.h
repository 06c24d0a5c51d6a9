// Limited-memory BFGS for smooth and piecewise-smooth costs, with no
// third-party dependency; registered as "lbfgs".
//
// Each iteration takes the two-loop-recursion direction d = -H g (H0 scaled by
// s'y / y'y of the newest pair; steepest descent when there is no pair, with a
// first trial step of min(1, 1/|d|)). The line search is the bracketing and
// bisection search of Lewis & Overton (2013), "Nonsmooth optimization via
// quasi-Newton methods": it doubles the step until the weak Wolfe condition
// holds and bisects once a step fails Armijo, which suits costs with kinks.
// A failed or non-finite evaluation counts as a failed Armijo test (step too
// long). When the search ends with an Armijo-only step, that step is taken.
// Pairs are stored only when s'y > 1e-6 |s|^2 |g| (cautious update of
// Li & Fukushima, 2001), which keeps H positive definite on non-convex costs.
// When no step satisfies Armijo, the memory is dropped and steepest descent is
// tried once before returning kLineSearchFailed.
//
// Uses every field of opt::SolverOptions. A timeout is checked before each
// iteration and between trial steps.
#pragma once

#include <string>

#include "quadhand/core/status.h"
#include "quadhand/opt/solver.h"

namespace quadhand::solvers {

class LbfgsSolver final : public opt::Solver {
 public:
  std::string name() const override { return "lbfgs"; }
  bool available() const override { return true; }

 protected:
  void DoSolve(const opt::Objective& objective, const VecX& x0,
               const opt::SolverOptions& options, opt::SolveResult* result) const override;
};

// Registers "lbfgs" in the opt solver registry (it takes no ":argument").
// Safe to call any number of times, from any thread.
core::Status RegisterLbfgsSolver();

}  // namespace quadhand::solvers
