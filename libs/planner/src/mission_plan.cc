#include "quadhand/planner/mission_plan.h"

#include <algorithm>
#include <chrono>
#include <functional>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "quadhand/core/text.h"
#include "quadhand/env/exact_mesh_model.h"
#include "quadhand/env/link_surface_samples.h"
#include "quadhand/geometry/mesh_distance.h"
#include "quadhand/geometry/mesh_to_sdf.h"
#include "quadhand/geometry/primitives.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/planner/terminal_state.h"

namespace quadhand::planner {
namespace {

constexpr const char* kHeldObjectLinkName = "quadhand_held_object";
constexpr const char* kHeldObjectJointName = "quadhand_held_object_joint";
constexpr double kGravity = 9.81;
// The rest-to-rest line of degree 7 (MINCO of order 4 with one piece and
// every derivative zero at both ends) covers L in T with a top speed of
// 35/16 L/T and a top acceleration of 84 sqrt(5)/25 L/T^2.
constexpr double kRestLineSpeedFactor = 35.0 / 16.0;
const double kRestLineAccelerationFactor = 84.0 * std::sqrt(5.0) / 25.0;

BoundaryState AtRest(const Vec3& position, double yaw, const VecX& joints) {
  BoundaryState state;
  state.position = position;
  state.yaw = yaw;
  state.joints = joints;
  return state;
}

// A leg of one piece from the whole state `from` to `to` in `duration`
// seconds: the base's position with its velocity, acceleration and jerk,
// the yaw and joints with their rates, matched at both ends. The piece is
// the one polynomial of degree 7 (3 for yaw and joints) that does, so a
// motion of lower degree between the two states is reproduced exactly: a
// hover, or a target's motion at a constant velocity or acceleration.
core::Result<WholeBodyTrajectory> StateToStateLeg(const BoundaryState& from, const BoundaryState& to, double duration,
                                                  const traj::FlatnessOptions& flatness) {
  const int n = static_cast<int>(from.joints.size());
  return TrajectoryThrough(from, to, MatX(3, 0), MatX(1 + n, 0), VecX::Constant(1, duration), flatness);
}

// A leg from `from` (at rest) to `to_position` at rest, yaw and joints
// held, in `duration` seconds: a hover when the two positions are the same.
core::Result<WholeBodyTrajectory> RestToRestLeg(const BoundaryState& from, const Vec3& to_position, double duration,
                                                const traj::FlatnessOptions& flatness) {
  return StateToStateLeg(AtRest(from.position, from.yaw, from.joints), AtRest(to_position, from.yaw, from.joints),
                         duration, flatness);
}

robot::CollisionGeometry ObjectGeometry(const ObjectShape& shape) {
  robot::CollisionGeometry g;
  switch (shape.kind) {
    case ObjectShape::Kind::kBox:
      g.type = robot::GeometryType::kBox;
      g.box_size = shape.box_size;
      break;
    case ObjectShape::Kind::kCylinder:
      g.type = robot::GeometryType::kCylinder;
      g.radius = shape.radius;
      g.length = shape.length;
      break;
    case ObjectShape::Kind::kSphere:
      g.type = robot::GeometryType::kSphere;
      g.radius = shape.radius;
      break;
    case ObjectShape::Kind::kMesh:
      g.type = robot::GeometryType::kMesh;
      g.mesh_path = shape.mesh_path;
      break;
  }
  return g;
}

// What is in the gripper between a grasp and its release.
struct HeldObject {
  size_t grasp_step = 0;
  MissionObject object;
  Pose object_in_tool = Pose::Identity();
};

// The scene, robot and checking models of one phase of the mission: before
// the first grasp, while an object is held, after its release, ...
struct Phase {
  const PlanningContext* context = nullptr;
  std::unique_ptr<PlanningContext> owned;
  std::shared_ptr<const std::vector<Vec3>> points, checked_points;
  // While something is held: the clouds before its grasp took the points
  // on and around it, which its release gives back (below, Release).
  std::shared_ptr<const std::vector<Vec3>> points_before_grasp, checked_before_grasp;
  std::optional<HeldObject> held;
  // While something is held: its collision elements in its own frame, and
  // its link in the phase's robot (the last).
  std::vector<geometry::TriangleMesh> object_elements;
  int object_link = -1;
  // While something is held: the robot without it, and the object alone.
  std::unique_ptr<env::ExactMeshModel> robot_only, object_only;
  // With a moving target (MovingToolGoal): the points that move with it,
  // where they are at t = 0 (the mission's clock), as this phase has them
  // (a grasp of the target's object takes its points out, its release
  // gives them back); while something is held, their exact models for the
  // robot without it and for the object alone. The context's
  // moving_scene() is built on them for the phase's robot.
  std::shared_ptr<const std::vector<Vec3>> moving_points, moving_checked;
  std::shared_ptr<const std::vector<Vec3>> moving_before_grasp, moving_checked_before_grasp;
  std::unique_ptr<env::ExactMeshModel> moving_robot_only, moving_object_only;
};

std::pair<Vec3, Vec3> SceneBounds(const std::vector<Vec3>& points) {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Vec3& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return {lo, hi};
}

robot::Link ObjectLink(const MissionObject& object) {
  robot::Link link;
  link.name = kHeldObjectLinkName;
  link.collisions.push_back(ObjectGeometry(object.shape));
  link.mass = object.mass;
  return link;
}

// The object's collision elements in its own frame (the shape tessellated
// as the robot's primitives are, a mesh repaired as the robot's are).
core::Result<std::vector<geometry::TriangleMesh>> ObjectElements(const robot::RobotModel& robot,
                                                                 const MissionObject& object) {
  auto with = robot.WithFixedLink(0, kHeldObjectJointName, ObjectLink(object), Pose::Identity());
  if (!with.ok()) return with.status();
  return robot::LinkCollisionElements(*with, with->num_links() - 1);
}

// The held object's SDF for the optimiser: a primitive's closed-form
// distance (outside its tessellation, which the checks use, by at most the
// tessellation's tolerance: never nearer), a mesh's from its elements.
core::Result<geometry::SdfGrid> ObjectSdf(const ObjectShape& shape, const std::vector<geometry::TriangleMesh>& elements,
                                          const MissionPlanOptions& options) {
  geometry::SdfGenerationOptions generation;
  generation.resolution = options.object_sdf_resolution;
  generation.padding = options.object_sdf_padding;
  // A grid the optimiser can afford per grasp: the object is something a
  // gripper holds, and a larger one is a unit error or the wrong option.
  constexpr long kMaxObjectSdfNodes = 50'000'000;
  const auto too_large = core::Status::InvalidArgument(core::Format(
      "the held object's SDF would have more than %ld nodes at mission.object_sdf_resolution %g m: is the object "
      "(or its unit) right?",
      kMaxObjectSdfNodes, options.object_sdf_resolution));
  if (shape.kind == ObjectShape::Kind::kMesh) {
    auto dims = geometry::SdfGridDims(elements, generation);
    if (!dims.ok()) return dims.status();
    if (static_cast<long>(dims->x()) * dims->y() * dims->z() > kMaxObjectSdfNodes) return too_large;
    return geometry::GenerateSdf(elements, kHeldObjectLinkName, "mission object", generation);
  }
  Vec3 half;
  std::function<double(const Vec3&)> distance;
  switch (shape.kind) {
    case ObjectShape::Kind::kBox: {
      geometry::Box box;
      box.size = shape.box_size;
      half = 0.5 * shape.box_size;
      distance = [box](const Vec3& p) { return geometry::SignedDistance(box, p); };
      break;
    }
    case ObjectShape::Kind::kCylinder: {
      geometry::Cylinder cylinder;
      cylinder.radius = shape.radius;
      cylinder.length = shape.length;
      half = Vec3(shape.radius, shape.radius, 0.5 * shape.length);
      distance = [cylinder](const Vec3& p) { return geometry::SignedDistance(cylinder, p); };
      break;
    }
    default: {
      geometry::Sphere sphere;
      sphere.radius = shape.radius;
      half = Vec3::Constant(shape.radius);
      distance = [sphere](const Vec3& p) { return geometry::SignedDistance(sphere, p); };
      break;
    }
  }
  geometry::SdfGridInfo info;
  info.link_name = kHeldObjectLinkName;
  info.frame = kHeldObjectLinkName;
  info.source = "mission object";
  info.resolution = options.object_sdf_resolution;
  info.origin = -half - Vec3::Constant(options.object_sdf_padding);
  info.geometry_min = -half;
  info.geometry_max = half;
  const Vec3 extent = 2.0 * (half + Vec3::Constant(options.object_sdf_padding));
  for (int a = 0; a < 3; ++a) info.dims[a] = static_cast<int>(std::ceil(extent[a] / info.resolution - 1e-9)) + 1;
  if (info.NumNodes() > kMaxObjectSdfNodes) return too_large;
  std::vector<float> values(static_cast<size_t>(info.NumNodes()));
  size_t n = 0;
  for (int k = 0; k < info.dims.z(); ++k) {
    for (int j = 0; j < info.dims.y(); ++j) {
      for (int i = 0; i < info.dims.x(); ++i) {
        values[n++] = static_cast<float>(distance(info.origin + info.resolution * Vec3(i, j, k)));
      }
    }
  }
  return geometry::SdfGrid(std::move(info), std::move(values));
}

// Builds the phase that holds `held` (robot = context's base robot plus
// the object, whose elements ObjectElements made) or nothing, on the given
// clouds.
core::Result<Phase> MakePhase(const PlanningContext& base, std::optional<HeldObject> held,
                              std::vector<geometry::TriangleMesh> object_elements,
                              std::shared_ptr<const std::vector<Vec3>> points,
                              std::shared_ptr<const std::vector<Vec3>> checked_points, const MissionPlanOptions& options,
                              std::shared_ptr<const std::vector<Vec3>> moving_points,
                              std::shared_ptr<const std::vector<Vec3>> moving_checked) {
  Phase phase;
  phase.points = points;
  phase.checked_points = checked_points;
  phase.moving_points = moving_points;
  phase.moving_checked = moving_checked;
  phase.held = held;
  robot::RobotModel robot = base.robot();
  std::vector<std::pair<int, geometry::SdfGrid>> given;
  if (held) {
    const int tool_link = base.robot().LinkIndex(base.task().tool_link);
    auto with = base.robot().WithFixedLink(tool_link, kHeldObjectJointName, ObjectLink(held->object), held->object_in_tool);
    if (!with.ok()) return with.status();
    robot = std::move(*with);
    phase.object_link = robot.num_links() - 1;
    auto grid = ObjectSdf(held->object.shape, object_elements, options);
    if (!grid.ok()) return grid.status();
    given.emplace_back(phase.object_link, std::move(*grid));
    phase.object_elements = std::move(object_elements);
  }
  auto context = base.ForMissionPhase(std::move(robot), points, checked_points, std::move(given), moving_points,
                                      moving_checked);
  if (!context.ok()) return context.status();
  phase.owned = std::move(*context);
  phase.context = phase.owned.get();
  if (held) {
    const robot::RobotModel& r = phase.context->robot();
    const std::shared_ptr<const scene::PointGrid>& index = phase.context->checked_index();
    std::vector<int> robot_links;
    for (int link : r.CollisionLinks()) {
      if (link != phase.object_link) robot_links.push_back(link);
    }
    // The robot without the object, and the object alone, on one cloud.
    auto split = [&](const std::shared_ptr<const scene::PointGrid>& cloud, std::unique_ptr<env::ExactMeshModel>* robot_only,
                     std::unique_ptr<env::ExactMeshModel>* object_only) -> core::Status {
      auto robot_model = env::ExactMeshModel::Create(r, cloud, robot_links);
      if (!robot_model.ok()) return robot_model.status();
      auto object_model = env::ExactMeshModel::Create(r, cloud, {phase.object_link});
      if (!object_model.ok()) return object_model.status();
      *robot_only = std::move(*robot_model);
      *object_only = std::move(*object_model);
      return core::Status::Ok();
    };
    QUADHAND_RETURN_IF_ERROR(split(index, &phase.robot_only, &phase.object_only));
    if (moving_checked != nullptr && !moving_checked->empty()) {
      QUADHAND_RETURN_IF_ERROR(split(
          std::make_shared<const scene::PointGrid>(*moving_checked, env::ExactMeshModel::kIndexCellSize),
          &phase.moving_robot_only, &phase.moving_object_only));
    }
  }
  return phase;
}

// `points` without those within `margin` of the object (world pose
// `object_pose`): a grasped object leaves the scene.
core::Result<std::vector<Vec3>> WithoutObject(const std::vector<Vec3>& points,
                                              const std::vector<geometry::TriangleMesh>& elements,
                                              const Pose& object_pose, double margin) {
  std::vector<std::unique_ptr<geometry::MeshDistanceQuery>> queries;
  for (const geometry::TriangleMesh& mesh : elements) {
    auto query = geometry::MeshDistanceQuery::Create(mesh, true);
    if (!query.ok()) return query.status();
    queries.push_back(std::move(*query));
  }
  const Pose world_to_object = object_pose.inverse();
  Vec3 box_min = Vec3::Constant(std::numeric_limits<double>::infinity()), box_max = -box_min;
  for (const geometry::TriangleMesh& mesh : elements) {
    for (const Vec3& v : mesh.vertices) {
      box_min = box_min.cwiseMin(v);
      box_max = box_max.cwiseMax(v);
    }
  }
  box_min -= Vec3::Constant(margin);
  box_max += Vec3::Constant(margin);
  std::vector<Vec3> kept;
  kept.reserve(points.size());
  for (const Vec3& p : points) {
    const Vec3 local = world_to_object * p;
    if ((local.array() < box_min.array()).any() || (local.array() > box_max.array()).any()) {
      kept.push_back(p);  // farther than the margin from the object's box
      continue;
    }
    bool near = false;
    for (const auto& query : queries) near = near || query->SignedDistance(local) <= margin;
    if (!near) kept.push_back(p);
  }
  return kept;
}

// The released object's surface at `object_pose`, sampled `spacing` apart.
std::vector<Vec3> ObjectSurface(const std::vector<geometry::TriangleMesh>& elements, const Pose& object_pose,
                                double spacing) {
  std::vector<Vec3> surface;
  for (const geometry::TriangleMesh& mesh : elements) {
    for (const Vec3& p : env::SampleLinkSurface(mesh, spacing).points) surface.push_back(object_pose * p);
  }
  return surface;
}

// The phase after grasp step `i` of `task`, the tool at `tool` (world) as
// it closes: the object held where it lies relative to the tool (as the
// task places it when it is held from the start), its points, and those
// within its scene_margin, gone from both clouds. An object that moves with
// the target (`moving_object`: the grasp after a moving reach) is where
// its pose says at t = 0, and so is `tool` (in the target's frame at
// t = 0): it and its margin leave the moving clouds, the still ones stay.
core::Result<Phase> PhaseAfterGrasp(const PlanningContext& base, const Phase& before, const Task& task, size_t i,
                                    const Pose& tool, const MissionPlanOptions& options, bool moving_object = false) {
  const MissionStep& step = task.mission[i];
  HeldObject held;
  held.grasp_step = i;
  held.object = step.object;
  auto points = before.points;
  auto checked = before.checked_points;
  auto moving = before.moving_points;
  auto moving_checked = before.moving_checked;
  auto elements = ObjectElements(base.robot(), step.object);
  if (!elements.ok()) return elements.status().WithPrefix(task.file + ": " + StepName(task.mission, i));
  if (step.held_at_start) {
    held.object_in_tool = step.object.pose;
  } else {
    held.object_in_tool = tool.inverse() * step.object.pose;
    auto without = [&](const std::vector<Vec3>& cloud) -> core::Result<std::shared_ptr<const std::vector<Vec3>>> {
      auto kept = WithoutObject(cloud, *elements, step.object.pose, step.scene_margin);
      if (!kept.ok()) return kept.status();
      if (kept->empty() && !moving_object) {
        return core::Status::InvalidArgument(task.file + ": " + StepName(task.mission, i) +
                                             ": the object's scene_margin takes every scene point");
      }
      return std::make_shared<const std::vector<Vec3>>(std::move(*kept));
    };
    std::shared_ptr<const std::vector<Vec3>>& from = moving_object ? moving : points;
    std::shared_ptr<const std::vector<Vec3>>& from_checked = moving_object ? moving_checked : checked;
    if (from != nullptr) {
      const bool same = from == from_checked;
      auto kept = without(*from);
      if (!kept.ok()) return kept.status();
      from = std::move(*kept);
      if (same) {
        from_checked = from;
      } else if (from_checked != nullptr) {
        auto kept_checked = without(*from_checked);
        if (!kept_checked.ok()) return kept_checked.status();
        from_checked = std::move(*kept_checked);
      }
    }
  }
  auto phase = MakePhase(base, held, std::move(*elements), points, checked, options, moving, moving_checked);
  if (!phase.ok()) return phase.status().WithPrefix(task.file + ": " + StepName(task.mission, i));
  phase->points_before_grasp = before.points;
  phase->checked_before_grasp = before.checked_points;
  phase->moving_before_grasp = before.moving_points;
  phase->moving_checked_before_grasp = before.moving_checked;
  return phase;
}

// The phase after the held object's release at step `i`, left at
// `object_pose` (world): its surface joins the scene. The points its grasp
// took (the object's own scan, and whatever it stood on within
// scene_margin) come back: the scan is the only evidence of that space, and
// without them the support would keep a hole the size of the object that a
// later leg could be certified through. Where the object was is then
// occupied by its old scan (conservative: an object put back where it was
// taken from meets it).
core::Result<Phase> PhaseAfterRelease(const PlanningContext& base, const Phase& before, const Task& task, size_t i,
                                      const Pose& object_pose, const MissionPlanOptions& options) {
  if (!before.held) return core::Status::Internal("release without a held object");
  const std::vector<Vec3> surface = ObjectSurface(before.object_elements, object_pose, options.released_surface_spacing);
  auto with = [&surface](const std::vector<Vec3>& cloud) {
    auto out = std::make_shared<std::vector<Vec3>>(cloud);
    out->insert(out->end(), surface.begin(), surface.end());
    return std::shared_ptr<const std::vector<Vec3>>(std::move(out));
  };
  auto points = with(*before.points_before_grasp);
  auto checked = before.points_before_grasp == before.checked_before_grasp ? points
                                                                            : with(*before.checked_before_grasp);
  auto phase = MakePhase(base, std::nullopt, {}, points, checked, options, before.moving_before_grasp,
                         before.moving_checked_before_grasp);
  if (!phase.ok()) return phase.status().WithPrefix(task.file + ": " + StepName(task.mission, i));
  return phase;
}

// The first phase: the task's scene (its clouds are the context's).
std::shared_ptr<Phase> FirstPhase(const PlanningContext& base) {
  auto first = std::make_shared<Phase>();
  first->context = &base;
  first->points = std::shared_ptr<const std::vector<Vec3>>(&base.points(), [](auto*) {});
  first->checked_points = &base.points() == &base.checked_points()
                              ? first->points
                              : std::shared_ptr<const std::vector<Vec3>>(&base.checked_points(), [](auto*) {});
  if (base.moving_scene() != nullptr) {
    first->moving_points = std::shared_ptr<const std::vector<Vec3>>(&base.moving_points(), [](auto*) {});
    first->moving_checked = std::shared_ptr<const std::vector<Vec3>>(&base.moving_checked_points(), [](auto*) {});
  }
  return first;
}

// Folds one leg's post-check into the mission's: every check's worst,
// times shifted by the leg's start.
void MergeReport(const PostCheckReport& leg, double offset, bool first, PostCheckReport* all) {
  if (first) {
    *all = leg;
    all->certified_intervals.clear();
  } else {
    all->passed = all->passed && leg.passed;
    all->certified = all->certified && leg.certified;
    if (leg.min_clearance_exact < all->min_clearance_exact) {
      all->min_clearance_exact = leg.min_clearance_exact;
      all->min_clearance_exact_is_bound = leg.min_clearance_exact_is_bound;
      all->closest_link = leg.closest_link;
    }
    all->min_clearance_model = std::min(all->min_clearance_model, leg.min_clearance_model);
    if (leg.min_self_distance < all->min_self_distance) {
      all->min_self_distance = leg.min_self_distance;
      all->closest_self_pair = leg.closest_self_pair;
    }
    if (leg.certified_clearance < all->certified_clearance) {
      all->certified_clearance = leg.certified_clearance;
      all->certified_margin = leg.certified_margin;
    }
    all->certified_self_distance = std::min(all->certified_self_distance, leg.certified_self_distance);
    all->certificate_samples += leg.certificate_samples;
    for (const auto& [name, ratio] : leg.violations) {
      auto found = std::find_if(all->violations.begin(), all->violations.end(),
                                [&name = name](const auto& v) { return v.first == name; });
      if (found == all->violations.end()) {
        all->violations.emplace_back(name, ratio);
      } else {
        found->second = std::max(found->second, ratio);
      }
    }
    for (CheckResult check : leg.checks) {
      check.time += offset;
      auto found = std::find_if(all->checks.begin(), all->checks.end(), [&check](const CheckResult& c) {
        return c.kind == check.kind && c.joint == check.joint && c.name == check.name;
      });
      if (found == all->checks.end()) {
        all->checks.push_back(check);
        continue;
      }
      // The first failure stands; until one, the worst: the least
      // clearance, the largest excess, the mission's own start and end.
      if (!found->passed) continue;
      const bool clearance = check.kind == CheckKind::kClearance || check.kind == CheckKind::kSelfClearance ||
                             check.kind == CheckKind::kHeldObjectClearance;
      const bool worse = !check.passed || check.kind == CheckKind::kEndState ||
                         (check.kind != CheckKind::kStartState &&
                          (clearance ? check.value < found->value : check.value > found->value));
      if (worse) *found = check;
    }
  }
  all->clearance_checked_until = offset + leg.clearance_checked_until;
  for (CertifiedInterval interval : leg.certified_intervals) {
    interval.t0 += offset;
    interval.t1 += offset;
    all->certified_intervals.push_back(interval);
  }
}

}  // namespace

class MissionPhaseCache::Impl {
 public:
  std::shared_ptr<const Phase> Find(const PlanningContext* context, const std::string& key) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (context != context_) return nullptr;
    auto found = phases_.find(key);
    return found == phases_.end() ? nullptr : found->second;
  }
  void Keep(const PlanningContext* context, const std::string& key, std::shared_ptr<const Phase> phase) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (context != context_) {  // another context's phases are of no use
      phases_.clear();
      context_ = context;
    }
    if (phases_.size() >= kMaxPhases) phases_.clear();
    phases_[key] = std::move(phase);
  }

 private:
  static constexpr size_t kMaxPhases = 16;
  std::mutex mutex_;
  const PlanningContext* context_ = nullptr;
  std::map<std::string, std::shared_ptr<const Phase>> phases_;
};

