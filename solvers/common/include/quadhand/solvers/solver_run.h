// Bookkeeping for one solve of a back-end that wraps a third-party optimiser
// (ceres, ipopt, nlopt), so that every back-end stops by the same rules and
// reports the same way (docs/solvers.md).
//
// The wrapper routes every evaluation through Evaluate() and reports every
// iterate its library accepts to AcceptIterate(), which applies the tests of
// opt::SolverOptions in the order LbfgsSolver applies them: gradient,
// relative cost decrease over the window, iteration cap, time cap. The
// wrapper then stops its library the library's way and calls Finish().
// Not thread-safe; one SolverRun per DoSolve() call.
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include "quadhand/core/types.h"
#include "quadhand/opt/objective.h"
#include "quadhand/opt/solve_result.h"
#include "quadhand/opt/solver_options.h"

namespace quadhand::solvers {

class SolverRun {
 public:
  // Why AcceptIterate() asks to stop (kNone: go on).
  enum class Stop {
    kNone,
    kConverged,
    kMaxIterations,
    kTimeout,
    kLineSearchFailed,
    kEvaluationFailed,
  };

  // `label` prefixes the per-iteration lines printed at verbosity 2.
  SolverRun(const opt::Objective& objective, const opt::SolverOptions& options, std::string label);

  int num_variables() const { return n_; }
  const opt::SolverOptions& options() const { return options_; }

  // Seconds since construction, what is left of max_time_seconds (never
  // negative; infinity without a limit), and whether the limit is reached.
  double Elapsed() const;
  double RemainingSeconds() const;
  bool TimeUp() const;

  // f(x) and, when `grad` is not null, df/dx (n values each way). False when
  // the objective failed or its cost or gradient was not finite. A point
  // evaluated among the last few calls is answered from a cache (exact match
  // of x; a cached failure stays a failure), so a library that evaluates its
  // accepted point twice costs one Objective::Evaluate.
  bool Evaluate(const double* x, double* cost, double* grad);

  // Evaluations that reached the objective (cache answers excluded) since
  // the last accepted iterate, by outcome.
  int successes_since_iterate() const { return successes_since_iterate_; }
  int failures_since_iterate() const { return failures_since_iterate_; }
  // True when evaluations were tried since the last iterate and all failed.
  bool OnlyFailuresSinceIterate() const {
    return failures_since_iterate_ > 0 && successes_since_iterate_ == 0;
  }

  // x of the most recent successful evaluation whose cost is exactly `cost`
  // (null when none is cached), for libraries that report an iterate's cost
  // but not its x. Valid until the next Evaluate().
  const double* RecentPointWithCost(double cost) const;

  // Records an iterate the library accepted: the first call is x0 (iteration
  // 0), each later call one accepted step. `x` may be null when the library
  // does not expose it (the last known x is kept); `gradient_max_norm` may be
  // NaN when unknown (the gradient test is then skipped). When x is given and
  // its gradient is cached, |g|inf is computed from it instead (libraries
  // differ in rounding). Returns the first test that is met, with its reason
  // in stop_message(). Once a stop is recorded, later calls change nothing
  // and return it (a library may evaluate a little after being told to stop).
  Stop AcceptIterate(const double* x, double cost, double gradient_max_norm);

  // The gradient of the last accepted iterate arrived later (a library that
  // asks for the cost first): records its |g|inf and applies the gradient
  // test. Ignored when x is not the last accepted iterate.
  Stop RefineIterateGradient(const double* x, double gradient_max_norm);

  // For libraries that are stopped between evaluations: when the time limit
  // is reached, records kTimeout (as AcceptIterate would) and returns true.
  // This and StopIfStalled return true, changing nothing, once any stop is
  // recorded.
  bool StopIfTimeUp();
  // For libraries that do not say which evaluations are line-search trials:
  // when `limit` evaluations that reached the objective have passed since the
  // last accepted iterate, records kEvaluationFailed when they all failed and
  // kLineSearchFailed otherwise, and returns true.
  bool StopIfStalled(int limit);

  // Accepted steps so far (AcceptIterate calls minus one, at least 0).
  int iterations() const { return iterations_; }
  bool has_iterate() const { return has_iterate_; }
  Stop stop() const { return stop_; }
  const std::string& stop_message() const { return stop_message_; }

  // The library's final point, when it reports one: its cost and gradient
  // come from the cache (one more evaluation when they are not there). When
  // `counts_as_step` and x differs from the last accepted iterate, it counts
  // as one more accepted step (a library that stops on its own test before
  // showing the iterate to the wrapper). Ignored when x cannot be evaluated.
  void SetFinalPoint(const double* x, bool counts_as_step);

  // Fills status, message, x, cost, gradient_max_norm and iterations of
  // *result from the final point (SetFinalPoint) or else the last accepted
  // iterate; x stays x0 and the cost NaN when no iterate with a known x was
  // accepted.
  void Finish(opt::SolveStatus status, std::string message, opt::SolveResult* result) const;

  // The SolveStatus matching a Stop other than kNone.
  static opt::SolveStatus StatusOf(Stop stop);

 private:
  struct CachedPoint {
    VecX x;
    double cost = 0.0;
    VecX grad;
    bool has_grad = false;
    bool ok = false;
  };
  const CachedPoint* Find(const double* x, bool need_grad) const;
  bool GradientTest(double gradient_max_norm);  // records kConverged when met
  bool SameX(const VecX& a, const double* b) const;

  const opt::Objective& objective_;
  const opt::SolverOptions& options_;
  std::string label_;
  int n_;
  std::chrono::steady_clock::time_point start_;

  std::vector<CachedPoint> cache_;  // ring of recent evaluations
  int cache_next_ = 0;
  int successes_since_iterate_ = 0;
  int failures_since_iterate_ = 0;

  bool has_iterate_ = false;
  VecX x_;  // last accepted iterate (or final point)
  bool x_known_ = false;
  double cost_ = 0.0;
  double gradient_max_norm_ = 0.0;
  int iterations_ = 0;
  std::vector<double> costs_;  // cost of each accepted iterate, from x0 on
  Stop stop_ = Stop::kNone;
  std::string stop_message_;
};

}  // namespace quadhand::solvers
