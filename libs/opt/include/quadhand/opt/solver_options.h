// Settings shared by every Solver back-end. A back-end ignores the fields it
// has no equivalent for and says so in its header.
#pragma once

#include <limits>
#include <string>

namespace quadhand::opt {

struct SolverOptions {
  // Stop with kMaxIterations after this many accepted steps (>= 0; 0 only
  // evaluates x0 and checks the gradient).
  int max_iterations = 1000;

  // Stop with kTimeout once this much wall time (seconds, > 0) has passed
  // since Solve() started. Checked between evaluations, so one slow
  // evaluation can overshoot it. Infinity means no limit.
  double max_time_seconds = std::numeric_limits<double>::infinity();

  // Converged when |f_{k-w} - f_k| / max(1, |f_k|) < relative_cost_tolerance,
  // with w = relative_cost_window accepted steps (>= 0; 0 disables the test).
  double relative_cost_tolerance = 1e-10;
  // Window w of the test above (>= 1). A window longer than one step avoids
  // stopping on a single short step.
  int relative_cost_window = 3;

  // Converged when the largest gradient component |g_i| <= gradient_tolerance
  // (>= 0; 0 stops only at an exactly zero gradient). An absolute, unscaled test.
  double gradient_tolerance = 1e-6;

  // Number of (s, y) pairs kept by limited-memory quasi-Newton methods (>= 1).
  int memory_size = 8;

  // Line search: accept step t along descent direction d when
  //   f(x + t d) <= f(x) + c1 t g'd                     (Armijo, sufficient decrease)
  //   g(x + t d)'d >= c2 g'd                            (weak Wolfe, curvature)
  // with 0 < c1 < c2 < 1, and give up after line_search_max_steps trials (>= 1).
  double line_search_c1 = 1e-4;
  double line_search_c2 = 0.9;
  int line_search_max_steps = 60;

  // 0: silent; 1: one summary line; 2: also one line per iteration. Printed
  // through core::LogInfo, so the application's log level still applies.
  int verbosity = 0;

  // True when every field is in range; otherwise false with the reason in
  // *why (when not null), naming the offending field.
  bool IsValid(std::string* why) const;
};

}  // namespace quadhand::opt
