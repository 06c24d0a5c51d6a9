#include "quadhand/opt/solver.h"

#include <chrono>
#include <cmath>
#include <exception>
#include <string>

#include "quadhand/core/log.h"

namespace quadhand::opt {
namespace {

// Counts evaluations and turns exceptions into failed evaluations, so that
// nothing thrown by a cost crosses a back-end (some are C libraries).
class GuardedObjective final : public Objective {
 public:
  explicit GuardedObjective(const Objective& inner) : inner_(inner) {}

  int num_variables() const override { return inner_.num_variables(); }
  int evaluations() const { return evaluations_; }
  const std::string& exception_message() const { return exception_message_; }

 protected:
  bool DoEvaluate(const VecX& x, double* cost, VecX* grad) const override {
    ++evaluations_;
    try {
      return inner_.Evaluate(x, cost, grad);
    } catch (const std::exception& e) {
      exception_message_ = e.what();
    } catch (...) {
      exception_message_ = "unknown exception";
    }
    return false;
  }

 private:
  const Objective& inner_;
  mutable int evaluations_ = 0;
  mutable std::string exception_message_;
};

}  // namespace

SolveResult Solver::Solve(const Objective& objective, const VecX& x0,
                          const SolverOptions& options) const {
  const auto start = std::chrono::steady_clock::now();
  SolveResult result;
  result.solver = name();
  result.x = x0;
  const int n = objective.num_variables();
  std::string why;
  if (!available()) {
    result.status = SolveStatus::kNotAvailable;
    result.message = "solver '" + result.solver + "' was built without its library";
  } else if (!options.IsValid(&why)) {
    result.status = SolveStatus::kInvalidInput;
    result.message = "invalid options: " + why;
  } else if (n < 1) {
    result.status = SolveStatus::kInvalidInput;
    result.message = "the objective has " + std::to_string(n) + " variables";
  } else if (x0.size() != n) {
    result.status = SolveStatus::kInvalidInput;
    result.message = "x0 has " + std::to_string(x0.size()) + " entries, the objective " +
                     std::to_string(n) + " variables";
  } else if (!x0.allFinite()) {
    result.status = SolveStatus::kInvalidInput;
    result.message = "x0 is not finite";
  } else {
    GuardedObjective guarded(objective);
    DoSolve(guarded, x0, options, &result);
    result.evaluations = guarded.evaluations();
    if (!guarded.exception_message().empty()) {
      result.message += (result.message.empty() ? "" : "; ") +
                        std::string("the objective threw: ") + guarded.exception_message();
    }
  }
  result.wall_time_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (options.verbosity >= 1) core::LogInfo("%s", result.BriefReport().c_str());
  return result;
}

}  // namespace quadhand::opt
