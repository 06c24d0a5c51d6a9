#include "quadhand/planner/planning_context.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <thread>

#include "quadhand/core/text.h"
#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/mesh_repair.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/robot/srdf.h"

#include "quadhand/scene/point_cloud.h"

namespace quadhand::planner {
namespace {

core::Status CheckRepresentationNames(const PlanningContextOptions& options) {
  for (const std::string& name : options.representations) QUADHAND_RETURN_IF_ERROR(CheckRepresentationName(name));
  return core::Status::Ok();
}

// What a mission's grasps can only be checked against once the robot and
// the configuration are known: the payload limit, and that a mesh object
// bounds a volume (repaired as the robot's meshes are).
core::Status CheckMissionObjects(const Task& task, const PlanningContextOptions& options) {
  for (size_t i = 0; i < task.mission.size(); ++i) {
    const MissionStep& step = task.mission[i];
    if (step.kind != StepKind::kGrasp) continue;
    const std::string where = task.file + ": " + StepName(task.mission, i);
    if (step.object.mass > options.payload_limit) {
      return core::Status::InvalidArgument(
          where + core::Format(": the object's mass %g kg is above the robot's payload limit %g kg (planner "
                               "configuration mission.payload_limit)",
                               step.object.mass, options.payload_limit));
    }
    if (step.object.shape.kind != ObjectShape::Kind::kMesh) continue;
    geometry::MeshRepairOptions repair;
    repair.tolerance = options.mesh_repair_tolerance;
    geometry::MeshRepairReport report;
    auto shells = geometry::ReadMeshShells(step.object.shape.mesh_path, repair, &report);
    if (!shells.ok()) return shells.status().WithPrefix(where);
    if (!report.problem.empty()) {
      return core::Status::InvalidArgument(where + ": the object mesh '" + step.object.shape.mesh_path +
                                           "' does not bound a volume, even repaired: " + report.problem);
    }
  }
  return core::Status::Ok();
}

}  // namespace

core::Result<std::unique_ptr<PlanningContext>> PlanningContext::Load(const std::string& task_path,
                                                                     const PlanningContextOptions& options) {
  QUADHAND_RETURN_IF_ERROR(CheckRepresentationNames(options));
  auto task = LoadTask(task_path);
  if (!task.ok()) return task.status();
  auto robot = robot::RobotModel::LoadFromUrdfFile(task->robot_path);
  if (!robot.ok()) return robot.status();
  auto scans = scene::LoadScans(task->scans);
  if (!scans.ok()) return scans.status();
  auto checked = scans->unfiltered_points.empty()
                     ? nullptr
                     : std::make_shared<const std::vector<Vec3>>(std::move(scans->unfiltered_points));
  auto context = Create(std::move(*task), std::move(*robot),
                        std::make_shared<const std::vector<Vec3>>(std::move(scans->points)), scans->dropped_non_finite,
                        options, std::move(checked));
  if (context.ok()) (*context)->scene_load_seconds_ = scans->load_seconds;
  return context;
}

core::Result<std::unique_ptr<PlanningContext>> PlanningContext::Create(
    Task task, robot::RobotModel robot, std::shared_ptr<const std::vector<Vec3>> points, long dropped_non_finite,
    const PlanningContextOptions& options, std::shared_ptr<const std::vector<Vec3>> checked_points) {
  return Build(std::move(task), std::move(robot), std::move(points), dropped_non_finite, options,
               std::move(checked_points), {}, /*mission_phase=*/false);
}

void PlanningContext::AppendLoadedSdfs(std::vector<std::pair<int, geometry::SdfGrid>>* sdfs) const {
  if (sdf_grids_ == nullptr) return;
  for (size_t g = 0; g < sdf_links_.size(); ++g) sdfs->emplace_back(sdf_links_[g], (*sdf_grids_)[g]);
}

core::Result<std::unique_ptr<PlanningContext>> PlanningContext::ForMissionPhase(
    robot::RobotModel robot, std::shared_ptr<const std::vector<Vec3>> points,
    std::shared_ptr<const std::vector<Vec3>> checked_points,
    std::vector<std::pair<int, geometry::SdfGrid>> given_sdfs, std::shared_ptr<const std::vector<Vec3>> moving_points,
    std::shared_ptr<const std::vector<Vec3>> moving_checked_points) const {
  // The grids this context loaded serve the phase too (its robot is this
  // one, plus perhaps a held object): no file is read again.
  AppendLoadedSdfs(&given_sdfs);
  // This context's own (Build copies them into the phase's).
  auto unowned = [](const std::vector<Vec3>& cloud) {
    return std::shared_ptr<const std::vector<Vec3>>(&cloud, [](const std::vector<Vec3>*) {});
  };
  if (moving_points == nullptr) moving_points = unowned(moving_points_);
  if (moving_checked_points == nullptr) moving_checked_points = unowned(moving_checked_points_);
  auto phase = Build(task_, std::move(robot), std::move(points), dropped_non_finite_, options_,
                     std::move(checked_points), std::move(given_sdfs), /*mission_phase=*/true,
                     std::move(moving_points), std::move(moving_checked_points));
  if (phase.ok()) (*phase)->scene_load_seconds_ = 0.0;
  return phase;
}

core::Result<std::unique_ptr<PlanningContext>> PlanningContext::ForLocalScene(
    Task task, std::shared_ptr<const std::vector<Vec3>> points) const {
  if (task.robot_path != task_.robot_path || task.sdf_dir != task_.sdf_dir) {
    return core::Status::InvalidArgument("a local scene's task must have its context's robot and sdf_dir");
  }
  if (!task.mission.empty() || MovingToolGoal(task) != nullptr) {
    return core::Status::InvalidArgument("a local scene's task may not have a mission or a moving target");
  }
  // The same robot and options: this context's grids are shared, not
  // copied (a local scene is built at every replan).
  auto local = Build(std::move(task), robot_, std::move(points), 0, options_, nullptr, {}, /*mission_phase=*/true,
                     nullptr, nullptr, /*same_robot=*/this);
  if (local.ok()) (*local)->scene_load_seconds_ = 0.0;
  return local;
}

core::Result<std::unique_ptr<PlanningContext>> PlanningContext::ForLocalMission(
    Task task, std::shared_ptr<const std::vector<Vec3>> points) const {
  if (task.robot_path != task_.robot_path || task.sdf_dir != task_.sdf_dir) {
    return core::Status::InvalidArgument("a local mission's task must have its context's robot and sdf_dir");
  }
  if (MovingToolGoal(task) != nullptr) {
    return core::Status::InvalidArgument("a local mission's task may not have a moving target");
  }
  auto local = Build(std::move(task), robot_, std::move(points), 0, options_, nullptr, {}, /*mission_phase=*/false,
                     nullptr, nullptr, /*same_robot=*/this);
  if (local.ok()) (*local)->scene_load_seconds_ = 0.0;
  return local;
}

core::Result<std::unique_ptr<PlanningContext>> PlanningContext::Build(
    Task task, robot::RobotModel robot, std::shared_ptr<const std::vector<Vec3>> points, long dropped_non_finite,
    const PlanningContextOptions& options, std::shared_ptr<const std::vector<Vec3>> checked_points,
    std::vector<std::pair<int, geometry::SdfGrid>> given_sdfs, bool mission_phase,
    std::shared_ptr<const std::vector<Vec3>> moving_given, std::shared_ptr<const std::vector<Vec3>> moving_checked_given,
    const PlanningContext* same_robot) {
  QUADHAND_RETURN_IF_ERROR(CheckRepresentationNames(options));
  if (checked_points == nullptr) checked_points = points;
  for (const auto* cloud : {&points, &checked_points}) {
    if (!*cloud || (*cloud)->empty()) return core::Status::InvalidArgument("the scene has no points");
    for (const Vec3& p : **cloud) {
      if (!p.allFinite()) return core::Status::InvalidArgument("the scene has a non-finite point");
    }
  }
  QUADHAND_RETURN_IF_ERROR(ApplyRobot(robot, &task));
  // A phase has its mission's task, whose objects were checked with it.
  if (!mission_phase) QUADHAND_RETURN_IF_ERROR(CheckMissionObjects(task, options));
  geometry::MeshRepairOptions repair;
  repair.tolerance = options.mesh_repair_tolerance;
  if (std::string why; !repair.IsValid(&why)) return core::Status::InvalidArgument(why);
  robot.set_mesh_repair_tolerance(options.mesh_repair_tolerance);
  // quadhand-sdfgen cached its repairs of the meshes next to the SDFs.
  if (!task.sdf_dir.empty()) robot.set_mesh_cache_dir(robot::MeshCacheDirOf(task.sdf_dir));
  std::unique_ptr<PlanningContext> context(new PlanningContext(std::move(task), std::move(robot)));
  context->options_ = options;
  context->points_ = std::move(points);
  context->checked_points_ = std::move(checked_points);
  context->dropped_non_finite_ = dropped_non_finite;
  const Task& t = context->task_;
  const ToolGoal* moving_tool = MovingToolGoal(t);
  const MovingTarget* moving = moving_tool != nullptr ? &*moving_tool->moving : nullptr;
  if (moving != nullptr && mission_phase) {
    // A phase's moving points are given (its mission took the held object
    // out of them): the still cloud has none left to split.
    if (moving_given != nullptr) context->moving_points_ = *moving_given;
    if (moving_checked_given != nullptr) context->moving_checked_points_ = *moving_checked_given;
  } else if (moving != nullptr) {
    QUADHAND_RETURN_IF_ERROR(context->SplitMovingPoints());
  }

  std::vector<Vec3> contain = options.front_end_also_contain;
  contain.push_back(t.start.position);
  if (t.terminal) contain.push_back(t.terminal->position);
  if (t.tool) {
    // A goal given as a tool pose: the base ends within the arm's reach of
    // it (from the URDF; a prismatic joint without limits has none, and
    // then the scene's extent bounds the search).
    const int tool_link = context->robot_.LinkIndex(t.tool_link);
    const double reach = tool_link >= 0 ? robot::LinkOriginReach(context->robot_)[tool_link] : 0.0;
    if (std::isfinite(reach)) {
      contain.push_back(t.tool->position - Vec3::Constant(reach));
      contain.push_back(t.tool->position + Vec3::Constant(reach));
    }
  }
  FrontEndOptions front_end_options = options.front_end;
  if (front_end_options.size_from_robot) {
    auto extents = robot::StowedHalfExtents(context->robot_);
    if (!extents.ok()) return extents.status().WithPrefix(t.robot_path);
    const double half_width = std::min(extents->x(), extents->y());
    if (half_width > 0.0) {
      front_end_options.inflation_radius = half_width;
      front_end_options.inflation_height = extents->z() > 0.0 ? extents->z() : half_width;
      front_end_options.shortcut_clearance = front_end_options.shortcut_ratio * half_width;
    }
  }
  context->front_end_inflation_ = front_end_options.inflation_radius;
  // The front end's map needs only the points and these options: it is
  // built on a second core while the index, the exact model and the
  // representations are built on this one (a local scene's context is
  // built at every replan, and the two are its largest parts). The
  // results are the same either way.
  auto build_front_end = [&]() { return FrontEndMap::Build(context->points(), front_end_options, contain); };
  std::future<core::Result<FrontEndMap>> front_end_future;
  if (std::thread::hardware_concurrency() > 1) front_end_future = std::async(std::launch::async, build_front_end);

  // The cloud is indexed once here and shared by the post-check and the
  // representations whose index has the same cell (when both see the same
  // points: with a voxel filter the post-check sees the unfiltered ones).
  auto checked_index =
      std::make_shared<const scene::PointGrid>(context->checked_points(), env::ExactMeshModel::kIndexCellSize);
  const bool same_points = context->checked_points_ == context->points_;
  auto index = same_points ? checked_index : nullptr;
  const auto robot_load_start = std::chrono::steady_clock::now();
  context->checked_index_ = checked_index;
  auto exact = env::ExactMeshModel::Create(context->robot_, checked_index);
  if (!exact.ok()) return exact.status().WithPrefix(t.robot_path);
  context->exact_ = std::move(*exact);

  std::optional<std::vector<std::pair<int, int>>> srdf_disabled;
  if (!t.srdf_path.empty()) {
    auto pairs = robot::LoadSrdfDisabledPairs(t.srdf_path, context->robot_);
    if (!pairs.ok()) return pairs.status();
    srdf_disabled = std::move(*pairs);
  }
  env::SelfCollisionOptions self_options;
  self_options.safety_distance = t.self_safety_distance;
  if (!t.sdf_dir.empty()) self_options.sample_cache_dir = robot::MeshCacheDirOf(t.sdf_dir);
  auto self_collision = env::SelfCollisionModel::Create(context->robot_, *context->exact_, srdf_disabled, self_options);
  if (!self_collision.ok()) return self_collision.status().WithPrefix(t.robot_path);
  context->self_collision_ = std::move(*self_collision);

  // The link SDFs, loaded once for MRC-SDF and the self-collision penalty.
  env::SharedSdfGrids sdf_grids;
  const bool mrc_sdf = std::find(options.representations.begin(), options.representations.end(), "mrc_sdf") !=
                       options.representations.end();
  double sdf_load_ms = 0.0;
  // The moving points get an MRC-SDF model for the optimiser (none when no
  // representation is asked for: quadhand-flightcheck's exact checks).
  const bool moving_points = !context->moving_points_.empty() && !options.representations.empty();
  if (same_robot != nullptr && same_robot->sdf_grids_ != nullptr) {
    sdf_grids = same_robot->sdf_grids_;
    context->sdf_links_ = same_robot->sdf_links_;
  } else if (mrc_sdf || moving_points || !context->self_collision_->pairs().empty()) {
    const auto load_start = std::chrono::steady_clock::now();
    std::vector<int> links;
    std::vector<geometry::SdfGrid> grids;
    const core::Status loaded = env::LoadLinkSdfGrids(context->robot_, t.sdf_dir, &links, &grids, std::move(given_sdfs));
    // MRC-SDF cannot plan without them; the other representations can, and
    // then the optimiser has no self-collision term (the post-check still
    // keeps the pairs apart, with the exact meshes).
    if (!loaded.ok() && (mrc_sdf || moving_points)) return loaded;
    if (loaded.ok()) {
      for (size_t g = 0; g < grids.size(); ++g) {
        const core::Status tolerance_fits = geometry::CheckRepairTolerance(options.mesh_repair_tolerance, grids[g].info().resolution);
        if (!tolerance_fits.ok()) {
          return tolerance_fits.WithPrefix(t.sdf_dir + ": link '" + context->robot_.link(links[g]).name + "'");
        }
      }
      sdf_grids = std::make_shared<const std::vector<geometry::SdfGrid>>(std::move(grids));
      context->sdf_links_ = links;
      sdf_load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - load_start).count();
    }
  }
  if (sdf_grids != nullptr) {
    context->sdf_grids_ = sdf_grids;
    if (!context->self_collision_->pairs().empty()) {
      QUADHAND_RETURN_IF_ERROR(context->self_collision_->AttachSdfGrids(sdf_grids));
    }
  }

