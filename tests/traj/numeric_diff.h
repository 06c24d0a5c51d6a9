// Finite-difference helpers for the traj gradient tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

#include <Eigen/Core>

namespace quadhand::traj::testing {

// Central differences of a scalar function, coordinate by coordinate, with
// step h_i = step * max(1, |x_i|). `points` = 3 (error O(h^2)) or 5 (O(h^4)).
inline Eigen::VectorXd NumericGradient(const std::function<double(const Eigen::VectorXd&)>& f,
                                       const Eigen::VectorXd& x, double step, int points = 5) {
  Eigen::VectorXd g(x.size());
  Eigen::VectorXd y = x;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double h = step * std::max(1.0, std::abs(x[i]));
    auto at = [&](double delta) {
      y[i] = x[i] + delta;
      const double v = f(y);
      y[i] = x[i];
      return v;
    };
    if (points == 3) {
      g[i] = (at(h) - at(-h)) / (2.0 * h);
    } else {
      g[i] = (8.0 * (at(h) - at(-h)) - (at(2.0 * h) - at(-2.0 * h))) / (12.0 * h);
    }
  }
  return g;
}

// The error measure of every gradient test:
//   max_i |analytic_i - numeric_i| / max(max_i |numeric_i|, floor).
// The floor (default 1e-12) only guards a numeric gradient that is all zero.
inline double RelativeError(const Eigen::VectorXd& analytic, const Eigen::VectorXd& numeric,
                            double floor = 1e-12) {
  if (analytic.size() == 0) return 0.0;
  const double scale = std::max(numeric.cwiseAbs().maxCoeff(), floor);
  return (analytic - numeric).cwiseAbs().maxCoeff() / scale;
}

// "1.234e-09": for RecordProperty.
inline std::string Sci(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3e", v);
  return buf;
}

}  // namespace quadhand::traj::testing