MissionPhaseCache::MissionPhaseCache() : impl_(std::make_unique<Impl>()) {}
MissionPhaseCache::~MissionPhaseCache() = default;

namespace {

class MissionPlanner {
 public:
  MissionPlanner(const PlanningContext& context, const Task& task, size_t representation, const PlannerOptions& options,
                 const opt::Solver& solver, MissionPhaseCache* cache)
      : base_(context), representation_(representation), options_(options), solver_(solver), task_(task),
        cache_(cache), tool_link_(context.robot().LinkIndex(task.tool_link)) {}

  core::Result<PlanResult> Run();

 private:
  // One leg's outcome; false when the step failed (result_ says why).
  core::Result<bool> PlanStep(size_t i);
  // `goal_moves`: the leg's task has the moving target's tool goal.
  core::Result<bool> ReachLeg(size_t i, const Task& leg_task, bool relaxed_object, bool goal_moves = false);
  // A reach of the moving target: planned as a goal is (the arrival
  // optimised, the insertion inside the leg), on the target's clock from
  // the leg's start; the vehicle then moves with the target.
  core::Result<bool> MovingReachLeg(size_t i);
  // While the vehicle moves with the target: a leg of `duration` that goes
  // on moving with it, the base `offset` (world, at the leg's start) farther
  // in the target's frame at the end, the tool on `line` (given in the
  // target's frame at t = 0; disabled: the tool stays where it is in that
  // frame, checked as follow_target).
  core::Result<bool> FollowLeg(size_t i, double duration, const Vec3& offset, const InsertionGoal& line,
                               bool relaxed_object);
  // From a state moving with the target to rest, straight on (part of step i).
  core::Result<bool> BrakeLeg(size_t i);
  // The post-check of a leg the mission makes itself (not optimised) from
  // state_ to `end`, in `scene`; its time is added to the result's.
  PostCheckReport LegPostCheck(const WholeBodyTrajectory& trajectory, const Task& leg_task, const BoundaryState& end,
                               const InsertionGoal& line, const PlanningScene& scene);
  // The steps of the vias reach step `reach`'s leg passed (pending_vias_),
  // from the leg's start and the via check's times in it.
  void PassedVias(size_t reach, double leg_start, const std::vector<double>& via_times);
  core::Result<bool> RestLeg(size_t i, const Vec3& to_position, double duration, const InsertionGoal& line,
                             bool relaxed_object);
  // Checks `trajectory` (from state_) as step i's leg and appends it.
  core::Result<bool> CheckAndAppend(size_t i, WholeBodyTrajectory trajectory, const Task& leg_task,
                                    const BoundaryState& end, const InsertionGoal& insertion, bool relaxed_object,
                                    PostCheckReport robot_report);
  // A mission's reach with an insertion: flown to the insertion's start
  // (where it comes to rest), then the insertion as a line. The rest
  // before the line is where the flight settles (a tool centimetres off
  // after the arm's last motion would fly the line off it), and a line
  // that puts the held object down (`places`: a release next) lets the
  // object touch its support, while the transit keeps it clear.
  core::Result<bool> InsertionLeg(size_t i, bool places);
  // InvalidArgument naming step i when the robot has no tool link.
  core::Status RequireToolLink(size_t i) const;
  // A rest-to-rest line's duration from the state (tool at `tool`).
  double LineDuration(const Vec3& tool, const Vec3& direction, double length, std::optional<double> max_speed) const;
  core::Status Grasp(size_t i);
  core::Status Release(size_t i);
  // The phase after step i (a grasp or a release): from the cache, or built.
  core::Status ChangePhase(size_t i);
  Task LegTask() const;
  // The pose of `link` of `robot` at the state the mission has reached (at
  // rest; moving with the target, as the plan flies it there).
  Pose LinkAtState(const robot::RobotModel& robot, int link) const {
    if (with_target_ && whole_) {
      const WholeBodySample last = whole_->Sample(whole_->duration());
      return robot::LinkPose(robot, last.BasePose(), last.joints, link);
    }
    return robot::LinkPose(robot, HoverPose(state_.position, state_.yaw), state_.joints, link);
  }
  // The same in the frame the mission's objects are given in: the world,
  // or while moving with the target its frame at t = 0.
  Pose LinkForObjects(const robot::RobotModel& robot, int link) const {
    const Pose pose = LinkAtState(robot, link);
    return with_target_ ? TaskMotion().Displacement(Now()).inverse() * pose : pose;
  }
  double Now() const { return whole_ ? whole_->duration() : 0.0; }
  // The moving target's motion on the mission's clock.
  const TargetMotion& TaskMotion() const { return *base_.moving_scene()->motion; }
  // The phase's scene for the next leg; its exact model without the held
  // object when asked (the object is then checked on its own). With a
  // moving target, its moving part on the target's clock from the leg's
  // start (leg_moving_; the goal moves with it when `goal_moves`).
  PlanningScene Scene(bool without_held_object, bool goal_moves = false);
  bool Fail(size_t i, PlanStatus status, const std::string& why);

