// Ipopt (interior-point filter line search; here without constraints or
// bounds, so it is a quasi-Newton method with a backtracking Armijo line
// search) behind opt::Solver; registered as "ipopt". The problem is posed as
// an NLP with n variables, no bounds and m = 0 constraints: the planner's
// unconstrained penalty formulation. The Hessian is Ipopt's limited-memory
// approximation, so only cost and gradient are needed; the linear solver is
// MUMPS. When Ipopt was not found at build time the class still exists,
// available() is false and Solve() returns kNotAvailable.
//
// Mapping of opt::SolverOptions (docs/solvers.md has the full table):
//   gradient_tolerance      -> tol and dual_inf_tol (with nlp_scaling_method
//                              none and m = 0 Ipopt's optimality error is
//                              |g|inf, the same test as lbfgs; tol must be
//                              > 0, so 0 becomes the smallest normal double)
//   relative_cost_tolerance, relative_cost_window -> the same windowed test
//                              as lbfgs, in intermediate_callback; Ipopt's
//                              "acceptable" heuristic is off (acceptable_iter 0)
//   max_iterations          -> max_iter (and checked in the callback)
//   max_time_seconds        -> checked in the callback once per iteration
//                              (wall time); max_cpu_time = the same value as
//                              a second guard
//   memory_size             -> limited_memory_max_history
//   line_search_*           -> not used (Ipopt's own filter line search)
//   verbosity               -> one line per iteration through core::LogInfo
//                              at 2; Ipopt itself prints nothing
// eval_f evaluates cost and gradient together (one Objective::Evaluate per
// point; eval_grad_f at the same point is answered from a cache). A failed or
// non-finite evaluation makes eval_f return false, which Ipopt's line search
// answers by cutting the step.
#pragma once

#include <string>

#include "quadhand/core/status.h"
#include "quadhand/opt/solver.h"

namespace quadhand::solvers {

class IpoptSolver final : public opt::Solver {
 public:
  std::string name() const override { return "ipopt"; }
  bool available() const override;

 protected:
  void DoSolve(const opt::Objective& objective, const VecX& x0,
               const opt::SolverOptions& options, opt::SolveResult* result) const override;
};

// Registers "ipopt" in the opt solver registry (it takes no ":argument").
// Registered also when Ipopt is absent (available() == false). Safe to call
// any number of times, from any thread.
core::Status RegisterIpoptSolver();

}  // namespace quadhand::solvers
