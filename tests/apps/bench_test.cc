// Command-line behaviour of quadhand-bench: bad input gives exit code 2, one
// line and no results file; shards together give exactly the records of one
// run (all but the wall times), and scripts/bench_report.py merges them into
// the same table rows and rejects overlapping shards.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "support/run_command.h"
#include "support/window_cup_task.h"

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using testing::CountLines;
using testing::ReadAll;
using testing::RunCommand;

const std::string kBench = std::string(QUADHAND_BIN_DIR) + "/quadhand-bench";
const std::string kRoot = QUADHAND_SOURCE_DIR;

class BenchCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("quadhand_bench_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // Coarse link SDFs keep the test quick; the trials are what they are with them.
    std::ofstream(dir_ / "task.yaml") << testing::WindowCupTaskText();
    std::string line;
    std::ifstream bench_in(kRoot + "/data/bench/window_cup.yaml");
    std::ofstream bench(Config());
    while (std::getline(bench_in, line)) {
      if (line.rfind("task:", 0) == 0) line = "task: task.yaml";
      bench << line << "\n";
    }
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static std::string Config() { return (dir_ / "bench.yaml").string(); }
  static std::string Path(const std::string& name) { return (dir_ / name).string(); }

  void ExpectBadInput(const std::string& arguments, const std::string& fragment) {
    const std::string out = Path("bad.jsonl");
    fs::remove(out);
    const auto r = RunCommand(kBench + " " + arguments + " --out " + out);
    EXPECT_EQ(r.exit_code, 2) << arguments << "\n" << r.err;
    const size_t at = r.err.find("quadhand-bench: error");
    ASSERT_NE(at, std::string::npos) << r.err;
    EXPECT_EQ(CountLines(r.err.substr(at)), 1) << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << arguments;
  }

  static fs::path dir_;
};

fs::path BenchCliTest::dir_;

// Records by (trial, representation, solver), without the wall-time fields.
std::map<std::string, nlohmann::json> Records(const std::vector<std::string>& files) {
  std::map<std::string, nlohmann::json> records;
  for (const std::string& file : files) {
    std::istringstream lines(ReadAll(file));
    std::string line;
    while (std::getline(lines, line)) {
      nlohmann::json record = nlohmann::json::parse(line);
      for (const char* timing : {"solve_ms", "front_end_ms", "post_check_ms", "representation_build_ms", "plan_ms"}) {
        EXPECT_TRUE(record.contains(timing)) << line;
        record.erase(timing);
      }
      record.erase("mission_phase_build_ms");
      const std::string key = std::to_string(record["trial"].get<int>()) + " " +
                              record["representation"].get<std::string>() + " " +
                              record["solver"].get<std::string>();
      EXPECT_TRUE(records.emplace(key, record).second) << "duplicate " << key;
    }
  }
  return records;
}

TEST_F(BenchCliTest, HelpListsEveryOption) {
  const auto r = RunCommand(kBench + " --help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* option : {"--config", "--trials", "--first", "--solvers", "--representations", "--shard", "--out",
                             "--package-path"}) {
    EXPECT_NE(r.out.find(option), std::string::npos) << option;
  }
}

