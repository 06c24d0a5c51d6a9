#include "quadhand/planner/task.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>

#include <yaml-cpp/yaml.h>

#include "quadhand/core/file_util.h"
#include "quadhand/core/text.h"
#include "quadhand/core/yaml_text.h"
#include "quadhand/scene/point_cloud.h"
#include "quadhand/scene/scans.h"

namespace quadhand::planner {
namespace {

// Errors carry "<file>: <key>: <problem>".
class Reader {
 public:
  // Messages name `file`; relative paths resolve against `base_dir`.
  Reader(std::string file, std::string base_dir) : file_(std::move(file)), base_dir_(std::move(base_dir)) {}

  core::Status Error(const std::string& key, const std::string& problem) const {
    return core::Status::InvalidArgument(file_ + ": " + (key.empty() ? "" : key + ": ") + problem);
  }

  core::Status CheckKeys(const YAML::Node& map, const std::string& where, const std::set<std::string>& allowed) const {
    if (!map.IsMap()) return Error(where, "expected a mapping");
    for (const auto& entry : map) {
      const std::string key = entry.first.as<std::string>();
      if (allowed.count(key) == 0) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        return Error(where.empty() ? key : where + "." + key, "unknown key (expected one of: " + list + ")");
      }
    }
    return core::Status::Ok();
  }

  core::Status Number(const YAML::Node& node, const std::string& key, double* out) const {
    if (!node || !node.IsScalar()) return Error(key, "expected a number");
    try {
      *out = node.as<double>();
    } catch (const YAML::Exception&) {
      return Error(key, "expected a number, got '" + node.Scalar() + "'");
    }
    if (!std::isfinite(*out)) return Error(key, "must be a finite number");
    return core::Status::Ok();
  }

  // `true` or `false`, nothing else (YAML's yes/on/1 are refused as typos).
  core::Status Bool(const YAML::Node& node, const std::string& key, bool* out) const {
    if (!node || !node.IsScalar() || (node.Scalar() != "true" && node.Scalar() != "false")) {
      return Error(key, "expected true or false");
    }
    *out = node.Scalar() == "true";
    return core::Status::Ok();
  }

  core::Status Vector(const YAML::Node& node, const std::string& key, int size, VecX* out) const {
    if (!node || !node.IsSequence()) return Error(key, "expected a list of numbers");
    if (size >= 0 && static_cast<int>(node.size()) != size) {
      return Error(key, "expected " + std::to_string(size) + " numbers, got " + std::to_string(node.size()));
    }
    out->resize(static_cast<Eigen::Index>(node.size()));
    for (size_t i = 0; i < node.size(); ++i) {
      QUADHAND_RETURN_IF_ERROR(Number(node[i], key + "[" + std::to_string(i) + "]", &(*out)[i]));
    }
    return core::Status::Ok();
  }

  core::Status Vector3(const YAML::Node& node, const std::string& key, Vec3* out) const {
    VecX v;
    QUADHAND_RETURN_IF_ERROR(Vector(node, key, 3, &v));
    *out = v;
    return core::Status::Ok();
  }

  core::Status Path(const YAML::Node& node, const std::string& key, std::string* out) const {
    if (!node || !node.IsScalar() || node.Scalar().empty()) return Error(key, "expected a file or folder path");
    *out = core::ResolvePath(base_dir_, node.Scalar());
    return core::Status::Ok();
  }

 private:
  std::string file_;
  std::string base_dir_;
};

constexpr double kMaxYaw = 1000.0;

core::Status ReadState(const Reader& r, const YAML::Node& node, const std::string& where, bool with_rates,
                       BoundaryState* state) {
  QUADHAND_RETURN_IF_ERROR(r.Vector3(node["position"], where + ".position", &state->position));
  if (with_rates && node["velocity"]) QUADHAND_RETURN_IF_ERROR(r.Vector3(node["velocity"], where + ".velocity", &state->velocity));
  if (with_rates && node["acceleration"]) {
    QUADHAND_RETURN_IF_ERROR(r.Vector3(node["acceleration"], where + ".acceleration", &state->acceleration));
  }
  QUADHAND_RETURN_IF_ERROR(r.Number(node["yaw"], where + ".yaw", &state->yaw));
  // Beyond this a yaw is a typo, and the terminal yaw, unwrapped next to the
  // start's, would lose its precision.
  if (std::abs(state->yaw) > kMaxYaw) return r.Error(where + ".yaw", "must be within +-1000 rad");
  QUADHAND_RETURN_IF_ERROR(r.Vector(node["joints"], where + ".joints", -1, &state->joints));
  return core::Status::Ok();
}

core::Status ReadUnitQuaternion(const Reader& r, const YAML::Node& node, const std::string& key, Quat* out) {
  VecX q;
  QUADHAND_RETURN_IF_ERROR(r.Vector(node, key, 4, &q));
  if (std::abs(q.norm() - 1.0) > 1e-3) {
    return r.Error(key, "expected a unit quaternion [w, x, y, z] (norm " + std::to_string(q.norm()) + ")");
  }
  *out = Quat(q[0], q[1], q[2], q[3]).normalized();
  return core::Status::Ok();
}

core::Status ReadPose(const Reader& r, const YAML::Node& node, const std::string& key, Pose* pose) {
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys(node, key, {"position", "orientation"}));
  Vec3 position;
  Quat orientation;
  QUADHAND_RETURN_IF_ERROR(r.Vector3(node["position"], key + ".position", &position));
  QUADHAND_RETURN_IF_ERROR(ReadUnitQuaternion(r, node["orientation"], key + ".orientation", &orientation));
  *pose = MakePose(position, orientation.toRotationMatrix());
  return core::Status::Ok();
}