  const PlanningContext& base_;
  size_t representation_;
  const PlannerOptions& options_;
  const opt::Solver& solver_;
  const Task& task_;
  std::shared_ptr<const Phase> phase_;
  std::string phase_key_;  // the grasps and releases that made phase_ (MissionPhaseCache)
  MissionPhaseCache* cache_ = nullptr;
  // The tool link: the same index in every phase's robot (a held object is
  // appended after every link); -1 when the robot has none.
  int tool_link_ = -1;
  BoundaryState state_;
  std::optional<Vec3> last_insertion_;  // of the latest reach with one
  // Vias the next reach passes on its way (a via followed by a reach or
  // another via), in order: they are constraints of that reach's leg.
  std::vector<size_t> pending_vias_;
  PlanResult result_;
  std::optional<WholeBodyTrajectory> whole_;
  bool first_leg_ = true;
  // The leg's moving part (Scene()): the motion shifted to the leg's start,
  // for the robot and for the held object alone (CheckAndAppend).
  TargetMotion leg_motion_;
  MovingScene leg_moving_, leg_object_moving_;
  bool leg_moves_ = false;
  // The vehicle moves with the target: from its reach to the move after
  // its grasp (or the reach or via after that).
  bool with_target_ = false;
  // The moving reach's insertion direction in the target's frame at t = 0.
  std::optional<Vec3> moving_insertion_;
};

Task MissionPlanner::LegTask() const {
  Task leg = task_;
  leg.mission.clear();
  leg.terminal.reset();
  leg.tool.reset();
  leg.start = state_;
  for (size_t v : pending_vias_) leg.vias.push_back({task_.mission[v].via_position, task_.mission[v].via_tolerance});
  return leg;
}

PlanningScene MissionPlanner::Scene(bool without_held_object, bool goal_moves) {
  const PlanningScene scene = phase_->context->Scene(representation_);
  const bool without = phase_->held && without_held_object;
  const MovingScene* phase_moving = phase_->context->moving_scene();
  leg_moves_ = phase_moving != nullptr;
  if (leg_moves_) {
    leg_motion_ = phase_moving->motion->Shifted(Now());
    leg_moving_ = *phase_moving;
    leg_moving_.motion = &leg_motion_;
    leg_moving_.goal_moves = goal_moves;
    if (without && phase_->moving_robot_only) leg_moving_.exact = phase_->moving_robot_only.get();
    leg_object_moving_ = leg_moving_;
    leg_object_moving_.exact = phase_->moving_object_only.get();
  }
  return PlanningScene{scene.robot,
                       scene.collision,
                       without ? *phase_->robot_only : scene.exact,
                       scene.front_end,
                       scene.per_plan_collision,
                       scene.self_collision,
                       leg_moves_ ? &leg_moving_ : nullptr};
}

bool MissionPlanner::Fail(size_t i, PlanStatus status, const std::string& why) {
  result_.success = false;
  result_.status = status;
  result_.message = StepName(task_.mission, i) + ": " + why;
  return false;
}

core::Result<bool> MissionPlanner::CheckAndAppend(size_t i, WholeBodyTrajectory trajectory, const Task& leg_task,
                                                  const BoundaryState& end, const InsertionGoal& insertion,
                                                  bool relaxed_object, PostCheckReport report) {
  const double start_s = Now();
  StepResult& step = result_.steps[i];
  // A step of two legs (a placing reach) adds the second to the first.
  const bool continuing = step.planned;
  const StepResult before = step;
  step.planned = true;
  if (!continuing) step.start_s = start_s;
  step.end_s = start_s + trajectory.duration();
  step.min_clearance = report.min_clearance_exact;
  step.min_clearance_is_bound = report.min_clearance_exact_is_bound;
  if (continuing && before.min_clearance < step.min_clearance) {
    step.min_clearance = before.min_clearance;
    step.min_clearance_is_bound = before.min_clearance_is_bound;
  }
  if (phase_->held) {
    // The object alone, judged by the post-check's own certificate with
    // the distance it must keep: the safety distance, or none (>= 0, the
    // tolerance's worth of bound) next to its grasp and release.
    Task object_task = leg_task;
    object_task.safety_distance =
        relaxed_object ? options_.post_check.clearance_tolerance : task_.safety_distance;
    const PlanningScene scene = phase_->context->Scene(representation_);
    const PostCheckReport object = PostCheck(trajectory, scene.robot, object_task, end, insertion, scene.collision,
                                             *phase_->object_only, nullptr, options_.post_check,
                                             leg_moves_ ? &leg_object_moving_ : nullptr);
    CheckResult held;
    held.kind = CheckKind::kHeldObjectClearance;
    held.name = CheckKindName(held.kind);
    held.bound = relaxed_object ? 0.0 : task_.safety_distance;
    for (const CheckResult& c : object.checks) {
      if (c.kind != CheckKind::kClearance) continue;
      held.passed = c.passed;
      held.value = c.value;
      held.time = c.time;
    }
    held.detail = core::Format("the held object certified %.4f m from the scene at every instant (it keeps ", held.value) +
                  (relaxed_object ? std::string("clearance >= 0 next to its grasp and release")
                                  : core::Format("the safety distance %.4f m", task_.safety_distance)) +
                  core::Format(", accepted down to %.4f m), least at t = %.3f s; sampled minimum %.4f m",
                               std::max(0.0, held.bound - options_.post_check.clearance_tolerance),
                               start_s + held.time, object.min_clearance_exact);
    step.held_object_min_clearance = object.min_clearance_exact;
    step.held_object_min_clearance_is_bound = object.min_clearance_exact_is_bound;
    if (continuing && before.held_object_min_clearance &&
        *before.held_object_min_clearance < *step.held_object_min_clearance) {
      step.held_object_min_clearance = before.held_object_min_clearance;
      step.held_object_min_clearance_is_bound = before.held_object_min_clearance_is_bound;
    }
    report.checks.push_back(held);
    report.passed = report.passed && held.passed;
    report.certified = report.certified && object.certified;
  }
  step.certified = report.passed && report.certified && (!continuing || before.certified);
  MissionLeg leg;
  leg.start_s = start_s;
  leg.end_s = start_s + trajectory.duration();
  leg.step = i;
  leg.robot = &phase_->context->robot();
  leg.robot_exact = phase_->held ? phase_->robot_only.get() : &phase_->context->exact();
  leg.object_exact = phase_->held ? phase_->object_only.get() : nullptr;
  leg.object_clearance = relaxed_object ? 0.0 : task_.safety_distance;
  leg.held_grasp_step = phase_->held ? static_cast<long>(phase_->held->grasp_step) : -1;
  leg.object_link = phase_->held ? phase_->object_link : -1;
  result_.mission_legs.push_back(leg);
  if (result_.mission_phases.empty() || result_.mission_phases.back() != phase_) {
    result_.mission_phases.push_back(phase_);
  }
  // The report names links and pairs of the task's robot: the held
  // object has its own figures, and a phase's pairs are numbered anew.
  if (report.closest_link >= base_.robot().num_links()) report.closest_link = -1;
  if (phase_->context != &base_) report.closest_self_pair = -1;
  MergeReport(report, start_s, first_leg_, &result_.post_check);
  first_leg_ = false;
  if (whole_) {
    auto joined = JoinedTrajectory(*whole_, trajectory);
    if (!joined.ok()) return joined.status();
    whole_ = std::move(*joined);
  } else {
    whole_ = std::move(trajectory);
  }
  result_.trajectory = whole_;
  result_.num_pieces = whole_->num_pieces();
  if (!report.passed) {
    return Fail(i, PlanStatus::kPostCheckFailed, report.FirstFailure().empty() ? "a post-check failed"
                                                                               : report.FirstFailure());
  }
  state_ = end;
  return true;
}

core::Result<bool> MissionPlanner::ReachLeg(size_t i, const Task& leg_task, bool relaxed_object, bool goal_moves) {
  auto planned = Plan(Scene(relaxed_object, goal_moves), leg_task, options_, solver_);
  if (!planned.ok()) {
    // The first step starts from the task's start: its errors are the
    // task's. A later one starts where the mission left the robot.
    if (i == 0 || planned.status().code() != core::StatusCode::kInvalidArgument) return planned.status();
    return Fail(i, PlanStatus::kMissionStepInvalid, planned.status().message());
  }
  PlanResult& leg = *planned;
  result_.front_end_ms += leg.front_end_ms;
  result_.per_plan_collision_ms += leg.per_plan_collision_ms;
  result_.solve_ms += leg.solve_ms;
  result_.post_check_ms += leg.post_check_ms;
  result_.iterations += leg.iterations;
  result_.evaluations += leg.evaluations;
  result_.attempts.insert(result_.attempts.end(), leg.attempts.begin(), leg.attempts.end());
  result_.alternatives_tried += leg.alternatives_tried;
  result_.final_cost = leg.final_cost;
  result_.path = leg.path;
  result_.terminal = leg.terminal;
  result_.terminal_searched = leg.terminal_searched;
  result_.terminal_search = leg.terminal_search;
  result_.insertion = leg.insertion;
  if (goal_moves) {
    result_.moving_target = leg.moving_target;
    result_.terminal_at_zero = leg.terminal_at_zero;
    result_.insertion_at_zero = leg.insertion_at_zero;
    result_.target_at_zero = leg.target_at_zero;
    result_.arrival_rounds = leg.arrival_rounds;
    result_.target_out_of_reach_m = leg.target_out_of_reach_m;
    // The leg's times on the mission's clock.
    result_.arrival_guess_s = Now() + leg.arrival_guess_s;
    result_.target_out_of_reach_at_s = Now() + leg.target_out_of_reach_at_s;
    if (leg.trajectory) {
      result_.target_met_s = Now() + leg.trajectory->duration();
      result_.target_met_insertion = leg.insertion;
    }
  }
  if (!leg.trajectory) return Fail(i, leg.status, leg.message);
  if (leg.insertion.enabled) last_insertion_ = leg.insertion.direction;
  const double leg_start = Now();
  auto appended = CheckAndAppend(i, std::move(*leg.trajectory), leg_task, leg.terminal, leg.insertion,
                                 relaxed_object, leg.post_check);
  if (appended.ok() && !leg_task.vias.empty()) PassedVias(i, leg_start, leg.post_check.via_times);
  return appended;
}

void MissionPlanner::PassedVias(size_t reach, double leg_start, const std::vector<double>& via_times) {
  // The vias and the reach share one leg and its figures; each via's step
  // ends when the base comes closest to its point.
  StepResult& reached = result_.steps[reach];
  double start = leg_start;
  for (size_t k = 0; k < pending_vias_.size(); ++k) {
    StepResult& via = result_.steps[pending_vias_[k]];
    const double end = k < via_times.size() ? leg_start + via_times[k] : start;
    const StepKind kind = via.kind;
    via = reached;
    via.kind = kind;
    via.start_s = start;
    via.end_s = std::max(start, end);
    start = via.end_s;
  }
  reached.start_s = start;
  pending_vias_.clear();
}

PostCheckReport MissionPlanner::LegPostCheck(const WholeBodyTrajectory& trajectory, const Task& leg_task,
                                            const BoundaryState& end, const InsertionGoal& line,
                                            const PlanningScene& scene) {
  const auto check_start = std::chrono::steady_clock::now();
  PostCheckReport report = PostCheck(trajectory, scene.robot, leg_task, end, line, scene.collision, scene.exact,
                                     scene.self_collision, options_.post_check, scene.moving);
  result_.post_check_ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - check_start).count();
  return report;
}

