#include "quadhand/sim/figure_eight.h"

#include <algorithm>
#include <cmath>

#include "quadhand/traj/flatness.h"

namespace quadhand::sim {
namespace {

// Value and three derivatives of a scalar function of time.
struct Jet {
  double v = 0.0, d1 = 0.0, d2 = 0.0, d3 = 0.0;
};

// Ramped time: tau' = r(t), r rising from 0 to 1 over `ramp` with the quintic
// smoothstep S(s) = 10 s^3 - 15 s^4 + 6 s^5, 1 in the middle, falling
// symmetrically at the end; tau(total) = total - ramp.
Jet RampedTime(double t, double total, double ramp) {
  auto up = [ramp](double u) {
    Jet j;
    if (ramp <= 0.0) {
      j.v = u;
      j.d1 = 1.0;
      return j;
    }
    const double s = std::clamp(u / ramp, 0.0, 1.0);
    const double s2 = s * s, s3 = s2 * s, s4 = s3 * s;
    j.v = ramp * (s3 * s3 - 3.0 * s4 * s + 2.5 * s4);
    j.d1 = 10.0 * s3 - 15.0 * s4 + 6.0 * s4 * s;
    j.d2 = (30.0 * s2 - 60.0 * s3 + 30.0 * s4) / ramp;
    j.d3 = (60.0 * s - 180.0 * s2 + 120.0 * s3) / (ramp * ramp);
    return j;
  };
  Jet j;
  if (t <= ramp) return up(t);
  if (t >= total - ramp) {
    const Jet m = up(total - t);
    j.v = (total - ramp) - m.v;
    j.d1 = m.d1;
    j.d2 = -m.d2;
    j.d3 = m.d3;
    return j;
  }
  j.v = 0.5 * ramp + (t - ramp);
  j.d1 = 1.0;
  return j;
}

// a sin(k tau + phase) and its derivatives for tau(t) given as a jet.
Jet SineOf(const Jet& tau, double a, double k, double phase) {
  const double arg = k * tau.v + phase;
  const double s = std::sin(arg), c = std::cos(arg);
  Jet j;
  j.v = a * s;
  j.d1 = a * k * c * tau.d1;
  j.d2 = -a * k * k * s * tau.d1 * tau.d1 + a * k * c * tau.d2;
  j.d3 = -a * k * k * k * c * tau.d1 * tau.d1 * tau.d1 - 3.0 * a * k * k * s * tau.d1 * tau.d2 + a * k * c * tau.d3;
  return j;
}

bool Fail(std::string* why, const std::string& message) {
  if (why) *why = message;
  return false;
}

}  // namespace

bool FigureEightOptions::IsValid(std::string* why) const {
  if (!(length > 0.0 && width > 0.0)) return Fail(why, "length and width must be > 0");
  if (!center.allFinite()) return Fail(why, "center must be finite");
  if (!(period > 0.0)) return Fail(why, "period must be > 0");
  if (loops < 1) return Fail(why, "loops must be >= 1");
  if (!(ramp >= 0.0 && ramp <= loops * period)) return Fail(why, "ramp must be in [0, loops * period]");
  if (!(dt > 0.0 && dt <= 0.1)) return Fail(why, "dt must be in (0, 0.1]");
  // The plan is held in memory and written as one row per dt (a bound also
  // keeps the products below finite).
  const double rows = (static_cast<double>(loops) * period + ramp) / dt;
  if (!(rows <= kMaxFigureEightRows)) {
    return Fail(why, "(loops x period + ramp) / dt must be at most 1e7 rows");
  }
  if (!std::isfinite(yaw)) return Fail(why, "yaw must be finite");
  const size_t n = joint_center.size();
  if (joint_amplitude.size() != n || joint_period.size() != n || joint_phase.size() != n) {
    return Fail(why, "joint_center, joint_amplitude, joint_period and joint_phase need the same length");
  }
  for (double p : joint_period) {
    if (!(p > 0.0)) return Fail(why, "joint periods must be > 0");
  }
  return true;
}

core::Result<Plan> MakeFigureEightPlan(const FigureEightOptions& o, const std::vector<std::string>& joint_names,
                                       const VecX& lower, const VecX& upper, const VecX& max_rate) {
  std::string why;
  if (!o.IsValid(&why)) return core::Status::InvalidArgument("figure eight: " + why);
  const int n = static_cast<int>(joint_names.size());
  if (static_cast<int>(o.joint_center.size()) != n) {
    return core::Status::InvalidArgument("figure eight: " + std::to_string(o.joint_center.size()) +
                                         " joint motions for " + std::to_string(n) + " actuated joints");
  }
  const double omega = 2.0 * M_PI / o.period;
  const double total = o.loops * o.period + o.ramp;
  const long steps = std::lround(std::ceil(total / o.dt - 1e-9));
  traj::FlatnessOptions flat;
  flat.gravity = o.gravity;

  Plan plan;
  plan.joint_names = joint_names;
  plan.rows.reserve(steps + 1);
  for (long i = 0; i <= steps; ++i) {
    const double t = i == steps ? total : i * o.dt;
    const Jet tau = RampedTime(t, total, o.ramp);
    const Jet x = SineOf(tau, 0.5 * o.length, omega, 0.0);
    const Jet y = SineOf(tau, 0.5 * o.width, 2.0 * omega, 0.0);
    PlanRow r;
    r.t = t;
    r.position = o.center + Vec3(x.v, y.v, 0.0);
    r.velocity = Vec3(x.d1, y.d1, 0.0);
    r.acceleration = Vec3(x.d2, y.d2, 0.0);
    const Vec3 jerk(x.d3, y.d3, 0.0);
    const traj::FlatState state = traj::FlatForward(r.velocity, r.acceleration, jerk, o.yaw, 0.0, flat);
    r.attitude = state.attitude();
    r.yaw = o.yaw;
    r.yaw_rate = 0.0;
    r.joints = VecX(n);
    r.joint_rates = VecX(n);
    for (int k = 0; k < n; ++k) {
      const Jet q = SineOf(tau, o.joint_amplitude[k], 2.0 * M_PI / o.joint_period[k], o.joint_phase[k]);
      r.joints[k] = o.joint_center[k] + q.v;
      r.joint_rates[k] = q.d1;
      if (r.joints[k] < lower[k] - 1e-9 || r.joints[k] > upper[k] + 1e-9) {
        return core::Status::InvalidArgument("figure eight: " + joint_names[k] + " leaves its limits [" +
                                             std::to_string(lower[k]) + ", " + std::to_string(upper[k]) + "]");
      }
      if (max_rate[k] > 0.0 && std::abs(q.d1) > max_rate[k] + 1e-9) {
        return core::Status::InvalidArgument("figure eight: " + joint_names[k] + " exceeds its rate limit " +
                                             std::to_string(max_rate[k]) + " rad/s");
      }
    }
    plan.rows.push_back(std::move(r));
  }
  return plan;
}

}  // namespace quadhand::sim