  context->robot_load_seconds_ =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - robot_load_start).count();
  context->sdf_load_seconds_ = sdf_load_ms / 1e3;

  // The front end's error comes first, as when it was built first.
  core::Status front_end_status = core::Status::Ok();
  auto take_front_end = [&]() {
    if (context->front_end_ != nullptr || !front_end_status.ok()) return;
    auto front_end = front_end_future.valid() ? front_end_future.get() : build_front_end();
    // The search box spans the scene and the task's start and goal: a far-off
    // start in the task is as likely the cause as a wide scene.
    if (!front_end.ok()) {
      front_end_status = front_end.status().WithPrefix(t.file + ": the start and goal with the scene " + t.scene_path);
      return;
    }
    context->front_end_ = std::make_unique<FrontEndMap>(std::move(*front_end));
  };
  for (const std::string& name : options.representations) {
    auto model = MakeRepresentation(name, context->robot_, t.sdf_dir, context->points(), options.representation_options,
                                    index, sdf_grids);
    if (!model.ok()) {
      take_front_end();
      return front_end_status.ok() ? model.status() : front_end_status;
    }
    // MRC-SDF's build time includes loading the grids it was handed.
    if (name == "mrc_sdf") model->build_ms += sdf_load_ms;
    context->representations_.push_back(std::move(*model));
    // A scene too large for the front end is refused before building more.
    if (front_end_future.valid() &&
        front_end_future.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
      take_front_end();
      if (!front_end_status.ok()) return front_end_status;
    }
  }
  take_front_end();
  if (!front_end_status.ok()) return front_end_status;
  if (moving != nullptr) {
    auto moving_part = context->MovingSceneFor(moving->motion, Pose::Identity());
    if (!moving_part.ok()) return moving_part.status();
    context->moving_ = std::move(*moving_part);
  }
  return context;
}

