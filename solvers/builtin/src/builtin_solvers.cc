#include "quadhand/solvers/builtin_solvers.h"

#include "quadhand/solvers/ceres_solver.h"
#include "quadhand/solvers/ipopt_solver.h"
#include "quadhand/solvers/lbfgs_solver.h"
#include "quadhand/solvers/nlopt_solver.h"

namespace quadhand::solvers {

core::Status RegisterBuiltinSolvers() {
  QUADHAND_RETURN_IF_ERROR(RegisterLbfgsSolver());
  QUADHAND_RETURN_IF_ERROR(RegisterCeresSolver());
  QUADHAND_RETURN_IF_ERROR(RegisterIpoptSolver());
  QUADHAND_RETURN_IF_ERROR(RegisterNloptSolver());
  return core::Status::Ok();
}

}  // namespace quadhand::solvers
