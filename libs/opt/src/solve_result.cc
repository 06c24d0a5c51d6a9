#include "quadhand/opt/solve_result.h"

#include <cstdio>

namespace quadhand::opt {

const char* SolveStatusName(SolveStatus status) {
  switch (status) {
    case SolveStatus::kConverged: return "converged";
    case SolveStatus::kMaxIterations: return "max iterations";
    case SolveStatus::kTimeout: return "timeout";
    case SolveStatus::kLineSearchFailed: return "line search failed";
    case SolveStatus::kEvaluationFailed: return "evaluation failed";
    case SolveStatus::kNotAvailable: return "not available";
    case SolveStatus::kInvalidInput: return "invalid input";
  }
  return "unknown";
}

std::string SolveResult::BriefReport() const {
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer),
                "%s: %s, cost %.9g, |g|inf %.3g, %d iterations, %d evaluations, %.3g s",
                solver.empty() ? "solver" : solver.c_str(), StatusName(), cost,
                gradient_max_norm, iterations, evaluations, wall_time_seconds);
  std::string report(buffer);
  if (!message.empty()) report += " (" + message + ")";
  return report;
}

}  // namespace quadhand::opt