core::Result<bool> MissionPlanner::RestLeg(size_t i, const Vec3& to_position, double duration,
                                           const InsertionGoal& line, bool relaxed_object) {
  auto trajectory = RestToRestLeg(state_, to_position, duration, options_.cost.flatness);
  if (!trajectory.ok()) return trajectory.status();
  const BoundaryState end = AtRest(to_position, state_.yaw, state_.joints);
  const Task leg_task = LegTask();
  // The object is judged on its own (CheckAndAppend), so that its failures
  // are named held_object_clearance.
  const PlanningScene scene = Scene(true);
  PostCheckReport report = LegPostCheck(*trajectory, leg_task, end, line, scene);
  return CheckAndAppend(i, std::move(*trajectory), leg_task, end, line, relaxed_object, std::move(report));
}

core::Result<bool> MissionPlanner::MovingReachLeg(size_t i) {
  const MissionStep& step = task_.mission[i];
  QUADHAND_RETURN_IF_ERROR(RequireToolLink(i));
  Task leg = LegTask();
  leg.tool = step.reach_tool;
  auto reached = ReachLeg(i, leg, false, /*goal_moves=*/true);
  if (!reached.ok() || !*reached) return reached;
  with_target_ = true;
  if (result_.insertion_at_zero.enabled) moving_insertion_ = result_.insertion_at_zero.direction;
  return true;
}

