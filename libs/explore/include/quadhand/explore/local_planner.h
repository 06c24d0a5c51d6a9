// One receding-horizon plan of onboard perception (docs/perception.md,
// "Planning from the map"): from a state of the vehicle, a whole-body plan
// certified against what the rolling map has not seen free, to the task's
// goal when the map shows it free and reachable, otherwise to a local target
// in the seen free space nearest the goal.
//
// The scene of a local plan is the map's obstacle boundary in a box about
// the start (perception::RollingMap::ObstacleBoundary): the centres of the
// voxels that are not free (occupied, unknown, or outside the box) and touch
// a free one. The plan keeps the task's safety distance plus a tracking
// margin plus the ball radius of a voxel from those centres, which
// certifies the task's safety distance plus the margin from every point of
// every voxel not seen free: unknown space is never certified free. Every plan ends at rest, so the vehicle always holds a
// certified plan that stops inside seen free space.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/opt/solver.h"
#include "quadhand/perception/rolling_map.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/planning_context.h"

namespace quadhand::robot {
struct KinematicsState;
}  // namespace quadhand::robot

namespace quadhand::explore {

struct LocalPlannerOptions {
  // The scene box about the plan's start: its half extents, m. Beyond it
  // everything counts as an obstacle, so the plan stays inside it.
  Vec3 box_half_extent = Vec3(6.0, 6.0, 2.0);
  // A local target lies within this distance of the start, m.
  double horizon = 5.0;
  // Local targets are tried from a lattice of this spacing, m, nearest the
  // goal first; at most max_targets of them per plan, the a-th (from 0)
  // within horizon / 2^a of the start (a shorter hop when a far target
  // fails), each at least target_separation from those tried before (a
  // target next to one that failed fails alike).
  double target_spacing = 0.25;
  int max_targets = 3;
  double target_separation = 1.0;
  // A local target nearer the start than this is not worth a plan, m; and
  // one that ranks no nearer the goal than the start by this much is no
  // progress (LocalPlanResult::progress).
  double min_progress = 0.3;
  // Targets are ranked by their straight distance to the goal, or with
  // guide_cell > 0 by the guide's way to the goal (guide.h: through the
  // map's window round what it has seen occupied, unknown space open) on
  // cells of this edge, m. Off by default: it leads out of a dead end, but
  // its coarse cells can close a window, and in rooms it costs time
  // (docs/perception.md, "Local targets along a guide").
  double guide_cell = 0.0;
  // The local targets' height stays within this of the goal's, m (the
  // lattice covers the box otherwise).
  double max_height_offset = 1.0;
  // A local target is tried only where the robot hovering there (heading
  // from the start; the goal's joints, or the start's when the arm is
  // folded) clears the boundary by the planned
  // safety distance plus this, m (exact meshes): room for the optimiser.
  double target_clearance_margin = 0.05;
  // At most this many targets are tested that way per plan.
  int max_target_checks = 400;
  // Local plans fly within these (and the task's limits), m/s and m/s^2:
  // the controller tracks a gentle plan within about 3 cm, and an
  // aggressive one through a door by 13 cm (docs/perception.md).
  double max_speed = 1.5;
  double max_acceleration = 2.0;
  // Added to the planned safety distance for the vehicle's tracking error, m.
  double tracking_margin = 0.03;
  // Each target's plan tries at most this many other initial guesses
  // (PlannerOptions::alternative_guesses, capped): a local plan that fails
  // is retried at the next replan from a newer map, not at length now.
  int alternative_guesses = 1;
  // A start nearer the boundary than the certificate's floor (the task's
  // distance plus the ball radius: where a brake that could not stop short
  // of a new obstacle leaves the vehicle) plans a recovery: the post-check's
  // recovery rule (PostCheckOptions::recovery_time) holds the clearance at
  // least at the start's own for this long, s, and at the planned distance
  // from then on. Without it no plan could be certified from there.
  double recovery_time = 1.0;
  bool IsValid(std::string* why) const;
};

// The configuration local plans use when the user gives none: the model
// and the front end's map are built at every replan over a box full of
// boundary voxels, which lie on the rolling map's lattice (voxels
// `map_resolution` m), so MRC-SDF's far grid and the front end's voxels
// are the map's voxel, kept within [0.05, 0.1] m (finer grows the front
// end's grid by the cube; coarser closes gaps), and the far grid is
// searched out to 1 m only (docs/configuration.md).
void UseLocalPlanningDefaults(planner::PlannerConfig* config, double map_resolution = 0.1);

// The context local plans are made from (LocalPlanner::Create's `base`):
// the task's robot, its link SDFs (MRC-SDF) and goal. It never plans
// itself; a context needs points, so one 20 m above the task's start
// stands for the scene, which every local plan replaces with the map's.
core::Result<std::unique_ptr<planner::PlanningContext>> BaseContext(planner::Task task, robot::RobotModel robot,
                                                                    const planner::PlannerConfig& config);

// The same from a task file whose scene is not read (its key may be left
// out: the sensor gives the scene), nor robot loaded twice. Errors name the
// file.
core::Result<std::unique_ptr<planner::PlanningContext>> BaseContextOfTaskFile(const std::string& task_path,
                                                                              const planner::PlannerConfig& config);

struct GraspWork;

// The legs a task is flown as under perception, each a task whose goal is
// one terminal state at rest: the task itself when its goal is one, or each
// reach of a mission of reaches in turn (a reach with a whole-body state
// and no tool pose), every leg starting where the one before ends. With
// `grasp` (GraspWorkOfTask), the steps from its reach on are the grasp's,
// flown on the grasp map, and the last leg ends at its staging state.
// Anything else (a tool pose, grasp, release, move, via, hold or moving
// target) is refused (InvalidArgument naming the task file): not flown
// under perception yet.
core::Result<std::vector<planner::Task>> LegsOfTask(const planner::Task& task, const GraspWork* grasp = nullptr);

enum class LocalPlanStatus {
  kToGoal,         // certified, to the task's goal
  kToLocalTarget,  // certified, to a local target
  kNoTarget,       // no seen-free point of the box is a target
  kFailed,         // every target tried failed its plan
  kTurnInPlace,    // certified, a turn in place to look round (PlanTurnIn)
};
const char* LocalPlanStatusName(LocalPlanStatus status);
// A plan was made and certified (to the goal, to a local target, or a turn).
inline bool IsCertified(LocalPlanStatus status) {
  return status == LocalPlanStatus::kToGoal || status == LocalPlanStatus::kToLocalTarget ||
         status == LocalPlanStatus::kTurnInPlace;
}

// What a local plan came to and cost: what a flight logs of each replan.
struct LocalPlanSummary {
  LocalPlanStatus status = LocalPlanStatus::kFailed;
  int targets_tried = 0;
  size_t scene_points = 0;
  double scene_ms = 0.0;    // the obstacle boundary out of the map
  double context_ms = 0.0;  // its representations and front-end map
  double plan_ms = 0.0;     // the plans, every target tried
  double total_ms = 0.0;
  // The distance planned with: PlannedSafetyDistance, or less when the
  // start was nearer the boundary than that (never less than the task's
  // distance plus the map's ball radius, which the certificate needs).
  double safety_distance = 0.0;
  // The start's clearance to the boundary's centres (exact link meshes),
  // and whether it was inside that floor, so that the plan is a recovery
  // (LocalPlannerOptions::recovery_time).
  double start_clearance = 0.0;
  bool recovery = false;
  std::string message;      // why the last target failed, for people
};

// What a local plan from one start needs of the rolling map, taken at once:
// a planner in another thread than the map's plans from this while the map
// takes new frames (quadhand-online --perception). The map's boundary in the
// box about the start, and the lattice points the map had seen free.
struct LocalMapSnapshot {
  Vec3 start = Vec3::Zero();  // the position it was taken about
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();
  std::shared_ptr<const std::vector<Vec3>> boundary;
  double resolution = 0.1;           // the map's voxel edge, m
  bool goal_seen_free = false;       // the goal in the box and seen free
  std::vector<Vec3> seen_free;       // target lattice points seen free, in lattice order
  // Each one's rank (smaller first): the guide's way to the goal, m, or
  // without a guide (guide_cell 0) its straight distance to the goal; one
  // the guide cannot reach ranks after every other, by straight distance.
  std::vector<double> seen_free_rank;
  double start_rank = 0.0;           // the start's, alike
  double ms = 0.0;                   // taking it
};

struct LocalPlanResult : LocalPlanSummary {
  planner::PlanResult plan;  // the certified plan (kToGoal, kToLocalTarget)
  Vec3 target = Vec3::Zero();
  // Every target a plan was tried to, in order (the certified one last).
  std::vector<Vec3> tried_targets;
  // Certified to the goal, or to a target that ranks nearer the goal than
  // the start by at least min_progress. A certified plan without it hops
  // along the frontier where the vehicle is (a local minimum): a vehicle
  // there looks round first (exploration_flight.h).
  bool progress = false;
};

class LocalPlanner {
 public:
  // `base` is the task's context (its robot, link SDFs and goal); it and
  // `solver` must outlive the planner. InvalidArgument for bad options or a
  // task that is not a goal at rest (a mission, a tool pose or a moving
  // target are not flown under perception yet).
  static core::Result<std::unique_ptr<LocalPlanner>> Create(const planner::PlanningContext& base,
                                                            const planner::PlannerOptions& options,
                                                            const opt::Solver& solver,
                                                            const LocalPlannerOptions& local);

