// CeresSolver when Ceres was not found at build time: it exists so that
// configs naming "ceres" still parse, and reports that it cannot run.
#include "quadhand/solvers/ceres_solver.h"

namespace quadhand::solvers {

bool CeresSolver::available() const { return false; }

void CeresSolver::DoSolve(const opt::Objective&, const VecX&, const opt::SolverOptions&,
                          opt::SolveResult* result) const {
  // Not reached: Solver::Solve() returns kNotAvailable before calling DoSolve().
  result->status = opt::SolveStatus::kNotAvailable;
  result->message =
      "QuadHand was built without Ceres (install libceres-dev and re-run CMake)";
}

}  // namespace quadhand::solvers
