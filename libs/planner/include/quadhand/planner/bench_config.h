// The benchmark configuration (quadhand-bench --config, docs/benchmark.md):
// the task the trials plan and the box and yaw range their starts are drawn
// from.
//
//   task: window_cup_task.yaml          # relative to the config's folder
//   start_box: {min: [x, y, z], max: [x, y, z]}   # m, world ENU
//   yaw: [min, max]                     # rad, optional (default [-pi, pi])
#pragma once

#include <string>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::planner {

struct BenchConfig {
  std::string task_path;  // resolved against the config's folder
  Vec3 box_min = Vec3::Zero(), box_max = Vec3::Zero();
  double yaw_min = -M_PI, yaw_max = M_PI;
};

// Reads a benchmark configuration. Unknown keys, missing or malformed values,
// non-finite numbers and min > max are errors naming the file and the key.
core::Result<BenchConfig> LoadBenchConfig(const std::string& path);
// The same from YAML text; errors name `name`, `task` is resolved against
// the folder of `name`.
core::Result<BenchConfig> ParseBenchConfig(const std::string& text, const std::string& name);

}  // namespace quadhand::planner
