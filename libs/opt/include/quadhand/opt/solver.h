// The interface every optimisation back-end implements (solvers/<name>/).
#pragma once

#include <string>

#include "quadhand/core/types.h"
#include "quadhand/opt/objective.h"
#include "quadhand/opt/solve_result.h"
#include "quadhand/opt/solver_options.h"

namespace quadhand::opt {

// Minimises an Objective without constraints from a starting point.
//
// Solve() is non-virtual: it checks what every back-end would check and then
// calls DoSolve(). It returns kNotAvailable when available() is false, and
// kInvalidInput for invalid options, n < 1, x0.size() != n or a non-finite x0
// (each without evaluating the objective). It counts the evaluations, turns an
// exception thrown by the objective into a failed evaluation, and fills
// SolveResult::solver, evaluations and wall_time_seconds itself.
class Solver {
 public:
  virtual ~Solver() = default;

  // Registry name, e.g. "lbfgs" or "nlopt:LD_MMA".
  virtual std::string name() const = 0;

  // False when the back-end's library was not found at build time; Solve()
  // then returns kNotAvailable.
  virtual bool available() const = 0;

  SolveResult Solve(const Objective& objective, const VecX& x0,
                    const SolverOptions& options) const;

 protected:
  // Called only with valid options and a finite x0 of size n >= 1. Fills
  // status, x, cost, gradient_max_norm, iterations and message of *result
  // (which arrives with x = x0). Must not throw.
  virtual void DoSolve(const Objective& objective, const VecX& x0,
                       const SolverOptions& options, SolveResult* result) const = 0;
};

}  // namespace quadhand::opt
