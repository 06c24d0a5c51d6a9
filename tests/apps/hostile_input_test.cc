// Every file a user hands to a program, replaced in turn by each kind of
// hostile file (missing, a folder, a FIFO, /dev/zero, empty, binary garbage,
// truncated, a symlink loop, a YAML alias bomb, 64 GiB of zeros without a
// line break, a name with a line break), for every command-line program: exit code 2,
// one stderr line naming the path as the user gave it, no file left in the
// output folder, no hang (each run has a time limit). Then the same
// programs still work on good input. The per-program tests (plan_test.cc,
// bench_test.cc, sdfgen_test.cc, sim_cli_test.cc, online_cli_test.cc) hold
// the format-specific cases.
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "support/run_command.h"
#include "support/window_cup_task.h"

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using testing::CountLines;
using testing::ReadAll;
using testing::RunCommand;

const std::string kBin = QUADHAND_BIN_DIR;
const std::string kRoot = QUADHAND_SOURCE_DIR;

class HostileInputTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("quadhand_hostile_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "in");
    // Good inputs.
    std::ofstream(In("task.yaml")) << testing::WindowCupTaskText();
    std::string bench = "task: " + In("task.yaml") + "\nstart_box: {min: [-1.8, -0.4, 0.9], max: [-1.4, 0.4, 1.3]}\n";
    std::ofstream(In("bench.yaml")) << bench;
    std::ofstream(In("cube.off")) << "OFF\n8 6 0\n-0.05 -0.05 -0.05\n0.05 -0.05 -0.05\n0.05 0.05 -0.05\n"
                                     "-0.05 0.05 -0.05\n-0.05 -0.05 0.05\n0.05 -0.05 0.05\n0.05 0.05 0.05\n"
                                     "-0.05 0.05 0.05\n4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n"
                                     "4 3 0 4 7\n";
    std::string plan =
        "t,px,py,pz,vx,vy,vz,ax,ay,az,qw,qx,qy,qz,yaw,yaw_rate,joint1,joint2,joint3,joint1_rate,joint2_rate,"
        "joint3_rate\n";
    for (int k = 0; k <= 20; ++k) plan += std::to_string(0.01 * k) + ",0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.3,0.1,0,0,0,0\n";
    std::ofstream(In("plan.csv")) << plan;
    // Hostile ones, by kind; each is what the user names on the command line.
    for (const auto& kind : Kinds()) MakeHostile(kind.first);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static std::string In(const std::string& name) { return (dir_ / "in" / name).string(); }
  static std::string Out() { return (dir_ / "out").string(); }

  // (kind, the hostile file's path for that kind).
  static std::vector<std::pair<std::string, std::string>> Kinds() {
    return {{"missing", In("missing.file")},   {"folder", In("folder")},       {"fifo", In("fifo")},
            {"device", "/dev/zero"},           {"empty", In("empty.file")},    {"garbage", In("garbage.file")},
            {"truncated", In("truncated.file")}, {"loop", In("loop.file")}, {"alias bomb", In("bomb.file")},
            {"64 GiB of zeros", In("zeros.file")}, {"a line break in the name", In("line\nbreak.file")}};
  }

  // How a message names `path`: control characters escaped (core::PrintError).
  static std::string AsPrinted(std::string path) {
    for (size_t at = path.find('\n'); at != std::string::npos; at = path.find('\n', at + 2)) path.replace(at, 1, "\\n");
    return path;
  }

  static void MakeHostile(const std::string& kind) {
    if (kind == "folder") fs::create_directories(In("folder"));
    if (kind == "fifo") {
      ASSERT_EQ(mkfifo(In("fifo").c_str(), 0600), 0);
    }
    if (kind == "empty") std::ofstream(In("empty.file"));
    if (kind == "garbage") {
      std::mt19937 rng(7);
      std::string bytes(4096, '\0');
      for (char& c : bytes) c = static_cast<char>(rng() & 0xff);
      std::ofstream(In("garbage.file"), std::ios::binary) << bytes;
    }
    if (kind == "truncated") {
      const std::string task = ReadAll(In("task.yaml"));
      std::ofstream(In("truncated.file")) << task.substr(0, task.size() / 3) << "start: {position: [1, ";
    }
    if (kind == "loop") fs::create_symlink(In("loop.file"), In("loop.file"));
    if (kind == "alias bomb") {  // 9^9 nodes from 300 bytes
      std::string bomb = "a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n";
      for (char level = 'b'; level <= 'i'; ++level) {
        bomb += std::string(1, level) + ": &" + level + " [";
        for (int k = 0; k < 9; ++k) bomb += std::string(k ? ", " : "") + "*" + static_cast<char>(level - 1);
        bomb += "]\n";
      }
      std::ofstream(In("bomb.file")) << bomb;
    }
    if (kind == "64 GiB of zeros") {  // sparse: no line break anywhere, far more than fits in memory
      std::ofstream(In("zeros.file"));
      fs::resize_file(In("zeros.file"), 64ull << 30);
    }
  }

  // Runs `line` against a fresh, empty output folder and checks the
  // contract; `hostile` is the path the message must name.
  void ExpectRefused(const std::string& program, const std::string& line, const std::string& hostile,
                     const std::string& kind) {
    fs::remove_all(Out());
    fs::create_directories(Out());
    const auto r = RunCommand("timeout 60 " + kBin + "/" + program + " " + line);
    SCOPED_TRACE(program + " " + line + " (" + kind + ")");
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(CountLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(hostile), std::string::npos) << "the message does not name the file: " << r.err;
    EXPECT_NE(r.err.find(program + ": error"), std::string::npos) << r.err;
    std::vector<std::string> left;
    for (const auto& entry : fs::recursive_directory_iterator(Out())) left.push_back(entry.path().string());
    EXPECT_TRUE(left.empty()) << "left behind: " << (left.empty() ? "" : left.front());
  }

  static fs::path dir_;
};