core::Status PlanningContext::SplitMovingPoints() {
  const MovingTarget& moving = *MovingToolGoal(task_)->moving;
  if (!moving.moving_box) return core::Status::Ok();
  const TargetBox& box = *moving.moving_box;
  auto split = [&box](const std::vector<Vec3>& cloud, std::vector<Vec3>* still, std::vector<Vec3>* moving_part) {
    for (const Vec3& p : cloud) (box.Contains(p) ? moving_part : still)->push_back(p);
  };
  const bool same_points = checked_points_ == points_;
  auto still = std::make_shared<std::vector<Vec3>>();
  split(*points_, still.get(), &moving_points_);
  if (same_points) {
    moving_checked_points_ = moving_points_;
    points_ = checked_points_ = still;
  } else {
    auto checked_still = std::make_shared<std::vector<Vec3>>();
    split(*checked_points_, checked_still.get(), &moving_checked_points_);
    points_ = still;
    checked_points_ = checked_still;
  }
  if (points_->empty() || checked_points_->empty()) {
    return core::Status::InvalidArgument(task_.file + ": goal.tool.motion.moving_points: the box holds every point of "
                                         "the scene; something must stand still");
  }
  return core::Status::Ok();
}

core::Result<std::unique_ptr<MovingSceneModels>> PlanningContext::MovingSceneFor(const TargetMotion& motion,
                                                                                 const Pose& placement) const {
  const ToolGoal* tool = MovingToolGoal(task_);
  if (tool == nullptr) return core::Status::InvalidArgument(task_.file + ": the task's target does not move");
  auto owned = std::make_unique<MovingSceneModels>();
  owned->motion = motion;
  for (const Vec3& p : moving_points_) owned->points.push_back(placement * p);
  for (const Vec3& p : moving_checked_points_) owned->checked_points.push_back(placement * p);
  MovingScene& scene = owned->scene;
  scene.motion = &owned->motion;
  scene.target_at_zero =
      placement * MakePose(tool->position, tool->orientation.toRotationMatrix());
  if (!owned->checked_points.empty()) {
    if (!options_.representations.empty()) {
      auto model = MakeRepresentation("mrc_sdf", robot_, task_.sdf_dir, owned->points, options_.representation_options,
                                      nullptr, sdf_grids_);
      if (!model.ok()) return model.status();
      owned->collision = std::move(model->scene_model);
      scene.collision = owned->collision.get();
    }
    auto exact = env::ExactMeshModel::Create(robot_, owned->checked_points);
    if (!exact.ok()) return exact.status().WithPrefix(task_.robot_path);
    owned->exact = std::move(*exact);
    scene.exact = owned->exact.get();
    const Vec3 center = motion.Center(0.0);
    for (const Vec3& p : owned->checked_points) scene.radius = std::max(scene.radius, (p - center).head<2>().norm());
  }
  return owned;
}

PlanningScene PlanningContext::Scene(size_t index) const {
  const Representation& model = representations_.at(index);
  return PlanningScene{robot_, *model.scene_model, *exact_, *front_end_, model.per_plan,
                       self_collision_.get(), moving_scene()};
}

}  // namespace quadhand::planner