core::Status ReadTopic(const Reader& r, const YAML::Node& node, const std::string& key, std::string* out) {
  if (!node || !node.IsScalar() || node.Scalar().empty()) return r.Error(key, "expected a ROS topic or frame name");
  *out = node.Scalar();
  return core::Status::Ok();
}

// A scene entry {bag, cloud_topic, odom_topic | world_frame, extrinsic,
// max_pose_gap} (docs/task_format.md, "Recorded clouds in a ROS 1 bag").
core::Status ReadBagScan(const Reader& r, const YAML::Node& entry, const std::string& key, scene::ScanSource* source) {
  scene::BagCloudSource bag;
  QUADHAND_RETURN_IF_ERROR(r.Path(entry["bag"], key + ".bag", &bag.path));
  QUADHAND_RETURN_IF_ERROR(ReadTopic(r, entry["cloud_topic"], key + ".cloud_topic", &bag.cloud_topic));
  if (entry["odom_topic"] && entry["world_frame"]) {
    return r.Error(key, "odom_topic and world_frame are two ways to place the clouds: give one");
  }
  if (entry["odom_topic"]) {
    QUADHAND_RETURN_IF_ERROR(ReadTopic(r, entry["odom_topic"], key + ".odom_topic", &bag.odom_topic));
  } else if (entry["world_frame"]) {
    QUADHAND_RETURN_IF_ERROR(ReadTopic(r, entry["world_frame"], key + ".world_frame", &bag.world_frame));
  }
  if (const YAML::Node extrinsic = entry["extrinsic"]) {
    if (bag.odom_topic.empty()) return r.Error(key + ".extrinsic", "is only used with odom_topic (/tf gives the sensor's frame)");
    QUADHAND_RETURN_IF_ERROR(ReadPose(r, extrinsic, key + ".extrinsic", &bag.extrinsic));
  }
  if (entry["max_pose_gap"]) {
    QUADHAND_RETURN_IF_ERROR(r.Number(entry["max_pose_gap"], key + ".max_pose_gap", &bag.max_pose_gap));
    if (!(bag.max_pose_gap > 0.0)) return r.Error(key + ".max_pose_gap", "must be > 0 s");
  }
  if (entry["skip_unusable"]) {
    QUADHAND_RETURN_IF_ERROR(r.Bool(entry["skip_unusable"], key + ".skip_unusable", &source->skip_unusable_clouds));
  }
  source->path = bag.path;
  source->bag = std::move(bag);
  return core::Status::Ok();
}

// scene: a path, or a list of {file, pose, crop, voxel} (contracts.md),
// {bag, cloud_topic, ...} or {frames, skip_unusable, crop, voxel}.
core::Status ReadScene(const Reader& r, const YAML::Node& node, Task* task) {
  if (node.IsScalar()) {
    scene::ScanSource source;
    QUADHAND_RETURN_IF_ERROR(r.Path(node, "scene", &source.path));
    task->scans = {source};
    task->scene_path = source.path;
    return core::Status::Ok();
  }
  if (!node.IsSequence() || node.size() == 0) {
    return r.Error("scene",
                   "expected a point cloud path or a list of scans ({file, pose, crop, voxel}, {bag, ...} or {frames, ...})");
  }
  task->scans.clear();
  for (size_t i = 0; i < node.size(); ++i) {
    const std::string key = "scene[" + std::to_string(i) + "]";
    const YAML::Node entry = node[i];
    scene::ScanSource source;
    if (entry.IsMap() && entry["bag"]) {
      QUADHAND_RETURN_IF_ERROR(r.CheckKeys(entry, key, {"bag", "cloud_topic", "odom_topic", "extrinsic", "world_frame",
                                                        "max_pose_gap", "skip_unusable", "crop", "voxel"}));
      QUADHAND_RETURN_IF_ERROR(ReadBagScan(r, entry, key, &source));
    } else if (entry.IsMap() && entry["frames"]) {
      QUADHAND_RETURN_IF_ERROR(r.CheckKeys(entry, key, {"frames", "skip_unusable", "crop", "voxel"}));
      QUADHAND_RETURN_IF_ERROR(r.Path(entry["frames"], key + ".frames", &source.path));
      source.frame_folder = true;
      if (entry["skip_unusable"]) {
        QUADHAND_RETURN_IF_ERROR(r.Bool(entry["skip_unusable"], key + ".skip_unusable", &source.skip_unusable_clouds));
      }
    } else {
      QUADHAND_RETURN_IF_ERROR(r.CheckKeys(entry, key, {"file", "pose", "crop", "voxel"}));
      QUADHAND_RETURN_IF_ERROR(r.Path(entry["file"], key + ".file", &source.path));
      if (const YAML::Node pose = entry["pose"]) {
        QUADHAND_RETURN_IF_ERROR(ReadPose(r, pose, key + ".pose", &source.sensor_to_world));
      }
    }
    if (const YAML::Node crop = entry["crop"]) {
      QUADHAND_RETURN_IF_ERROR(r.CheckKeys(crop, key + ".crop", {"min", "max"}));
      scene::CropBox box;
      QUADHAND_RETURN_IF_ERROR(r.Vector3(crop["min"], key + ".crop.min", &box.min));
      QUADHAND_RETURN_IF_ERROR(r.Vector3(crop["max"], key + ".crop.max", &box.max));
      if (!(box.min.array() < box.max.array()).all()) return r.Error(key + ".crop", "min must be below max on every axis");
      source.crop = box;
    }
    if (entry["voxel"]) {
      QUADHAND_RETURN_IF_ERROR(r.Number(entry["voxel"], key + ".voxel", &source.voxel));
      if (!(source.voxel > 0.0)) return r.Error(key + ".voxel", "must be a positive leaf size in metres");
    }
    task->scans.push_back(source);
  }
  task->scene_path = task->scans.front().path;
  return core::Status::Ok();
}