fs::path HostileInputTest::dir_;

// One file argument of a program; {} in the command is the file.
struct FileArgument {
  std::string program, command;
};

TEST_F(HostileInputTest, EveryFileArgumentOfEveryProgramRefusesEveryKindOfHostileFile) {
  const std::string out = Out();
  const std::string vehicle = " --vehicle udp://127.0.0.1:9 ";
  const std::string sim_config = " --config " + kRoot + "/data/sim/quadhand_sim.yaml ";
  const std::vector<FileArgument> arguments = {
      {"quadhand-plan", "{} --out " + out + "/plan.csv --report " + out + "/report.json"},
      {"quadhand-plan", In("task.yaml") + " --planner-config {} --out " + out + "/plan.csv --report " + out +
                            "/report.json"},
      {"quadhand-sdfgen", "--urdf {} --out " + out + "/sdf"},
      {"quadhand-sdfgen", "--mesh {} --link cube --out " + out + "/sdf"},
      {"quadhand-sdfgen", "info {}"},
      {"quadhand-sdfgen", "probe {} 0 0 0"},
      {"quadhand-bench", "--config {} --trials 1 --out " + out + "/bench.jsonl"},
      {"quadhand-bench", "--config " + In("bench.yaml") + " --planner-config {} --trials 1 --out " + out +
                             "/bench.jsonl"},
      {"quadhand-sim", "--track {}" + sim_config + "--out " + out + "/flown.csv"},
      {"quadhand-sim", "--track " + In("plan.csv") + " --config {} --out " + out + "/flown.csv"},
      {"quadhand-sim", "--udp udp://127.0.0.1:39999 --duration 1" + sim_config + "--start-task {} --log " + out +
                           "/flown.csv"},
      {"quadhand-sim", "--udp udp://127.0.0.1:39999 --duration 1" + sim_config + "--signing-key {} --log " + out +
                           "/flown.csv"},
      {"quadhand-online", "{}" + vehicle + "--log " + out + "/flight.csv"},
      {"quadhand-online", In("task.yaml") + vehicle + "--planner-config {} --log " + out + "/flight.csv"},
      {"quadhand-online", In("task.yaml") + vehicle + "--signing-key {} --log " + out + "/flight.csv"},
  };
  for (const FileArgument& argument : arguments) {
    for (const auto& [kind, path] : Kinds()) {
      std::string line = argument.command;
      line.replace(line.find("{}"), 2, "'" + path + "'");  // quoted: a name may hold a line break
      ExpectRefused(argument.program, line, AsPrinted(path), kind);
    }
  }
  // Files a task names (scene, robot): the path as the task writes it.
  for (const std::string key : {"scene", "robot"}) {
    for (const auto& [kind, path] : Kinds()) {
      if (path.find('\n') != std::string::npos) continue;  // not a YAML scalar as it stands
      std::ofstream(In("named.yaml")) << testing::WindowCupTaskText({{key + ":", key + ": " + path}});
      ExpectRefused("quadhand-plan", In("named.yaml") + " --out " + out + "/plan.csv --report " + out + "/report.json",
                    path, key + " " + kind);
    }
  }
}

// After all that, the programs still do their work on good input.
TEST_F(HostileInputTest, TheProgramsStillWorkOnGoodInput) {
  const std::string out = Out();
  fs::remove_all(out);
  fs::create_directories(out);
  const auto plan = RunCommand(kBin + "/quadhand-plan " + In("task.yaml") + " --out " + out + "/plan.csv --report " +
                               out + "/report.json");
  EXPECT_EQ(plan.exit_code, 0) << plan.err;
  EXPECT_TRUE(fs::exists(out + "/plan.csv"));
  const auto sdf = RunCommand(kBin + "/quadhand-sdfgen -q --mesh " + In("cube.off") + " --link cube --out " + out +
                              "/sdf --resolution 0.01");
  EXPECT_EQ(sdf.exit_code, 0) << sdf.err;
  EXPECT_TRUE(fs::exists(out + "/sdf/cube.qhsdf"));
  const auto flown = RunCommand(kBin + "/quadhand-sim -q --track " + In("plan.csv") + " --config " + kRoot +
                                "/data/sim/quadhand_sim.yaml --out " + out + "/flown.csv");
  EXPECT_EQ(flown.exit_code, 0) << flown.err;
  const auto bench = RunCommand(kBin + "/quadhand-bench --config " + In("bench.yaml") + " --trials 1 --out " + out +
                                "/bench.jsonl");
  EXPECT_EQ(bench.exit_code, 0) << bench.err;
}

}  // namespace
}  // namespace quadhand
