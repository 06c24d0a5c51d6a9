// The default task (data/tasks/window_cup.yaml) for the command-line tests:
// coarse link SDFs generated once per test process, and the task's text with
// absolute paths, so that a test can write it anywhere.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "support/run_command.h"

namespace quadhand::testing {

// Coarse (5 mm) link SDFs of the reference robot, made by quadhand-sdfgen
// into a temporary folder on first use and removed when the process exits.
inline const std::string& CoarseSdfDir() {
  struct Folder {
    std::string path;
    Folder() {
      path = (std::filesystem::temp_directory_path() / ("quadhand_test_sdf_" + std::to_string(getpid()))).string();
      const auto r = RunCommand(std::string(QUADHAND_BIN_DIR) + "/quadhand-sdfgen -q --urdf " +
                                QUADHAND_SOURCE_DIR + "/meshes/quadhand/quadhand.urdf --out " + path +
                                " --resolution 0.005 --padding 0.05");
      EXPECT_EQ(r.exit_code, 0) << r.err;
    }
    ~Folder() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  };
  static const Folder folder;
  return folder.path;
}

// A bundled task's text (data/tasks/<name>) with absolute robot, scene and
// SDF (CoarseSdfDir()) paths; a line starting with a key of `replace`
// becomes its value ("" drops the line). Blank lines are dropped.
inline std::string BundledTaskText(const std::string& name,
                                   const std::vector<std::pair<std::string, std::string>>& replace = {}) {
  const std::string root = QUADHAND_SOURCE_DIR;
  std::ifstream in(root + "/data/tasks/" + name);
  std::string text, line;
  while (std::getline(in, line)) {
    if (line.rfind("robot:", 0) == 0) line = "robot: " + root + "/meshes/quadhand/quadhand.urdf";
    if (line.rfind("sdf_dir:", 0) == 0) line = "sdf_dir: " + CoarseSdfDir();
    if (line.rfind("scene:", 0) == 0) line = "scene: " + root + "/data/scenes/window_cup.pcd";
    for (const auto& [key, value] : replace) {
      if (line.rfind(key, 0) == 0) line = value;
    }
    if (!line.empty()) text += line + "\n";
  }
  return text;
}

// The default task's text (data/tasks/window_cup.yaml), as BundledTaskText.
inline std::string WindowCupTaskText(const std::vector<std::pair<std::string, std::string>>& replace = {}) {
  return BundledTaskText("window_cup.yaml", replace);
}

// The default task with its goal written as a mission: one reach with the
// goal's keys, then `more_steps` (list items, indented as such).
inline std::string WindowCupMissionText(const std::string& more_steps) {
  const std::string text = WindowCupTaskText({});
  const size_t goal = text.find("\ngoal:\n"), limits = text.find("\nlimits:\n");
  if (goal == std::string::npos || limits == std::string::npos) return text;
  const std::string block = text.substr(goal + 7, limits + 1 - (goal + 7));
  std::string indented;
  for (size_t at = 0; at < block.size();) {
    const size_t end = block.find('\n', at);
    indented += "    " + block.substr(at, end + 1 - at);
    at = end + 1;
  }
  return text.substr(0, goal + 1) + "mission:\n  - reach:\n" + indented + more_steps + text.substr(limits + 1);
}

}  // namespace quadhand::testing