// goal.tool.motion and goal.tool.max_relative_speed (contracts.md 0.3):
// a constant motion or a path file, and the box of scene points moving with
// the target.
core::Status ReadMotion(const Reader& r, const YAML::Node& tool_node, const std::string& where, ToolGoal* tool) {
  const YAML::Node node = tool_node["motion"];
  const std::string key = where + ".motion";
  QUADHAND_RETURN_IF_ERROR(
      r.CheckKeys(node, key, {"velocity", "acceleration", "yaw_rate", "file", "moving_points"}));
  MovingTarget moving;
  if (node["file"]) {
    for (const char* constant : {"velocity", "acceleration", "yaw_rate"}) {
      if (node[constant]) {
        return r.Error(key + "." + constant, "give a constant motion (velocity, acceleration, yaw_rate) or a file, not both");
      }
    }
    QUADHAND_RETURN_IF_ERROR(r.Path(node["file"], key + ".file", &moving.path_file));
    auto text = core::ReadFileToString(moving.path_file);
    if (!text.ok()) return r.Error(key + ".file", text.status().message());
    auto path = ParseTargetPath(*text, moving.path_file);
    if (!path.ok()) return r.Error(key + ".file", path.status().message());
    moving.motion = TargetMotion::Sampled(std::move(*path));
  } else {
    if (!node["velocity"]) return r.Error(key + ".velocity", "missing (m/s, world frame; or give a path file)");
    Vec3 velocity = Vec3::Zero(), acceleration = Vec3::Zero();
    double yaw_rate = 0.0;
    QUADHAND_RETURN_IF_ERROR(r.Vector3(node["velocity"], key + ".velocity", &velocity));
    if (node["acceleration"]) {
      QUADHAND_RETURN_IF_ERROR(r.Vector3(node["acceleration"], key + ".acceleration", &acceleration));
    }
    if (node["yaw_rate"]) QUADHAND_RETURN_IF_ERROR(r.Number(node["yaw_rate"], key + ".yaw_rate", &yaw_rate));
    moving.motion = TargetMotion::Constant(tool->position, velocity, acceleration, yaw_rate);
  }
  if (const YAML::Node box = node["moving_points"]) {
    QUADHAND_RETURN_IF_ERROR(r.CheckKeys(box, key + ".moving_points", {"min", "max"}));
    TargetBox moving_box;
    QUADHAND_RETURN_IF_ERROR(r.Vector3(box["min"], key + ".moving_points.min", &moving_box.min));
    QUADHAND_RETURN_IF_ERROR(r.Vector3(box["max"], key + ".moving_points.max", &moving_box.max));
    if (!(moving_box.min.array() <= moving_box.max.array()).all()) {
      return r.Error(key + ".moving_points", "not a box: min must not exceed max on any axis");
    }
    moving.moving_box = moving_box;
  }
  if (const YAML::Node speed = tool_node["max_relative_speed"]) {
    double value = 0.0;
    QUADHAND_RETURN_IF_ERROR(r.Number(speed, where + ".max_relative_speed", &value));
    if (!(value > 0.0)) return r.Error(where + ".max_relative_speed", "must be a positive speed in m/s");
    moving.max_relative_speed = value;
  }
  tool->moving = std::move(moving);
  return core::Status::Ok();
}

core::Status ReadTool(const Reader& r, const YAML::Node& node, const std::string& where, ToolGoal* tool) {
  QUADHAND_RETURN_IF_ERROR(
      r.CheckKeys(node, where, {"position", "orientation", "insertion", "motion", "max_relative_speed"}));
  QUADHAND_RETURN_IF_ERROR(r.Vector3(node["position"], where + ".position", &tool->position));
  QUADHAND_RETURN_IF_ERROR(ReadUnitQuaternion(r, node["orientation"], where + ".orientation", &tool->orientation));
  if (const YAML::Node insertion = node["insertion"]) {
    QUADHAND_RETURN_IF_ERROR(r.CheckKeys(insertion, where + ".insertion", {"direction", "length"}));
    QUADHAND_RETURN_IF_ERROR(r.Vector3(insertion["direction"], where + ".insertion.direction", &tool->insertion_direction));
    QUADHAND_RETURN_IF_ERROR(r.Number(insertion["length"], where + ".insertion.length", &tool->insertion_length));
    if (tool->insertion_direction.norm() < 1e-9) return r.Error(where + ".insertion.direction", "must not be zero");
    if (!(tool->insertion_length > 0.0 && tool->insertion_length <= 10.0)) {
      return r.Error(where + ".insertion.length", "must be in (0, 10] m");
    }
    tool->insertion_direction.normalize();
    tool->has_insertion = true;
  }
  if (node["motion"]) {
    QUADHAND_RETURN_IF_ERROR(ReadMotion(r, node, where, tool));
  } else if (node["max_relative_speed"]) {
    return r.Error(where + ".max_relative_speed", "given for a target that does not move (no motion)");
  }
  return core::Status::Ok();
}

// The keys of `goal` (or of a `reach` step): a terminal state and/or a tool pose.
core::Status ReadGoal(const Reader& r, const YAML::Node& node, const std::string& where,
                      std::optional<BoundaryState>* terminal, std::optional<ToolGoal>* tool) {
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys(node, where, {"position", "yaw", "joints", "tool"}));
  if (node["position"] || node["yaw"] || node["joints"]) {
    BoundaryState state;
    QUADHAND_RETURN_IF_ERROR(ReadState(r, node, where, false, &state));
    *terminal = state;
  }
  if (node["tool"]) {
    ToolGoal goal;
    QUADHAND_RETURN_IF_ERROR(ReadTool(r, node["tool"], where + ".tool", &goal));
    *tool = goal;
  }
  if (!*terminal && !*tool) return r.Error(where, "needs a terminal state (position, yaw, joints) or a tool pose");
  if (*terminal && *tool && (*tool)->moving) {
    return r.Error(where, "a moving target's terminal state follows the target and is found by the planner: give "
                          "only the tool pose (no position, yaw or joints)");
  }
  return core::Status::Ok();
}

