// The stages Plan() and Replan() share (defined in planner.cc). Plan():
// resolve the goal, check the end points, find the front-end path, make the
// initial guess, build the collision model, optimise (solve, post-check,
// raise weights, solve again). Replan(): its own guess from the current plan
// and start check, then the same last two stages.
#pragma once

#include <memory>
#include <vector>

#include "quadhand/planner/planner.h"

namespace quadhand::planner {

// The initial guess of an optimisation: MINCO waypoints and piece durations.
struct InitialGuess {
  MatX position_waypoints;  // 3 x (pieces - 1)
  MatX aux_waypoints;       // (1 + joints) x (pieces - 1)
  VecX durations;           // pieces
};

// The collision model a plan is optimised against: the scene's own, or one
// built for this plan (scene.per_plan_collision) along `path` with the piece
// boundaries start, the guess's waypoints, end.
struct PlanCollision {
  const env::CollisionModel* model = nullptr;
  std::unique_ptr<env::CollisionModel> owned;
};

// False, with result->status kRepresentationFailed and the reason, when the
// representation cannot represent this plan's scene (kInfeasible); other
// failures are errors.
core::Result<bool> BuildPlanCollision(const PlanningScene& scene, const std::vector<Vec3>& path, const Vec3& start,
                                      const InitialGuess& guess, const Vec3& end, PlanCollision* collision,
                                      PlanResult* result);

// The balls that hold the guess's waypoints on the task's vias, in order:
// for each via the nearest waypoint after the previous via's (the front end
// makes every via a corner and the guess a waypoint on every corner).
core::Result<std::vector<WaypointBall>> ViaBalls(const std::vector<ViaPoint>& vias, const MatX& waypoints);

// Creates the whole-body problem from task.start to result->terminal (with
// result->insertion) and runs SolveAndPostCheck from the guess on `schedule`.
core::Status Optimise(const PlanningScene& scene, const PlanCollision& collision, const Task& task,
                      const InitialGuess& guess, const PlannerOptions& options, const SolveSchedule& schedule,
                      PlanResult* result);

}  // namespace quadhand::planner