TEST_F(BenchCliTest, BadInputExitsWithTwoAndOneLine) {
  const std::string config = " --config " + Config() + " --trials 1";
  ExpectBadInput(config + " --representations mrc_sdf,octree", "unknown representation 'octree'");
  ExpectBadInput(config + " --solvers lbfgs,newton", "newton");
  ExpectBadInput(config + " --solvers nlopt:LN_COBYLA", "LN_COBYLA");
  ExpectBadInput(config + " --shard 2/2", "--shard '2/2'");
  ExpectBadInput(config + " --shard 0/0", "--shard '0/0'");
  ExpectBadInput(config + " --shard one/two", "--shard 'one/two'");
  ExpectBadInput(config + " --trials 0", "--trials");
  ExpectBadInput("--config " + Path("missing.yaml"), "missing.yaml");

  std::ofstream(Path("no_box.yaml")) << "task: task.yaml\nyaw: [0, 1]\n";
  ExpectBadInput("--config " + Path("no_box.yaml"), "no_box.yaml");
  std::ofstream(Path("not_yaml.yaml")) << "task: [unclosed\n";
  ExpectBadInput("--config " + Path("not_yaml.yaml"), "not_yaml.yaml");
  std::ofstream(Path("no_task.yaml")) << "task: nowhere.yaml\nstart_box: {min: [0, 0, 1], max: [1, 1, 1.5]}\n";
  ExpectBadInput("--config " + Path("no_task.yaml"), "nowhere.yaml");
  std::ofstream(Path("typo.yaml")) << "task: task.yaml\nstart_box: {min: [0, 0, 1], max: [1, 1, 1.5]}\nyaww: [0, 1]\n";
  ExpectBadInput("--config " + Path("typo.yaml"), "yaww: unknown key");
  std::ofstream(Path("infinite.yaml")) << "task: task.yaml\nstart_box: {min: [0, 0, 1], max: [1, 1, .inf]}\n";
  ExpectBadInput("--config " + Path("infinite.yaml"), "finite");
  std::ofstream(Path("huge.yaml")) << "task: task.yaml\nstart_box: {min: [-1e300, 0, 1], max: [1e300, 1, 1.5]}\n";
  ExpectBadInput("--config " + Path("huge.yaml"), "huge.yaml: start_box: min and max must be finite and within 1000 m");
  std::ofstream(Path("twice.yaml")) << "task: task.yaml\nstart_box: {min: [0, 0, 1], max: [1, 1, 1.5]}\ntask: x.yaml\n";
  ExpectBadInput("--config " + Path("twice.yaml"), "duplicate key 'task'");
  // Found before any trial runs (2^31 - 1 - 600 + 1000 overflows an int).
  ExpectBadInput(" --config " + Config() + " --first 2147483000 --trials 1000", "--first + --trials");
  // A start box inside the first wall: refused before anything else is printed.
  std::ofstream(Path("in_wall.yaml")) << "task: task.yaml\nstart_box: {min: [-1.02, 1.0, 1.4], max: [-0.98, 1.2, 1.5]}\n";
  {
    const auto r = RunCommand(kBench + " --config " + Path("in_wall.yaml") + " --trials 2 --out " + Path("bad.jsonl"));
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(CountLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find("in_wall.yaml: start_box: trial 0: no start clear of the scene"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(Path("bad.jsonl")));
  }
  for (const std::string& out : {dir_.string(), Config(), Path("missing/records.jsonl")}) {
    const auto r = RunCommand(kBench + config + " --out " + out);
    EXPECT_EQ(r.exit_code, 2) << out << "\n" << r.err;
    EXPECT_EQ(CountLines(r.err), 1) << r.err;
    EXPECT_EQ(r.err.find("trial"), std::string::npos) << "ran trials first: " << r.err;
  }
}

TEST_F(BenchCliTest, TwoShardsGiveTheRecordsOfOneRun) {
  const std::string common = kBench + " --config " + Config() + " --first 3 --trials 4";
  const auto whole = RunCommand(common + " --out " + Path("all.jsonl"));
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  for (int shard = 0; shard < 2; ++shard) {
    const auto r = RunCommand(common + " --shard " + std::to_string(shard) + "/2 --out " +
                              Path("shard" + std::to_string(shard) + ".jsonl"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  const auto one = Records({Path("all.jsonl")});
  const auto merged = Records({Path("shard0.jsonl"), Path("shard1.jsonl")});
  ASSERT_EQ(one.size(), 4u);
  for (const char* key : {"3 mrc_sdf lbfgs", "4 mrc_sdf lbfgs", "5 mrc_sdf lbfgs", "6 mrc_sdf lbfgs"}) {
    EXPECT_TRUE(one.count(key)) << key;
  }
  // Shard K of 2 holds the trials k with k % 2 == K.
  EXPECT_EQ(Records({Path("shard0.jsonl")}).count("4 mrc_sdf lbfgs"), 1u);
  EXPECT_EQ(Records({Path("shard1.jsonl")}).count("3 mrc_sdf lbfgs"), 1u);
  EXPECT_EQ(one, merged);

  // The report: the same success column from one run and from the shards;
  // a trial given twice is an error.
  const std::string report = "python3 " + kRoot + "/scripts/bench_report.py ";
  const auto table_one = RunCommand(report + Path("all.jsonl"));
  const auto table_merged = RunCommand(report + Path("shard0.jsonl") + " " + Path("shard1.jsonl"));
  ASSERT_EQ(table_one.exit_code, 0) << table_one.err;
  ASSERT_EQ(table_merged.exit_code, 0) << table_merged.err;
  const auto success_column = [](const std::string& table) {  // "| mrc_sdf | lbfgs | 3/4 (75 %) | ..."
    const size_t row = table.find("| mrc_sdf | lbfgs |");
    EXPECT_NE(row, std::string::npos) << table;
    if (row == std::string::npos) return std::string();
    const size_t begin = row + std::string("| mrc_sdf | lbfgs |").size();
    return table.substr(begin, table.find('|', begin) - begin);
  };
  EXPECT_EQ(success_column(table_one.out), success_column(table_merged.out));
  const auto overlapping = RunCommand(report + Path("all.jsonl") + " " + Path("shard0.jsonl"));
  EXPECT_NE(overlapping.exit_code, 0);
  EXPECT_NE(overlapping.err.find("trial"), std::string::npos) << overlapping.err;
}

using testing::WindowCupMissionText;

TEST_F(BenchCliTest, AMissionOfOneReachGivesTheGoalsRecordsAndLongerMissionsRecordTheirSteps) {
  std::ofstream(Path("one_reach.yaml")) << WindowCupMissionText("");
  std::ofstream(Path("lift.yaml")) << WindowCupMissionText(
      "  - grasp:\n      object: {shape: {cylinder: {radius: 0.04, length: 0.10}}, "
      "pose: {position: [-3.2, 0.0, 0.85], orientation: [1, 0, 0, 0]}}\n  - move: {length: 0.15}\n");
  for (const char* name : {"one_reach", "lift"}) {
    std::string text = ReadAll(Config());
    text.replace(text.find("task: task.yaml"), std::string("task: task.yaml").size(),
                 std::string("task: ") + name + ".yaml");
    std::ofstream(Path(std::string(name) + "_bench.yaml")) << text;
  }
  const std::string trials = " --first 1 --trials 3";
  const auto goal = RunCommand(kBench + " --config " + Config() + trials + " --out " + Path("goal.jsonl"));
  ASSERT_EQ(goal.exit_code, 0) << goal.err;
  const auto reach =
      RunCommand(kBench + " --config " + Path("one_reach_bench.yaml") + trials + " --out " + Path("reach.jsonl"));
  ASSERT_EQ(reach.exit_code, 0) << reach.err;
  auto goal_records = Records({Path("goal.jsonl")});
  auto reach_records = Records({Path("reach.jsonl")});
  ASSERT_EQ(reach_records.size(), 3u);
  for (auto& [key, record] : reach_records) {
    ASSERT_TRUE(record.contains("steps")) << record;
    EXPECT_EQ(record["steps"].size(), 1u);
    record.erase("steps");
  }
  EXPECT_EQ(goal_records, reach_records);

  const auto lift = RunCommand(kBench + " --config " + Path("lift_bench.yaml") + trials + " --out " + Path("lift.jsonl"));
  ASSERT_EQ(lift.exit_code, 0) << lift.err;
  int successes = 0;
  for (const auto& [key, record] : Records({Path("lift.jsonl")})) {
    ASSERT_EQ(record["steps"].size(), 3u) << record;
    EXPECT_EQ(record["steps"][1]["kind"], "grasp");
    if (!record["success"].get<bool>()) continue;
    ++successes;
    for (const auto& step : record["steps"]) EXPECT_TRUE(step["certified"].get<bool>()) << record;
  }
  EXPECT_GE(successes, 2);
}

// The moving-cup benchmark (data/bench/moving_cup.yaml): trial k moves the
// cup at speeds[k % 4] in a heading drawn with seed k, passing its place in
// the task at pass_time; each record says how, the summary has a line per
// speed with the certified rate and the tool's distance to the cup.
TEST_F(BenchCliTest, TheMovingCupBenchmarkMovesEachTrialsCupAndSummarisesEachSpeed) {
  std::ofstream(Path("moving_cup.yaml")) << testing::BundledTaskText("moving_cup.yaml");
  std::string line, text;
  std::ifstream bench_in(kRoot + "/data/bench/moving_cup.yaml");
  while (std::getline(bench_in, line)) text += (line.rfind("task:", 0) == 0 ? "task: moving_cup.yaml" : line) + "\n";
  std::ofstream(Path("moving_bench.yaml")) << text;
  const auto r = RunCommand(kBench + " --config " + Path("moving_bench.yaml") + " --trials 4 --out " +
                            Path("moving.jsonl"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const double speeds[] = {0.0, 0.25, 0.5, 1.0};
  for (const auto& [key, record] : Records({Path("moving.jsonl")})) {
    const int k = record["trial"].get<int>();
    ASSERT_TRUE(record.contains("target")) << record;
    EXPECT_DOUBLE_EQ(record["target"]["speed_mps"].get<double>(), speeds[k % 4]);
    const double heading = record["target"]["heading_rad"].get<double>();
    // Along y within 0.1 rad, either way.
    EXPECT_LT(std::abs(std::cos(heading)), std::sin(0.1) + 1e-9) << heading;
    EXPECT_TRUE(record["success"].get<bool>()) << record;
    EXPECT_TRUE(record["certified"].get<bool>()) << record;
    EXPECT_LT(record["tool_to_target_m"].get<double>(), 0.002);
  }
  for (const char* speed : {"@ target 0.00 m/s", "@ target 0.25 m/s", "@ target 0.50 m/s", "@ target 1.00 m/s"}) {
    EXPECT_NE(r.out.find(speed), std::string::npos) << r.out;
  }
  EXPECT_NE(r.out.find("certified 1/1 (100.0 %); tool to target at the grasp"), std::string::npos) << r.out;

  // Bad target sections, and a target for a task whose cup does not move.
  std::ofstream(Path("negative.yaml")) << "task: moving_cup.yaml\nstart_box: {min: [0, 0, 1], max: [1, 1, 1.5]}\n"
                                          "target: {speeds: [0.5, -1]}\n";
  ExpectBadInput("--config " + Path("negative.yaml"), "negative.yaml: target.speeds[1]: expected a speed in [0, 100]");
  std::ofstream(Path("typo_target.yaml")) << "task: moving_cup.yaml\nstart_box: {min: [0, 0, 1], max: [1, 1, 1.5]}\n"
                                             "target: {speeds: [0.5], pass: 3}\n";
  ExpectBadInput("--config " + Path("typo_target.yaml"), "typo_target.yaml: target.pass: unknown key");
  std::ofstream(Path("still.yaml")) << "task: task.yaml\nstart_box: {min: [0, 0, 1], max: [1, 1, 1.5]}\n"
                                       "target: {speeds: [0.5]}\n";
  ExpectBadInput("--config " + Path("still.yaml"), "still.yaml: target: the task's goal.tool has no motion");
}

}  // namespace
}  // namespace quadhand