// A number of a step in [low, high].
core::Status ReadRanged(const Reader& r, const YAML::Node& node, const std::string& key, double low, double high,
                        const char* range, double* out) {
  QUADHAND_RETURN_IF_ERROR(r.Number(node, key, out));
  if (!(*out >= low && *out <= high)) return r.Error(key, std::string("must be ") + range);
  return core::Status::Ok();
}

core::Status ReadObject(const Reader& r, const YAML::Node& node, const std::string& where, MissionObject* object) {
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys(node, where, {"shape", "pose", "mass"}));
  const YAML::Node shape = node["shape"];
  const std::string shape_key = where + ".shape";
  if (!shape || !shape.IsMap() || shape.size() != 1) {
    return r.Error(shape_key, "expected one of {box: {size: [x, y, z]}}, {cylinder: {radius, length}}, "
                              "{sphere: {radius}}, {mesh: path}");
  }
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys(shape, shape_key, {"box", "cylinder", "sphere", "mesh"}));
  ObjectShape& s = object->shape;
  constexpr double kMaxSize = 5.0;  // m: beyond it an object is a typo or a unit mix-up
  if (const YAML::Node box = shape["box"]) {
    s.kind = ObjectShape::Kind::kBox;
    QUADHAND_RETURN_IF_ERROR(r.CheckKeys(box, shape_key + ".box", {"size"}));
    QUADHAND_RETURN_IF_ERROR(r.Vector3(box["size"], shape_key + ".box.size", &s.box_size));
    if (!(s.box_size.minCoeff() > 0.0 && s.box_size.maxCoeff() <= kMaxSize)) {
      return r.Error(shape_key + ".box.size", "every edge must be in (0, 5] m");
    }
  } else if (const YAML::Node cylinder = shape["cylinder"]) {
    s.kind = ObjectShape::Kind::kCylinder;
    QUADHAND_RETURN_IF_ERROR(r.CheckKeys(cylinder, shape_key + ".cylinder", {"radius", "length"}));
    QUADHAND_RETURN_IF_ERROR(ReadRanged(r, cylinder["radius"], shape_key + ".cylinder.radius", 1e-6, kMaxSize,
                                        "in (0, 5] m", &s.radius));
    QUADHAND_RETURN_IF_ERROR(ReadRanged(r, cylinder["length"], shape_key + ".cylinder.length", 1e-6, kMaxSize,
                                        "in (0, 5] m", &s.length));
  } else if (const YAML::Node sphere = shape["sphere"]) {
    s.kind = ObjectShape::Kind::kSphere;
    QUADHAND_RETURN_IF_ERROR(r.CheckKeys(sphere, shape_key + ".sphere", {"radius"}));
    QUADHAND_RETURN_IF_ERROR(ReadRanged(r, sphere["radius"], shape_key + ".sphere.radius", 1e-6, kMaxSize,
                                        "in (0, 5] m", &s.radius));
  } else {
    s.kind = ObjectShape::Kind::kMesh;
    QUADHAND_RETURN_IF_ERROR(r.Path(shape["mesh"], shape_key + ".mesh", &s.mesh_path));
  }
  const YAML::Node pose = node["pose"];
  if (!pose) return r.Error(where + ".pose", "missing (the object's pose at the grasp: {position, orientation})");
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys(pose, where + ".pose", {"position", "orientation"}));
  Vec3 position;
  Quat orientation;
  QUADHAND_RETURN_IF_ERROR(r.Vector3(pose["position"], where + ".pose.position", &position));
  QUADHAND_RETURN_IF_ERROR(ReadUnitQuaternion(r, pose["orientation"], where + ".pose.orientation", &orientation));
  object->pose = MakePose(position, orientation.toRotationMatrix());
  if (node["mass"]) {
    // The robot's payload limit is checked with the robot (planner
    // configuration); this range only catches typos and unit mix-ups.
    QUADHAND_RETURN_IF_ERROR(ReadRanged(r, node["mass"], where + ".mass", 0.0, 100.0, "in [0, 100] kg", &object->mass));
  }
  return core::Status::Ok();
}

