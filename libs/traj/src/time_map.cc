#include "quadhand/traj/time_map.h"

#include <cassert>
#include <cfloat>
#include <cmath>

namespace quadhand::traj {

double TimeFromTau(double tau) {
  if (tau > 0.0) return 1.0 + tau * (1.0 + 0.5 * tau);
  const double den = 1.0 - tau * (1.0 - 0.5 * tau);
  return 1.0 / den;
}

double TimeDerivative(double tau) {
  if (tau > 0.0) return 1.0 + tau;
  const double den = 1.0 - tau * (1.0 - 0.5 * tau);
  return (1.0 - tau) / (den * den);
}

double TauFromTime(double time) {
  double t = time;
  if (!(t >= kMinTimeForInverse)) t = kMinTimeForInverse;  // also catches NaN
  if (t > DBL_MAX) t = DBL_MAX;
  if (t > 1.0) return std::sqrt(2.0) * std::sqrt(t - 0.5) - 1.0;  // sqrt(2t - 1) without overflow
  return 1.0 - std::sqrt(2.0 / t - 1.0);
}

void DurationsFromTaus(const Eigen::Ref<const Eigen::VectorXd>& taus, Eigen::VectorXd* durations) {
  assert(durations != nullptr);
  durations->resize(taus.size());
  for (Eigen::Index i = 0; i < taus.size(); ++i) (*durations)[i] = TimeFromTau(taus[i]);
}

core::Status TausFromDurations(const Eigen::Ref<const Eigen::VectorXd>& durations,
                               Eigen::VectorXd* taus) {
  if (taus == nullptr) return core::Status::InvalidArgument("TausFromDurations: null output");
  for (Eigen::Index i = 0; i < durations.size(); ++i) {
    if (!(durations[i] > 0.0) || !std::isfinite(durations[i])) {
      return core::Status::InvalidArgument("TausFromDurations: durations must be finite and > 0");
    }
  }
  taus->resize(durations.size());
  for (Eigen::Index i = 0; i < durations.size(); ++i) (*taus)[i] = TauFromTime(durations[i]);
  return core::Status::Ok();
}

void DurationGradientToTau(const Eigen::Ref<const Eigen::VectorXd>& taus,
                           const Eigen::Ref<const Eigen::VectorXd>& grad_durations,
                           Eigen::VectorXd* grad_taus) {
  assert(grad_taus != nullptr && taus.size() == grad_durations.size());
  grad_taus->resize(taus.size());
  for (Eigen::Index i = 0; i < taus.size(); ++i) {
    (*grad_taus)[i] = grad_durations[i] * TimeDerivative(taus[i]);
  }
}

}  // namespace quadhand::traj
