// CeresSolver with Ceres: the only translation unit that includes its headers.
#include "quadhand/solvers/ceres_solver.h"

#include <ceres/first_order_function.h>
#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>
#include <ceres/iteration_callback.h>
#include <ceres/types.h>

#include <string>
#include <vector>

#include "quadhand/solvers/solver_run.h"

namespace quadhand::solvers {
namespace {

using opt::SolveStatus;

// The cost as Ceres sees it; every evaluation goes through the SolverRun.
class Function final : public ceres::FirstOrderFunction {
 public:
  explicit Function(SolverRun* run) : run_(run) {}
  bool Evaluate(const double* parameters, double* cost, double* gradient) const override {
    return run_->Evaluate(parameters, cost, gradient);
  }
  int NumParameters() const override { return run_->num_variables(); }

 private:
  SolverRun* run_;
};

// Shows every iterate (x from the user's array, which Ceres updates before
// the callbacks run) to the SolverRun and stops Ceres when it says so.
class Callback final : public ceres::IterationCallback {
 public:
  Callback(SolverRun* run, const double* parameters) : run_(run), parameters_(parameters) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    const SolverRun::Stop stop =
        run_->AcceptIterate(parameters_, summary.cost, summary.gradient_max_norm);
    return stop == SolverRun::Stop::kNone ? ceres::SOLVER_CONTINUE
                                          : ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }

 private:
  SolverRun* run_;
  const double* parameters_;
};

}  // namespace

bool CeresSolver::available() const { return true; }

void CeresSolver::DoSolve(const opt::Objective& objective, const VecX& x0,
                          const opt::SolverOptions& options, opt::SolveResult* result) const {
  SolverRun run(objective, options, name());
  VecX parameters = x0;
  Callback callback(&run, parameters.data());

  ceres::GradientProblemSolver::Options ceres_options;
  ceres_options.line_search_direction_type =
      direction_ == Direction::kBfgs ? ceres::BFGS : ceres::LBFGS;
  ceres_options.line_search_type = ceres::WOLFE;
  ceres_options.max_lbfgs_rank = options.memory_size;
  ceres_options.line_search_sufficient_function_decrease = options.line_search_c1;
  ceres_options.line_search_sufficient_curvature_decrease = options.line_search_c2;
  ceres_options.max_num_line_search_step_size_iterations = options.line_search_max_steps;
  ceres_options.max_num_iterations = options.max_iterations;
  ceres_options.max_solver_time_in_seconds = run.RemainingSeconds();
  ceres_options.gradient_tolerance = options.gradient_tolerance;
  // The relative cost test is SolverOptions' windowed one, in the callback.
  ceres_options.function_tolerance = 0.0;
  ceres_options.parameter_tolerance = 0.0;
  ceres_options.logging_type = ceres::SILENT;
  ceres_options.minimizer_progress_to_stdout = false;
  ceres_options.update_state_every_iteration = true;
  ceres_options.callbacks.push_back(&callback);
  std::string why;
  if (!ceres_options.IsValid(&why)) {
    run.Finish(SolveStatus::kInvalidInput, "Ceres rejects the options: " + why, result);
    return;
  }

  ceres::GradientProblem problem(new Function(&run));  // takes ownership
  ceres::GradientProblemSolver::Summary summary;
  ceres::Solve(ceres_options, problem, parameters.data(), &summary);

  const std::string ceres_message = "Ceres: " + summary.message;
  switch (summary.termination_type) {
    case ceres::USER_SUCCESS:  // our callback stopped it
      run.Finish(SolverRun::StatusOf(run.stop()), run.stop_message(), result);
      return;
    case ceres::CONVERGENCE:  // its gradient test, before the callbacks saw the iterate
      run.SetFinalPoint(parameters.data(), /*counts_as_step=*/true);
      run.Finish(SolveStatus::kConverged, ceres_message, result);
      return;
    case ceres::NO_CONVERGENCE:  // its iteration or time cap
      run.SetFinalPoint(parameters.data(), /*counts_as_step=*/true);
      run.Finish(run.iterations() >= options.max_iterations ? SolveStatus::kMaxIterations
                                                            : SolveStatus::kTimeout,
                 ceres_message, result);
      return;
    case ceres::FAILURE:
    case ceres::USER_FAILURE:
      break;
  }
  // Ceres leaves the point alone on failure; the run has the last iterate.
  if (!run.has_iterate()) {
    run.Finish(SolveStatus::kEvaluationFailed,
               "the objective could not be evaluated (or was not finite) at x0; " + ceres_message,
               result);
  } else if (run.OnlyFailuresSinceIterate()) {
    run.Finish(SolveStatus::kEvaluationFailed,
               "every trial point of the last line search failed to evaluate (" +
                   std::to_string(run.failures_since_iterate()) + " trials); " + ceres_message,
               result);
  } else {
    run.Finish(SolveStatus::kLineSearchFailed, ceres_message, result);
  }
}

}  // namespace quadhand::solvers