// The step's one key is its kind; its value holds the step's keys.
core::Status ReadStep(const Reader& r, const YAML::Node& node, size_t index, std::vector<MissionStep>* mission) {
  const std::string at = "mission[" + std::to_string(index) + "]";
  static const std::map<std::string, StepKind> kKinds = {{"reach", StepKind::kReach}, {"move", StepKind::kMove},
                                                         {"via", StepKind::kVia},     {"grasp", StepKind::kGrasp},
                                                         {"release", StepKind::kRelease}, {"hold", StepKind::kHold}};
  if (!node.IsMap() || node.size() != 1) {
    return r.Error(at, "expected one step kind as the only key (reach, move, via, grasp, release or hold)");
  }
  const std::string kind_name = node.begin()->first.as<std::string>();
  const auto kind = kKinds.find(kind_name);
  if (kind == kKinds.end()) {
    return r.Error(at, "unknown step kind '" + kind_name + "' (expected reach, move, via, grasp, release or hold)");
  }
  const std::string where = at + "." + kind_name;
  const YAML::Node body = node.begin()->second;
  MissionStep step;
  step.kind = kind->second;
  // A step with nothing to give (a release with its default time) may be
  // written `- release: {}` or `- release:`.
  const bool empty_body = !body || body.IsNull();
  if (!empty_body && !body.IsMap()) return r.Error(where, "expected a mapping of the step's keys");
  const YAML::Node keys = empty_body ? YAML::Node(YAML::NodeType::Map) : body;

  // What is held before this step: the open grasp, if any.
  constexpr size_t kNothing = static_cast<size_t>(-1);
  size_t held = kNothing;
  for (size_t i = 0; i < mission->size(); ++i) {
    if ((*mission)[i].kind == StepKind::kGrasp) held = i;
    if ((*mission)[i].kind == StepKind::kRelease) held = kNothing;
  }
  const StepKind previous = mission->empty() ? StepKind::kHold : mission->back().kind;

  switch (step.kind) {
    case StepKind::kReach:
      QUADHAND_RETURN_IF_ERROR(ReadGoal(r, keys, where, &step.reach_state, &step.reach_tool));
      break;
    case StepKind::kMove: {
      QUADHAND_RETURN_IF_ERROR(r.CheckKeys(keys, where, {"direction", "length", "max_speed"}));
      if (!keys["length"]) return r.Error(where + ".length", "missing (the tool line's length, m)");
      QUADHAND_RETURN_IF_ERROR(r.Number(keys["length"], where + ".length", &step.move_length));
      if (!(step.move_length > 0.0)) return r.Error(where + ".length", "must be positive (a zero or negative move)");
      if (step.move_length > 10.0) return r.Error(where + ".length", "must be at most 10 m");
      if (keys["direction"]) {
        Vec3 direction;
        QUADHAND_RETURN_IF_ERROR(r.Vector3(keys["direction"], where + ".direction", &direction));
        if (direction.norm() < 1e-9) return r.Error(where + ".direction", "must not be zero");
        step.move_direction = direction.normalized();
      } else if (previous != StepKind::kGrasp && previous != StepKind::kRelease) {
        return r.Error(where + ".direction",
                       "missing: it may be left out only right after a grasp or a release (the tool then backs out "
                       "along the insertion)");
      }
      if (keys["max_speed"]) {
        double speed = 0.0;
        QUADHAND_RETURN_IF_ERROR(ReadRanged(r, keys["max_speed"], where + ".max_speed", 1e-3, 100.0,
                                            "in [0.001, 100] m/s", &speed));
        step.move_max_speed = speed;
      }
      break;
    }
    case StepKind::kVia:
      QUADHAND_RETURN_IF_ERROR(r.CheckKeys(keys, where, {"position", "tolerance"}));
      QUADHAND_RETURN_IF_ERROR(r.Vector3(keys["position"], where + ".position", &step.via_position));
      if (keys["tolerance"]) {
        QUADHAND_RETURN_IF_ERROR(ReadRanged(r, keys["tolerance"], where + ".tolerance", 1e-3, 1.0, "in [0.001, 1] m",
                                            &step.via_tolerance));
      }
      break;
    case StepKind::kGrasp:
      QUADHAND_RETURN_IF_ERROR(r.CheckKeys(keys, where, {"object", "scene_margin", "close_time"}));
      if (held != kNothing) {
        return r.Error(where, "a second grasp while the object of " + StepName(*mission, held) +
                                  " is held (release it first)");
      }
      if (!keys["object"]) return r.Error(where + ".object", "missing (shape, pose and mass of what is grasped)");
      QUADHAND_RETURN_IF_ERROR(ReadObject(r, keys["object"], where + ".object", &step.object));
      if (keys["scene_margin"]) {
        QUADHAND_RETURN_IF_ERROR(ReadRanged(r, keys["scene_margin"], where + ".scene_margin", 0.0, 0.5, "in [0, 0.5] m",
                                            &step.scene_margin));
      }
      if (keys["close_time"]) {
        QUADHAND_RETURN_IF_ERROR(ReadRanged(r, keys["close_time"], where + ".close_time", 0.0, 60.0, "in [0, 60] s",
                                            &step.close_time));
      }
      step.held_at_start = mission->empty();
      break;
    case StepKind::kRelease:
      QUADHAND_RETURN_IF_ERROR(r.CheckKeys(keys, where, {"open_time"}));
      if (held == kNothing) return r.Error(where, "nothing is held (no grasp before it, or its object was released already)");
      if (keys["open_time"]) {
        QUADHAND_RETURN_IF_ERROR(ReadRanged(r, keys["open_time"], where + ".open_time", 0.0, 60.0, "in [0, 60] s",
                                            &step.open_time));
      }
      break;
    case StepKind::kHold:
      QUADHAND_RETURN_IF_ERROR(r.CheckKeys(keys, where, {"duration"}));
      if (!keys["duration"]) return r.Error(where + ".duration", "missing (s)");
      QUADHAND_RETURN_IF_ERROR(ReadRanged(r, keys["duration"], where + ".duration", 1e-3, 3600.0, "in [0.001, 3600] s",
                                          &step.hold_duration));
      break;
  }
  mission->push_back(step);
  return core::Status::Ok();
}

// The tool's position where step `index` acts, when the mission's steps
// give it without the robot: the last reach's tool pose, moved by the moves
// after it. None when a reach gives only a whole-body state (then the robot's
// kinematics tell, and the check waits for them).
std::optional<Vec3> ToolPositionBefore(const std::vector<MissionStep>& mission, size_t index) {
  std::optional<Vec3> tool;
  for (size_t i = 0; i < index; ++i) {
    const MissionStep& step = mission[i];
    if (step.kind == StepKind::kReach) {
      tool.reset();
      if (step.reach_tool) tool = step.reach_tool->position;
    } else if (step.kind == StepKind::kMove && tool) {
      if (!step.move_direction) return std::nullopt;
      *tool += step.move_length * *step.move_direction;
    } else if (step.kind == StepKind::kVia) {
      return std::nullopt;
    }
  }
  return tool;
}

