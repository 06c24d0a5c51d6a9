// Ceres Solver's line-search minimiser (ceres::GradientProblemSolver) behind
// opt::Solver; registered as "ceres" (L-BFGS directions) and "ceres:BFGS"
// (dense BFGS, for small problems). When Ceres was not found at build time the
// class still exists, available() is false and Solve() returns kNotAvailable.
//
// Mapping of opt::SolverOptions (docs/solvers.md has the full table):
//   max_iterations          -> max_num_iterations (and checked per iterate)
//   max_time_seconds        -> max_solver_time_in_seconds (checked once per
//                              iteration, so a line search can overshoot it)
//   gradient_tolerance      -> gradient_tolerance (Ceres tests |g|inf too)
//   relative_cost_tolerance, relative_cost_window -> the same windowed test
//                              as lbfgs, applied in an IterationCallback;
//                              Ceres' own single-step function_tolerance and
//                              parameter_tolerance are 0, so they stop it
//                              only at a step that changes neither the cost
//                              nor x (which Ceres reports as convergence)
//   memory_size             -> max_lbfgs_rank
//   line_search_c1, c2      -> sufficient function / curvature decrease of
//                              Ceres' WOLFE search (strong Wolfe conditions)
//   line_search_max_steps   -> max_num_line_search_step_size_iterations
//   verbosity               -> one line per iteration through core::LogInfo
//                              at 2; Ceres' own logging stays silent
// A failed or non-finite evaluation is reported to Ceres as a failed
// evaluation, which its line search treats as a step that is too long.
#pragma once

#include <string>

#include "quadhand/core/status.h"
#include "quadhand/opt/solver.h"

namespace quadhand::solvers {

class CeresSolver final : public opt::Solver {
 public:
  // The search direction of Ceres' line-search minimiser.
  enum class Direction {
    kLbfgs,  // limited-memory BFGS ("ceres", "ceres:LBFGS")
    kBfgs,   // dense BFGS, O(n^2) memory and time per step ("ceres:BFGS")
  };

  explicit CeresSolver(Direction direction = Direction::kLbfgs) : direction_(direction) {}

  // "ceres" or "ceres:BFGS".
  std::string name() const override;
  bool available() const override;
  Direction direction() const { return direction_; }

 protected:
  void DoSolve(const opt::Objective& objective, const VecX& x0,
               const opt::SolverOptions& options, opt::SolveResult* result) const override;

 private:
  Direction direction_;
};

// Registers "ceres" in the opt solver registry. Its argument is empty,
// "LBFGS" or "BFGS"; anything else is InvalidArgument. Registered also when
// Ceres is absent (the solver then reports available() == false). Safe to
// call any number of times, from any thread.
core::Status RegisterCeresSolver();

}  // namespace quadhand::solvers
