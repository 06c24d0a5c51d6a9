// The hidden world of the flights on the sensor: posts of 0.15 m radius
// between a start at the origin and a goal 8 m along x, the first square
// in the way, so that the vehicle sees them only as it flies; optionally
// on a floor (z = 0, x in [-2, 10], |y| <= 3).
#pragma once

#include <cmath>
#include <vector>

#include "quadhand/core/types.h"

namespace quadhand::testing {

inline const std::vector<Vec3>& PostCentres() {
  static const std::vector<Vec3> centres = {Vec3(3.0, 0.0, 0.0), Vec3(5.0, 1.0, 0.0), Vec3(5.5, -1.2, 0.0)};
  return centres;
}

inline std::vector<Vec3> PostsWorld(bool with_floor) {
  std::vector<Vec3> points;
  if (with_floor) {
    for (double x = -2.0; x <= 10.0 + 1e-9; x += 0.05) {
      for (double y = -3.0; y <= 3.0 + 1e-9; y += 0.05) points.emplace_back(x, y, 0.0);
    }
  }
  for (const Vec3& c : PostCentres()) {
    for (double z = 0.0; z <= 3.0 + 1e-9; z += 0.04) {
      for (int a = 0; a < 24; ++a) {
        const double angle = a * 2.0 * M_PI / 24.0;
        points.emplace_back(c.x() + 0.15 * std::cos(angle), c.y() + 0.15 * std::sin(angle), z);
      }
    }
  }
  return points;
}

}  // namespace quadhand::testing
