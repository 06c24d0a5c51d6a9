// The global guide of onboard perception (docs/perception.md, "Local
// targets along a guide"): how far the goal is from a point along the
// shortest way through the rolling map's window that no occupied voxel
// blocks, unknown space counted open. Local targets are ranked by it, so a
// wall or a dead end sends the vehicle round, towards where the way may
// continue, instead of to the seen point nearest the goal as the crow flies.
//
// It is a heuristic for choosing targets and never a certificate: every
// plan is still certified against everything not seen free
// (local_planner.h). The way is searched on a coarse grid of cells
// (`cell` m): a cell holding an occupied voxel is blocked; moves go to the
// 26 neighbours at their centre distances. Only the layers within
// `height_range` of the goal's height are searched (where local targets
// may lie). A goal outside the window is reached from the window's open
// border cells, each at its straight distance to the goal.
#pragma once

#include <limits>
#include <vector>

#include "quadhand/core/types.h"
#include "quadhand/perception/rolling_map.h"

namespace quadhand::explore {

class Guide {
 public:
  static constexpr double kUnreachable = std::numeric_limits<double>::infinity();

  // The guide to `goal` through what `map` holds now. `cell` > 0 (m);
  // `height_range` >= 0 (m).
  static Guide Compute(const perception::RollingMap& map, const Vec3& goal, double cell, double height_range);

  // The way's length from `p` to the goal, m: the least, over the (up to)
  // eight cell centres about p the search reached, of the centre's length
  // plus the straight distance from p to it. kUnreachable for a point
  // outside the searched cells, or with none of those centres reached
  // (walled in, or blocked).
  double CostAt(const Vec3& p) const;

  int blocked_cells() const { return blocked_; }

 private:
  Vec3 lo_ = Vec3::Zero();
  double cell_ = 1.0;
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  std::vector<float> cost_;
  int blocked_ = 0;
};

}  // namespace quadhand::explore
