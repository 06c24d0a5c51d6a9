// NLopt's gradient-based local algorithms (through its C++ API) behind
// opt::Solver; registered as "nlopt" (LD_LBFGS) and "nlopt:ALGORITHM" for any
// of SupportedAlgorithms(), named as NLopt names them without the NLOPT_
// prefix (e.g. "nlopt:LD_MMA"). When NLopt was not found at build time the
// class still exists, available() is false and Solve() returns kNotAvailable.
//
// NLopt reports no iterations, only evaluations. Here an iteration is an
// evaluation that lowers the best cost found so far (the first evaluation,
// at x0, is iteration 0); SolverOptions' tests are applied at those points.
// Mapping of opt::SolverOptions (docs/solvers.md has the full table):
//   gradient_tolerance      -> |g|inf at each new best point (NLopt has no
//                              gradient test of its own to set)
//   relative_cost_tolerance, relative_cost_window -> the same windowed test
//                              as lbfgs over the sequence of best costs;
//                              ftol_rel stays unset, xtol_rel is machine
//                              epsilon (it stops only a step that leaves x
//                              unchanged); some algorithms have built-in
//                              tests of their own (e.g. LD_LBFGS stops at
//                              |g|inf <= 1e-8), reported as converged
//   max_iterations          -> cap on new best points (maxeval stays unset)
//   line_search_max_steps   -> n + line_search_max_steps evaluations in a
//                              row without a new best point end the solve
//                              (line search failed, or evaluation failed
//                              when they all failed): room for one
//                              truncated-Newton step of n Hessian-vector
//                              products plus a line search
//   max_time_seconds        -> checked at every evaluation, and maxtime
//   memory_size             -> vector_storage (LBFGS, VAR1/2, TNEWTON*)
//   line_search_c1, c2      -> not used (each algorithm has its own search)
//   verbosity               -> one line per new best point at 2
// Luksan's codes (LD_LBFGS, LD_VAR1/2, LD_TNEWTON*) see the cost scaled by
// 1 / max(1, |g(x0)|inf): they try a unit first step along -g, hopeless on
// costs with gradients of order 1e6. Results and tests use the true cost.
// A failed or non-finite evaluation is returned to NLopt as cost +infinity
// (and a zero gradient), which its line searches treat as a step too long.
// The solve is stopped with nlopt::opt::force_stop() when a test is met.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/opt/solver.h"

namespace quadhand::solvers {

class NloptSolver final : public opt::Solver {
 public:
  static constexpr const char* kDefaultAlgorithm = "LD_LBFGS";

  // `algorithm` is one of SupportedAlgorithms() (empty: kDefaultAlgorithm).
  // InvalidArgument, saying why, for an unknown name, a derivative-free one
  // (LN_*, GN_*), a global one (GD_*: they need finite bounds) and the
  // meta-algorithms that need a subsidiary optimiser (AUGLAG, MLSL).
  static core::Result<std::unique_ptr<NloptSolver>> Create(const std::string& algorithm);

  // The gradient-based local algorithms that run without constraints or
  // bounds: LD_LBFGS, LD_MMA, LD_CCSAQ, LD_SLSQP, LD_VAR1, LD_VAR2,
  // LD_TNEWTON, LD_TNEWTON_RESTART, LD_TNEWTON_PRECOND,
  // LD_TNEWTON_PRECOND_RESTART.
  static std::vector<std::string> SupportedAlgorithms();

  // "nlopt:" + algorithm(), e.g. "nlopt:LD_LBFGS".
  std::string name() const override { return "nlopt:" + algorithm_; }
  bool available() const override;
  const std::string& algorithm() const { return algorithm_; }

 protected:
  void DoSolve(const opt::Objective& objective, const VecX& x0,
               const opt::SolverOptions& options, opt::SolveResult* result) const override;

 private:
  explicit NloptSolver(std::string algorithm) : algorithm_(std::move(algorithm)) {}

  std::string algorithm_;
};

// Registers "nlopt" in the opt solver registry; its argument is passed to
// NloptSolver::Create. Registered also when NLopt is absent (available() ==
// false, the names are still checked). Safe to call any number of times,
// from any thread.
core::Status RegisterNloptSolver();

}  // namespace quadhand::solvers
