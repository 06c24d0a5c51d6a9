// Everything a plan needs that is built once per task file and scene: the
// task, the robot (with the task's joint limits applied), the scene cloud,
// the collision representations by name, the exact clearance of the
// post-check and the front-end map. quadhand-plan, quadhand-bench and
// quadhand-online load it the same way.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/geometry/sdf_grid.h"
#include "quadhand/planner/front_end.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/post_check.h"
#include "quadhand/planner/representation.h"
#include "quadhand/planner/task.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/scene/point_grid.h"

namespace quadhand::planner {

struct PlanningContextOptions {
  // Built in this order; names from RepresentationNames().
  std::vector<std::string> representations = {"mrc_sdf"};
  FrontEndOptions front_end;
  RepresentationOptions representation_options;
  // Points the front-end map must cover besides the cloud, the task's start,
  // its terminal state and (for a tool-pose goal) the arm's reach around the
  // tool: e.g. the corners of a benchmark's start box.
  std::vector<Vec3> front_end_also_contain;
  // The tolerance the robot's meshes are repaired with
  // (robot::RobotModel::mesh_repair_tolerance): the one quadhand-sdfgen
  // used for the link SDFs, and at most their resolution.
  double mesh_repair_tolerance = 1e-6;
  // The heaviest object a mission may grasp, kg: the paper's platform
  // (1.7 kg) flies a 150 g payload; twice that by default. A grasp of a
  // heavier one is refused (exit 2) naming the step.
  double payload_limit = 0.3;
};

// The moving part of a scene for one motion of the target (moving_scene.h),
// owning its models; `scene` points into them.
struct MovingSceneModels {
  TargetMotion motion;
  std::vector<Vec3> points, checked_points;  // at t = 0
  std::unique_ptr<env::CollisionModel> collision;
  std::unique_ptr<env::ExactMeshModel> exact;
  MovingScene scene;
};

class PlanningContext {
 public:
  // Loads the task, its robot and scene and builds the representations.
  // Errors name the file and the problem (InvalidArgument for an unknown
  // representation name).
  static core::Result<std::unique_ptr<PlanningContext>> Load(const std::string& task_path,
                                                             const PlanningContextOptions& options);

  // The same from a task, robot and cloud already in memory (the Python
  // module's way in): checks the task against the robot, then builds as
  // Load() does. The cloud is shared, not copied; it must be non-empty and
  // finite. `dropped_non_finite` is what the caller removed, for the record.
  // `checked_points`, when not null, are what the post-check judges plans
  // against instead of `points` (the scans before a voxel filter reduced
  // them: a plan must clear the raw points, not only their centroids).
  static core::Result<std::unique_ptr<PlanningContext>> Create(
      Task task, robot::RobotModel robot, std::shared_ptr<const std::vector<Vec3>> points, long dropped_non_finite,
      const PlanningContextOptions& options, std::shared_ptr<const std::vector<Vec3>> checked_points = nullptr);

  // The context of one phase of a mission (planner/mission_plan.h): this
  // context's task and options with `robot` (this robot, or this robot
  // holding an object: robot::RobotModel::WithFixedLink) and the scene
  // `points` (checked_points: what the post-check judges against; null:
  // the same), with grasped objects taken out and released ones put in.
  // `given_sdfs` are the SDFs of links without a file in the task's
  // sdf_dir (a held object's, made in memory), by robot link index. With
  // a moving target (MovingToolGoal), `moving_points` and
  // `moving_checked_points` (at t = 0; null: this context's) are the
  // phase's points that move with it: its moving_scene() is built on them
  // for the phase's robot.
  core::Result<std::unique_ptr<PlanningContext>> ForMissionPhase(
      robot::RobotModel robot, std::shared_ptr<const std::vector<Vec3>> points,
      std::shared_ptr<const std::vector<Vec3>> checked_points,
      std::vector<std::pair<int, geometry::SdfGrid>> given_sdfs,
      std::shared_ptr<const std::vector<Vec3>> moving_points = nullptr,
      std::shared_ptr<const std::vector<Vec3>> moving_checked_points = nullptr) const;

  // The context of another task for this context's robot (its loaded link
  // SDFs reused, no file read again) on the scene `points`: a local plan of
  // onboard perception (explore/local_planner.h), whose scene is what the
  // sensor has shown and whose start and goal change at every replan. The
  // task's robot and sdf_dir must be this context's; it may not have a
  // mission or a moving target.
  core::Result<std::unique_ptr<PlanningContext>> ForLocalScene(Task task,
                                                               std::shared_ptr<const std::vector<Vec3>> points) const;
  // The same for a task with a mission (no moving target): the close work
  // of a grasp under perception (explore/grasp_map.h), planned by PlanTask
  // on what a fine map about the object has seen. Its objects are checked
  // as a loaded task's are.
  core::Result<std::unique_ptr<PlanningContext>> ForLocalMission(Task task,
                                                                 std::shared_ptr<const std::vector<Vec3>> points) const;

