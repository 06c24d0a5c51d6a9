#include "quadhand/opt/solver_options.h"

#include <cmath>

namespace quadhand::opt {
namespace {

bool Fail(std::string* why, const std::string& reason) {
  if (why != nullptr) *why = reason;
  return false;
}

}  // namespace

bool SolverOptions::IsValid(std::string* why) const {
  if (max_iterations < 0) return Fail(why, "max_iterations must be >= 0");
  if (std::isnan(max_time_seconds) || max_time_seconds <= 0.0)
    return Fail(why, "max_time_seconds must be > 0 (infinity for no limit)");
  if (!std::isfinite(relative_cost_tolerance) || relative_cost_tolerance < 0.0)
    return Fail(why, "relative_cost_tolerance must be finite and >= 0");
  if (relative_cost_window < 1) return Fail(why, "relative_cost_window must be >= 1");
  if (!std::isfinite(gradient_tolerance) || gradient_tolerance < 0.0)
    return Fail(why, "gradient_tolerance must be finite and >= 0");
  // Each pair is two vectors of the problem's size: past a thousand the
  // memory (not the convergence) is what grows.
  if (memory_size < 1 || memory_size > 1000) return Fail(why, "memory_size must be in [1, 1000]");
  if (!(line_search_c1 > 0.0 && line_search_c1 < 1.0))
    return Fail(why, "line_search_c1 must lie in (0, 1)");
  if (!(line_search_c2 > line_search_c1 && line_search_c2 < 1.0))
    return Fail(why, "line_search_c2 must lie in (line_search_c1, 1)");
  if (line_search_max_steps < 1 || line_search_max_steps > 1000) {
    return Fail(why, "line_search_max_steps must be in [1, 1000]");
  }
  if (verbosity < 0 || verbosity > 2) return Fail(why, "verbosity must be 0, 1 or 2");
  return true;
}

}  // namespace quadhand::opt
