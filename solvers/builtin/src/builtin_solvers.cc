#include "quadhand/solvers/builtin_solvers.h"

#include "quadhand/solvers/lbfgs_solver.h"

namespace quadhand::solvers {

core::Status RegisterBuiltinSolvers() {
  QUADHAND_RETURN_IF_ERROR(RegisterLbfgsSolver());
  return core::Status::Ok();
}

}  // namespace quadhand::solvers
