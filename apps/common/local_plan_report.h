// What quadhand-explore's and quadhand-map --plan's JSON reports share: a
// local plan's summary (explore/local_planner.h) and a list of times as
// count, median, p95 and max. Header-only: only the programs that write
// these reports (and link explore and nlohmann_json) include it.
#pragma once

#include <algorithm>
#include <vector>

#include <nlohmann/json.hpp>

#include "quadhand/core/statistics.h"
#include "quadhand/explore/local_planner.h"

namespace quadhand::apps {

inline nlohmann::json CountMedianP95Max(const std::vector<double>& values) {
  return {{"count", values.size()},
          {"median", core::RankQuantile(values, 0.5)},
          {"p95", core::RankQuantile(values, 0.95)},
          {"max", values.empty() ? 0.0 : *std::max_element(values.begin(), values.end())}};
}

// The keys of one replan in a report's replan_log, less its time and
// whatever the program adds.
inline nlohmann::json LocalPlanSummaryJson(const explore::LocalPlanSummary& plan) {
  return {{"status", explore::LocalPlanStatusName(plan.status)},
          {"total_ms", plan.total_ms},
          {"scene_ms", plan.scene_ms},
          {"context_ms", plan.context_ms},
          {"plan_ms", plan.plan_ms},
          {"safety_distance", plan.safety_distance},
          {"start_clearance", plan.start_clearance},
          {"recovery", plan.recovery},
          {"boundary_voxels", plan.scene_points},
          {"targets_tried", plan.targets_tried},
          {"message", plan.message}};
}

}  // namespace quadhand::apps
