// Penalty functions of the whole-body cost (paper Sec. VI).
#pragma once

namespace quadhand::opt {

// The paper's smoothed L1 (Eq. for l(x)), with smoothing mu > 0:
//   0 for x < 0;  (mu - x/2) (x/mu)^3 for 0 <= x <= mu;  x - mu/2 for x > mu.
// C^2 at 0 and C^1 at mu. Returns the value and writes dl/dx to *slope.
inline double SmoothedL1(double x, double mu, double* slope) {
  if (x <= 0.0) {
    *slope = 0.0;
    return 0.0;
  }
  if (x >= mu) {
    *slope = 1.0;
    return x - 0.5 * mu;
  }
  const double r = x / mu;
  *slope = r * r * (3.0 - 2.0 * r);
  return (mu - 0.5 * x) * r * r * r;
}

}  // namespace quadhand::opt