  const PlanningContextOptions& options() const { return options_; }
  const Task& task() const { return task_; }
  const robot::RobotModel& robot() const { return robot_; }
  // A task whose target moves (goal.tool.motion, or a mission's moving
  // reach: MovingToolGoal): the scene points inside
  // its moving_points box at t = 0 are taken out of points() and
  // checked_points() and kept here, with their own models (moving_scene.h).
  // Null when the target does not move.
  const MovingScene* moving_scene() const { return moving_ ? &moving_->scene : nullptr; }
  const std::vector<Vec3>& moving_points() const { return moving_points_; }
  const std::vector<Vec3>& moving_checked_points() const { return moving_checked_points_; }
  // The moving part for another motion of the same target, its points first
  // placed by `placement` (a benchmark's trial; a target measured elsewhere
  // than the task said), with this context's still scene: to plan with it,
  // set PlanningScene::moving to its `scene` and give the task the same
  // motion and the tool goal placed alike. InvalidArgument when the task's
  // target does not move.
  core::Result<std::unique_ptr<MovingSceneModels>> MovingSceneFor(const TargetMotion& motion,
                                                                  const Pose& placement) const;
  const std::vector<Vec3>& points() const { return *points_; }  // planned against
  const std::vector<Vec3>& checked_points() const { return *checked_points_; }  // post-checked against
  double scene_load_seconds() const { return scene_load_seconds_; }  // Load(): reading and filtering the scans
  // Loading the robot's collision geometry: its meshes (their exact model
  // and self-collision samples) and its link SDFs, the latter also counted
  // in MRC-SDF's build time.
  double robot_load_seconds() const { return robot_load_seconds_; }
  double sdf_load_seconds() const { return sdf_load_seconds_; }
  long dropped_non_finite_points() const { return dropped_non_finite_; }
  const env::ExactMeshModel& exact() const { return *exact_; }
  // The index of checked_points() that exact() queries, to share with other
  // exact models of the same cloud.
  const std::shared_ptr<const scene::PointGrid>& checked_index() const { return checked_index_; }
  // The robot's self-collision pairs (task keys self_safety_distance, srdf).
  const env::SelfCollisionModel& self_collision() const { return *self_collision_; }
  const FrontEndMap& front_end() const { return *front_end_; }
  // The front end's inflation radius (FrontEndOptions::size_from_robot).
  double front_end_inflation() const { return front_end_inflation_; }
  const std::vector<Representation>& representations() const { return representations_; }
  // The scene of representation `index` (in PlanningContextOptions order);
  // valid while this context lives.
  PlanningScene Scene(size_t index = 0) const;

 private:
  PlanningContext(Task task, robot::RobotModel robot) : task_(std::move(task)), robot_(std::move(robot)) {}
  // A moving target's points out of the cloud (their models: MovingSceneFor).
  core::Status SplitMovingPoints();
  // The link SDFs this context loaded, by robot link index, appended to
  // *sdfs: another context of the same robot takes them instead of files.
  void AppendLoadedSdfs(std::vector<std::pair<int, geometry::SdfGrid>>* sdfs) const;
  static core::Result<std::unique_ptr<PlanningContext>> Build(
      Task task, robot::RobotModel robot, std::shared_ptr<const std::vector<Vec3>> points, long dropped_non_finite,
      const PlanningContextOptions& options, std::shared_ptr<const std::vector<Vec3>> checked_points,
      std::vector<std::pair<int, geometry::SdfGrid>> given_sdfs, bool mission_phase,
      std::shared_ptr<const std::vector<Vec3>> moving_given = nullptr,
      std::shared_ptr<const std::vector<Vec3>> moving_checked_given = nullptr,
      const PlanningContext* same_robot = nullptr);

  PlanningContextOptions options_;
  Task task_;
  robot::RobotModel robot_;
  std::shared_ptr<const std::vector<Vec3>> points_;
  std::shared_ptr<const std::vector<Vec3>> checked_points_;  // points_ unless a voxel filter reduced them
  long dropped_non_finite_ = 0;
  double scene_load_seconds_ = 0.0;
  double robot_load_seconds_ = 0.0;
  double sdf_load_seconds_ = 0.0;
  std::shared_ptr<const scene::PointGrid> checked_index_;
  std::unique_ptr<env::ExactMeshModel> exact_;
  std::unique_ptr<env::SelfCollisionModel> self_collision_;
  std::unique_ptr<FrontEndMap> front_end_;
  double front_end_inflation_ = 0.0;
  std::vector<Representation> representations_;
  // The moving target's points at t = 0 as the task places them, and their
  // part of the scene for the task's motion (moving_scene()).
  std::vector<Vec3> moving_points_, moving_checked_points_;
  std::unique_ptr<MovingSceneModels> moving_;
  // The link SDFs loaded (null: none), and their robot links, for the
  // phases of a mission (ForMissionPhase).
  std::shared_ptr<const std::vector<geometry::SdfGrid>> sdf_grids_;
  std::vector<int> sdf_links_;
};

}  // namespace quadhand::planner
