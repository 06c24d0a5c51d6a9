#include "quadhand/explore/grasp_under_perception.h"

#include <chrono>
#include <cmath>

#include "quadhand/planner/mission_plan.h"
#include "quadhand/planner/whole_body_problem.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/link_meshes.h"

namespace quadhand::explore {
namespace {

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

// The box of the robot's collision geometry hovering at each of `states`.
core::Status GrowByRobot(const robot::RobotModel& robot, const std::vector<planner::BoundaryState>& states, Vec3* lo,
                         Vec3* hi) {
  auto vertices = robot::LinkCollisionVertices(robot);
  if (!vertices.ok()) return vertices.status();
  robot::KinematicsState kinematics;
  for (const planner::BoundaryState& state : states) {
    robot::ComputeKinematics(robot, planner::HoverPose(state.position, state.yaw), state.joints, &kinematics);
    for (size_t link = 0; link < vertices->size(); ++link) {
      for (const Vec3& v : (*vertices)[link]) {
        const Vec3 w = kinematics.link_poses[link] * v;
        *lo = lo->cwiseMin(w);
        *hi = hi->cwiseMax(w);
      }
    }
  }
  return core::Status::Ok();
}

}  // namespace

bool GraspOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(resolution) && resolution >= 0.002 && resolution <= 0.05)) {
    return Fail(why, "the grasp map's resolution must be in [0.002, 0.05] m");
  }
  if (!(std::isfinite(approach) && approach >= 0.0 && approach <= 2.0)) {
    return Fail(why, "the grasp approach must be in [0, 2] m");
  }
  if (!(std::isfinite(box_margin) && box_margin >= 0.05 && box_margin <= 2.0)) {
    return Fail(why, "the grasp map's box margin must be in [0.05, 2] m");
  }
  if (!(std::isfinite(frame_rate) && frame_rate > 0.0 && frame_rate <= 1000.0)) {
    return Fail(why, "the grasp map's frame rate must be in (0, 1000] Hz");
  }
  if (miss_stride < 1 || miss_stride > 64) return Fail(why, "the grasp map's miss stride must be in [1, 64]");
  return true;
}

core::Result<std::optional<GraspWork>> GraspWorkOfTask(const planner::Task& task, const robot::RobotModel& robot,
                                                       const GraspOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(why);
  const std::vector<planner::MissionStep>& mission = task.mission;
  const std::string refused = task.file + ": under perception ";
  size_t grasp = mission.size();
  for (size_t k = 0; k < mission.size(); ++k) {
    if (mission[k].kind == planner::StepKind::kGrasp) {
      grasp = k;
      break;
    }
  }
  if (grasp == mission.size()) return std::optional<GraspWork>();
  const std::string grasp_name = planner::StepName(mission, grasp);
  if (mission[grasp].held_at_start) {
    return core::Status::InvalidArgument(refused + grasp_name + ": an object held from the start is not flown yet");
  }
  if (grasp == 0 || mission[grasp - 1].kind != planner::StepKind::kReach) {
    return core::Status::InvalidArgument(refused + grasp_name + " must come right after the reach that grasps");
  }
  const planner::MissionStep& reach = mission[grasp - 1];
  if (!reach.reach_state || !reach.reach_tool || !reach.reach_tool->has_insertion || reach.reach_tool->moving) {
    return core::Status::InvalidArgument(refused + planner::StepName(mission, grasp - 1) +
                                         ": the reach of a grasp needs a whole-body state, a tool pose and an "
                                         "insertion (the approach is flown along it on the grasp map), and a still "
                                         "target");
  }
  for (size_t k = grasp + 1; k < mission.size(); ++k) {
    if (mission[k].kind != planner::StepKind::kMove && mission[k].kind != planner::StepKind::kHold) {
      return core::Status::InvalidArgument(refused + planner::StepName(mission, k) +
                                           ": after a grasp only moves and holds are flown yet");
    }
  }
  GraspWork work;
  work.reach_step = grasp - 1;
  work.steps.assign(mission.begin() + static_cast<long>(grasp - 1), mission.end());
  work.object = mission[grasp].object;
  work.scene_margin = mission[grasp].scene_margin;
  work.tool_position = reach.reach_tool->position;
  const Vec3 direction = reach.reach_tool->insertion_direction;
  const double length = reach.reach_tool->insertion_length;
  planner::BoundaryState at = *reach.reach_state;
  at.velocity = at.acceleration = at.jerk = Vec3::Zero();
  at.yaw_rate = 0.0;
  at.joint_rates = VecX();
  work.staging = at;
  work.staging.position -= direction * (length + options.approach);
  // Every state the work passes at rest: the staging, the insertion's
  // start and end, and each move's end (the arm and yaw held).
  planner::BoundaryState insertion_start = at;
  insertion_start.position -= direction * length;
  std::vector<planner::BoundaryState> states = {work.staging, insertion_start, at};
  for (size_t k = grasp + 1; k < mission.size(); ++k) {
    if (mission[k].kind != planner::StepKind::kMove) continue;
    const Vec3 along = mission[k].move_direction ? *mission[k].move_direction : Vec3(-direction);
    at.position += along * mission[k].move_length;
    states.push_back(at);
  }
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  QUADHAND_RETURN_IF_ERROR(GrowByRobot(robot, states, &lo, &hi).WithPrefix(task.robot_path));
  const Vec3 object = work.object.pose.translation();
  const double radius = work.object.shape.BoundingRadius();
  lo = lo.cwiseMin(object - Vec3::Constant(radius));
  hi = hi.cwiseMax(object + Vec3::Constant(radius));
  work.box_lo = lo - Vec3::Constant(options.box_margin);
  work.box_hi = hi + Vec3::Constant(options.box_margin);
  return std::optional<GraspWork>(std::move(work));
}

