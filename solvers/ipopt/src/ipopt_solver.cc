// IpoptSolver with Ipopt: the only translation unit that includes its headers.
#include "quadhand/solvers/ipopt_solver.h"

#include <IpIpoptApplication.hpp>
#include <IpSolveStatistics.hpp>
#include <IpTNLP.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "quadhand/solvers/solver_run.h"

namespace quadhand::solvers {
namespace {

using Ipopt::Index;
using Ipopt::Number;
using opt::SolveStatus;

// Ipopt reads bounds at or beyond +-1e19 (nlp_lower/upper_bound_inf) as none.
constexpr Number kNoBound = 1e19;

// min f(x) over R^n: n variables, no bounds, no constraints.
class UnconstrainedNlp final : public Ipopt::TNLP {
 public:
  UnconstrainedNlp(SolverRun* run, const VecX& x0)
      : run_(run), x0_(x0), gradient_(run->num_variables()) {}

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac_g, Index& nnz_h_lag,
                    IndexStyleEnum& index_style) override {
    n = run_->num_variables();
    m = 0;
    nnz_jac_g = 0;
    nnz_h_lag = 0;
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Index n, Number* x_l, Number* x_u, Index, Number*, Number*) override {
    std::fill(x_l, x_l + n, -kNoBound);
    std::fill(x_u, x_u + n, kNoBound);
    return true;
  }

  bool get_starting_point(Index n, bool init_x, Number* x, bool init_z, Number*, Number*, Index,
                          bool init_lambda, Number*) override {
    if (!init_x || init_z || init_lambda) return false;  // only x is asked for with m = 0
    std::copy(x0_.data(), x0_.data() + n, x);
    return true;
  }

  // Cost and gradient together: Ipopt asks for the gradient at every point
  // it accepts, and most trial points are accepted.
  bool eval_f(Index, const Number* x, bool, Number& obj_value) override {
    return run_->Evaluate(x, &obj_value, gradient_.data());
  }

  bool eval_grad_f(Index, const Number* x, bool, Number* grad_f) override {
    double cost = 0.0;
    return run_->Evaluate(x, &cost, grad_f);  // from the cache after eval_f
  }

  bool eval_g(Index, const Number*, bool, Index, Number*) override { return true; }

  bool eval_jac_g(Index, const Number*, bool, Index, Index, Index*, Index*, Number*) override {
    return true;
  }

  // eval_h is not overridden: hessian_approximation = limited-memory.

  void finalize_solution(Ipopt::SolverReturn, Index, const Number* x, const Number*,
                         const Number*, Index, const Number*, const Number*, Number,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    if (x != nullptr) run_->SetFinalPoint(x, /*counts_as_step=*/false);
  }

  // Called once per iteration (iteration 0: x0) before Ipopt's own tests.
  // With m = 0 and no scaling, inf_du is |g|inf at the iterate.
  bool intermediate_callback(Ipopt::AlgorithmMode mode, Index, Number obj_value, Number,
                             Number inf_du, Number, Number, Number, Number, Number, Index,
                             const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    if (mode == Ipopt::RestorationPhaseMode) return !run_->TimeUp();
    const double* x = run_->RecentPointWithCost(obj_value);
    return run_->AcceptIterate(x, obj_value, inf_du) == SolverRun::Stop::kNone;
  }

 private:
  SolverRun* run_;
  VecX x0_;
  VecX gradient_;  // scratch for eval_f
};

const char* ReturnName(Ipopt::ApplicationReturnStatus status) {
  switch (status) {
    case Ipopt::Solve_Succeeded: return "Solve_Succeeded";
    case Ipopt::Solved_To_Acceptable_Level: return "Solved_To_Acceptable_Level";
    case Ipopt::Infeasible_Problem_Detected: return "Infeasible_Problem_Detected";
    case Ipopt::Search_Direction_Becomes_Too_Small: return "Search_Direction_Becomes_Too_Small";
    case Ipopt::Diverging_Iterates: return "Diverging_Iterates";
    case Ipopt::User_Requested_Stop: return "User_Requested_Stop";
    case Ipopt::Feasible_Point_Found: return "Feasible_Point_Found";
    case Ipopt::Maximum_Iterations_Exceeded: return "Maximum_Iterations_Exceeded";
    case Ipopt::Restoration_Failed: return "Restoration_Failed";
    case Ipopt::Error_In_Step_Computation: return "Error_In_Step_Computation";
    case Ipopt::Maximum_CpuTime_Exceeded: return "Maximum_CpuTime_Exceeded";
    case Ipopt::Not_Enough_Degrees_Of_Freedom: return "Not_Enough_Degrees_Of_Freedom";
    case Ipopt::Invalid_Problem_Definition: return "Invalid_Problem_Definition";
    case Ipopt::Invalid_Option: return "Invalid_Option";
    case Ipopt::Invalid_Number_Detected: return "Invalid_Number_Detected";
    case Ipopt::Unrecoverable_Exception: return "Unrecoverable_Exception";
    case Ipopt::NonIpopt_Exception_Thrown: return "NonIpopt_Exception_Thrown";
    case Ipopt::Insufficient_Memory: return "Insufficient_Memory";
    case Ipopt::Internal_Error: return "Internal_Error";
  }
  return "unknown Ipopt status";
}

// Sets every option; false with the name of the one Ipopt rejected.
bool SetOptions(const opt::SolverOptions& options, double max_seconds,
                Ipopt::OptionsList* list, std::string* rejected) {
  const double tol = std::max(options.gradient_tolerance, std::numeric_limits<double>::min());
  const auto set_string = [&](const char* name, const char* value) {
    if (!list->SetStringValue(name, value)) *rejected = name;
    return rejected->empty();
  };
  const auto set_number = [&](const char* name, double value) {
    if (!list->SetNumericValue(name, value)) *rejected = name;
    return rejected->empty();
  };
  const auto set_integer = [&](const char* name, int value) {
    if (!list->SetIntegerValue(name, value)) *rejected = name;
    return rejected->empty();
  };
  return set_string("sb", "yes") && set_integer("print_level", 0) &&
         set_string("hessian_approximation", "limited-memory") &&
         set_integer("limited_memory_max_history", options.memory_size) &&
         set_string("linear_solver", "mumps") && set_string("nlp_scaling_method", "none") &&
         set_number("tol", tol) && set_number("dual_inf_tol", tol) &&
         set_integer("acceptable_iter", 0) && set_integer("max_iter", options.max_iterations) &&
         (!std::isfinite(max_seconds) || set_number("max_cpu_time", max_seconds));
}

}  // namespace

