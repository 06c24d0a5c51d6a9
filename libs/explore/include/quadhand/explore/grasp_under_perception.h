// A grasp under perception (docs/perception.md, "A grasp under
// perception"): the mission's reach that closes the gripper on an object,
// its grasp and the moves and holds after it, flown on a second, fine map
// about the object once exploration has brought the vehicle near.
//
// The exploration map's voxels (0.05-0.1 m) are certified with a ball of
// half their diagonal about each centre not seen free: a gripper whose
// fingers pass 3.5 cm from a cup and 6 cm above what it stands on cannot be
// certified there. The grasp map (5 mm voxels in a box about the work) is
// fed every frame, from afar as well (a ray is walked where it crosses the
// box); the work is planned on it by the known-scene mission planner
// (PlanTask), whose scene is the grasp map's obstacle boundary and whose
// safety distance is the task's plus the tracking margin plus the grasp
// map's ball radius: nothing is certified through space not seen free.
//
// What is taken on trust, as a known scene's scan is: the voxels the
// object is in. A not-free voxel of the grasp map whose centre lies within
// the grasp's scene_margin plus the voxel's ball radius of the declared
// object leaves the obstacles with the object (a scan's points within
// scene_margin of it leave a known scene). So the certificate holds against
// everything not seen free except within scene_margin plus twice the ball
// radius of the declared object (1.9 cm at the defaults).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/opt/solver.h"
#include "quadhand/perception/rolling_map.h"
#include "quadhand/planner/mission.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::explore {

struct GraspOptions {
  // The grasp map's voxel edge, m. Its ball radius (half the diagonal,
  // 4.3 mm) is added to the safety distance: 5 mm voxels keep a gripper
  // whose fingers end 6 cm above a surface certified where 1 cm voxels
  // (8.7 mm) do not, the surface's returns scattering a centimetre or two
  // above it at grazing angles.
  double resolution = 0.005;
  // The vehicle explores to the reach's state moved back along its
  // insertion by the insertion's length plus this (m), at rest, and flies
  // the rest on the grasp map: on the exploration map the fingers at the
  // insertion's start (centimetres above the object) are not certified.
  double approach = 0.15;
  // The grasp map's box holds the robot at every state of the work (the
  // staging, the insertion's ends, each move's end) with this much room
  // (m): more than the safety distance, the tracking margin and the ball.
  double box_margin = 0.15;
  // The grasp map takes at most this many frames a second (the scene
  // holds still, and each frame's rays cost 100 times the exploration
  // map's there), and of the pixels that saw nothing every miss_stride-th
  // along each image axis (its voxels are a few pixels' footprint wide at
  // a few metres). Fewer rays free less: never less safe.
  double frame_rate = 10.0;
  int miss_stride = 2;
  bool IsValid(std::string* why) const;
};

// The part of a mission flown on the grasp map.
struct GraspWork {
  size_t reach_step = 0;  // the mission's reach whose tool closes on the object (the grasp is the next step)
  // Where exploration ends, at rest: the reach's state moved back along
  // its insertion by the insertion's length plus GraspOptions::approach.
  planner::BoundaryState staging;
  // The reach (state, tool pose, insertion), the grasp, and the moves and
  // holds after it: the mission PlanTask plans from the staging state.
  std::vector<planner::MissionStep> steps;
  planner::MissionObject object;
  double scene_margin = 0.01;
  Vec3 tool_position = Vec3::Zero();  // the reach's tool point: a grasp is judged by the flown tool's distance from it
  Vec3 box_lo = Vec3::Zero(), box_hi = Vec3::Zero();  // the grasp map's box, world
};

// The grasp work of `task`'s mission: none without a grasp. Flown under
// perception: reaches at rest (exploration legs), then at most one grasp,
// whose reach gives a whole-body state, a tool pose and an insertion, and
// after which come only moves and holds. Anything else is refused naming
// the step (InvalidArgument). The box needs the robot's link meshes.
core::Result<std::optional<GraspWork>> GraspWorkOfTask(const planner::Task& task, const robot::RobotModel& robot,
                                                       const GraspOptions& options);

// The fine map about a grasp: a rolling map over the work's box, fed the
// same frames as the exploration map.
class GraspMap {
 public:
  // `map` gives the sensor model and range (its resolution and window are
  // replaced by the grasp's). InvalidArgument for bad options.
  static core::Result<std::unique_ptr<GraspMap>> Create(const GraspWork& work, const GraspOptions& options,
                                                        const perception::RollingMapOptions& map);
  // The take-off ball, taken as free (RollingMap::MarkFree), as on the
  // exploration map.
  void MarkFree(const Vec3& centre, double radius);
  // One frame (world frame), as RollingMap::Insert.
  core::Status Insert(const std::vector<Vec3>& points, const Vec3& origin, const std::vector<Vec3>& misses);
  // What a plan of the work keeps its distance from: the centres of the
  // map's obstacle boundary in the box (every face of the box among them),
  // less the voxels taken to be the object's (above).
  std::vector<Vec3> Obstacles() const;
  // What the last Insert found in space the map had seen free (RollingMap::
  // NewlyBlocked) in the box, less the object's voxels: where it was, and
  // where it is held when `held` gives its pose now (a held object seen
  // moving with the tool is not a new obstacle). A plan certified before
  // is checked again against these while it is flown.
  std::vector<Vec3> NewObstacles(const std::optional<Pose>& held = std::nullopt) const;
  double BallRadius() const { return map_->BoundaryBallRadius(); }
  const perception::RollingMap& map() const { return *map_; }

 private:
  GraspMap(const GraspWork& work, std::unique_ptr<perception::RollingMap> map);
  const GraspWork& work_;
  std::unique_ptr<perception::RollingMap> map_;
};

// The work planned on the grasp map.
struct GraspPlan {
  bool certified = false;  // every step passed the post-check
  std::string message;     // why not, naming the step
  planner::PlanResult plan;  // its trajectory (when certified) and steps, times from the plan's start
  size_t obstacles = 0;    // boundary voxel centres planned against
  double safety_distance = 0.0;
  double ms = 0.0;  // the obstacles, the context and the plan
};

class GraspPlanner {
 public:
  // `base` is a context of the task's robot (its link SDFs are reused);
  // `task` the whole task (its limits, safety distance, self-collision
  // rules). All must outlive the planner.
  GraspPlanner(const planner::PlanningContext& base, const planner::Task& task, const GraspWork& work,
               const planner::PlannerOptions& options, const opt::Solver& solver, double tracking_margin);
  // The work from `start` (at rest, near the staging state) on what `map`
  // has seen. Errors only for inconsistent input.
  core::Result<GraspPlan> Plan(const GraspMap& map, const planner::BoundaryState& start) const;
  // The safety distance of its plans from the boundary centres of a grasp
  // map of voxels `resolution` m.
  double PlannedSafetyDistance(double resolution) const;

 private:
  const planner::PlanningContext& base_;
  const planner::Task& task_;
  const GraspWork& work_;
  planner::PlannerOptions options_;
  const opt::Solver& solver_;
  double tracking_margin_;
};

}  // namespace quadhand::explore