GraspMap::GraspMap(const GraspWork& work, std::unique_ptr<perception::RollingMap> map)
    : work_(work), map_(std::move(map)) {}

core::Result<std::unique_ptr<GraspMap>> GraspMap::Create(const GraspWork& work, const GraspOptions& options,
                                                         const perception::RollingMapOptions& map) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(why);
  perception::RollingMapOptions fine = map;
  fine.resolution = options.resolution;
  // Whole rays: the grasp's figures were measured on them, and a grasp
  // needs every voxel about the object that any ray saw free.
  fine.stop_ray_after_crossed = 0;
  // Two voxels more than the box each way: ObstacleBoundary reads the
  // voxels just outside it.
  fine.window_half_extent = 0.5 * (work.box_hi - work.box_lo) + Vec3::Constant(2.0 * options.resolution);
  auto rolling = perception::RollingMap::Create(fine);
  if (!rolling.ok()) return rolling.status();
  (*rolling)->MoveWindow(0.5 * (work.box_lo + work.box_hi));
  return std::unique_ptr<GraspMap>(new GraspMap(work, std::move(*rolling)));
}

void GraspMap::MarkFree(const Vec3& centre, double radius) { map_->MarkFree(centre, radius); }

core::Status GraspMap::Insert(const std::vector<Vec3>& points, const Vec3& origin, const std::vector<Vec3>& misses) {
  return map_->Insert(points, origin, misses);
}

std::vector<Vec3> GraspMap::Obstacles() const {
  const double keep_off = work_.scene_margin + BallRadius();
  std::vector<Vec3> obstacles;
  for (const Vec3& centre : map_->ObstacleBoundary(work_.box_lo, work_.box_hi)) {
    if (planner::DistanceToObjectSurface(work_.object, centre) > keep_off) obstacles.push_back(centre);
  }
  return obstacles;
}

std::vector<Vec3> GraspMap::NewObstacles(const std::optional<Pose>& held) const {
  const double keep_off = work_.scene_margin + BallRadius();
  planner::MissionObject held_object = work_.object;
  if (held) held_object.pose = *held;
  std::vector<Vec3> found;
  for (const Vec3& centre : map_->NewlyBlocked()) {
    if (((centre - work_.box_lo).array() < 0.0).any() || ((work_.box_hi - centre).array() < 0.0).any()) continue;
    if (planner::DistanceToObjectSurface(work_.object, centre) <= keep_off) continue;
    if (held && planner::DistanceToObjectSurface(held_object, centre) <= keep_off) continue;
    found.push_back(centre);
  }
  return found;
}

GraspPlanner::GraspPlanner(const planner::PlanningContext& base, const planner::Task& task, const GraspWork& work,
                           const planner::PlannerOptions& options, const opt::Solver& solver, double tracking_margin)
    : base_(base), task_(task), work_(work), options_(options), solver_(solver), tracking_margin_(tracking_margin) {}

double GraspPlanner::PlannedSafetyDistance(double resolution) const {
  return task_.safety_distance + tracking_margin_ + perception::VoxelBallRadius(resolution);
}

core::Result<GraspPlan> GraspPlanner::Plan(const GraspMap& map, const planner::BoundaryState& start) const {
  if (!start.position.allFinite() || start.joints.size() != work_.staging.joints.size()) {
    return core::Status::InvalidArgument("grasp: the start is not finite or has the wrong joints");
  }
  const auto started = std::chrono::steady_clock::now();
  GraspPlan out;
  out.safety_distance = PlannedSafetyDistance(map.map().options().resolution);
  // The boundary keeps a body that starts in seen free space in it: the
  // base must stand in a voxel the grasp map has seen free.
  if (map.map().State(start.position) != perception::VoxelState::kFree) {
    out.message = "the vehicle's own place is not seen free on the grasp map";
    out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
    return out;
  }
  auto obstacles = std::make_shared<const std::vector<Vec3>>(map.Obstacles());
  out.obstacles = obstacles->size();
  planner::Task task = task_;
  task.start = start;
  task.mission = work_.steps;
  task.terminal.reset();
  task.tool.reset();
  task.vias.clear();
  task.safety_distance = out.safety_distance;
  task.scene_path = "the grasp map";
  auto context = base_.ForLocalMission(std::move(task), std::move(obstacles));
  auto done = [&]() {
    out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
    return out;
  };
  if (!context.ok()) {
    out.message = context.status().message();
    return done();
  }
  // The scene is what the sensor has shown: a start or a step it makes
  // impossible is an ordinary outcome here, not bad input.
  auto planned = planner::PlanTask(**context, 0, options_, solver_);
  if (!planned.ok()) {
    out.message = planned.status().message();
    return done();
  }
  out.plan = std::move(*planned);
  out.certified = out.plan.success && out.plan.trajectory.has_value();
  out.message = out.plan.message;
  return done();
}

}  // namespace quadhand::explore
