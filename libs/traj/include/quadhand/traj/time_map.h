// Map between an unconstrained variable tau in R and a piece duration T > 0,
// so that durations can be optimised without bounds:
//   T(tau) = 1 + tau + tau^2 / 2        for tau > 0
//   T(tau) = 1 / (1 - tau + tau^2 / 2)  for tau <= 0
// T is C^2, strictly increasing, T(0) = 1 s, T -> 0 as tau -> -inf and grows
// quadratically as tau -> +inf. Durations are in seconds.
#pragma once

#include <Eigen/Core>

#include "quadhand/core/status.h"

namespace quadhand::traj {

// T(tau) > 0 (may underflow to 0 only for tau below about -1e154).
double TimeFromTau(double tau);

// dT/dtau (> 0).
double TimeDerivative(double tau);

// The inverse tau(T). Requires T > 0 and finite; other inputs are clamped
// to [kMinTimeForInverse, DBL_MAX] first, so the result is always finite.
double TauFromTime(double time);
inline constexpr double kMinTimeForInverse = 1e-12;

// Element-wise T(tau).
void DurationsFromTaus(const Eigen::Ref<const Eigen::VectorXd>& taus, Eigen::VectorXd* durations);

// Element-wise tau(T); fails with kInvalidArgument (leaving `taus` untouched)
// if a duration is not finite and positive.
core::Status TausFromDurations(const Eigen::Ref<const Eigen::VectorXd>& durations,
                               Eigen::VectorXd* taus);

// Chain rule dJ/dtau_i = dJ/dT_i * dT/dtau(tau_i). `grad_taus` is resized.
void DurationGradientToTau(const Eigen::Ref<const Eigen::VectorXd>& taus,
                           const Eigen::Ref<const Eigen::VectorXd>& grad_durations,
                           Eigen::VectorXd* grad_taus);

}  // namespace quadhand::traj
