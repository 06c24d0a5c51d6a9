// What quadhand-sim --world and quadhand-explore say of a hidden world
// before a simulated sensor renders it, and quadhand-explore of its start.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "quadhand/core/types.h"
#include "quadhand/sim/sensor.h"

namespace quadhand::apps {

// One warning line on stderr when the world's points lie farther apart than
// the sensor's discs cover (sim::PointSpacing at 0.9: the spacing of all
// but its sparsest tenth): the sensor would see through its surfaces and
// free the space behind them, which no real sensor does. A world is not
// refused for it: the verdicts are still against the true points.
inline void WarnWhenTheSensorSeesThrough(const char* program, const std::string& world_path,
                                         const std::vector<Vec3>& world, const sim::SensorConfig& sensor) {
  const double spacing = sim::PointSpacing(world, 0.9);
  const double needed = spacing / std::sqrt(2.0);
  if (spacing <= 0.0 || sensor.splat_radius >= needed) return;
  std::fprintf(stderr,
               "%s: warning: %s: a tenth of its points are %.3f m or more from their nearest, and discs of "
               "sensor.splat_radius %.3f m leave holes between them that the simulated sensor sees through "
               "(docs/sim.md, \"Points as discs\"); a radius of %.3f m or more covers them\n",
               program, world_path.c_str(), spacing, sensor.splat_radius, std::ceil(needed * 1000.0) / 1000.0);
}

// One warning line on stderr when a point of the world lies inside the
// ball about the start that the map takes as free at take-off (no sensor
// sees the vehicle's own space): the planner may plan through it.
inline void WarnWhenTheStartBallHoldsTheWorld(const char* program, const std::string& world_path,
                                              const std::vector<Vec3>& world, const Vec3& start,
                                              double start_free_radius) {
  double nearest = std::numeric_limits<double>::infinity();
  for (const Vec3& p : world) nearest = std::min(nearest, (p - start).norm());
  if (nearest >= start_free_radius) return;
  std::fprintf(stderr,
               "%s: warning: %s: a point of the world lies %.3f m from the start, inside --start-free-radius "
               "%.3f m, which the map takes as free (docs/perception.md, \"Planning from the map\")\n",
               program, world_path.c_str(), nearest, start_free_radius);
}

}  // namespace quadhand::apps
