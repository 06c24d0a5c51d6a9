// Planning a whole task: a goal, or a mission (planner/mission.h,
// docs/missions.md) as one trajectory.
//
// A mission is flown as legs that meet at rest: every step ends at rest (a
// reach at its terminal state, a move at the end of its line, a via at its
// point, a grasp, release or hold after its time), so the legs join into one
// piecewise polynomial that is as smooth at each junction as inside a leg.
// A reach (and a via) is planned by Plan() from where the step before it
// ended; a move is a straight rest-to-rest line of the base with the arm and
// yaw held; a grasp, release or hold is a hover. Between a grasp and its
// release the robot carries the object as one more link fixed to the tool
// link (its SDF made in memory for the optimiser, its exact shape for the
// checks), and the scene points within the grasp's scene_margin of it are
// gone; after the release its surface is scene.
//
// Every leg is post-checked (the continuous-time certificate included)
// against the scene of its phase, the robot without the object at the
// safety distance and, while something is held, the object alone by the
// held_object_clearance rule of contracts.md 0.3: the safety distance, or
// clearance >= 0 on the grasp step, a move right after it, the insertion
// of a reach right before a release (flown as a leg of its own, a line
// from the insertion's start) and the release step (docs/missions.md).
#pragma once

#include <cstddef>
#include <memory>

#include "quadhand/core/status.h"
#include "quadhand/opt/solver.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/planning_context.h"

namespace quadhand::planner {

// The phases of a mission that PlanTask built (the scene after each grasp
// and release, with its representations and front-end map), kept for later
// plans of the same task from the same context: a phase depends on the
// object and where it is held or left, not on the start (quadhand-bench's
// trials, replans). Thread-safe; at most 16 phases, of one context.
class MissionPhaseCache {
 public:
  MissionPhaseCache();
  ~MissionPhaseCache();
  MissionPhaseCache(const MissionPhaseCache&) = delete;
  MissionPhaseCache& operator=(const MissionPhaseCache&) = delete;

  class Impl;
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

// Plans context.task() with representation `representation` (its index in
// the context): a goal, or a mission of one reach, exactly as Plan() does
// (the result then has one step); a longer mission leg by leg as above.
// A step that cannot be planned ends the plan: the result names it in
// `message`, its steps from that one on are not `planned`, and `trajectory`
// holds the legs planned before it. Errors (exit 2 in the applications) are
// for input that cannot be right whatever the plan.
core::Result<PlanResult> PlanTask(const PlanningContext& context, size_t representation, const PlannerOptions& options,
                                  const opt::Solver& solver);

// The same for `task`: context.task() with other values that do not change
// what the context built (another start, as quadhand-bench draws them).
// With `cache` (null: none), the phases come from it when it has them.
core::Result<PlanResult> PlanTask(const PlanningContext& context, const Task& task, size_t representation,
                                  const PlannerOptions& options, const opt::Solver& solver,
                                  MissionPhaseCache* cache = nullptr);

// A mission's scene and held object as a flight really went, for judging
// its record (quadhand-flightcheck): the phases PlanTask builds, changed at
// the gripper events the vehicle reported and with the tool where it was
// then (the object is held where the flown tool closed on it, and left
// where the flown tool opened), not where a plan meant them to be.
class MissionReplay {
 public:
  // The first phase of context.task()'s mission (an object held from the
  // start attached). Errors name the task file and the step.
  static core::Result<std::unique_ptr<MissionReplay>> Start(const PlanningContext& context,
                                                            const MissionPlanOptions& options);
  ~MissionReplay();

  // The gripper closed with the vehicle at this base pose and these joints:
  // the next grasp step's object is held where it lies relative to the
  // tool. InvalidArgument when the robot has no tool link, the mission has
  // no grasp left, or something is held already. `target` is the moving
  // target's displacement from t = 0 then (MovingToolGoal; the object of
  // the grasp after its reach moves with it).
  core::Status GripperClosed(const Pose& base, const VecX& joints, const Pose& target = Pose::Identity());
  // The gripper opened there: the held object is left where the tool holds
  // it and joins the scene. Opening with nothing held changes nothing.
  core::Status GripperOpened(const Pose& base, const VecX& joints);

  struct Clearances {
    double robot = 0.0;  // the robot's links (without the held object), m
    int robot_link = -1;
    double object = 0.0;  // the held object; +infinity when nothing is held
  };
  // Exact clearances, against the phase's scene, of the robot at this base
  // pose and these joints (the search capped at `reach`); the points that
  // move with a moving target where its displacement `target` puts them.
  Clearances Measure(const Pose& base, const VecX& joints, double reach, const Pose& target = Pose::Identity()) const;
  // The robot of the current phase (a held object is its last link).
  const robot::RobotModel& robot() const;
  // The grasp step of the held object; -1 when nothing is held.
  long held_step() const;

  class Impl;

 private:
  explicit MissionReplay(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace quadhand::planner
