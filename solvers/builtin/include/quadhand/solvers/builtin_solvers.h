// One call that puts every back-end built into this binary in the opt solver
// registry, for apps that pick solvers by name.
#pragma once

#include "quadhand/core/status.h"

namespace quadhand::solvers {

// Registers "lbfgs", "ceres", "ipopt" and "nlopt" (docs/solvers.md), the last
// three also when their library is absent: they then report available() ==
// false. Idempotent and thread-safe.
core::Status RegisterBuiltinSolvers();

}  // namespace quadhand::solvers
