// What a Solver returns: every ordinary outcome is a status, never an exception.
#pragma once

#include <limits>
#include <string>

#include "quadhand/core/types.h"

namespace quadhand::opt {

enum class SolveStatus {
  kConverged,         // a convergence test of SolverOptions was met
  kMaxIterations,     // SolverOptions::max_iterations reached
  kTimeout,           // SolverOptions::max_time_seconds reached
  kLineSearchFailed,  // no acceptable step along a descent direction
  kEvaluationFailed,  // Objective::Evaluate failed (or was not finite) where it must not
  kNotAvailable,      // the back-end was built without its library
  kInvalidInput,      // bad options, wrong x0 size, non-finite x0, ...
};

// Short lower-case name, e.g. "converged", "line search failed".
const char* SolveStatusName(SolveStatus status);

struct SolveResult {
  SolveStatus status = SolveStatus::kInvalidInput;
  std::string solver;  // name of the back-end that produced this result
  // Best point found (x0 when nothing was evaluated) and its cost (NaN when
  // it was never evaluated successfully).
  VecX x;
  double cost = std::numeric_limits<double>::quiet_NaN();
  double gradient_max_norm = std::numeric_limits<double>::quiet_NaN();  // |g(x)|_inf
  int iterations = 0;   // accepted steps
  int evaluations = 0;  // calls of Objective::Evaluate (cost and gradient together)
  double wall_time_seconds = 0.0;
  std::string message;  // why it stopped, in words

  // True for kConverged.
  bool converged() const { return status == SolveStatus::kConverged; }
  const char* StatusName() const { return SolveStatusName(status); }
  // One line: solver, status, cost, gradient norm, counts, time and message.
  std::string BriefReport() const;
};

}  // namespace quadhand::opt
