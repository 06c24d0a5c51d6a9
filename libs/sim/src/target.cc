#include "quadhand/sim/target.h"

#include <cmath>
#include <optional>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "quadhand/core/file_util.h"
#include "quadhand/core/yaml_text.h"

namespace quadhand::sim {
namespace {

// The finite numbers of a YAML list, or none.
std::optional<std::vector<double>> Numbers(const YAML::Node& node) {
  if (!node || !node.IsSequence()) return std::nullopt;
  std::vector<double> values;
  for (const YAML::Node& item : node) {
    double v = 0.0;
    if (!item.IsScalar() || !YAML::convert<double>::decode(item, v) || !std::isfinite(v)) return std::nullopt;
    values.push_back(v);
  }
  return values;
}

// The walk advances in steps of at most this much simulated time.
constexpr double kWalkStep = 0.01;

}  // namespace

bool SimTargetOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!(rate > 0.0 && rate <= 1000.0)) return fail("target rate must be in (0, 1000] Hz");
  if (!(noise >= 0.0 && noise <= 1.0)) return fail("target noise must be in [0, 1] m");
  if (!(yaw_noise >= 0.0 && yaw_noise <= 1.0)) return fail("target yaw noise must be in [0, 1] rad");
  if (!(random_walk >= 0.0 && random_walk <= 10.0)) return fail("target random walk must be in [0, 10] m/s/sqrt(s)");
  return true;
}

SimTarget::SimTarget(const Pose& pose, traj::TargetMotion motion, const SimTargetOptions& options)
    : pose_(pose), motion_(std::move(motion)), options_(options), rng_(options.seed) {}

void SimTarget::AdvanceWalk(double t) {
  if (options_.random_walk <= 0.0) return;
  std::normal_distribution<double> unit(0.0, 1.0);
  while (walk_time_ < t) {
    const double h = std::min(kWalkStep, t - walk_time_);
    walk_offset_ += walk_velocity_ * h;
    walk_velocity_ += options_.random_walk * std::sqrt(h) * Vec3(unit(rng_), unit(rng_), 0.0);
    walk_time_ += h;
  }
}

Vec3 SimTarget::Position(double t) {
  AdvanceWalk(t);
  return motion_.Displacement(t) * pose_.translation() + walk_offset_;
}

Pose SimTarget::PoseAt(double t) {
  return MakePose(Position(t), Eigen::AngleAxisd(Yaw(t), Vec3::UnitZ()).toRotationMatrix() * pose_.linear());
}

bool SimTarget::MeasurementDue(double t, TargetSample* sample) {
  if (t + 1e-9 < next_measurement_) return false;
  std::normal_distribution<double> unit(0.0, 1.0);
  sample->time = t;
  sample->true_position = Position(t);
  sample->true_yaw = Yaw(t);
  sample->measured_position =
      sample->true_position + options_.noise * Vec3(unit(rng_), unit(rng_), unit(rng_));
  sample->measured_yaw = sample->true_yaw + options_.yaw_noise * unit(rng_);
  next_measurement_ += 1.0 / options_.rate;
  if (next_measurement_ <= t) next_measurement_ = t + 1.0 / options_.rate;
  return true;
}

core::Result<TaskTarget> LoadTaskTarget(const std::string& task_path) {
  auto text = core::ReadFileToString(task_path);
  if (!text.ok()) return text.status();
  QUADHAND_RETURN_IF_ERROR(core::CheckYamlText(*text, task_path));
  YAML::Node root;
  try {
    root = YAML::Load(*text);
  } catch (const YAML::Exception& e) {
    return core::Status::InvalidArgument(task_path + ": not valid YAML: " + e.what());
  }
  auto fail = [&task_path](const std::string& key, const std::string& problem) {
    return core::Status::InvalidArgument(task_path + ": " + key + ": " + problem);
  };
  const YAML::Node goal = root.IsMap() ? root["goal"] : YAML::Node();
  const YAML::Node tool = goal && goal.IsMap() ? goal["tool"] : YAML::Node();
  const YAML::Node motion = tool && tool.IsMap() ? tool["motion"] : YAML::Node();
  if (!motion || !motion.IsMap()) return fail("goal.tool.motion", "missing: the task's target does not move");
  TaskTarget target;
  const auto position = Numbers(tool["position"]);
  if (!position || position->size() != 3) return fail("goal.tool.position", "expected a list of 3 numbers");
  const auto q = Numbers(tool["orientation"]);
  if (!q || q->size() != 4 ||
      std::abs(std::sqrt((*q)[0] * (*q)[0] + (*q)[1] * (*q)[1] + (*q)[2] * (*q)[2] + (*q)[3] * (*q)[3]) - 1.0) > 1e-3) {
    return fail("goal.tool.orientation", "expected a unit quaternion [w, x, y, z]");
  }
  target.pose = MakePose(Vec3((*position)[0], (*position)[1], (*position)[2]),
                         Quat((*q)[0], (*q)[1], (*q)[2], (*q)[3]).normalized().toRotationMatrix());
  const Vec3 origin = target.pose.translation();
  if (const YAML::Node file = motion["file"]) {
    if (!file.IsScalar()) return fail("goal.tool.motion.file", "expected a path");
    const std::string path = core::ResolvePath(core::DirectoryOf(task_path), file.as<std::string>());
    auto path_text = core::ReadFileToString(path);
    if (!path_text.ok()) return fail("goal.tool.motion.file", path_text.status().message());
    auto samples = traj::ParseTargetPath(*path_text, path);
    if (!samples.ok()) return fail("goal.tool.motion.file", samples.status().message());
    target.motion = traj::TargetMotion::Sampled(std::move(*samples));
    return target;
  }
  const auto velocity = Numbers(motion["velocity"]);
  if (!velocity || velocity->size() != 3) return fail("goal.tool.motion.velocity", "expected a list of 3 numbers");
  Vec3 acceleration = Vec3::Zero();
  if (motion["acceleration"]) {
    const auto a = Numbers(motion["acceleration"]);
    if (!a || a->size() != 3) return fail("goal.tool.motion.acceleration", "expected a list of 3 numbers");
    acceleration = Vec3((*a)[0], (*a)[1], (*a)[2]);
  }
  double yaw_rate = 0.0;
  if (motion["yaw_rate"] && (!motion["yaw_rate"].IsScalar() ||
                             !YAML::convert<double>::decode(motion["yaw_rate"], yaw_rate) || !std::isfinite(yaw_rate))) {
    return fail("goal.tool.motion.yaw_rate", "expected a number");
  }
  target.motion = traj::TargetMotion::Constant(origin, Vec3((*velocity)[0], (*velocity)[1], (*velocity)[2]),
                                               acceleration, yaw_rate);
  return target;
}

}  // namespace quadhand::sim
