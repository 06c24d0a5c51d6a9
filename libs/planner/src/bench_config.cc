#include "quadhand/planner/bench_config.h"

#include <cmath>

#include <yaml-cpp/yaml.h>

#include "quadhand/core/file_util.h"
#include "quadhand/core/yaml_text.h"

namespace quadhand::planner {

core::Result<BenchConfig> ParseBenchConfig(const std::string& text, const std::string& name) {
  QUADHAND_RETURN_IF_ERROR(core::CheckYamlText(text, name));
  BenchConfig config;
  auto fail = [&name](const std::string& what) { return core::Status::InvalidArgument(name + ": " + what); };
  // A scalar that is not a number ("a", "1e999x") is reported with its key.
  auto number = [](const YAML::Node& node, double* value) {
    return node.IsScalar() && YAML::convert<double>::decode(node, *value);
  };
  try {
    const YAML::Node root = YAML::Load(text);
    if (!root.IsMap()) return fail("expected a mapping with task, start_box and optionally yaw");
    for (auto it = root.begin(); it != root.end(); ++it) {
      if (!it->first.IsScalar()) return fail("keys must be plain words (task, start_box, yaw)");
      const std::string key = it->first.as<std::string>();
      if (key != "task" && key != "start_box" && key != "yaw" && key != "target") {
        return fail(key + ": unknown key (expected task, start_box, yaw, target)");
      }
    }
    if (!root["task"] || !root["task"].IsScalar() || root["task"].as<std::string>().empty()) {
      return fail("task: expected the task file's path");
    }
    config.task_path = core::ResolvePath(core::DirectoryOf(name), root["task"].as<std::string>());
    const YAML::Node box = root["start_box"];
    if (!box || !box.IsMap()) return fail("start_box: expected {min: [x, y, z], max: [x, y, z]}");
    for (auto it = box.begin(); it != box.end(); ++it) {
      if (!it->first.IsScalar()) return fail("start_box: keys must be min and max");
      const std::string key = it->first.as<std::string>();
      if (key != "min" && key != "max") return fail("start_box." + key + ": unknown key (expected min, max)");
    }
    for (const char* key : {"min", "max"}) {
      const YAML::Node corner = box[key];
      if (!corner || !corner.IsSequence() || corner.size() != 3) {
        return fail(std::string("start_box.") + key + ": expected three numbers");
      }
      for (int i = 0; i < 3; ++i) {
        double value = 0.0;
        if (!number(corner[i], &value)) return fail(std::string("start_box.") + key + ": expected three numbers");
        (std::string(key) == "min" ? config.box_min : config.box_max)[i] = value;
      }
    }
    if (const YAML::Node yaw = root["yaw"]) {
      if (!yaw.IsSequence() || yaw.size() != 2 || !number(yaw[0], &config.yaw_min) ||
          !number(yaw[1], &config.yaw_max)) {
        return fail("yaw: expected [min, max] in radians");
      }
    }
    if (const YAML::Node target = root["target"]) {
      if (!target.IsMap()) return fail("target: expected {speeds: [...], heading: [min, max], pass_time: s}");
      BenchTarget moving;
      for (auto it = target.begin(); it != target.end(); ++it) {
        const std::string key = it->first.IsScalar() ? it->first.as<std::string>() : "";
        if (key != "speeds" && key != "heading" && key != "pass_time") {
          return fail("target." + key + ": unknown key (expected speeds, heading, pass_time)");
        }
      }
      const YAML::Node speeds = target["speeds"];
      if (!speeds || !speeds.IsSequence() || speeds.size() == 0) return fail("target.speeds: expected a list of speeds (m/s)");
      for (size_t i = 0; i < speeds.size(); ++i) {
        double value = 0.0;
        if (!number(speeds[i], &value) || !std::isfinite(value) || value < 0.0 || value > 100.0) {
          return fail("target.speeds[" + std::to_string(i) + "]: expected a speed in [0, 100] m/s");
        }
        moving.speeds.push_back(value);
      }
      if (const YAML::Node heading = target["heading"]) {
        if (!heading.IsSequence() || heading.size() != 2 || !number(heading[0], &moving.heading_min) ||
            !number(heading[1], &moving.heading_max) || !std::isfinite(moving.heading_min) ||
            !std::isfinite(moving.heading_max) || moving.heading_min > moving.heading_max) {
          return fail("target.heading: expected [min, max] in radians, min <= max");
        }
      }
      if (const YAML::Node pass = target["pass_time"]) {
        if (!number(pass, &moving.pass_time) || !std::isfinite(moving.pass_time) || moving.pass_time < 0.0 ||
            moving.pass_time > 1000.0) {
          return fail("target.pass_time: expected a time in [0, 1000] s");
        }
      }
      config.target = moving;
    }
  } catch (const YAML::Exception& e) {
    return fail("malformed benchmark config: " + e.msg);
  }
  // Starts are drawn in the box and the planner's search covers it: a box a
  // kilometre across is a typo, not a benchmark.
  if (!(config.box_min.allFinite() && config.box_max.allFinite() &&
        (config.box_min.array() <= config.box_max.array()).all() && config.box_min.cwiseAbs().maxCoeff() <= 1000.0 &&
        config.box_max.cwiseAbs().maxCoeff() <= 1000.0)) {
    return fail("start_box: min and max must be finite and within 1000 m, with min <= max");
  }
  if (!(std::isfinite(config.yaw_min) && std::isfinite(config.yaw_max) && config.yaw_min <= config.yaw_max)) {
    return fail("yaw: min and max must be finite, with min <= max");
  }
  return config;
}

core::Result<BenchConfig> LoadBenchConfig(const std::string& path) {
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return text.status();
  return ParseBenchConfig(*text, path);
}

}  // namespace quadhand::planner
