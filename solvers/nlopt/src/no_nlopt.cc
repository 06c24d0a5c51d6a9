// NloptSolver when NLopt was not found at build time: it exists so that
// configs naming "nlopt:..." still parse, and reports that it cannot run.
#include "quadhand/solvers/nlopt_solver.h"

namespace quadhand::solvers {

bool NloptSolver::available() const { return false; }

void NloptSolver::DoSolve(const opt::Objective&, const VecX&, const opt::SolverOptions&,
                          opt::SolveResult* result) const {
  // Not reached: Solver::Solve() returns kNotAvailable before calling DoSolve().
  result->status = opt::SolveStatus::kNotAvailable;
  result->message =
      "QuadHand was built without NLopt (install libnlopt-cxx-dev and re-run CMake)";
}

}  // namespace quadhand::solvers
