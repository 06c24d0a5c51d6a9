// A plan flown slower: the same waypoints of the base, the yaw and the
// joints with every duration multiplied by `factor` >= 1. A MINCO
// trajectory scaled in time is again the MINCO of the same waypoints with
// the scaled durations and the boundary derivatives divided by factor^k, so
// without an insertion the slowed plan is the original in scaled time,
// exactly. With an insertion, its last piece (the straight descent) keeps
// its own duration: the tool stays on the insertion line only with the
// attitudes it was planned with (slowed uniformly, the arm no longer makes
// up for the tilt, and the tool leaves the line); the transit through the
// same waypoints is then a new MINCO, not a rescaling. Either way the
// attitudes follow from new accelerations, so the original's certificate
// does not carry over: the slowed plan is post-checked afresh.
// quadhand-online flies plans slowed to the speed its link allows
// (docs/online.md, "Latency").
#pragma once

#include "quadhand/core/status.h"
#include "quadhand/planner/planner.h"

namespace quadhand::planner {

// The largest speed of the base over the trajectory, sampled every `step` s
// (and at its end).
double PeakSpeed(const WholeBodyTrajectory& trajectory, double step = 0.01);

// `plan` (successful, starting and ending at rest: every derivative of its
// head and tail below 1e-9) slowed by `factor` in [1, 1000], and its
// post-check against `task` (the task the plan was made for: its start is
// the plan's start) with options.post_check. success and status say
// whether the slowed plan passed; InvalidArgument for a plan without a
// trajectory, one not at rest at either end, or a bad factor.
core::Result<PlanResult> SlowDown(const PlanResult& plan, double factor, const PlanningScene& scene,
                                  const Task& task, const PlannerOptions& options);

}  // namespace quadhand::planner
