// NloptSolver with NLopt: the only translation unit that includes nlopt.hpp.
#include "quadhand/solvers/nlopt_solver.h"

#include <nlopt.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "quadhand/solvers/solver_run.h"

namespace quadhand::solvers {
namespace {

using opt::SolveStatus;

struct Context {
  SolverRun* run;
  nlopt::opt* optimizer;
  int stall_limit;  // evaluations without a new best point before giving up
  bool scale_by_first_gradient = false;
  double scale = 1.0;  // NLopt sees scale * cost; our tests see the cost itself
  double best = HUGE_VAL;
};

// Luksan's codes in NLopt (LBFGS, VAR1/2, the truncated-Newton family) try a
// first step of unit length along -g and give up after ten halvings, so on a
// cost whose gradient is of order 1e6 (the planner's, at its initial guess)
// they never take a step. They get the cost multiplied by 1 / max(1, |g(x0)|inf),
// which makes that first trial step move no variable by more than 1: the
// minimiser is the same; their built-in gradient test (|g|inf <= 1e-8 on what
// they see) becomes 1e-8 / scale on the true gradient.
bool StartsWithUnitStep(const std::string& algorithm) {
  return algorithm == "LD_LBFGS" || algorithm == "LD_VAR1" || algorithm == "LD_VAR2" ||
         algorithm.rfind("LD_TNEWTON", 0) == 0;
}

// The cost as NLopt sees it. A new best point is an iterate for the
// SolverRun; when one of its tests is met, NLopt is asked to stop.
double Cost(const std::vector<double>& x, std::vector<double>& grad, void* data) {
  Context& context = *static_cast<Context*>(data);
  SolverRun& run = *context.run;
  const bool want_gradient = !grad.empty();
  double cost = 0.0;
  if (!run.Evaluate(x.data(), &cost, want_gradient ? grad.data() : nullptr)) {
    if (!run.has_iterate() ||  // the first evaluation is at x0
        run.StopIfStalled(context.stall_limit) || run.StopIfTimeUp()) {
      context.optimizer->force_stop();
    }
    std::fill(grad.begin(), grad.end(), 0.0);
    return HUGE_VAL;
  }
  double g_max = std::numeric_limits<double>::quiet_NaN();
  if (want_gradient) {
    g_max = 0.0;
    for (double g : grad) g_max = std::max(g_max, std::abs(g));
  }
  if (context.scale_by_first_gradient && !run.has_iterate() && want_gradient) {
    context.scale = 1.0 / std::max(1.0, g_max);  // fixed at x0, before NLopt sees a value
  }
  SolverRun::Stop stop = SolverRun::Stop::kNone;
  if (cost < context.best) {
    context.best = cost;
    stop = run.AcceptIterate(x.data(), cost, g_max);
  } else if (want_gradient && cost == context.best) {
    stop = run.RefineIterateGradient(x.data(), g_max);  // the gradient asked for later
  }
  if (stop != SolverRun::Stop::kNone || run.StopIfStalled(context.stall_limit) ||
      run.StopIfTimeUp()) {
    context.optimizer->force_stop();
  }
  if (context.scale != 1.0) {
    for (double& g : grad) g *= context.scale;
  }
  return context.scale * cost;
}

const char* ResultName(nlopt::result result) {
  switch (result) {
    case nlopt::SUCCESS: return "NLOPT_SUCCESS";
    case nlopt::STOPVAL_REACHED: return "NLOPT_STOPVAL_REACHED";
    case nlopt::FTOL_REACHED: return "NLOPT_FTOL_REACHED";
    case nlopt::XTOL_REACHED: return "NLOPT_XTOL_REACHED";
    case nlopt::MAXEVAL_REACHED: return "NLOPT_MAXEVAL_REACHED";
    case nlopt::MAXTIME_REACHED: return "NLOPT_MAXTIME_REACHED";
    default: break;
  }
  return "NLopt failure code";
}

}  // namespace

bool NloptSolver::available() const { return true; }

void NloptSolver::DoSolve(const opt::Objective& objective, const VecX& x0,
                          const opt::SolverOptions& options, opt::SolveResult* result) const {
  SolverRun run(objective, options, name());
  const std::string label = "NLopt " + algorithm_ + ": ";
  // One truncated-Newton iteration may take n Hessian-vector products (each a
  // gradient evaluation) and then a line search.
  const int stall_limit = static_cast<int>(x0.size()) + options.line_search_max_steps;
  std::vector<double> x(x0.data(), x0.data() + x0.size());
  double cost = HUGE_VAL;
  nlopt::result code = nlopt::FAILURE;
  std::string failure;  // what NLopt threw, if anything
  bool roundoff = false;
  try {
    nlopt::opt optimizer(algorithm_.c_str(), static_cast<unsigned>(x0.size()));
    Context context{&run, &optimizer, stall_limit};
    context.scale_by_first_gradient = StartsWithUnitStep(algorithm_);
    optimizer.set_min_objective(Cost, &context);
    optimizer.set_vector_storage(static_cast<unsigned>(options.memory_size));
    // Only a step that leaves x unchanged in floating point meets this test.
    optimizer.set_xtol_rel(std::numeric_limits<double>::epsilon());
    const double remaining = run.RemainingSeconds();
    if (std::isfinite(remaining)) optimizer.set_maxtime(std::max(remaining, 1e-9));
    try {
      code = optimizer.optimize(x, cost);
    } catch (const nlopt::roundoff_limited&) {
      roundoff = true;
    } catch (const nlopt::forced_stop&) {
      failure = "forced stop";
    }
  } catch (const std::invalid_argument& e) {
    run.Finish(SolveStatus::kInvalidInput, label + "invalid arguments (" + e.what() + ")", result);
    return;
  } catch (const std::bad_alloc&) {
    failure = "out of memory";
  } catch (const std::exception& e) {
    failure = e.what();
  }

  if (run.stop() != SolverRun::Stop::kNone) {  // one of our tests stopped it
    run.Finish(SolverRun::StatusOf(run.stop()), run.stop_message(), result);
    return;
  }
  if (!run.has_iterate()) {  // NLopt evaluates x0 first
    run.Finish(SolveStatus::kEvaluationFailed,
               "the objective could not be evaluated (or was not finite) at x0", result);
    return;
  }
  if (run.OnlyFailuresSinceIterate()) {
    run.Finish(SolveStatus::kEvaluationFailed,
               label + "stopped after every evaluation since the last improvement failed (" +
                   std::to_string(run.failures_since_iterate()) + ")",
               result);
    return;
  }
  if (!roundoff && failure.empty()) {
    switch (code) {
      case nlopt::SUCCESS:
      case nlopt::STOPVAL_REACHED:
      case nlopt::FTOL_REACHED:
      case nlopt::XTOL_REACHED:
        run.Finish(SolveStatus::kConverged,
                   label + ResultName(code) + " (a convergence test of its own)", result);
        return;
      case nlopt::MAXEVAL_REACHED:  // not set here; mapped for completeness
        run.Finish(SolveStatus::kMaxIterations, label + ResultName(code), result);
        return;
      case nlopt::MAXTIME_REACHED:
        run.Finish(SolveStatus::kTimeout, label + ResultName(code), result);
        return;
      default:
        failure = ResultName(code);
        break;
    }
  }
  run.Finish(SolveStatus::kLineSearchFailed,
             label + (roundoff ? "halted by roundoff errors (no further decrease found in "
                                 "floating point)"
                               : "failed (" + failure + ")"),
             result);
}

}  // namespace quadhand::solvers