core::Status ReadMission(const Reader& r, const YAML::Node& node, std::vector<MissionStep>* mission) {
  if (!node.IsSequence() || node.size() == 0) return r.Error("mission", "expected a non-empty list of steps");
  for (size_t i = 0; i < node.size(); ++i) QUADHAND_RETURN_IF_ERROR(ReadStep(r, node[i], i, mission));
  for (size_t i = 0; i < mission->size(); ++i) {
    const MissionStep& step = (*mission)[i];
    if (step.kind != StepKind::kGrasp || step.held_at_start) continue;
    const std::optional<Vec3> tool = ToolPositionBefore(*mission, i);
    if (!tool) continue;
    const double gap = DistanceToObjectSurface(step.object, *tool);
    if (gap > kGraspReach) {
      return r.Error(StepName(*mission, i), core::Format("the object is not within reach of the tool: its surface is "
                                                         "%.3f m from the tool's position at this step (at most %.2f m)",
                                                         gap, kGraspReach));
    }
  }
  // A move without a direction backs out along an insertion: the reach
  // before its grasp or release must have one.
  for (size_t i = 0; i < mission->size(); ++i) {
    const MissionStep& step = (*mission)[i];
    if (step.kind != StepKind::kMove || step.move_direction) continue;
    bool found = false;
    for (size_t j = i; j-- > 0;) {
      const MissionStep& before = (*mission)[j];
      if (before.kind == StepKind::kReach) {
        found = before.reach_tool && before.reach_tool->has_insertion;
        break;
      }
      if (before.kind == StepKind::kMove || before.kind == StepKind::kVia) break;
    }
    if (!found) {
      return r.Error("mission[" + std::to_string(i) + "].move.direction",
                     "missing, and no insertion to back out along (the reach before the grasp or release has no "
                     "tool insertion): give a direction");
    }
  }
  return core::Status::Ok();
}

// A path key of the task, optional where the caller supplies it instead.
core::Status ReadSource(const Reader& r, const YAML::Node& root, const char* key, bool supplied, std::string* out) {
  if (supplied && !root[key]) return core::Status::Ok();
  return r.Path(root[key], key, out);
}

