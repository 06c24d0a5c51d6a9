#include "quadhand/planner/task.h"

#include <cmath>
#include <set>

#include <yaml-cpp/yaml.h>

#include "quadhand/core/file_util.h"
#include "quadhand/core/text.h"
#include "quadhand/core/yaml_text.h"

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

// scene: a path, or a list of {file, pose, crop, voxel} (contracts.md).
core::Status ReadScene(const Reader& r, const YAML::Node& node, Task* task) {
  if (node.IsScalar()) {
    scene::ScanSource source;
    QUADHAND_RETURN_IF_ERROR(r.Path(node, "scene", &source.path));
    task->scans = {source};
    task->scene_path = source.path;
    return core::Status::Ok();
  }
  if (!node.IsSequence() || node.size() == 0) {
    return r.Error("scene", "expected a point cloud path or a list of scans ({file, pose, crop, voxel})");
  }
  task->scans.clear();
  for (size_t i = 0; i < node.size(); ++i) {
    const std::string key = "scene[" + std::to_string(i) + "]";
    const YAML::Node entry = node[i];
    QUADHAND_RETURN_IF_ERROR(r.CheckKeys(entry, key, {"file", "pose", "crop", "voxel"}));
    scene::ScanSource source;
    QUADHAND_RETURN_IF_ERROR(r.Path(entry["file"], key + ".file", &source.path));
    if (const YAML::Node pose = entry["pose"]) {
      QUADHAND_RETURN_IF_ERROR(r.CheckKeys(pose, key + ".pose", {"position", "orientation"}));
      Vec3 position;
      Quat orientation;
      QUADHAND_RETURN_IF_ERROR(r.Vector3(pose["position"], key + ".pose.position", &position));
      QUADHAND_RETURN_IF_ERROR(ReadUnitQuaternion(r, pose["orientation"], key + ".pose.orientation", &orientation));
      source.sensor_to_world = MakePose(position, orientation.toRotationMatrix());
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

core::Status ReadTool(const Reader& r, const YAML::Node& node, ToolGoal* tool) {
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys(node, "goal.tool", {"position", "orientation", "insertion"}));
  QUADHAND_RETURN_IF_ERROR(r.Vector3(node["position"], "goal.tool.position", &tool->position));
  QUADHAND_RETURN_IF_ERROR(ReadUnitQuaternion(r, node["orientation"], "goal.tool.orientation", &tool->orientation));
  if (const YAML::Node insertion = node["insertion"]) {
    QUADHAND_RETURN_IF_ERROR(r.CheckKeys(insertion, "goal.tool.insertion", {"direction", "length"}));
    QUADHAND_RETURN_IF_ERROR(r.Vector3(insertion["direction"], "goal.tool.insertion.direction", &tool->insertion_direction));
    QUADHAND_RETURN_IF_ERROR(r.Number(insertion["length"], "goal.tool.insertion.length", &tool->insertion_length));
    if (tool->insertion_direction.norm() < 1e-9) return r.Error("goal.tool.insertion.direction", "must not be zero");
    if (!(tool->insertion_length > 0.0 && tool->insertion_length <= 10.0)) {
      return r.Error("goal.tool.insertion.length", "must be in (0, 10] m");
    }
    tool->insertion_direction.normalize();
    tool->has_insertion = true;
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
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys(root, "", {"robot", "sdf_dir", "scene", "start", "goal", "limits", "safety_distance", "tool_link",
                                                  "self_safety_distance", "srdf"}));
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
  if (!goal) return r.Error("goal", "missing");
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys(goal, "goal", {"position", "yaw", "joints", "tool"}));
  const bool any_state_key = goal["position"] || goal["yaw"] || goal["joints"];
  if (any_state_key) {
    BoundaryState terminal;
    QUADHAND_RETURN_IF_ERROR(ReadState(r, goal, "goal", false, &terminal));
    task.terminal = terminal;
  }
  if (goal["tool"]) {
    ToolGoal tool;
    QUADHAND_RETURN_IF_ERROR(ReadTool(r, goal["tool"], &tool));
    task.tool = tool;
  }
  if (!task.terminal && !task.tool) return r.Error("goal", "needs a terminal state (position, yaw, joints) or a tool pose");

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

core::Result<Task> LoadTask(const std::string& path) {
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return text.status();
  return ParseTaskText(*text, path, core::DirectoryOf(path), TaskSources{});
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
  if (task->terminal) QUADHAND_RETURN_IF_ERROR(check(task->terminal->joints, "goal.joints"));
  task->start.joint_rates = VecX::Zero(n);
  if (task->terminal) task->terminal->joint_rates = VecX::Zero(n);
  task->limits.joint_lower = lower;
  task->limits.joint_upper = upper;
  task->limits.joint_rate_max = robot.VelocityLimits();
  if (robot.LinkIndex(task->tool_link) < 0 && (task->tool_link_given || task->tool)) {
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

}  // namespace quadhand::planner