  // A plan from `start` (world ENU; usually a state on the plan being flown)
  // in what `map` has seen. Ordinary outcomes are statuses; errors only for
  // inconsistent input (joint counts, non-finite states).
  // `avoid`: targets (the goal among them) within target_separation of
  // these are not tried, e.g. the ones that failed from the same state at
  // rest before: the same map and start would fail them again.
  core::Result<LocalPlanResult> PlanFrom(const perception::RollingMap& map, const planner::BoundaryState& start,
                                         const std::vector<Vec3>& avoid = {}) const;
  // PlanFrom in two steps: the map's part (a few ms), and the plan from it
  // (no map needed, so in any thread). Snapshot needs only the start's
  // position. `v_max` > 0 lowers the speed limit further (a slow link).
  LocalMapSnapshot Snapshot(const perception::RollingMap& map, const Vec3& start) const;
  core::Result<LocalPlanResult> PlanIn(const LocalMapSnapshot& snapshot, const planner::BoundaryState& start,
                                       double v_max = 0.0, const std::vector<Vec3>& avoid = {}) const;

  // A turn in place from `start` (at rest) to the heading `yaw` (rad; the
  // turn goes the shorter way): certified like any local plan, so the arm's
  // sweep stays clear of what the map has not seen free. The arm folds to
  // the joints that hold the robot nearest its base, where that makes it
  // more than 1 cm smaller (a vehicle with its arm out cannot turn in a
  // small seen-free ball), else, or when that turn fails, keeps its joints.
  // Hops from the folded joints keep them (PlanIn); the plan to the goal
  // unfolds the arm.
  // What a vehicle at a dead end does to look round (look_round.h): a
  // camera sees a narrow view, and a wall ahead can hide every way on.
  // kTurnInPlace when certified, else kFailed with the reason.
  core::Result<LocalPlanResult> PlanTurnFrom(const perception::RollingMap& map, const planner::BoundaryState& start,
                                             double yaw) const;
  core::Result<LocalPlanResult> PlanTurnIn(const LocalMapSnapshot& snapshot, const planner::BoundaryState& start,
                                           double yaw, double v_max = 0.0) const;