core::Result<Task> ParseTask(const std::string& name, const std::string& base_dir, const YAML::Node& root,
                             const TaskSources& sources) {
  const Reader r(name, base_dir);
  Task task;
  task.file = name;
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys(root, "", {"robot", "sdf_dir", "scene", "start", "goal", "mission", "limits",
                                                  "safety_distance", "tool_link", "self_safety_distance", "srdf"}));
  QUADHAND_RETURN_IF_ERROR(ReadSource(r, root, "robot", sources.robot_given, &task.robot_path));
  QUADHAND_RETURN_IF_ERROR(ReadSource(r, root, "sdf_dir", sources.robot_given, &task.sdf_dir));
  if (!sources.scene_given || root["scene"]) {
    if (!root["scene"]) return r.Error("scene", "expected a point cloud path or a list of scans ({file, pose, crop, voxel})");
    QUADHAND_RETURN_IF_ERROR(ReadScene(r, root["scene"], &task));
  }

  const YAML::Node start = root["start"];
  if (!start) return r.Error("start", "missing");
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys(start, "start", {"position", "velocity", "acceleration", "yaw", "joints"}));
  QUADHAND_RETURN_IF_ERROR(ReadState(r, start, "start", true, &task.start));

  const YAML::Node goal = root["goal"];
  const YAML::Node mission = root["mission"];
  if (goal && mission) return r.Error("mission", "a task has goal or mission, not both");
  if (!goal && !mission) return r.Error("goal", "missing (a goal, or a mission: a list of steps)");
  if (goal) QUADHAND_RETURN_IF_ERROR(ReadGoal(r, goal, "goal", &task.terminal, &task.tool));
  std::optional<size_t> moving_reach;  // a longer mission's moving reach
  if (mission) {
    QUADHAND_RETURN_IF_ERROR(ReadMission(r, mission, &task.mission));
    // A mission of one reach is that goal (contracts.md).
    if (task.mission.size() == 1 && task.mission[0].kind == StepKind::kReach) {
      task.terminal = task.mission[0].reach_state;
      task.tool = task.mission[0].reach_tool;
    } else {
      // A longer mission's moving target (docs/moving_targets.md, "In a
      // mission"): one, reached with nothing held, then grasped or the end.
      bool holding = false;
      const std::vector<MissionStep>& steps = task.mission;
      for (size_t i = 0; i < steps.size(); ++i) {
        const MissionStep& step = steps[i];
        if (step.kind == StepKind::kGrasp) holding = true;
        if (step.kind == StepKind::kRelease) holding = false;
        if (!(step.reach_tool && step.reach_tool->moving)) continue;
        auto key_of = [](size_t k, StepKind kind) {
          return "mission[" + std::to_string(k) + "]." + StepKindName(kind);
        };
        const std::string key = key_of(i, step.kind) + ".tool.motion";
        if (moving_reach) {
          return r.Error(key, "a mission has one moving target at most; " + StepName(steps, *moving_reach) +
                                  " moves already");
        }
        if (holding) {
          return r.Error(key, "a moving reach while an object is held (placing it onto a moving target) is not "
                              "supported (docs/moving_targets.md)");
        }
        if (i + 1 < steps.size() && steps[i + 1].kind != StepKind::kGrasp) {
          return r.Error(key, "a moving reach is followed by a grasp, or ends the mission; " +
                                  StepName(steps, i + 1) + " is not a grasp (docs/moving_targets.md)");
        }
        if (i + 1 < steps.size()) {
          // Named: the step after the grasp, or the grasp when nothing follows.
          const size_t after = std::min(i + 2, steps.size() - 1);
          const StepKind kind = steps[after].kind;
          if (after == i + 1 || (kind != StepKind::kMove && kind != StepKind::kReach && kind != StepKind::kVia)) {
            return r.Error("mission[" + std::to_string(after) + "]",
                           "after the grasp of a moving target the vehicle moves with it: the step after the grasp "
                           "is a move (a lift in the target's frame), a reach or a via (docs/moving_targets.md)");
          }
          const MissionStep& grasp = steps[i + 1];
          const std::optional<TargetBox>& box = step.reach_tool->moving->moving_box;
          if (box && !box->Contains(grasp.object.pose.translation())) {
            return r.Error(key_of(i + 1, StepKind::kGrasp) + ".object.pose",
                           "the object of a moving target moves with it: its pose (at t = 0, as the target's) "
                           "must lie inside " + key + ".moving_points");
          }
        }
        moving_reach = i;
      }
    }
  }

  if (const YAML::Node limits = root["limits"]) {
    QUADHAND_RETURN_IF_ERROR(r.CheckKeys(limits, "limits", {"v_max", "a_max", "yaw_rate_max", "body_rate_xy_max"}));
    // The ranges hold every multirotor from a slow indoor one to a racing
    // one (tens of m/s, several g, ~30 rad/s); outside them a value is a
    // typo or a unit mix-up, and would only make a plan fail after seconds.
    struct Field {
      const char* key;
      double* value;
      double low, high;
      const char* range;
    };
    const Field fields[] = {{"v_max", &task.limits.v_max, 0.01, 100.0, "in [0.01, 100] m/s"},
                            {"a_max", &task.limits.a_max, 0.01, 200.0, "in [0.01, 200] m/s^2"},
                            {"yaw_rate_max", &task.limits.yaw_rate_max, 0.01, 50.0, "in [0.01, 50] rad/s"},
                            {"body_rate_xy_max", &task.limits.body_rate_xy_max, 0.01, 50.0, "in [0.01, 50] rad/s"}};
    for (const Field& field : fields) {
      if (!limits[field.key]) continue;
      const std::string key = std::string("limits.") + field.key;
      QUADHAND_RETURN_IF_ERROR(r.Number(limits[field.key], key, field.value));
      if (!(*field.value >= field.low && *field.value <= field.high)) {
        return r.Error(key, std::string("must be ") + field.range);
      }
    }
  }
  // A target faster than the robot may fly can only be caught by luck; the
  // terminal state follows the target, so it would break the limit.
  if (const ToolGoal* moving_tool = MovingToolGoal(task)) {
    const MovingTarget& moving = *moving_tool->moving;
    const std::string motion_key =
        moving_reach ? "mission[" + std::to_string(*moving_reach) + "].reach.tool.motion" : "goal.tool.motion";
    const double horizon = moving.motion.sampled() ? 1e9 : 0.0;  // a path: every row; constant: at t = 0
    const double speed = moving.motion.MaxSpeed(0.0, horizon);
    if (speed > task.limits.v_max) {
      return r.Error(motion_key + (moving.path_file.empty() ? ".velocity" : ".file"),
                     core::Format("the target moves at %.3f m/s, above limits.v_max (%.3f m/s)", speed,
                                  task.limits.v_max));
    }
    // The terminal state turns with the target.
    const double turn = moving.motion.MaxYawRate(horizon);
    if (turn > task.limits.yaw_rate_max) {
      return r.Error(motion_key + (moving.path_file.empty() ? ".yaw_rate" : ".file"),
                     core::Format("the target turns at %.3f rad/s, above limits.yaw_rate_max (%.3f rad/s)", turn,
                                  task.limits.yaw_rate_max));
    }
  }
  if (const YAML::Node tool_link = root["tool_link"]) {
    if (!tool_link.IsScalar() || tool_link.Scalar().empty()) return r.Error("tool_link", "expected a link name");
    task.tool_link = tool_link.Scalar();
    task.tool_link_given = true;
  }
  if (root["safety_distance"]) {
    QUADHAND_RETURN_IF_ERROR(r.Number(root["safety_distance"], "safety_distance", &task.safety_distance));
    if (!(task.safety_distance >= 0.0 && task.safety_distance <= 1.0)) {
      return r.Error("safety_distance", "must be in [0, 1] m");
    }
  }
  if (root["self_safety_distance"]) {
    QUADHAND_RETURN_IF_ERROR(r.Number(root["self_safety_distance"], "self_safety_distance", &task.self_safety_distance));
    if (!(task.self_safety_distance >= 0.0 && task.self_safety_distance <= 0.5)) {
      return r.Error("self_safety_distance", "must be in [0, 0.5] m");
    }
  }
  if (root["srdf"]) QUADHAND_RETURN_IF_ERROR(r.Path(root["srdf"], "srdf", &task.srdf_path));
  // A start faster than the limits allow cannot begin a plan that keeps them.
  if (task.start.velocity.norm() > task.limits.v_max) {
    return r.Error("start.velocity", "its speed " + std::to_string(task.start.velocity.norm()) +
                                         " m/s is above limits.v_max (" + std::to_string(task.limits.v_max) +
                                         " m/s): no plan from it keeps the limit");
  }
  if (task.start.acceleration.norm() > task.limits.a_max) {
    return r.Error("start.acceleration", "its norm " + std::to_string(task.start.acceleration.norm()) +
                                             " m/s^2 is above limits.a_max (" + std::to_string(task.limits.a_max) +
                                             " m/s^2): no plan from it keeps the limit");
  }
  return task;
}

}  // namespace

