// IpoptSolver when Ipopt was not found at build time: it exists so that
// configs naming "ipopt" still parse, and reports that it cannot run.
#include "quadhand/solvers/ipopt_solver.h"

namespace quadhand::solvers {

bool IpoptSolver::available() const { return false; }

void IpoptSolver::DoSolve(const opt::Objective&, const VecX&, const opt::SolverOptions&,
                          opt::SolveResult* result) const {
  // Not reached: Solver::Solve() returns kNotAvailable before calling DoSolve().
  result->status = opt::SolveStatus::kNotAvailable;
  result->message =
      "QuadHand was built without Ipopt (install coinor-libipopt-dev and re-run CMake)";
}

}  // namespace quadhand::solvers