  const planner::BoundaryState& goal() const { return goal_; }
  const LocalPlannerOptions& options() const { return local_; }
  // The first plan time in [from, the plan's end] (sampled every `step` s,
  // and the end) at which the robot on `trajectory` comes nearer than
  // `distance` to one of `obstacles` (exact link meshes against points);
  // none when it never does. For a plan certified against an older map and
  // the obstacles a newer frame found in space that map had seen free
  // (RollingMap::NewlyBlocked), with PlannedSafetyDistance as the distance.
  std::optional<double> FirstConflict(const planner::WholeBodyTrajectory& trajectory, double from,
                                      const std::vector<Vec3>& obstacles, double distance, double step = 0.02) const;
  // The acceleration local plans keep within (the task's, and max_acceleration).
  double AccelerationLimit() const;
  // The safety distance local plans keep from the boundary's centres: the
  // task's, plus tracking_margin, plus the map's ball radius.
  // (A map of voxels `map_resolution` m.)
  double PlannedSafetyDistance(double map_resolution) const;

 private:
  LocalPlanner(const planner::PlanningContext& base, const planner::PlannerOptions& options, const opt::Solver& solver,
               const LocalPlannerOptions& local);
  struct Prepared;
  // The plan's task and context from the snapshot; false (result's status
  // and message set) when the context cannot be built.
  core::Result<bool> Prepare(const LocalMapSnapshot& snapshot, const planner::BoundaryState& start, double v_max,
                             LocalPlanResult* result, Prepared* prepared) const;
  // The robot hovering at `terminal` clears the boundary by the prepared
  // safety distance plus `margin` (exact meshes).
  bool HoverClears(const Prepared& prepared, const planner::BoundaryState& terminal, double margin,
                   robot::KinematicsState* kinematics) const;
  const planner::PlanningContext& base_;
  planner::PlannerOptions options_;
  const opt::Solver& solver_;
  LocalPlannerOptions local_;
  planner::BoundaryState goal_;
  // The robot's collision vertices per link (link frame), and its joints
  // that hold them nearest the base: a turn in place folds the arm to them
  // first where that makes the robot smaller (PlanTurnIn).
  std::vector<std::vector<Vec3>> link_vertices_;
  VecX compact_joints_;
  double compact_radius_ = 0.0;
  double RadiusAt(const VecX& joints) const;
};

}  // namespace quadhand::explore
