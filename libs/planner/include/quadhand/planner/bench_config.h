// The benchmark configuration (quadhand-bench --config, docs/benchmark.md):
// the task the trials plan and the box and yaw range their starts are drawn
// from.
//
//   task: window_cup_task.yaml          # relative to the config's folder
//   start_box: {min: [x, y, z], max: [x, y, z]}   # m, world ENU
//   yaw: [min, max]                     # rad, optional (default [-pi, pi])
//   target:                             # optional: the task's target moves (docs/moving_targets.md)
//     speeds: [0.0, 0.25, 0.5, 1.0]     # m/s: trial k moves it at speeds[k % count]
//     heading: [min, max]               # rad from world x about z, drawn with seed k;
//                                       # the sign of the motion is drawn too
//     pass_time: 6.0                    # s: it passes its place in the task then
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::planner {

// A benchmark of a moving target: each trial moves the task's target (and
// its moving points) in a straight line at one of `speeds`, along a heading
// drawn in [heading_min, heading_max] (or against it), so that it passes
// the place the task gives it at `pass_time` after the start.
struct BenchTarget {
  std::vector<double> speeds;  // m/s, each >= 0
  double heading_min = -M_PI, heading_max = M_PI;
  double pass_time = 6.0;  // s
};

struct BenchConfig {
  std::string task_path;  // resolved against the config's folder
  Vec3 box_min = Vec3::Zero(), box_max = Vec3::Zero();
  double yaw_min = -M_PI, yaw_max = M_PI;
  std::optional<BenchTarget> target;
};

// Reads a benchmark configuration. Unknown keys, missing or malformed values,
// non-finite numbers and min > max are errors naming the file and the key.
core::Result<BenchConfig> LoadBenchConfig(const std::string& path);
// The same from YAML text; errors name `name`, `task` is resolved against
// the folder of `name`.
core::Result<BenchConfig> ParseBenchConfig(const std::string& text, const std::string& name);

}  // namespace quadhand::planner