core::Result<bool> MissionPlanner::FollowLeg(size_t i, double duration, const Vec3& offset, const InsertionGoal& line,
                                             bool relaxed_object) {
  const TargetMotion& motion = TaskMotion();
  const double start = Now();
  const Pose at_start = motion.Displacement(start);
  // Where the base is in the target's frame at t = 0, then moved on with it.
  BoundaryState at_zero = StateAtZero(state_, motion, start);
  at_zero.joints = state_.joints;
  at_zero.position += at_start.linear().transpose() * offset;
  const BoundaryState end = MovedState(at_zero, motion, start + duration);
  auto trajectory = StateToStateLeg(state_, end, duration, options_.cost.flatness);
  if (!trajectory.ok()) return trajectory.status();
  const Task leg_task = LegTask();
  const PlanningScene scene = Scene(true, /*goal_moves=*/true);
  PostCheckReport report = LegPostCheck(*trajectory, leg_task, end, line, scene);
  if (!line.enabled) {
    // The tool holds its place on the target while the gripper closes: its
    // distance from there, in the target's frame, at the post-check's step.
    const Vec3 tool_start = (at_start.inverse() * LinkAtState(scene.robot, tool_link_)).translation();
    CheckResult follow;
    follow.kind = CheckKind::kFollowTarget;
    follow.name = CheckKindName(follow.kind);
    follow.bound = options_.post_check.position_tolerance;
    follow.value = 0.0;
    const int steps = std::max(1, static_cast<int>(std::ceil(duration / options_.post_check.dt)));
    for (int k = 0; k <= steps; ++k) {
      const double t = duration * k / steps;
      const WholeBodySample sample = trajectory->Sample(t);
      const Vec3 tool = robot::LinkPose(scene.robot, sample.BasePose(), sample.joints, tool_link_).translation();
      const double off = ((motion.Displacement(start + t).inverse() * tool) - tool_start).norm();
      if (off > follow.value) {
        follow.value = off;
        follow.time = t;
      }
    }
    follow.passed = follow.value <= follow.bound;
    follow.detail = core::Format("the tool stays within %.4f m of where it met the moving target, in its frame, "
                                 "while the gripper closes (at most %.4f m)",
                                 follow.value, follow.bound);
    report.checks.push_back(follow);
    report.passed = report.passed && follow.passed;
    report.certified = report.certified && follow.passed;
  }
  return CheckAndAppend(i, std::move(*trajectory), leg_task, end, line, relaxed_object, std::move(report));
}

