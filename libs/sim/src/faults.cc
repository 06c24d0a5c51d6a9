#include "quadhand/sim/faults.h"

#include <cmath>
#include <tuple>

namespace quadhand::sim {
namespace {

constexpr double kFeetPerMetre = 1.0 / 0.3048;

bool Fail(std::string* why, const std::string& message) {
  if (why) *why = message;
  return false;
}

}  // namespace

bool FaultConfig::IsValid(int num_actuated, std::string* why) const {
  auto in = [](double v, double low, double high) { return v >= low && v <= high; };
  // A hurricane is 33 m/s: beyond 30 m/s no multirotor flies, and a value
  // there is a unit error.
  if (!in(wind.steady.norm(), 0.0, 30.0)) return Fail(why, "faults.wind.steady must be at most 30 m/s");
  if (!in(wind.gust_intensity, 0.0, 15.0)) return Fail(why, "faults.wind.gust_intensity must be in [0, 15] m/s");
  if (!in(wind.altitude, 0.1, 300.0)) return Fail(why, "faults.wind.altitude must be in [0.1, 300] m");
  if (!in(wind.min_airspeed, 0.1, 30.0)) return Fail(why, "faults.wind.min_airspeed must be in [0.1, 30] m/s");
  if (!in(wind.base_drag_area, 0.0, 10.0)) return Fail(why, "faults.wind.base_drag_area must be in [0, 10] m^2");
  if (!in(wind.arm_drag_coefficient, 0.0, 5.0)) return Fail(why, "faults.wind.arm_drag_coefficient must be in [0, 5]");
  if (!in(wind.air_density, 0.1, 5.0)) return Fail(why, "faults.wind.air_density must be in [0.1, 5] kg/m^3");
  if (motor.rotor < -1 || motor.rotor > 3) return Fail(why, "faults.motor.rotor must be 0, 1, 2 or 3 (or -1: none)");
  if (!in(motor.thrust_factor, 0.0, 1.0)) return Fail(why, "faults.motor.thrust_factor must be in [0, 1]");
  if (!in(servo.extra_lag, 0.0, 5.0)) return Fail(why, "faults.servo.extra_lag must be in [0, 5] s");
  if (servo.stall_joint < -1 || servo.stall_joint >= num_actuated) {
    return Fail(why, "faults.servo.stall_joint must be an actuated joint index (0.." + std::to_string(num_actuated - 1) +
                         ") or -1");
  }
  if (!in(servo.stall_time, 0.0, 1e6)) return Fail(why, "faults.servo.stall_time must be in [0, 1e6] s");
  if (!in(payload_mass_factor, 0.0, 10.0)) return Fail(why, "faults.payload_mass_factor must be in [0, 10]");
  const EstimateFault& e = estimate;
  if (!(e.jump.norm() <= 10.0)) return Fail(why, "faults.estimate.jump.offset must be at most 10 m");
  if (!(e.drift.norm() <= 1.0)) return Fail(why, "faults.estimate.drift must be at most 1 m/s");
  for (const auto& [name, start, length] : {std::tuple{"jump", e.jump_time, 0.0},
                                            std::tuple{"freeze", e.freeze_time, e.freeze_duration},
                                            std::tuple{"nan", e.nan_time, e.nan_duration}}) {
    if (!(start < 0.0 || in(start, 0.0, 1e6)) || !in(length, 0.0, 1e6)) {
      return Fail(why, std::string("faults.estimate.") + name + ": time and duration must be in [0, 1e6] s");
    }
  }
  return true;
}

DrydenGusts::DrydenGusts(const WindFault& wind) : wind_(wind) {
  const double h = std::max(wind.altitude, 0.1) * kFeetPerMetre;
  const double scale = 0.177 + 0.000823 * h;
  length_w_ = wind.altitude;
  length_uv_ = wind.altitude / std::pow(scale, 1.2);
  sigma_uv_ = wind.gust_intensity;
  sigma_w_ = wind.gust_intensity * std::pow(scale, 0.4);
  const Vec3 horizontal(wind.steady.x(), wind.steady.y(), 0.0);
  if (horizontal.norm() > 1e-9) along_ = horizontal.normalized();
  across_ = Vec3::UnitZ().cross(along_);
}

Vec3 DrydenGusts::Step(double dt, double airspeed, std::mt19937_64* rng) {
  if (!(sigma_uv_ > 0.0) || !(dt > 0.0)) return current_ = Vec3::Zero();
  const double speed = std::max(wind_.min_airspeed, std::isfinite(airspeed) ? airspeed : 0.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double root_dt = std::sqrt(dt);
  if (!started_) {
    // From the filters' stationary distribution, not from calm air: the
    // longitudinal lag is L_u / V, tens of seconds at hover, longer than a
    // flight. Lyapunov of the cascade below: var x1 = 1 / (2T),
    // cov(x1, x2) = var x2 = 1 / (4T).
    started_ = true;
    const double t_u = length_uv_ / speed;
    u_ = std::sqrt(0.5 / t_u) * normal(*rng);
    for (auto [length, x1, x2] : {std::tuple{length_uv_, &v1_, &v2_}, std::tuple{length_w_, &w1_, &w2_}}) {
      const double t = length / speed;
      *x1 = std::sqrt(0.5 / t) * normal(*rng);
      *x2 = 0.5 * *x1 + std::sqrt(0.125 / t) * normal(*rng);
    }
  }
  // First order K / (1 + T s) on unit white noise: variance K^2 / (2 T).
  const double t_u = length_uv_ / speed;
  u_ += -u_ / t_u * dt + root_dt / t_u * normal(*rng);
  const double longitudinal = sigma_uv_ * std::sqrt(2.0 * t_u) * u_;
  // Second order K (1 + sqrt(3) T s) / (1 + T s)^2 as two lags x1, x2, the
  // output K (x2 + sqrt(3) (x1 - x2)): variance K^2 (1 + 3) / (4 T) = K^2 / T.
  auto second_order = [&](double length, double sigma, double* x1, double* x2) {
    const double t = length / speed;
    const double x1_before = *x1;
    *x1 += -*x1 / t * dt + root_dt / t * normal(*rng);
    *x2 += (x1_before - *x2) / t * dt;
    return sigma * std::sqrt(t) * (*x2 + std::sqrt(3.0) * (*x1 - *x2));
  };
  const double lateral = second_order(length_uv_, sigma_uv_, &v1_, &v2_);
  const double vertical = second_order(length_w_, sigma_w_, &w1_, &w2_);
  current_ = longitudinal * along_ + lateral * across_ + vertical * Vec3::UnitZ();
  return current_;
}

}  // namespace quadhand::sim
