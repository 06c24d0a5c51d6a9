// Command-line behaviour of quadhand-plan: bad input gives exit code 2, one
// line naming the file and the problem, and no output file.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "support/run_command.h"
#include "support/window_cup_task.h"

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using testing::CountLines;
using testing::RunCommand;

const std::string kPlan = std::string(QUADHAND_BIN_DIR) + "/quadhand-plan";

class PlanCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("quadhand_plan_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The default task with absolute paths and `replace` applied line by line
  // (a line starting with the key is replaced; "" removes it).
  std::string WriteTask(const std::vector<std::pair<std::string, std::string>>& replace) {
    const std::string path = (dir_ / "task.yaml").string();
    std::ofstream(path) << testing::WindowCupTaskText(replace);
    return path;
  }

  void ExpectBadInput(const std::string& task, const std::string& fragment) {
    const std::string out = (dir_ / "plan.csv").string(), report = (dir_ / "report.json").string();
    const auto r = RunCommand(kPlan + " " + task + " --out " + out + " --report " + report);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(CountLines(r.err.substr(r.err.find("quadhand-plan: error"))), 1) << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(report));
  }

  fs::path dir_;
};

TEST_F(PlanCliTest, HelpListsEveryOption) {
  const auto r = RunCommand(kPlan + " --help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* option : {"--out", "--report", "--html", "--solver", "--representation", "--dt", "--seed", "--verbose"}) {
    EXPECT_NE(r.out.find(option), std::string::npos) << option;
  }
}

TEST_F(PlanCliTest, RejectsBadTasks) {
  ExpectBadInput((dir_ / "missing.yaml").string(), "missing.yaml");
  ExpectBadInput(WriteTask({{"  joints: [0.3, -0.2, 0.0]", "  joints: [0.3, -0.2]"}}), "start.joints: expected 3");
  ExpectBadInput(WriteTask({{"  joints: [0.3, -0.2, 0.0]", "  joints: [2.5, -0.2, 0.0]"}}), "outside its limits");
  ExpectBadInput(WriteTask({{"  yaw: 3.14159265", "  yaw: north"}}), "start.yaw");
  ExpectBadInput(WriteTask({{"safety_distance:", "safety_distanse: 0.03"}}), "unknown key");
  ExpectBadInput(WriteTask({{"scene:", "scene: /nonexistent/scene.pcd"}}), "/nonexistent/scene.pcd");
  ExpectBadInput(WriteTask({{"sdf_dir:", "sdf_dir: /nonexistent/sdf"}}), "/nonexistent/sdf");
  ExpectBadInput(WriteTask({{"safety_distance:", "tool_link: gripper_tip"}}),
                 "tool_link: the robot (");
  ExpectBadInput(WriteTask({{"safety_distance:", "tool_link: gripper_tip"}}), "no link named 'gripper_tip'");
  ExpectBadInput(WriteTask({{"safety_distance:", "tool_link: [a, b]"}}), "tool_link: expected a link name");
  // Start inside the first wall.
  ExpectBadInput(WriteTask({{"  position: [0.5, 0.2, 1.2]", "  position: [-1.0, 1.0, 1.2]"}}), "in collision");
  {
    const std::string path = (dir_ / "broken.yaml").string();
    std::ofstream(path) << "robot: [unclosed\n";
    ExpectBadInput(path, "broken.yaml");
  }
}

TEST_F(PlanCliTest, RejectsBadOptions) {
  const std::string task = WriteTask({});
  const std::string outputs = " --out " + (dir_ / "p.csv").string() + " --report " + (dir_ / "r.json").string();
  for (const auto& [args, fragment] : std::vector<std::pair<std::string, std::string>>{
           {" --solver nosuch", "unknown solver"},
           {" --representation voxels", "voxels"},
           {" --dt 0", "--dt"},
           {" --dt nan", "--dt"}}) {
    const auto r = RunCommand(kPlan + " " + task + outputs + args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
  }
}

}  // namespace
}  // namespace quadhand