core::Result<bool> MissionPlanner::BrakeLeg(size_t i) {
  // Straight on, as a constant deceleration would stop: the end at rest
  // half the time's travel on, yaw likewise; long enough that the stop
  // asks for a fifth of a_max on average (the polynomial's peak is about
  // twice its mean), never shorter than a move.
  const double speed = state_.velocity.norm();
  const double duration = std::max({options_.mission.move_min_duration, 5.0 * speed / task_.limits.a_max,
                                    5.0 * std::abs(state_.yaw_rate) / task_.limits.yaw_rate_max, 0.1});
  BoundaryState end = AtRest(state_.position + 0.5 * duration * state_.velocity, state_.yaw + 0.5 * duration * state_.yaw_rate,
                             state_.joints);
  auto trajectory = StateToStateLeg(state_, end, duration, options_.cost.flatness);
  if (!trajectory.ok()) return trajectory.status();
  const Task leg_task = LegTask();
  const PlanningScene scene = Scene(true);
  PostCheckReport report = LegPostCheck(*trajectory, leg_task, end, InsertionGoal{}, scene);
  with_target_ = false;
  return CheckAndAppend(i, std::move(*trajectory), leg_task, end, InsertionGoal{}, false, std::move(report));
}

core::Status MissionPlanner::RequireToolLink(size_t i) const {
  if (tool_link_ >= 0) return core::Status::Ok();
  return core::Status::InvalidArgument(task_.file + ": " + StepName(task_.mission, i) +
                                       ": tool_link: the robot has no link named '" + task_.tool_link + "'");
}

double MissionPlanner::LineDuration(const Vec3& tool, const Vec3& direction, double length,
                                    std::optional<double> max_speed) const {
  // The top speed and acceleration, and the tool within half the
  // insertion tolerance of its line while the airframe tilts to
  // accelerate sideways (the tool's lever arm times the tilt).
  const double speed = std::min(max_speed.value_or(options_.mission.move_speed), task_.limits.v_max);
  double acceleration = task_.limits.a_max;
  const double lever = (tool - state_.position).norm();
  const double sideways = std::hypot(direction.x(), direction.y());
  if (lever * sideways > 1e-9) {
    acceleration =
        std::min(acceleration, kGravity * 0.5 * options_.post_check.insertion_tolerance / (lever * sideways));
  }
  return std::max({options_.mission.move_min_duration, kRestLineSpeedFactor * length / speed,
                   std::sqrt(kRestLineAccelerationFactor * length / acceleration)});
}

core::Result<bool> MissionPlanner::InsertionLeg(size_t i, bool places) {
  const MissionStep& step = task_.mission[i];
  const ToolGoal& tool = *step.reach_tool;
  const PlanningScene scene = Scene(false);
  QUADHAND_RETURN_IF_ERROR(RequireToolLink(i));
  const int tool_link = tool_link_;
  BoundaryState terminal;
  Task leg = LegTask();
  if (step.reach_state) {
    terminal = *step.reach_state;
  } else {
    TerminalStateOptions search = options_.terminal_state;
    search.clearance_tolerance = options_.post_check.clearance_tolerance;
    auto found = FindTerminalState(scene.robot, scene.collision, scene.exact, leg, tool, tool_link, search, solver_);
    if (!found.ok()) {
      if (found.status().code() != core::StatusCode::kInfeasible) return found.status();
      return Fail(i, PlanStatus::kTerminalStateFailed, found.status().message());
    }
    terminal = found->state;
  }
  terminal.yaw = state_.yaw + std::remainder(terminal.yaw - state_.yaw, 2.0 * M_PI);
  const Pose at_goal =
      robot::LinkPose(scene.robot, HoverPose(terminal.position, terminal.yaw), terminal.joints, tool_link);
  const double mismatch = (at_goal.translation() - tool.position).norm();
  if (mismatch > options_.post_check.position_tolerance) {
    return core::Status::InvalidArgument(task_.file + ": " + StepName(task_.mission, i) +
                                         core::Format(": the state puts the tool %.4f m from tool.position", mismatch));
  }
  const Vec3 back = tool.insertion_direction * tool.insertion_length;
  leg.terminal = AtRest(terminal.position - back, terminal.yaw, terminal.joints);
  auto transit = ReachLeg(i, leg, false);
  if (!transit.ok() || !*transit) return transit;
  const InsertionGoal line = InsertionOf(tool, tool_link);
  last_insertion_ = tool.insertion_direction;
  const double duration = LineDuration(at_goal.translation() - back, tool.insertion_direction, tool.insertion_length,
                                       std::nullopt);
  return RestLeg(i, terminal.position, duration, line, places);
}

core::Status MissionPlanner::Grasp(size_t i) {
  const MissionStep& step = task_.mission[i];
  QUADHAND_RETURN_IF_ERROR(RequireToolLink(i));
  // (Both in the target's frame at t = 0 when it moves: LinkForObjects.)
  const Pose tool = LinkForObjects(base_.robot(), tool_link_);
  if (!step.held_at_start) {
    // The task's check of the reach waits for the kinematics when the reach
    // before gives only a state: here the tool is where the plan put it.
    const double gap = DistanceToObjectSurface(step.object, tool.translation());
    if (gap > kGraspReach) {
      return core::Status::InvalidArgument(
          task_.file + ": " + StepName(task_.mission, i) +
          core::Format(": the object is not within reach of the tool: its surface is %.3f m from the tool's "
                       "position at this step (at most %.2f m)",
                       gap, kGraspReach));
    }
  }
  auto phase = PhaseAfterGrasp(base_, *phase_, task_, i, tool, options_.mission, with_target_);
  if (!phase.ok()) return phase.status();
  phase_ = std::make_shared<const Phase>(std::move(*phase));
  return core::Status::Ok();
}