bool IpoptSolver::available() const { return true; }

void IpoptSolver::DoSolve(const opt::Objective& objective, const VecX& x0,
                          const opt::SolverOptions& options, opt::SolveResult* result) const {
  SolverRun run(objective, options, name());
  // No console journal: Ipopt prints nothing, whatever its options say.
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app =
      new Ipopt::IpoptApplication(/*create_console_out=*/false);
  std::string rejected;
  // max_cpu_time must be positive; the callback checks the wall-time limit.
  const double max_seconds = std::max(run.RemainingSeconds(), 1e-6);
  if (!SetOptions(options, max_seconds, Ipopt::GetRawPtr(app->Options()), &rejected)) {
    run.Finish(SolveStatus::kInvalidInput, "Ipopt rejects the value of option " + rejected,
               result);
    return;
  }
  std::istringstream no_options_file;  // ignore any ipopt.opt in the working directory
  Ipopt::ApplicationReturnStatus status = app->Initialize(no_options_file);
  if (status != Ipopt::Solve_Succeeded) {
    run.Finish(SolveStatus::kInvalidInput,
               std::string("Ipopt failed to initialise: ") + ReturnName(status), result);
    return;
  }
  Ipopt::SmartPtr<Ipopt::TNLP> nlp = new UnconstrainedNlp(&run, x0);
  status = app->OptimizeTNLP(nlp);

  const std::string ipopt_message = std::string("Ipopt: ") + ReturnName(status);
  if (run.stop() != SolverRun::Stop::kNone) {  // our callback stopped it
    run.Finish(SolverRun::StatusOf(run.stop()), run.stop_message(), result);
    return;
  }
  if (!run.has_iterate()) {
    run.Finish(SolveStatus::kEvaluationFailed,
               "the objective could not be evaluated (or was not finite) at x0; " + ipopt_message,
               result);
    return;
  }
  switch (status) {
    case Ipopt::Solve_Succeeded:
    case Ipopt::Solved_To_Acceptable_Level:
      run.Finish(SolveStatus::kConverged, ipopt_message, result);
      return;
    case Ipopt::Maximum_Iterations_Exceeded:
      run.Finish(SolveStatus::kMaxIterations, ipopt_message, result);
      return;
    case Ipopt::Maximum_CpuTime_Exceeded:
      run.Finish(SolveStatus::kTimeout, ipopt_message, result);
      return;
    case Ipopt::Invalid_Number_Detected:
    case Ipopt::Error_In_Step_Computation:
      run.Finish(SolveStatus::kEvaluationFailed, ipopt_message, result);
      return;
    case Ipopt::Not_Enough_Degrees_Of_Freedom:
    case Ipopt::Invalid_Problem_Definition:
    case Ipopt::Invalid_Option:
      run.Finish(SolveStatus::kInvalidInput, ipopt_message, result);
      return;
    case Ipopt::Restoration_Failed:
    case Ipopt::Search_Direction_Becomes_Too_Small:
      if (run.OnlyFailuresSinceIterate()) {
        run.Finish(SolveStatus::kEvaluationFailed,
                   "every trial point since the last iterate failed to evaluate (" +
                       std::to_string(run.failures_since_iterate()) + " trials); " +
                       ipopt_message,
                   result);
        return;
      }
      break;
    default:
      break;
  }
  // Diverging iterates, internal errors and the statuses that cannot occur
  // with m = 0: the method stopped without an acceptable step.
  run.Finish(SolveStatus::kLineSearchFailed, ipopt_message, result);
}

}  // namespace quadhand::solvers
