// What of a plan moves with a moving target (target_motion.h,
// docs/moving_targets.md): the target's motion, and the scene points inside
// the task's moving_points box, kept apart from the still scene as their
// own collision model and exact model at t = 0. The optimiser and the
// post-check query them with the robot moved back by the target's
// displacement at each sample's time.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/env/exact_mesh_model.h"
#include "quadhand/planner/target_motion.h"
#include "quadhand/planner/whole_body_problem.h"

namespace quadhand::planner {

struct MovingScene {
  const TargetMotion* motion = nullptr;            // null: nothing moves
  const env::CollisionModel* collision = nullptr;  // the moving points at t = 0; null: none
  const env::ExactMeshModel* exact = nullptr;      // the same, exact, for the post-check; null: none
  // The farthest moving point from the target's position at t = 0, metres:
  // with the turn rate it bounds how fast a moving point goes.
  double radius = 0.0;
  // The target's pose (the tool goal's) at t = 0: a replan against a new
  // prediction of the target carries the grasp from the old pose to it.
  Pose target_at_zero = Pose::Identity();
  // Whether the plan's goal moves with the target (its end state, its
  // insertion line and its tool judged in the target's frame). False for a
  // leg of a mission that only passes the moving points on its way to a
  // still goal (mission_plan.h).
  bool goal_moves = true;

  bool moves() const { return motion != nullptr; }
  bool has_points() const { return exact != nullptr; }
  // The most speed of a moving point over [0, horizon] (0 without points).
  double PointSpeed(double horizon) const {
    return has_points() ? motion->MaxSpeed(radius, horizon) : 0.0;
  }
};

// The whole scene as it stands at time t, as one collision model: the
// still scene's model and the moving points' model, the latter queried with
// each link moved back by the target's displacement at t (for the
// terminal-state search at an arrival time). Penalties add, clearances take
// the least; its links are both models' links. Both models must outlive it.
class SceneAtTimeModel final : public env::CollisionModel {
 public:
  SceneAtTimeModel(const env::CollisionModel& still, const env::CollisionModel& moving, const TargetMotion& motion,
                   double t);

  std::string name() const override { return still_.name(); }
  env::DistanceQuality distance_quality() const override;
  const std::vector<int>& links() const override { return links_; }
  double LinkPenalty(int link, const Pose& X_WL, const env::PenaltyParameters& parameters,
                     const env::QueryContext& context, env::LinkWrench* wrench) const override;
  double LinkClearance(int link, const Pose& X_WL, double search_radius,
                       const env::QueryContext& context) const override;

 private:
  bool Has(const std::vector<int>& slots, int link) const {
    return link >= 0 && link < static_cast<int>(slots.size()) && slots[link] >= 0;
  }

  const env::CollisionModel& still_;
  const env::CollisionModel& moving_;
  Pose displacement_, back_;
  std::vector<int> links_, still_slots_, moving_slots_;
};

// A state that grasps the target at t = 0, moved to grasp it at time t:
// the base at Displacement(t) of its position, with the velocity and its
// derivatives of that target-fixed point, the yaw turned with the target at
// its rate, the joints as they were, at rest.
BoundaryState MovedState(const BoundaryState& at_zero, const TargetMotion& motion, double t);

// The inverse: a state at time t taken back to t = 0 (position and yaw only;
// the rates are zero, as a reference state's).
BoundaryState StateAtZero(const BoundaryState& at_t, const TargetMotion& motion, double t);

// An insertion (its tool pose and line) moved by Displacement(t).
InsertionGoal MovedInsertion(const InsertionGoal& at_zero, const TargetMotion& motion, double t);

// The same moves by any rigid `move` whose rotation turns about z by `turn`
// (rad, given so that a turn past pi keeps its sign and count): a state at
// rest (position moved, yaw turned, every rate zero) and an insertion.
BoundaryState MovedRestState(const BoundaryState& state, const Pose& move, double turn);
InsertionGoal MovedInsertion(const InsertionGoal& insertion, const Pose& move);

// The same for link poses: `kinematics` with every link pose moved by the
// inverse of Displacement(t), as the moving points' models see the robot.
robot::KinematicsState InTargetFrameAtZero(const robot::KinematicsState& kinematics, const TargetMotion& motion,
                                           double t);
// The same for a displacement given (one a record measured).
robot::KinematicsState InTargetFrameAtZero(const robot::KinematicsState& kinematics, const Pose& displacement);

// The clearance of `kinematics` against the still scene's `still` model
// and, when given, against the moving points' `moving` model (at t = 0) as
// the target's `displacement` has moved them, searched out to `reach`;
// `link` (optional) gets the nearest link. What a flown record is judged by.
double StillAndMovingClearance(const robot::KinematicsState& kinematics, const env::CollisionModel& still,
                               const env::CollisionModel* moving, const Pose& displacement, double reach,
                               int* link = nullptr);

}  // namespace quadhand::planner