core::Status MissionPlanner::Release(size_t i) {
  if (!phase_->held) return core::Status::Internal("release without a held object");
  const Pose object_pose = LinkAtState(phase_->context->robot(), phase_->object_link);
  auto phase = PhaseAfterRelease(base_, *phase_, task_, i, object_pose, options_.mission);
  if (!phase.ok()) return phase.status();
  phase_ = std::make_shared<const Phase>(std::move(*phase));
  return core::Status::Ok();
}

core::Status MissionPlanner::ChangePhase(size_t i) {
  const MissionStep& step = task_.mission[i];
  // What the new phase depends on: the phase before it, and where the
  // object is held (a grasp) or left (a release), to a nanometre.
  std::string key = phase_key_ + (step.kind == StepKind::kGrasp ? "g" : "r") + std::to_string(i) + ":";
  Pose pose = step.object.pose;
  if (step.kind == StepKind::kRelease) {
    pose = LinkAtState(phase_->context->robot(), phase_->object_link);
  } else if (!step.held_at_start) {
    const robot::RobotModel& robot = base_.robot();
    if (tool_link_ >= 0) pose = LinkForObjects(robot, tool_link_).inverse() * pose;
  }
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) key += core::Format("%.9f,", pose.matrix()(r, c));
  }
  if (cache_ != nullptr) {
    if (auto cached = cache_->impl().Find(&base_, key)) {
      phase_ = std::move(cached);
      phase_key_ = key;
      return core::Status::Ok();
    }
  }
  QUADHAND_RETURN_IF_ERROR(step.kind == StepKind::kGrasp ? Grasp(i) : Release(i));
  phase_key_ = key;
  if (cache_ != nullptr) cache_->impl().Keep(&base_, key, phase_);
  return core::Status::Ok();
}

core::Result<bool> MissionPlanner::PlanStep(size_t i) {
  const std::vector<MissionStep>& mission = task_.mission;
  const MissionStep& step = mission[i];
  switch (step.kind) {
    case StepKind::kReach: {
      // (A mission of one reach never comes here: it plans as its goal,
      // the insertion inside the optimised leg.)
      if (step.reach_tool && step.reach_tool->moving) return MovingReachLeg(i);
      with_target_ = false;  // a reach from a state moving with the target leaves it
      if (step.reach_tool && step.reach_tool->has_insertion) {
        const bool places = phase_->held && i + 1 < mission.size() && mission[i + 1].kind == StepKind::kRelease;
        return InsertionLeg(i, places);
      }
      Task leg = LegTask();
      leg.terminal = step.reach_state;
      leg.tool = step.reach_tool;
      return ReachLeg(i, leg, false);
    }
    case StepKind::kVia: {
      // Before a reach (or another via), a constraint of the reach's leg:
      // passed without stopping. Before anything else (a hover, a line, the
      // gripper, the mission's end) the robot has to be somewhere at rest,
      // and the via's point is the only place given: it ends there, yaw and
      // joints as they are.
      with_target_ = false;
      pending_vias_.push_back(i);
      if (i + 1 < mission.size() &&
          (mission[i + 1].kind == StepKind::kReach || mission[i + 1].kind == StepKind::kVia)) {
        return true;
      }
      pending_vias_.pop_back();
      Task leg = LegTask();
      leg.terminal = AtRest(step.via_position, state_.yaw, state_.joints);
      return ReachLeg(i, leg, false);
    }
    case StepKind::kMove: {
      const bool after_grasp_or_release =
          i > 0 && (mission[i - 1].kind == StepKind::kGrasp || mission[i - 1].kind == StepKind::kRelease);
      Vec3 direction;
      if (step.move_direction) {
        direction = *step.move_direction;
      } else if (with_target_ && moving_insertion_) {
        direction = -(TaskMotion().Displacement(Now()).linear() * *moving_insertion_);
      } else if (last_insertion_) {
        direction = -*last_insertion_;
      } else {
        return Fail(i, PlanStatus::kMissionStepInvalid,
                    "no direction given and no insertion before it to back out along");
      }
      const robot::RobotModel& robot = phase_->context->robot();
      QUADHAND_RETURN_IF_ERROR(RequireToolLink(i));
      const int tool_link = tool_link_;
      const Pose tool = LinkAtState(robot, tool_link);
      const double length = step.move_length;
      const double duration = LineDuration(tool.translation(), direction, length, step.move_max_speed);
      // The scene's bounds: the box of its points. A move is a short
      // straight line near what the robot handles; one that leaves the
      // scanned volume is a mistake in the task (a sign, a unit).
      Vec3 tool_end = tool.translation() + direction * step.move_length;
      if (with_target_) {
        // The line is drawn in the target's frame: where the tool ends
        // moves on with the target for the line's duration.
        const double now = Now();
        tool_end = TaskMotion().Displacement(now + duration) * (TaskMotion().Displacement(now).inverse() * tool_end);
      }
      const auto [scene_min, scene_max] = SceneBounds(base_.points());
      if ((tool_end.array() < scene_min.array()).any() || (tool_end.array() > scene_max.array()).any()) {
        if (with_target_) {
          // Where the target has gone by then is the planner's arrival, not
          // a mistake in the task.
          return Fail(i, PlanStatus::kMissionStepInvalid,
                      core::Format("the lift in the moving target's frame ends with the tool at (%.3f, %.3f, %.3f), "
                                   "outside the scene's bounds (%.3f, %.3f, %.3f) to (%.3f, %.3f, %.3f): the target "
                                   "leaves the scanned volume by then",
                                   tool_end.x(), tool_end.y(), tool_end.z(), scene_min.x(), scene_min.y(),
                                   scene_min.z(), scene_max.x(), scene_max.y(), scene_max.z()));
        }
        return core::Status::InvalidArgument(
            task_.file + ": " + StepName(mission, i) +
            core::Format(": the move ends with the tool at (%.3f, %.3f, %.3f), outside the scene's bounds "
                         "(%.3f, %.3f, %.3f) to (%.3f, %.3f, %.3f)",
                         tool_end.x(), tool_end.y(), tool_end.z(), scene_min.x(), scene_min.y(), scene_min.z(),
                         scene_max.x(), scene_max.y(), scene_max.z()));
      }
      InsertionGoal line;
      line.enabled = true;
      line.tool_link = tool_link;
      line.tool_position = tool.translation() + direction * length;
      line.tool_orientation = Quat(tool.linear());
      line.direction = direction;
      line.length = length;
      const bool relaxed = after_grasp_or_release && mission[i - 1].kind == StepKind::kGrasp;
      if (with_target_) {
        // A line in the target's frame (a lift off a moving belt), checked
        // there (the line given at t = 0); then to rest, unless a reach or a
        // via is next (it starts from the moving state).
        const Pose back = TaskMotion().Displacement(Now()).inverse();
        InsertionGoal at_zero = line;
        at_zero.tool_position = back * line.tool_position;
        at_zero.tool_orientation = Quat(back.linear() * line.tool_orientation.toRotationMatrix());
        at_zero.direction = back.linear() * line.direction;
        auto moved = FollowLeg(i, duration, direction * length, at_zero, relaxed);
        if (!moved.ok() || !*moved) return moved;
        const bool leg_next = i + 1 < mission.size() &&
                              (mission[i + 1].kind == StepKind::kReach || mission[i + 1].kind == StepKind::kVia);
        return leg_next ? moved : BrakeLeg(i);
      }
      return RestLeg(i, state_.position + direction * length, duration, line, relaxed);
    }
    case StepKind::kGrasp: {
      const auto phase_start = std::chrono::steady_clock::now();
      QUADHAND_RETURN_IF_ERROR(ChangePhase(i));
      result_.mission_phase_ms +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - phase_start).count();
      if (with_target_) return FollowLeg(i, step.close_time, Vec3::Zero(), InsertionGoal{}, true);
      return RestLeg(i, state_.position, step.close_time, InsertionGoal{}, true);
    }
    case StepKind::kRelease: {
      auto held = RestLeg(i, state_.position, step.open_time, InsertionGoal{}, true);
      if (!held.ok() || !*held) return held;
      const auto phase_start = std::chrono::steady_clock::now();
      QUADHAND_RETURN_IF_ERROR(ChangePhase(i));
      result_.mission_phase_ms +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - phase_start).count();
      return true;
    }
    case StepKind::kHold:
      return RestLeg(i, state_.position, step.hold_duration, InsertionGoal{}, false);
  }
  return core::Status::Internal("unknown step kind");
}

