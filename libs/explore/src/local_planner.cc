#include "quadhand/explore/local_planner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include "quadhand/core/text.h"
#include "quadhand/env/exact_mesh_model.h"
#include "quadhand/explore/grasp_under_perception.h"
#include "quadhand/explore/guide.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/link_meshes.h"

namespace quadhand::explore {
namespace {

// m: a start inside the tracking margin plans with this less than it has.
constexpr double kStartSlack = 1e-3;
// m: a local target's hop shorter than this sideways has no heading of its own.
constexpr double kLeastHeading = 0.2;

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

bool Positive(double x, double hi) { return std::isfinite(x) && x > 0.0 && x <= hi; }

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

bool LocalPlannerOptions::IsValid(std::string* why) const {
  if (!box_half_extent.allFinite() || (box_half_extent.array() < 0.5).any() || (box_half_extent.array() > 100.0).any()) {
    return Fail(why, "box_half_extent must be in [0.5, 100] m on every axis");
  }
  if (!Positive(horizon, 100.0)) return Fail(why, "horizon must be in (0, 100] m");
  if (!Positive(target_spacing, 10.0)) return Fail(why, "target_spacing must be in (0, 10] m");
  if (max_targets < 1 || max_targets > 100) return Fail(why, "max_targets must be in [1, 100]");
  if (!(std::isfinite(target_separation) && target_separation >= 0.0)) return Fail(why, "target_separation must be >= 0 m");
  if (!(std::isfinite(min_progress) && min_progress >= 0.0 && min_progress < horizon)) {
    return Fail(why, "min_progress must be in [0, horizon) m");
  }
  if (!(std::isfinite(guide_cell) && (guide_cell == 0.0 || (guide_cell >= 0.05 && guide_cell <= 5.0)))) {
    return Fail(why, "guide_cell must be 0 (no guide) or in [0.05, 5] m");
  }
  if (!(std::isfinite(max_height_offset) && max_height_offset >= 0.0)) return Fail(why, "max_height_offset must be >= 0 m");
  if (!(std::isfinite(target_clearance_margin) && target_clearance_margin >= 0.0 && target_clearance_margin <= 1.0)) {
    return Fail(why, "target_clearance_margin must be in [0, 1] m");
  }
  if (max_target_checks < 1) return Fail(why, "max_target_checks must be >= 1");
  if (!Positive(max_speed, 100.0)) return Fail(why, "max_speed must be in (0, 100] m/s");
  if (!Positive(max_acceleration, 100.0)) return Fail(why, "max_acceleration must be in (0, 100] m/s^2");
  if (!(std::isfinite(tracking_margin) && tracking_margin >= 0.0 && tracking_margin <= 1.0)) {
    return Fail(why, "tracking_margin must be in [0, 1] m");
  }
  if (alternative_guesses < 0 || alternative_guesses > 3) return Fail(why, "alternative_guesses must be in [0, 3]");
  if (!Positive(recovery_time, 10.0)) return Fail(why, "recovery_time must be in (0, 10] s");
  return true;
}

const char* LocalPlanStatusName(LocalPlanStatus status) {
  switch (status) {
    case LocalPlanStatus::kToGoal: return "to_goal";
    case LocalPlanStatus::kToLocalTarget: return "to_local_target";
    case LocalPlanStatus::kNoTarget: return "no_target";
    case LocalPlanStatus::kFailed: return "failed";
    case LocalPlanStatus::kTurnInPlace: return "turn_in_place";
  }
  return "unknown";
}

LocalPlanner::LocalPlanner(const planner::PlanningContext& base, const planner::PlannerOptions& options,
                           const opt::Solver& solver, const LocalPlannerOptions& local)
    : base_(base), options_(options), solver_(solver), local_(local) {}

core::Result<std::unique_ptr<LocalPlanner>> LocalPlanner::Create(const planner::PlanningContext& base,
                                                                  const planner::PlannerOptions& options,
                                                                  const opt::Solver& solver,
                                                                  const LocalPlannerOptions& local) {
  if (std::string why; !local.IsValid(&why)) return core::Status::InvalidArgument("local planner: " + why);
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("planner: " + why);
  const planner::Task& task = base.task();
  if (!planner::PlansAsGoal(task) || !task.mission.empty() || !task.terminal || task.tool) {
    return core::Status::InvalidArgument(task.file +
                                         ": under perception only a goal at rest is flown (goal.position, yaw, "
                                         "joints); a mission or a tool pose is not yet");
  }
  planner::PlannerOptions capped = options;
  capped.alternative_guesses = std::min(options.alternative_guesses, local.alternative_guesses);
  std::unique_ptr<LocalPlanner> planner(new LocalPlanner(base, capped, solver, local));
  planner->goal_ = *task.terminal;
  // The compact joints: a grid over the joints' limits (at most about 2000
  // configurations, and the goal's value of each joint), the one whose
  // collision vertices lie nearest the base; within 1 cm of that, the one
  // nearest the goal's joints, so that folding and unfolding move the arm
  // no more than they must (a wrist rolled half a turn for a millimetre
  // swings the base's yaw).
  const robot::RobotModel& robot = base.robot();
  auto vertices = robot::LinkCollisionVertices(robot);
  if (!vertices.ok()) return vertices.status().WithPrefix(task.robot_path);
  planner->link_vertices_ = std::move(*vertices);
  const long n = robot.num_actuated();
  planner->compact_joints_ = task.terminal->joints;
  planner->compact_radius_ = planner->RadiusAt(planner->compact_joints_);
  if (n > 0 && n == task.terminal->joints.size()) {
    const int per_joint = std::max(2, static_cast<int>(std::floor(std::pow(2000.0, 1.0 / static_cast<double>(n)))));
    VecX lower = robot.LowerLimits(), upper = robot.UpperLimits();
    for (long j = 0; j < n; ++j) {
      if (!std::isfinite(lower[j]) || !std::isfinite(upper[j])) {
        lower[j] = -M_PI;
        upper[j] = M_PI;
      }
    }
    const VecX& goal = task.terminal->joints;
    // Each joint's samples: the grid, then the goal's value.
    auto sample = [&](long j, int k) {
      return k == per_joint ? std::clamp(goal[j], lower[j], upper[j])
                            : lower[j] + (upper[j] - lower[j]) * k / (per_joint - 1);
    };
    std::vector<std::pair<double, VecX>> configurations;
    std::vector<int> index(static_cast<size_t>(n), 0);
    VecX joints(n);
    double smallest = planner->compact_radius_;
    while (true) {
      for (long j = 0; j < n; ++j) joints[j] = sample(j, index[static_cast<size_t>(j)]);
      const double radius = planner->RadiusAt(joints);
      smallest = std::min(smallest, radius);
      configurations.emplace_back(radius, joints);
      long j = 0;
      while (j < n && ++index[static_cast<size_t>(j)] == per_joint + 1) index[static_cast<size_t>(j++)] = 0;
      if (j == n) break;
    }
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& [radius, candidate] : configurations) {
      if (radius > smallest + 0.01 || (candidate - goal).norm() >= nearest) continue;
      nearest = (candidate - goal).norm();
      planner->compact_joints_ = candidate;
      planner->compact_radius_ = radius;
    }
  }
  return planner;
}

double LocalPlanner::RadiusAt(const VecX& joints) const {
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(base_.robot(), Pose::Identity(), joints, &kinematics);
  double radius = 0.0;
  for (size_t link = 0; link < link_vertices_.size(); ++link) {
    for (const Vec3& v : link_vertices_[link]) radius = std::max(radius, (kinematics.link_poses[link] * v).norm());
  }
  return radius;
}

void UseLocalPlanningDefaults(planner::PlannerConfig* config, double map_resolution) {
  const double cell = std::isfinite(map_resolution) ? std::clamp(map_resolution, 0.05, 0.1) : 0.1;
  config->representations.mrc_sdf.far_cell_size = cell;
  config->representations.mrc_sdf.far_max_steps = static_cast<int>(std::ceil(1.0 / cell - 1e-9));
  config->front_end.voxel_size = cell;
}

core::Result<std::vector<planner::Task>> LegsOfTask(const planner::Task& task, const GraspWork* grasp) {
  const std::string refused = task.file +
                              ": under perception only a goal at rest (goal.position, yaw, joints) or a mission of "
                              "reaches at rest is flown; ";
  if (task.mission.empty()) {
    if (!task.terminal || task.tool) return core::Status::InvalidArgument(refused + "a tool pose is not yet");
    return std::vector<planner::Task>{task};
  }
  std::vector<planner::Task> legs;
  planner::BoundaryState start = task.start;
  const size_t explored = grasp != nullptr ? std::min(grasp->reach_step, task.mission.size()) : task.mission.size();
  for (size_t k = 0; k < explored; ++k) {
    const planner::MissionStep& step = task.mission[k];
    const std::string which = "mission step " + std::to_string(k + 1) + " (" + planner::StepKindName(step.kind) + ")";
    if (step.kind != planner::StepKind::kReach) {
      return core::Status::InvalidArgument(refused + which + " is not yet");
    }
    if (!step.reach_state || step.reach_tool) {
      return core::Status::InvalidArgument(refused + which + ": a tool pose is not yet");
    }
    planner::Task leg = task;
    leg.mission.clear();
    leg.vias.clear();
    leg.tool.reset();
    leg.start = start;
    leg.terminal = *step.reach_state;
    start = *step.reach_state;
    legs.push_back(std::move(leg));
  }
  if (grasp != nullptr) {
    planner::Task leg = task;
    leg.mission.clear();
    leg.vias.clear();
    leg.tool.reset();
    leg.start = start;
    leg.terminal = grasp->staging;
    legs.push_back(std::move(leg));
  }
  return legs;
}

core::Result<std::unique_ptr<planner::PlanningContext>> BaseContext(planner::Task task, robot::RobotModel robot,
                                                                    const planner::PlannerConfig& config) {
  const Vec3 far_above = task.start.position + Vec3(0.0, 0.0, 20.0);
  return planner::PlanningContext::Create(std::move(task), std::move(robot),
                                          std::make_shared<const std::vector<Vec3>>(1, far_above), 0,
                                          planner::ContextOptions(config, {"mrc_sdf"}));
}

core::Result<std::unique_ptr<planner::PlanningContext>> BaseContextOfTaskFile(const std::string& task_path,
                                                                              const planner::PlannerConfig& config) {
  planner::TaskSources sources;
  sources.scene_given = true;
  auto task = planner::LoadTask(task_path, sources);
  if (!task.ok()) return task.status();
  auto robot = robot::RobotModel::LoadFromUrdfFile(task->robot_path);
  if (!robot.ok()) return robot.status();
  auto base = BaseContext(std::move(*task), std::move(*robot), config);
  if (!base.ok()) return base.status().WithPrefix(task_path);
  return base;
}

double LocalPlanner::PlannedSafetyDistance(double map_resolution) const {
  return base_.task().safety_distance + local_.tracking_margin + perception::VoxelBallRadius(map_resolution);
}

std::optional<double> LocalPlanner::FirstConflict(const planner::WholeBodyTrajectory& trajectory, double from,
                                                  const std::vector<Vec3>& obstacles, double distance,
                                                  double step) const {
  if (obstacles.empty() || !(step > 0.0)) return std::nullopt;
  const robot::RobotModel& robot = base_.robot();
  const env::ExactMeshModel& exact = base_.exact();
  // Each link's elements inside a ball about its frame's origin: a point
  // farther than that ball's radius plus `distance` needs no mesh query.
  std::vector<double> reach(static_cast<size_t>(robot.num_links()), 0.0);
  for (int link : exact.links()) {
    Vec3 lo, hi;
    exact.LinkBox(link, &lo, &hi);
    reach[static_cast<size_t>(link)] = lo.cwiseAbs().cwiseMax(hi.cwiseAbs()).norm();
  }
  robot::KinematicsState kinematics;
  const double end = trajectory.duration();
  for (double tau = std::max(0.0, from);; tau = std::min(end, tau + step)) {
    const planner::WholeBodySample s = trajectory.Sample(tau);
    robot::ComputeKinematics(robot, s.BasePose(), s.joints, &kinematics);
    for (int link : exact.links()) {
      const Pose& X_WL = kinematics.link_poses[static_cast<size_t>(link)];
      const Pose X_LW = X_WL.inverse();
      const double ball = reach[static_cast<size_t>(link)] + distance;
      for (const Vec3& p : obstacles) {
        if ((p - X_WL.translation()).squaredNorm() > ball * ball) continue;
        if (exact.LinkSignedDistance(link, X_LW * p) < distance) return tau;
      }
    }
    if (tau >= end) break;
  }
  return std::nullopt;
}

double LocalPlanner::AccelerationLimit() const {
  return std::min(base_.task().limits.a_max, local_.max_acceleration);
}

core::Result<LocalPlanResult> LocalPlanner::PlanFrom(const perception::RollingMap& map,
                                                     const planner::BoundaryState& start,
                                                     const std::vector<Vec3>& avoid) const {
  if (!start.position.allFinite()) return core::Status::InvalidArgument("local plan: the start state is not finite");
  return PlanIn(Snapshot(map, start.position), start, 0.0, avoid);
}

LocalMapSnapshot LocalPlanner::Snapshot(const perception::RollingMap& map, const Vec3& start) const {
  const auto begin = std::chrono::steady_clock::now();
  LocalMapSnapshot snapshot;
  snapshot.start = start;
  snapshot.lo = start - local_.box_half_extent;
  snapshot.hi = start + local_.box_half_extent;
  snapshot.resolution = map.options().resolution;
  snapshot.boundary = std::make_shared<const std::vector<Vec3>>(map.ObstacleBoundary(snapshot.lo, snapshot.hi));
  auto in_box = [&](const Vec3& p) {
    return ((p - snapshot.lo).array() >= 0.0).all() && ((snapshot.hi - p).array() >= 0.0).all();
  };
  // Only what seen free space joins to the start can be flown to: a point
  // seen free through a gap too small to fly (a ray through a wall) is
  // not a target. (A start whose own voxel is not free: every free point.)
  const perception::FreeRegion joined = map.ConnectedFree(snapshot.lo, snapshot.hi, start);
  const bool any_joined = joined.Contains(start);  // the flood starts there, or nothing is joined
  auto seen_free = [&](const Vec3& p) {
    return any_joined ? joined.Contains(p) : map.State(p) == perception::VoxelState::kFree;
  };
  snapshot.goal_seen_free = in_box(goal_.position) && seen_free(goal_.position);
  const double s = local_.target_spacing;
  const int n = static_cast<int>(std::floor(local_.horizon / s));
  for (int i = -n; i <= n; ++i) {
    for (int j = -n; j <= n; ++j) {
      for (int k = -n; k <= n; ++k) {
        const Vec3 offset(i * s, j * s, k * s);
        const double reach = offset.norm();
        if (reach > local_.horizon || reach < local_.min_progress) continue;
        const Vec3 p = start + offset;
        if (!in_box(p)) continue;
        if (std::abs(p.z() - goal_.position.z()) > local_.max_height_offset) continue;
        if (!seen_free(p)) continue;
        snapshot.seen_free.push_back(p);
      }
    }
  }
  // Beyond this, a target the guide cannot reach ranks after every other.
  constexpr double kUnreachableRank = 1e6;
  snapshot.seen_free_rank.reserve(snapshot.seen_free.size());
  if (local_.guide_cell > 0.0 && !snapshot.seen_free.empty()) {
    const Guide guide = Guide::Compute(map, goal_.position, local_.guide_cell, local_.max_height_offset);
    auto rank = [&](const Vec3& p) {
      const double cost = guide.CostAt(p);
      return std::isfinite(cost) ? cost : kUnreachableRank + (p - goal_.position).norm();
    };
    for (const Vec3& p : snapshot.seen_free) snapshot.seen_free_rank.push_back(rank(p));
    snapshot.start_rank = rank(start);
  } else {
    for (const Vec3& p : snapshot.seen_free) snapshot.seen_free_rank.push_back((p - goal_.position).norm());
    snapshot.start_rank = (start - goal_.position).norm();
  }
  snapshot.ms = MsSince(begin);
  return snapshot;
}

// What PlanIn and PlanTurnIn share: the task of a plan from `start` in the
// snapshot's boundary, its context, and the safety distance the start
// allows (a recovery from a start nearer than the certificate's floor).
struct LocalPlanner::Prepared {
  planner::Task task;
  std::unique_ptr<planner::PlanningContext> context;
  planner::PlannerOptions options;
};

core::Result<bool> LocalPlanner::Prepare(const LocalMapSnapshot& snapshot, const planner::BoundaryState& start,
                                         double v_max, LocalPlanResult* result, Prepared* prepared) const {
  const planner::Task& base_task = base_.task();
  if (!start.position.allFinite() || !start.velocity.allFinite() || !start.acceleration.allFinite() ||
      !start.jerk.allFinite() || !std::isfinite(start.yaw) || !std::isfinite(start.yaw_rate) ||
      !start.joints.allFinite()) {
    return core::Status::InvalidArgument("local plan: the start state is not finite");
  }
  if (start.joints.size() != goal_.joints.size()) {
    return core::Status::InvalidArgument("local plan: the start has the wrong number of joints");
  }
  if (snapshot.boundary == nullptr || (snapshot.start - start.position).norm() > 1e-9) {
    return core::Status::InvalidArgument("local plan: the map's snapshot was taken about another start");
  }
  result->scene_points = snapshot.boundary->size();
  result->scene_ms = snapshot.ms;

  planner::Task& task = prepared->task;
  task = base_task;
  task.scans.clear();
  task.start = start;
  task.safety_distance = PlannedSafetyDistance(snapshot.resolution);
  task.limits.v_max = std::min(task.limits.v_max, local_.max_speed);
  if (v_max > 0.0) task.limits.v_max = std::min(task.limits.v_max, v_max);
  task.limits.a_max = AccelerationLimit();
  const bool goal_in_box = ((goal_.position - snapshot.lo).array() >= 0.0).all() &&
                           ((snapshot.hi - goal_.position).array() >= 0.0).all();
  task.terminal = goal_;
  if (!goal_in_box) task.terminal->position = start.position;  // only what the front-end map must cover
  const auto context_start = std::chrono::steady_clock::now();
  auto context = base_.ForLocalScene(task, snapshot.boundary);
  result->context_ms = MsSince(context_start);
  if (!context.ok()) {
    result->status = LocalPlanStatus::kFailed;
    result->message = context.status().message();
    return false;
  }
  prepared->context = std::move(*context);
  // A start inside the tracking margin: a brake that could not stop short
  // of a new obstacle leaves the vehicle there, and refusing every plan
  // from it would hold the vehicle there for good. The tracking margin is
  // slack, not part of the certificate (the task's distance plus the ball
  // radius is), so it shrinks to what the start has, never below that.
  // A start inside that floor plans a recovery: never nearer the boundary
  // than it starts, and at the planned distance after recovery_time.
  const planner::PlanningScene scene = prepared->context->Scene(0);
  prepared->options = options_;
  result->start_clearance =
      planner::StateClearance(scene, start, options_.cost.flatness, planner::ClearanceSearchReach(task));
  if (result->start_clearance < task.safety_distance) {
    const double floor = base_task.safety_distance + perception::VoxelBallRadius(snapshot.resolution);
    if (result->start_clearance - kStartSlack >= floor) {
      task.safety_distance = result->start_clearance - kStartSlack;
    } else {
      result->recovery = true;
      prepared->options.post_check.recovery_time = local_.recovery_time;
      // From rest (a braked plan's stop) nothing needs braking; a start
      // moving towards the boundary may not go past its centres.
      prepared->options.post_check.recovery_min_clearance = 0.0;
    }
  }
  result->safety_distance = task.safety_distance;
  return true;
}

bool LocalPlanner::HoverClears(const Prepared& prepared, const planner::BoundaryState& terminal, double margin,
                               robot::KinematicsState* kinematics) const {
  robot::ComputeKinematics(prepared.context->robot(), planner::HoverPose(terminal.position, terminal.yaw),
                           terminal.joints, kinematics);
  const double needed = prepared.task.safety_distance + margin;
  return planner::StillAndMovingClearance(*kinematics, prepared.context->exact(), nullptr, Pose::Identity(),
                                          needed + 0.01) >= needed;
}

core::Result<LocalPlanResult> LocalPlanner::PlanIn(const LocalMapSnapshot& snapshot,
                                                   const planner::BoundaryState& start, double v_max,
                                                   const std::vector<Vec3>& avoid) const {
  const auto begin = std::chrono::steady_clock::now();
  LocalPlanResult result;
  Prepared prepared;
  auto ready = Prepare(snapshot, start, v_max, &result, &prepared);
  if (!ready.ok()) return ready.status();
  if (!*ready) {
    result.total_ms = MsSince(begin) + snapshot.ms;
    return result;
  }
  const planner::Task& task = prepared.task;
  const planner::PlanningScene scene = prepared.context->Scene(0);
  const planner::PlannerOptions& options = prepared.options;
  const planner::FrontEndMap& front_end = prepared.context->front_end();

  // The targets, best first: the goal when it is seen free and open to the
  // front end, then the lattice's seen-free points nearest the goal.
  std::vector<std::pair<double, Vec3>> candidates;
  if (snapshot.goal_seen_free && front_end.IsFree(goal_.position)) candidates.emplace_back(-1.0, goal_.position);
  if (snapshot.seen_free_rank.size() != snapshot.seen_free.size()) {
    return core::Status::InvalidArgument("local plan: the map's snapshot has no rank for its targets");
  }
  for (size_t n = 0; n < snapshot.seen_free.size(); ++n) {
    const Vec3& p = snapshot.seen_free[n];
    if (front_end.IsFree(p)) candidates.emplace_back(snapshot.seen_free_rank[n], p);
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  if (candidates.empty()) {
    result.status = LocalPlanStatus::kNoTarget;
    result.message = "no point of the box is seen free and open";
    result.total_ms = MsSince(begin) + snapshot.ms;
    return result;
  }

  robot::KinematicsState kinematics;
  // The robot at rest at the target: clear of the boundary, or not tried.
  auto hover_clears = [&](const planner::BoundaryState& terminal, double margin) {
    return HoverClears(prepared, terminal, margin, &kinematics);
  };
  // Attempt a takes the best target within horizon / 2^a of the start: when
  // the far targets fail (a turn through a door the solve cannot make in
  // one plan), a shorter hop towards them still moves the vehicle on.
  // The targets to avoid count as tried already (but are not reported).
  std::vector<Vec3> tried = avoid;
  // A hop ends with the goal's joints, but one from the folded arm (a turn
  // in place left it so) keeps it folded: only the plan to the goal
  // unfolds it: unfolding inside a hop swings the arm out near the walls
  // the fold was for.
  const bool folded = compact_joints_.size() == start.joints.size() && compact_joints_ != goal_.joints &&
                      (start.joints - compact_joints_).cwiseAbs().maxCoeff() < 1e-9;
  int checks = 0;
  const auto plan_start = std::chrono::steady_clock::now();
  for (int attempt = 0; attempt < local_.max_targets && checks < local_.max_target_checks; ++attempt) {
    const double reach = local_.horizon / static_cast<double>(1 << std::min(attempt, 20));
    std::optional<planner::Task> leg;
    bool is_goal = false;
    Vec3 target = Vec3::Zero();
    double target_rank = 0.0;
    for (const auto& [score, candidate] : candidates) {
      if (checks >= local_.max_target_checks) break;
      if ((candidate - start.position).norm() > reach) continue;
      bool near_tried = false;
      for (const Vec3& t : tried) near_tried = near_tried || (t - candidate).norm() < local_.target_separation;
      if (near_tried) continue;
      planner::Task candidate_leg = task;
      candidate_leg.terminal = goal_;
      const bool candidate_is_goal = score < 0.0;
      if (!candidate_is_goal) {
        candidate_leg.terminal->position = candidate;
        if (folded) candidate_leg.terminal->joints = start.joints;
        // The camera looks where the vehicle goes. A hop mostly up or down
        // has no heading of its own (atan2 of its few centimetres sideways
        // is noise, and turned a vehicle's back to the goal for good): it
        // faces the goal instead, or keeps the start's yaw right under it.
        Eigen::Vector2d heading = (candidate - start.position).head<2>();
        if (heading.norm() < kLeastHeading) heading = (goal_.position - start.position).head<2>();
        candidate_leg.terminal->yaw =
            heading.norm() < kLeastHeading ? start.yaw : std::atan2(heading.y(), heading.x());
      }
      // The planner's yaw is continuous: the terminal yaw nearest the start's.
      candidate_leg.terminal->yaw = start.yaw + std::remainder(candidate_leg.terminal->yaw - start.yaw, 2.0 * M_PI);
      ++checks;
      if (!hover_clears(*candidate_leg.terminal, candidate_is_goal ? 0.0 : local_.target_clearance_margin)) continue;
      leg = std::move(candidate_leg);
      is_goal = candidate_is_goal;
      target = candidate;
      target_rank = score;
      break;
    }
    if (!leg) continue;
    tried.push_back(target);
    auto planned = planner::Plan(scene, *leg, options, solver_);
    if (!planned.ok()) {
      result.message = planned.status().message();
      continue;
    }
    if (!planned->success) {
      result.message = planned->message;
      continue;
    }
    result.plan = std::move(*planned);
    result.target = target;
    result.status = is_goal ? LocalPlanStatus::kToGoal : LocalPlanStatus::kToLocalTarget;
    result.progress = is_goal || target_rank < snapshot.start_rank - local_.min_progress;
    break;
  }
  result.tried_targets.assign(tried.begin() + static_cast<long>(avoid.size()), tried.end());
  result.targets_tried = static_cast<int>(result.tried_targets.size());
  result.plan_ms = MsSince(plan_start);
  if (result.status == LocalPlanStatus::kFailed && result.message.empty()) {
    result.message = checks > 0 ? "no seen-free target leaves the robot room to hover" : "no target planned";
  }
  result.total_ms = MsSince(begin) + snapshot.ms;
  return result;
}

core::Result<LocalPlanResult> LocalPlanner::PlanTurnFrom(const perception::RollingMap& map,
                                                         const planner::BoundaryState& start, double yaw) const {
  if (!start.position.allFinite()) return core::Status::InvalidArgument("local plan: the start state is not finite");
  return PlanTurnIn(Snapshot(map, start.position), start, yaw);
}

core::Result<LocalPlanResult> LocalPlanner::PlanTurnIn(const LocalMapSnapshot& snapshot,
                                                       const planner::BoundaryState& start, double yaw,
                                                       double v_max) const {
  const auto begin = std::chrono::steady_clock::now();
  if (!std::isfinite(yaw)) return core::Status::InvalidArgument("local plan: the turn's heading is not finite");
  LocalPlanResult result;
  Prepared prepared;
  auto ready = Prepare(snapshot, start, v_max, &result, &prepared);
  if (!ready.ok()) return ready.status();
  if (*ready) {
    planner::Task turn = prepared.task;
    turn.terminal = start;
    turn.terminal->velocity = turn.terminal->acceleration = turn.terminal->jerk = Vec3::Zero();
    turn.terminal->yaw_rate = 0.0;
    turn.terminal->joint_rates = VecX();
    turn.terminal->yaw = start.yaw + std::remainder(yaw - start.yaw, 2.0 * M_PI);
    std::vector<VecX> arms;
    if (compact_joints_.size() == start.joints.size() && compact_radius_ < RadiusAt(start.joints) - 0.01) {
      arms.push_back(compact_joints_);
    }
    arms.push_back(start.joints);
    robot::KinematicsState kinematics;
    const auto plan_start = std::chrono::steady_clock::now();
    for (const VecX& arm : arms) {
      turn.terminal->joints = arm;
      if (!HoverClears(prepared, *turn.terminal, 0.0, &kinematics)) {
        result.message = "the robot turned to that heading would not clear what is not seen free";
        continue;
      }
      ++result.targets_tried;
      auto planned = planner::Plan(prepared.context->Scene(0), turn, prepared.options, solver_);
      if (!planned.ok()) {
        result.message = planned.status().message();
      } else if (!planned->success) {
        result.message = planned->message;
      } else {
        result.plan = std::move(*planned);
        result.target = start.position;
        result.status = LocalPlanStatus::kTurnInPlace;
        result.message.clear();
        break;
      }
    }
    result.plan_ms = MsSince(plan_start);
  }
  result.total_ms = MsSince(begin) + snapshot.ms;
  return result;
}

}  // namespace quadhand::explore
