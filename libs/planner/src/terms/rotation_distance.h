// The rotation distance d_R = (3 - tr(R R_g^T)) / 2 between a frame's
// rotation R and a goal rotation R_g (0 when equal, 2 at a half turn), and
// its gradient w.r.t. a world-frame rotation vector applied to R
// (R -> exp([phi]x) R). Shared by the insertion term and the terminal-state
// search, the two places that steer the tool's orientation.
#pragma once

#include "quadhand/core/types.h"

namespace quadhand::planner {

struct RotationDistance {
  double value = 0.0;
  Vec3 gradient = Vec3::Zero();
};

inline RotationDistance RotationDistanceTo(const Mat3& rotation, const Mat3& goal_rotation) {
  const Mat3 M = rotation * goal_rotation.transpose();
  RotationDistance d;
  d.value = 0.5 * (3.0 - M.trace());
  // d tr(exp([phi]x) M) / d phi = (M23 - M32, M31 - M13, M12 - M21).
  d.gradient = -0.5 * Vec3(M(1, 2) - M(2, 1), M(2, 0) - M(0, 2), M(0, 1) - M(1, 0));
  return d;
}

}  // namespace quadhand::planner