core::Result<PlanResult> MissionPlanner::Run() {
  state_ = task_.start;
  // Hovers and lines start at rest; only a reach (or a via) starts from a
  // moving state.
  const StepKind first_kind = task_.mission.front().kind;
  const bool moving = state_.velocity.norm() > 1e-9 || state_.acceleration.norm() > 1e-9 || state_.jerk.norm() > 1e-9 ||
                      std::abs(state_.yaw_rate) > 1e-9 ||
                      (state_.joint_rates.size() > 0 && state_.joint_rates.cwiseAbs().maxCoeff() > 1e-9);
  if (moving && first_kind != StepKind::kReach && first_kind != StepKind::kVia) {
    return core::Status::InvalidArgument(task_.file + ": " + StepName(task_.mission, 0) +
                                         ": a mission that does not begin with a reach or a via starts at rest "
                                         "(start velocity, acceleration and rates zero)");
  }
  result_.steps.resize(task_.mission.size());
  for (size_t i = 0; i < task_.mission.size(); ++i) result_.steps[i].kind = task_.mission[i].kind;
  phase_ = FirstPhase(base_);
  for (size_t i = 0; i < task_.mission.size(); ++i) {
    auto planned = PlanStep(i);
    if (!planned.ok()) return planned.status();
    if (!*planned) return std::move(result_);
  }
  result_.success = true;
  result_.status = PlanStatus::kSuccess;
  result_.message = "every step passed the post-check";
  return std::move(result_);
}

}  // namespace

core::Result<PlanResult> PlanTask(const PlanningContext& context, size_t representation, const PlannerOptions& options,
                                  const opt::Solver& solver) {
  return PlanTask(context, context.task(), representation, options, solver);
}

core::Result<PlanResult> PlanTask(const PlanningContext& context, const Task& task, size_t representation,
                                  const PlannerOptions& options, const opt::Solver& solver, MissionPhaseCache* cache) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("planner options: " + why);
  if (representation >= context.representations().size()) {
    return core::Status::InvalidArgument("no representation " + std::to_string(representation));
  }
  if (PlansAsGoal(task)) {
    auto result = Plan(context.Scene(representation), task, options, solver);
    if (!result.ok() || task.mission.empty()) return result;
    StepResult step;
    step.kind = task.mission[0].kind;
    step.planned = result->trajectory.has_value();
    step.end_s = result->trajectory ? result->trajectory->duration() : 0.0;
    step.min_clearance = result->post_check.min_clearance_exact;
    step.min_clearance_is_bound = result->post_check.min_clearance_exact_is_bound;
    step.certified = result->success && result->post_check.certified;
    result->steps = {step};
    return result;
  }
  return MissionPlanner(context, task, representation, options, solver, cache).Run();
}

class MissionReplay::Impl {
 public:
  Impl(const PlanningContext& base, const MissionPlanOptions& options) : base_(base), options_(options) {}

  const PlanningContext& base_;
  MissionPlanOptions options_;
  std::shared_ptr<const Phase> phase_;
  size_t next_grasp_ = 0;  // where the search for the next grasp step starts
  int tool_link_ = -1;
};

MissionReplay::MissionReplay(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
MissionReplay::~MissionReplay() = default;

core::Result<std::unique_ptr<MissionReplay>> MissionReplay::Start(const PlanningContext& context,
                                                                  const MissionPlanOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("mission options: " + why);
  auto impl = std::make_unique<Impl>(context, options);
  impl->tool_link_ = context.robot().LinkIndex(context.task().tool_link);
  impl->phase_ = FirstPhase(context);
  const Task& task = context.task();
  if (!task.mission.empty() && task.mission.front().kind == StepKind::kGrasp && task.mission.front().held_at_start) {
    auto phase = PhaseAfterGrasp(context, *impl->phase_, task, 0, Pose::Identity(), impl->options_);
    if (!phase.ok()) return phase.status();
    impl->phase_ = std::make_shared<const Phase>(std::move(*phase));
    impl->next_grasp_ = 1;
  }
  return std::unique_ptr<MissionReplay>(new MissionReplay(std::move(impl)));
}

core::Status MissionReplay::GripperClosed(const Pose& base, const VecX& joints, const Pose& target) {
  Impl& m = *impl_;
  const Task& task = m.base_.task();
  if (m.phase_->held) {
    return core::Status::InvalidArgument(task.file + ": the gripper closed again while holding the object of " +
                                         StepName(task.mission, m.phase_->held->grasp_step));
  }
  size_t i = m.next_grasp_;
  while (i < task.mission.size() && task.mission[i].kind != StepKind::kGrasp) ++i;
  if (i >= task.mission.size()) {
    return core::Status::InvalidArgument(task.file + ": the gripper closed, but the mission has no grasp left");
  }
  if (m.tool_link_ < 0) {
    return core::Status::InvalidArgument(task.file + ": the robot has no tool link '" + task.tool_link + "'");
  }
  Pose tool = robot::LinkPose(m.base_.robot(), base, joints, m.tool_link_);
  // The grasp after the moving reach takes the target's object, given (as
  // the tool is then put) in the target's frame at t = 0.
  const bool moving_object = i > 0 && task.mission[i - 1].reach_tool && task.mission[i - 1].reach_tool->moving;
  if (moving_object) tool = target.inverse() * tool;
  auto phase = PhaseAfterGrasp(m.base_, *m.phase_, task, i, tool, m.options_, moving_object);
  if (!phase.ok()) return phase.status();
  m.phase_ = std::make_shared<const Phase>(std::move(*phase));
  m.next_grasp_ = i + 1;
  return core::Status::Ok();
}

core::Status MissionReplay::GripperOpened(const Pose& base, const VecX& joints) {
  Impl& m = *impl_;
  if (!m.phase_->held) return core::Status::Ok();
  const Task& task = m.base_.task();
  const size_t grasp = m.phase_->held->grasp_step;
  size_t release = grasp;
  while (release < task.mission.size() && task.mission[release].kind != StepKind::kRelease) ++release;
  // The object is the phase robot's last link: where the tool holds it.
  const Pose object_pose = robot::LinkPose(m.phase_->context->robot(), base, joints, m.phase_->object_link);
  auto phase = PhaseAfterRelease(m.base_, *m.phase_, task, std::min(release, task.mission.size() - 1), object_pose,
                                 m.options_);
  if (!phase.ok()) return phase.status();
  m.phase_ = std::make_shared<const Phase>(std::move(*phase));
  return core::Status::Ok();
}

MissionReplay::Clearances MissionReplay::Measure(const Pose& base, const VecX& joints, double reach,
                                                 const Pose& target) const {
  const Phase& phase = *impl_->phase_;
  const robot::RobotModel& robot = phase.context->robot();
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(robot, base, joints, &kinematics);
  Clearances c;
  c.object = std::numeric_limits<double>::infinity();
  const MovingScene* moving = phase.context->moving_scene();
  const bool points_move = moving != nullptr && moving->has_points();
  if (!phase.held) {
    c.robot = StillAndMovingClearance(kinematics, phase.context->exact(), points_move ? moving->exact : nullptr, target,
                                      reach, &c.robot_link);
    return c;
  }
  c.robot = StillAndMovingClearance(kinematics, *phase.robot_only,
                                    points_move ? phase.moving_robot_only.get() : nullptr, target, reach,
                                    &c.robot_link);
  c.object = phase.object_only->LinkClearance(phase.object_link, kinematics.link_poses[phase.object_link], reach, {});
  if (points_move && phase.moving_object_only != nullptr) {
    const robot::KinematicsState moved = InTargetFrameAtZero(kinematics, target);
    c.object = std::min(c.object, phase.moving_object_only->LinkClearance(phase.object_link,
                                                                          moved.link_poses[phase.object_link], reach,
                                                                          {}));
  }
  return c;
}

const robot::RobotModel& MissionReplay::robot() const { return impl_->phase_->context->robot(); }

long MissionReplay::held_step() const {
  return impl_->phase_->held ? static_cast<long>(impl_->phase_->held->grasp_step) : -1;
}

}  // namespace quadhand::planner