core::Result<Task> LoadTask(const std::string& path) { return LoadTask(path, TaskSources{}); }

core::Result<Task> LoadTask(const std::string& path, const TaskSources& sources) {
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return text.status();
  return ParseTaskText(*text, path, core::DirectoryOf(path), sources);
}

core::Result<Task> ParseTaskText(const std::string& text, const std::string& name, const std::string& base_dir,
                                 const TaskSources& sources) {
  QUADHAND_RETURN_IF_ERROR(core::CheckYamlText(text, name));
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return core::Status::InvalidArgument(name + ": not valid YAML: line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  if (!root.IsMap()) return core::Status::InvalidArgument(name + ": expected a YAML mapping of task keys");
  try {
    return ParseTask(name, base_dir, root, sources);
  } catch (const YAML::Exception& e) {  // e.g. a key that is not a scalar
    return core::Status::InvalidArgument(name + ": malformed task: " + e.msg);
  }
}

std::vector<std::string> TaskCautions(const Task& task) {
  std::vector<std::string> cautions;
  for (size_t i = 0; i < task.scans.size(); ++i) {
    const scene::ScanSource& scan = task.scans[i];
    if (!(scan.voxel > task.safety_distance)) continue;
    cautions.push_back(core::Format(
        "%s: scene[%zu] (%s): voxel leaf %g m is coarser than safety_distance %g m: the planner's points may leave "
        "gaps a link fits through, and the post-check (every unfiltered point) would then reject its plans; a leaf "
        "of at most the safety distance avoids that",
        task.file.c_str(), i, scan.path.c_str(), scan.voxel, task.safety_distance));
  }
  return cautions;
}

core::Status ApplyRobot(const robot::RobotModel& robot, Task* task) {
  const int n = robot.num_actuated();
  const VecX lower = robot.LowerLimits(), upper = robot.UpperLimits();
  const std::vector<std::string> names = robot.ActuatedJointNames();
  auto check = [&](const VecX& joints, const std::string& key) -> core::Status {
    if (joints.size() != n) {
      return core::Status::InvalidArgument(task->file + ": " + key + ": expected " + std::to_string(n) +
                                           " joint values (the robot's actuated joints), got " +
                                           std::to_string(joints.size()));
    }
    for (int i = 0; i < n; ++i) {
      if (joints[i] < lower[i] - 1e-9 || joints[i] > upper[i] + 1e-9) {
        return core::Status::InvalidArgument(task->file + ": " + key + ": " + names[i] + " = " +
                                             std::to_string(joints[i]) + " is outside its limits [" +
                                             std::to_string(lower[i]) + ", " + std::to_string(upper[i]) + "]");
      }
    }
    return core::Status::Ok();
  };
  QUADHAND_RETURN_IF_ERROR(check(task->start.joints, "start.joints"));
  const bool terminal_from_mission = !task->mission.empty();
  if (task->terminal && !terminal_from_mission) QUADHAND_RETURN_IF_ERROR(check(task->terminal->joints, "goal.joints"));
  bool mission_uses_tool = false;
  for (size_t i = 0; i < task->mission.size(); ++i) {
    MissionStep& step = task->mission[i];
    if (step.reach_state) {
      QUADHAND_RETURN_IF_ERROR(check(step.reach_state->joints, "mission[" + std::to_string(i) + "].reach.joints"));
      step.reach_state->joint_rates = VecX::Zero(n);
    }
    mission_uses_tool |= step.reach_tool.has_value() || step.kind == StepKind::kMove || step.kind == StepKind::kGrasp;
  }
  task->start.joint_rates = VecX::Zero(n);
  if (task->terminal) task->terminal->joint_rates = VecX::Zero(n);
  task->limits.joint_lower = lower;
  task->limits.joint_upper = upper;
  task->limits.joint_rate_max = robot.VelocityLimits();
  if (robot.LinkIndex(task->tool_link) < 0 && (task->tool_link_given || task->tool || mission_uses_tool)) {
    std::string links;
    for (int i = 0; i < robot.num_links(); ++i) links += (links.empty() ? "" : ", ") + robot.link(i).name;
    return core::Status::InvalidArgument(task->file + ": tool_link: the robot (" + task->robot_path +
                                         ") has no link named '" + task->tool_link + "'" +
                                         (task->tool_link_given ? "" : " (the default; name the end effector with tool_link:)") +
                                         "; its links: " + links);
  }
  for (int i = 0; i < n; ++i) {
    if (!(task->limits.joint_rate_max[i] > 0.0)) {
      return core::Status::InvalidArgument(robot.name() + ": joint " + names[i] + " has no velocity limit in the URDF");
    }
  }
  return core::Status::Ok();
}

core::Result<std::vector<Vec3>> ScenePoints(const Task& task) {
  if (task.scans.empty()) return std::vector<Vec3>{};
  auto scans = scene::LoadScans(task.scans);
  if (!scans.ok()) return scans.status();
  return scans->unfiltered_points.empty() ? std::move(scans->points) : std::move(scans->unfiltered_points);
}

core::Result<std::vector<Vec3>> LoadWorldPoints(const std::string& path) {
  const std::string extension = std::filesystem::path(path).extension().string();
  if (extension == ".yaml" || extension == ".yml") {
    auto task = LoadTask(path);
    if (!task.ok()) return task.status();
    return ScenePoints(*task);
  }
  auto cloud = scene::LoadPointCloud(path);
  if (!cloud.ok()) return cloud.status();
  return std::move(cloud->points);
}

}  // namespace quadhand::planner
