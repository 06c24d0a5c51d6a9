// The second bundled robot (meshes/longarm: primitives overlapping, a Collada
// palm, a continuous wrist roll, an end effector called gripper_tip, no PCGC
// joint) end to end through the CLIs: its link SDFs (coarse, 4 mm, to keep
// the test short), each of its tasks in data/tasks planned with the
// post-check passed, the 3-D page written, and the plan flown by
// quadhand-sim with its own configuration.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "support/run_command.h"

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using testing::RunCommand;

const std::string kBin = QUADHAND_BIN_DIR;
const std::string kRoot = QUADHAND_SOURCE_DIR;

// The task file with absolute paths and the SDF folder replaced.
std::string TaskWithSdfDir(const std::string& task, const std::string& sdf_dir) {
  std::ifstream in(kRoot + "/data/tasks/" + task);
  std::string text, line;
  while (std::getline(in, line)) {
    if (line.rfind("robot:", 0) == 0) line = "robot: " + kRoot + "/meshes/longarm/longarm.urdf";
    if (line.rfind("sdf_dir:", 0) == 0) line = "sdf_dir: " + sdf_dir;
    if (line.rfind("scene:", 0) == 0) line = "scene: " + kRoot + "/data/scenes/window_cup.pcd";
    text += line + "\n";
  }
  return text;
}

TEST(SecondRobotTest, PlansEachOfItsTasksAndFliesThem) {
  const fs::path dir = fs::temp_directory_path() / ("quadhand_longarm_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string sdf_dir = (dir / "sdf").string();
  const auto sdfgen = RunCommand(kBin + "/quadhand-sdfgen --urdf " + kRoot + "/meshes/longarm/longarm.urdf --out " +
                                 sdf_dir + " --resolution 0.004 -q");
  ASSERT_EQ(sdfgen.exit_code, 0) << sdfgen.err;
  for (const char* task : {"longarm_cup.yaml", "longarm_windows.yaml"}) {
    SCOPED_TRACE(task);
    const std::string task_path = (dir / task).string();
    std::ofstream(task_path) << TaskWithSdfDir(task, sdf_dir);
    const std::string plan = (dir / "plan.csv").string(), report = (dir / "report.json").string(),
                      html = (dir / "plan.html").string(), flown = (dir / "flown.csv").string();
    const auto planned =
        RunCommand(kBin + "/quadhand-plan " + task_path + " --out " + plan + " --report " + report + " --html " + html);
    ASSERT_EQ(planned.exit_code, 0) << planned.out << planned.err;
    EXPECT_TRUE(fs::exists(html));
    std::ifstream in(report);
    const nlohmann::json json = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    ASSERT_TRUE(json.is_object());
    EXPECT_EQ(json["status"], "success");
    EXPECT_GE(json["min_clearance_exact_m"].get<double>(), 0.028);
    // The arm's links against the airframe, the battery and each other.
    EXPECT_GE(json["self_collision_pairs"].size(), 6u) << json["self_collision_pairs"].dump();
    // The front end keeps the robot's own half-width: rotor guards at
    // 0.12 + 0.065 m.
    EXPECT_NEAR(json["front_end_inflation_m"].get<double>(), 0.185, 1e-3);
    // PCGC asked for, but the robot has no joint for it: none acts, and the
    // summary says so.
    const auto flew = RunCommand(kBin + "/quadhand-sim --track " + plan + " --out " + flown + " --config " + kRoot +
                                 "/data/sim/longarm_sim.yaml --noise off --pcgc on");
    EXPECT_EQ(flew.exit_code, 0) << flew.err;
    EXPECT_NE(flew.out.find("PCGC off"), std::string::npos) << flew.out;
    EXPECT_TRUE(fs::exists(flown));
    for (const std::string& file : {plan, report, html, flown}) fs::remove(file);
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace quadhand
