// quadhand-online end to end on loopback UDP against quadhand-sim --udp
// --realtime: the default task flown to the cup; the vehicle killed in flight
// (exit 3 within the time-out); bad input (exit 2, one line, no log); --help;
// --dry-run.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "quadhand/core/isolated.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/scene/point_cloud.h"
#include "quadhand/sim/plan_io.h"
#include "support/posts_world.h"
#include "support/run_command.h"
#include "support/window_cup_scene.h"
#include "support/window_cup_task.h"

extern char** environ;

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using testing::CountLines;
using testing::ReadAll;
using testing::RunCommand;

const std::string kRoot = QUADHAND_SOURCE_DIR;
const std::string kOnline = std::string(QUADHAND_BIN_DIR) + "/quadhand-online";
const std::string kSim = std::string(QUADHAND_BIN_DIR) + "/quadhand-sim";
const std::string kProxy = std::string(QUADHAND_BIN_DIR) + "/quadhand-linkproxy";

const bool kSanitizedBuild = core::BuiltWithAddressSanitizer();

double Seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

// A UDP port that was free a moment ago.
int FreeUdpPort() {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address));
  socklen_t length = sizeof(address);
  getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  close(fd);
  return ntohs(address.sin_port);
}

// A child process with stdout and stderr in files.
struct Child {
  pid_t pid = -1;
  std::string out, err;
};

Child Spawn(const std::vector<std::string>& args, const std::string& out_base) {
  Child child;
  child.out = out_base + ".out";
  child.err = out_base + ".err";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, child.out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, child.err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const int rc = posix_spawn(&child.pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  EXPECT_EQ(rc, 0) << args[0];
  return child;
}

// Exit code, or -1 (and the child killed) after `timeout_s`.
int Wait(Child* child, double timeout_s) {
  const auto start = Clock::now();
  int status = 0;
  while (waitpid(child->pid, &status, WNOHANG) == 0) {
    if (Seconds(start) > timeout_s) {
      kill(child->pid, SIGKILL);
      waitpid(child->pid, &status, 0);
      child->pid = -1;
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  child->pid = -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

void Stop(Child* child) {
  if (child->pid <= 0) return;
  kill(child->pid, SIGTERM);
  Wait(child, 5.0);
}

class OnlineCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("quadhand_online_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    Stop(&sim_);
    fs::remove_all(dir_);
  }

  // The default task with absolute paths and the coarse SDFs.
  std::string WriteTask() {
    const std::string path = (dir_ / "task.yaml").string();
    std::ofstream(path) << testing::WindowCupTaskText();
    return path;
  }

  // quadhand-sim as the vehicle on a free loopback port, in real time.
  std::string StartVehicle(const std::string& task) {
    const int port = FreeUdpPort();
    const std::string url = "udp://127.0.0.1:" + std::to_string(port);
    sim_ = Spawn({kSim, "--udp", url, "--realtime", "--start-task", task, "--duration", "120", "-q", "--config",
                  kRoot + "/data/sim/quadhand_sim.yaml"},
                 (dir_ / "sim").string());
    return url;
  }

  // Flies the bundled mission `name` (data/tasks/missions/) over loopback
  // and expects it to arrive as ExpectBundledMissionArrives says.
  void FlyBundledMission(const std::string& name);

  fs::path dir_;
  Child sim_;
};

TEST_F(OnlineCliTest, FliesTheDefaultTaskToTheCupOverLoopback) {
  const std::string task = WriteTask();
  const std::string vehicle = StartVehicle(task);
  const std::string log = (dir_ / "flight.csv").string();
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--log", log, "--max-duration", "60"},
                       (dir_ / "online").string());
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out);
  ASSERT_EQ(code, 0) << out << ReadAll(online.err) << ReadAll(sim_.err);
  EXPECT_NE(out.find("OFFBOARD accepted"), std::string::npos) << out;
  EXPECT_NE(out.find("arming accepted"), std::string::npos) << out;
  EXPECT_NE(out.find("arrived after"), std::string::npos) << out;

  // The achieved setpoint rate is reported (not asserted: it depends on the machine's load).
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("setpoints at ([0-9.]+) Hz"))) << out;

  // From the log, independently of the program's own figures: the tool at
  // the last measured state is at the cup, and the flight stayed on the plan.
  auto robot = robot::RobotModel::LoadFromUrdfFile(kRoot + "/meshes/quadhand/quadhand.urdf");
  ASSERT_TRUE(robot.ok());
  auto flown = sim::LoadPlanCsv(log, robot->ActuatedJointNames());
  ASSERT_TRUE(flown.ok()) << flown.status().message();
  EXPECT_FALSE(fs::exists(log + ".partial"));  // renamed once complete
  const sim::PlanRow& last = flown->rows.back();
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(*robot, MakePose(last.position, last.attitude.toRotationMatrix()), last.joints, &kinematics);
  const Vec3 cup(-3.2, 0.0, 0.86);
  EXPECT_LT((kinematics.link_poses[robot->LinkIndex("tool")].translation() - cup).norm(), 0.02);
  // Tracking error while flying: 2-5 cm normally; the bound leaves room for
  // a loaded machine delaying the real-time simulator or the stream.
  ASSERT_TRUE(std::regex_search(out, m, std::regex("max ([0-9.]+) m\\n")));
  EXPECT_LT(std::stod(m[1]), 0.15) << out;
}

// A bundled mission's task with absolute robot and scene paths and the
// coarse SDFs (and optionally more text replacing a line).
std::string MissionTaskText(const std::string& name) {
  std::istringstream lines(ReadAll(kRoot + "/data/tasks/missions/" + name));
  std::string text, line;
  while (std::getline(lines, line)) {
    if (line.rfind("robot:", 0) == 0) line = "robot: " + kRoot + "/meshes/quadhand/quadhand.urdf";
    if (line.rfind("sdf_dir:", 0) == 0) line = "sdf_dir: " + testing::CoarseSdfDir();
    if (line.rfind("scene:", 0) == 0) line = "scene: " + kRoot + "/data/scenes/" + line.substr(line.rfind('/') + 1);
    text += line + "\n";
  }
  return text;
}

// A mission flown over loopback: planned as a whole, the gripper closed over
// MAVLink once the tool is on the plug (the simulator acknowledges it and
// carries the plug from then on), the robot and the plug judged by the
// rules of each step.
TEST_F(OnlineCliTest, FliesTheCableUnpluggingMissionAndCommandsTheGripper) {
  const std::string task = (dir_ / "task.yaml").string();
  std::ofstream(task) << MissionTaskText("cable_unplugging.yaml");
  const std::string vehicle = StartVehicle(task);
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--max-duration", "60"}, (dir_ / "online").string());
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out);
  ASSERT_EQ(code, 0) << out << ReadAll(online.err) << ReadAll(sim_.err);
  EXPECT_NE(out.find("closing the gripper (mission[1] (grasp))"), std::string::npos) << out;
  EXPECT_NE(out.find("gripper command of mission[1] (grasp) accepted"), std::string::npos) << out;
  EXPECT_NE(out.find("replans: 0 triggered"), std::string::npos) << out;  // a mission is flown as planned
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("held object: min clearance (-?[0-9.]+) m"))) << out;
  EXPECT_GE(std::stod(m[1]), 0.0) << out;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("gripper at mission\\[1\\] \\(grasp\\): the flown tool ([0-9.]+) m")))
      << out;
  EXPECT_LT(std::stod(m[1]), 0.01) << out;
}

// Half a second of outage mid-mission (the fault campaign's outage:0.5s
// row): the vehicle brakes along the plan, and the autopilot's
// offboard-loss failsafe takes it out of OFFBOARD meanwhile. Once the link
// is good, OFFBOARD is requested again, the vehicle goes back along its
// plan to the start of the leg and flies it again: the plug is grasped and
// pulled. Half a second without a state
// is more than --max-judged-gap: the flight is not called safe (exit 6),
// and the simulator's own record keeps the clearance.
TEST_F(OnlineCliTest, AMissionsOutageIsHeldThroughAndTheMissionResumed) {
  const std::string task = (dir_ / "task.yaml").string();
  std::ofstream(task) << MissionTaskText("cable_unplugging.yaml");
  const int sim_port = FreeUdpPort(), proxy_port = FreeUdpPort();
  const std::string vehicle = "udp://127.0.0.1:" + std::to_string(sim_port);
  const std::string proxy = "udp://127.0.0.1:" + std::to_string(proxy_port);
  sim_ = Spawn({kSim, "--udp", vehicle, "--realtime", "--start-task", task, "--duration", "120", "-q", "--config",
                kRoot + "/data/sim/quadhand_sim.yaml"},
               (dir_ / "sim").string());
  Child link = Spawn({kProxy, "--listen", proxy, "--vehicle", vehicle, "--outage", "4,0.5", "--seed", "1"},
                     (dir_ / "proxy").string());
  Child online = Spawn({kOnline, task, "--vehicle", proxy, "--max-duration", "60"}, (dir_ / "online").string());
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out);
  Stop(&link);
  Stop(&sim_);
  EXPECT_EQ(code, 6) << out << ReadAll(online.err);
  EXPECT_NE(out.find("CLEARANCE NOT VERIFIED"), std::string::npos) << out;
  EXPECT_NE(out.find("the autopilot left OFFBOARD during the link hold"), std::string::npos) << out;
  EXPECT_NE(out.find("resuming the mission: back along its plan"), std::string::npos) << out;
  EXPECT_NE(out.find("gripper command of mission[1] (grasp) accepted"), std::string::npos) << out;
  EXPECT_EQ(out.find("REFUSED"), std::string::npos) << out;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("gripper at mission\\[1\\] \\(grasp\\): the flown tool ([0-9.]+) m")))
      << out;
  EXPECT_LT(std::stod(m[1]), 0.01) << out;
}

// The other bundled missions, flown the same way: each arrives (exit 0: the
// online mode judged the robot and what it held on the vehicle's own
// states, within the safety distance less 2 mm) with the tool within 1 cm
// of every grasp and release (the targets, docs/benchmark.md).
void ExpectBundledMissionArrives(const std::string& out, const std::string& name) {
  EXPECT_NE(out.find("arrived after"), std::string::npos) << name << "\n" << out;
  EXPECT_NE(out.find("replans: 0 triggered"), std::string::npos) << name << "\n" << out;
  std::smatch m;
  std::string rest = out;
  int grippers = 0;
  while (std::regex_search(rest, m, std::regex("gripper at mission\\[[0-9]+\\] \\([a-z]+\\): the flown tool ([0-9.]+) m"))) {
    EXPECT_LT(std::stod(m[1]), 0.01) << name << "\n" << out;
    ++grippers;
    rest = m.suffix();
  }
  EXPECT_GE(grippers, 1) << name << "\n" << out;
}

void OnlineCliTest::FlyBundledMission(const std::string& name) {
  const std::string task = (dir_ / "task.yaml").string();
  std::ofstream(task) << MissionTaskText(name);
  const std::string vehicle = StartVehicle(task);
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--max-duration", "60"}, (dir_ / "online").string());
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out);
  ASSERT_EQ(code, 0) << name << "\n" << out << ReadAll(online.err) << ReadAll(sim_.err);
  ExpectBundledMissionArrives(out, name);
}

TEST_F(OnlineCliTest, FliesTheBundledDroneRescueWithinItsClearance) { FlyBundledMission("drone_rescue.yaml"); }

TEST_F(OnlineCliTest, FliesTheBundledGapCrossingGraspWithinItsClearance) { FlyBundledMission("gap_crossing_grasp.yaml"); }

TEST_F(OnlineCliTest, FliesTheBundledPlierPlacementWithinItsClearance) { FlyBundledMission("plier_placement.yaml"); }

// The narrow gap's start 3 (a reach through the 0.6 x 0.35 m gap), flown in
// lockstep with periodic replanning: no replan may turn the flight into a
// loop back through the gap. Until stop 55 a rejoining replan near the gap
// stretched a 0.13 s new part into a 3.4 s loop, and the periodic replans
// near the goal each spliced a plan several times longer than what was
// left: the vehicle crossed the gap five times, took 13-18 s and lost the
// clearance in 4 of 9 real-time flights. A certified periodic replan slower
// than what is left of the current plan is now dropped (one is, here).
TEST_F(OnlineCliTest, PeriodicReplansThroughTheNarrowGapNeverLoopBack) {
  const std::string task = (dir_ / "task.yaml").string();
  std::ofstream(task) << MissionTaskText("narrow_gap/start_3.yaml");
  const int port = FreeUdpPort();
  const std::string vehicle = "udp://127.0.0.1:" + std::to_string(port);
  sim_ = Spawn({kSim, "--udp", vehicle, "--start-task", task, "--duration", "120", "-q", "--config",
                kRoot + "/data/sim/quadhand_sim.yaml"},
               (dir_ / "sim").string());
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--max-duration", "40"}, (dir_ / "online").string());
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out);
  ASSERT_EQ(code, 0) << out << ReadAll(online.err) << ReadAll(sim_.err);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("arrived after ([0-9.]+) s"))) << out;
  // 1.9 s to take off, the 4.2-4.5 s plan and up to 2.5 s of settling.
  EXPECT_LT(std::stod(m[1]), 10.0) << out;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("([0-9]+) periodic dropped as slower"))) << out;
  EXPECT_GE(std::stoi(m[1]), 1) << out;
}

// A steady 3 m/s wind (the fault campaign's wind:3m/s row on this mission):
// the tilt into it moves the arm, and the tool stood 1.1 cm off its grasp
// pose, so the mission waited at its junction and ended holding (exit 1).
// Waiting there, the base's setpoints are shifted to bring the tool to its
// pose (--tool-trim), the cup is grasped within 1 cm and lifted.
TEST_F(OnlineCliTest, AMissionInSteadyWindShiftsTheBaseToBringTheToolToItsGrasp) {
  const std::string task = (dir_ / "task.yaml").string();
  std::ofstream(task) << MissionTaskText("gap_crossing_grasp.yaml");
  const std::string config = (dir_ / "windy.yaml").string();
  {
    std::istringstream lines(ReadAll(kRoot + "/data/sim/quadhand_sim.yaml"));
    std::ofstream windy(config);
    std::string line;
    while (std::getline(lines, line)) {
      if (line.rfind("robot:", 0) == 0) line = "robot: " + kRoot + "/meshes/quadhand/quadhand.urdf";
      windy << line << "\n";
    }
    windy << "faults: {wind: {steady: [-3, 1, 0]}}\n";
  }
  const int port = FreeUdpPort();
  const std::string vehicle = "udp://127.0.0.1:" + std::to_string(port);
  sim_ = Spawn({kSim, "--udp", vehicle, "--realtime", "--start-task", task, "--duration", "120", "-q", "--config",
                config},
               (dir_ / "sim").string());
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--max-duration", "60"}, (dir_ / "online").string());
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out);
  ASSERT_EQ(code, 0) << out << ReadAll(online.err) << ReadAll(sim_.err);
  EXPECT_NE(out.find("the base's setpoints shifted by"), std::string::npos) << out;
  ExpectBundledMissionArrives(out, "gap_crossing_grasp.yaml in wind");
}

// The dry run of a mission lists the gripper commands it would send.
TEST_F(OnlineCliTest, ADryRunOfAMissionListsItsGripperCommands) {
  const std::string task = (dir_ / "task.yaml").string();
  std::ofstream(task) << MissionTaskText("cable_unplugging.yaml");
  const auto r = RunCommand(kOnline + " " + task + " --dry-run");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("would command the gripper (MAV_CMD_DO_GRIPPER, grab) from plan time"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find(": mission[1] (grasp)"), std::string::npos) << r.out;
}

// A tool that never comes close enough to its grasp pose: the gripper is
// not closed, and the mission ends holding (exit 1), not "arrived".
TEST_F(OnlineCliTest, AMissionWhoseToolDoesNotSettleOnItsGraspEndsHolding) {
  const std::string task = (dir_ / "task.yaml").string();
  std::ofstream(task) << MissionTaskText("cable_unplugging.yaml");
  const std::string vehicle = StartVehicle(task);
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--max-duration", "15", "--gripper-tolerance", "0.00001"},
                       (dir_ / "online").string());
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out);
  EXPECT_EQ(code, 1) << out << ReadAll(online.err);
  EXPECT_NE(out.find("the tool did not settle within 0.0000 m of its pose for mission[1] (grasp)"), std::string::npos)
      << out;
  EXPECT_EQ(out.find("closing the gripper"), std::string::npos) << out;
}

// A vehicle that never settles at the first junction of a mission's legs
// (a tolerance no vehicle meets): the plan's clock waits there, and after
// --junction-timeout the mission ends holding (exit 1) before its grasp.
TEST_F(OnlineCliTest, AMissionThatDoesNotSettleAtAJunctionEndsHoldingThere) {
  const std::string task = (dir_ / "task.yaml").string();
  std::ofstream(task) << MissionTaskText("cable_unplugging.yaml");
  const std::string vehicle = StartVehicle(task);
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--max-duration", "12", "--junction-tolerance", "0.00001",
                        "--junction-timeout", "1"},
                       (dir_ / "online").string());
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out);
  EXPECT_EQ(code, 1) << out << ReadAll(online.err);
  EXPECT_NE(out.find("waiting at the end of leg 0 (mission[0] (reach)) for the vehicle to settle"), std::string::npos)
      << out;
  EXPECT_NE(out.find("the tool did not settle within 0.0000 m of its planned pose at the end of leg 0 (mission[0] "
                     "(reach)) in 1.0 s"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("closing the gripper"), std::string::npos) << out;
}

// The defect of stop 26: over 150 +- 50 ms with 10 % loss in bursts of 5,
// quadhand-online said "arrived" (exit 0) after a flight into the scene.
// Now it measures the latency, plans for it, and the simulator's own record
// of the flight keeps the safety distance (checked here against the exact
// meshes, independently of the program's figures).
TEST_F(OnlineCliTest, ASlowLossyLinkIsFlownWithinItsClearance) {
  const std::string task = WriteTask();
  const int sim_port = FreeUdpPort(), proxy_port = FreeUdpPort();
  const std::string vehicle = "udp://127.0.0.1:" + std::to_string(sim_port);
  const std::string proxy = "udp://127.0.0.1:" + std::to_string(proxy_port);
  const std::string flown = (dir_ / "sim_flown.csv").string();
  sim_ = Spawn({kSim, "--udp", vehicle, "--realtime", "--start-task", task, "--duration", "120", "-q", "--config",
                kRoot + "/data/sim/quadhand_sim.yaml", "--log", flown},
               (dir_ / "sim").string());
  Child link = Spawn({kProxy, "--listen", proxy, "--vehicle", vehicle, "--delay", "0.15", "--jitter", "0.05", "--loss",
                      "0.1", "--burst", "5", "--seed", "3"},
                     (dir_ / "proxy").string());
  Child online = Spawn({kOnline, task, "--vehicle", proxy, "--max-duration", "80"}, (dir_ / "online").string());
  const int code = Wait(&online, 100.0);
  const std::string out = ReadAll(online.out);
  Stop(&link);
  Stop(&sim_);
  EXPECT_NE(ReadAll(link.err).find("reordered"), std::string::npos) << ReadAll(link.err);
  // Exit 0 claims a kept clearance; exit 6 says it was lost: either is honest
  // and is checked against the simulator's record below; the plan must not
  // have failed.
  ASSERT_TRUE(code == 0 || code == 6) << code << "\n" << out << ReadAll(online.err);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("uplink median ([0-9.]+) ms"))) << out;
  EXPECT_GT(std::stod(m[1]), 100.0) << out;
  EXPECT_LT(std::stod(m[1]), 200.0) << out;

  auto robot = robot::RobotModel::LoadFromUrdfFile(kRoot + "/meshes/quadhand/quadhand.urdf");
  ASSERT_TRUE(robot.ok());
  auto rows = sim::LoadPlanCsv(flown, robot->ActuatedJointNames());
  ASSERT_TRUE(rows.ok()) << rows.status().message();
  robot::KinematicsState kinematics;
  double least = 1.0;
  for (const sim::PlanRow& row : rows->rows) {
    robot::ComputeKinematics(*robot, MakePose(row.position, row.attitude.toRotationMatrix()), row.joints, &kinematics);
    least = std::min(least, env::WholeBodyClearance(kinematics, *testing::WindowCup().exact, 0.3, {}));
  }
  const double required = 0.03 - 0.002;
  if (code == 0) {
    EXPECT_GE(least, required) << "exit 0 after a flight that came within " << least << " m\n" << out;
    const sim::PlanRow& last = rows->rows.back();
    robot::ComputeKinematics(*robot, MakePose(last.position, last.attitude.toRotationMatrix()), last.joints,
                             &kinematics);
    EXPECT_LT((kinematics.link_poses[robot->LinkIndex("tool")].translation() - Vec3(-3.2, 0.0, 0.86)).norm(), 0.01);
  } else {
    EXPECT_NE(out.find("CLEARANCE"), std::string::npos) << out;
  }
  EXPECT_GE(least, 0.0) << "the simulated vehicle went into the scene\n" << out;
}

// A hidden row of posts on a floor and a task across it (goal at rest),
// the task's scene the posts: what quadhand-sim --world renders; and the
// same task without a scene in posts_unseen.yaml.
std::string WritePostsTask(const fs::path& dir) {
  const std::vector<Vec3> world = testing::PostsWorld(/*with_floor=*/true);
  const std::string cloud = (dir / "posts.pcd").string();
  EXPECT_TRUE(scene::WritePcd(cloud, world).ok());
  const std::string task = (dir / "posts.yaml").string();
  const std::string common = "robot: " + kRoot + "/meshes/quadhand/quadhand.urdf\n" +
                             "sdf_dir: " + testing::CoarseSdfDir() + "\n" +
                             "start: {position: [0.0, 0.0, 1.2], yaw: 0.0, joints: [0.3, -0.2, 0.0]}\n"
                             "goal: {position: [8.0, 0.0, 1.2], yaw: 0.0, joints: [0.3, -0.2, 0.0]}\n"
                             "limits: {v_max: 2.0, a_max: 4.0, yaw_rate_max: 1.5, body_rate_xy_max: 3.0}\n"
                             "safety_distance: 0.03\n";
  std::ofstream(task) << common << "scene: " << cloud << "\n";
  // The same without a scene: what quadhand-online --perception is given.
  std::ofstream((dir / "posts_unseen.yaml").string()) << common;
  return task;
}

// quadhand-sim as the vehicle and its depth camera on the posts (frames sent
// to `frames_to`), quadhand-online --perception given `online_task` (by
// default the task without a scene) and receiving the frames on `frames`:
// its exit code and output, the simulator's record in `flown`.
std::pair<int, std::string> FlyPostsOnTheSensor(const fs::path& dir, const std::string& task,
                                                const std::string& frames_to, const std::string& frames,
                                                const std::string& flown, Child* sim,
                                                const std::string& online_task = "") {
  const std::string vehicle = "udp://127.0.0.1:" + std::to_string(FreeUdpPort());
  *sim = Spawn({kSim, "--udp", vehicle, "--realtime", "--start-task", task, "--duration", "120", "-q", "--config",
                kRoot + "/data/sim/quadhand_sim.yaml", "--world", (dir / "posts.pcd").string(), "--sensor", "depth",
                "--frames-to", frames_to, "--log", flown},
               (dir / "sim").string());
  Child online = Spawn({kOnline, online_task.empty() ? (dir / "posts_unseen.yaml").string() : online_task, "--vehicle",
                        vehicle, "--perception", "--frames",
                        frames, "--max-duration", "60"},
                       (dir / "online").string());
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out) + ReadAll(online.err);
  Stop(sim);
  return {code, out};
}

// quadhand-online --perception over loopback: quadhand-sim renders a depth
// camera's frames of a hidden row of posts from the true state and sends
// them beside the link; quadhand-online plans only from them, arrives, and
// the simulator's own record keeps the clearance against the true world.
TEST_F(OnlineCliTest, FliesUnseenPostsOnTheSensorsFramesOverLoopback) {
  const std::string task = WritePostsTask(dir_);
  const std::string frames = "udp://127.0.0.1:" + std::to_string(FreeUdpPort());
  const std::string flown = (dir_ / "sim_flown.csv").string();
  const auto [code, out] = FlyPostsOnTheSensor(dir_, task, frames, frames, flown, &sim_);
  ASSERT_EQ(code, 0) << out << ReadAll(sim_.err);
  EXPECT_NE(out.find("arrived after"), std::string::npos) << out;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("sensor: ([0-9]+) frames taken"))) << out;
  EXPECT_GT(std::stol(m[1]), 100) << out;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("local plans: ([0-9]+) \\(([0-9]+) to the goal, ([0-9]+) to local")))
      << out;
  EXPECT_GE(std::stoi(m[2]), 1) << out;
  EXPECT_GE(std::stoi(m[3]), 1) << out;  // the goal was hidden behind the first post
  ASSERT_TRUE(std::regex_search(out, m, std::regex("judged against ([0-9]+) points the sensor saw"))) << out;
  EXPECT_GT(std::stol(m[1]), 1000) << out;
  // The independent judge, against the true world.
  const auto check = RunCommand(std::string(QUADHAND_BIN_DIR) + "/quadhand-flightcheck " + task + " " + flown);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
}

// The posts known in advance: the task's scene is a prior map (obstacles
// where the sensor has seen nothing, no free space). The flight arrives and
// keeps its clearance; a scene that cannot be read is one error line.
TEST_F(OnlineCliTest, FliesPostsKnownFromThePriorMapOfTheTasksScene) {
  const std::string task = WritePostsTask(dir_);
  const std::string frames = "udp://127.0.0.1:" + std::to_string(FreeUdpPort());
  const std::string flown = (dir_ / "sim_flown.csv").string();
  const auto [code, out] = FlyPostsOnTheSensor(dir_, task, frames, frames, flown, &sim_, task);
  ASSERT_EQ(code, 0) << out << ReadAll(sim_.err);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("prior map: ([0-9]+) points from the task's scene"))) << out;
  EXPECT_GT(std::stol(m[1]), 1000) << out;
  EXPECT_NE(out.find("arrived after"), std::string::npos) << out;
  const auto check = RunCommand(std::string(QUADHAND_BIN_DIR) + "/quadhand-flightcheck " + task + " " + flown);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;

  std::string text = ReadAll(task);
  const size_t at = text.find("scene: ");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, text.find('\n', at) - at, "scene: " + (dir_ / "missing.pcd").string());
  const std::string broken = (dir_ / "posts_missing_scene.yaml").string();
  std::ofstream(broken) << text;
  const auto r = RunCommand(kOnline + " " + broken + " --vehicle udp://127.0.0.1:9 --perception");
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_EQ(CountLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("missing.pcd"), std::string::npos) << r.err;
  // Left out with --no-prior: the scene is not read at all.
  const auto unread =
      RunCommand(kOnline + " " + broken + " --vehicle udp://127.0.0.1:9 --perception --no-prior --max-duration 0.5");
  EXPECT_EQ(unread.err.find("missing.pcd"), std::string::npos) << unread.err;
}

// The same with the frames through quadhand-linkproxy and an outage of
// 1.5 s of them in flight: the sensor falls silent, the vehicle brakes and
// holds, and flies on with a fresh plan once frames return.
TEST_F(OnlineCliTest, ASensorOutageOverTheLinkBrakesAndTheFlightGoesOn) {
  const std::string task = WritePostsTask(dir_);
  const std::string frames = "udp://127.0.0.1:" + std::to_string(FreeUdpPort());
  const std::string proxied = "udp://127.0.0.1:" + std::to_string(FreeUdpPort());
  const std::string flown = (dir_ / "sim_flown.csv").string();
  Child link = Spawn({kProxy, "--listen", proxied, "--vehicle", frames, "--outage", "4,1.5", "--seed", "1"},
                     (dir_ / "proxy").string());
  const auto [code, out] = FlyPostsOnTheSensor(dir_, task, proxied, frames, flown, &sim_);
  Stop(&link);
  ASSERT_EQ(code, 0) << out << ReadAll(sim_.err);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("sensor silences: ([0-9]+); brakes for the sensor: ([0-9]+)")))
      << out;
  EXPECT_GE(std::stoi(m[1]), 1) << out;
  EXPECT_GE(std::stoi(m[2]), 1) << out;  // in flight when the frames stopped
  EXPECT_NE(out.find("braking along the plan"), std::string::npos) << out;
  EXPECT_NE(out.find("sensor frames again"), std::string::npos) << out;
  const auto check = RunCommand(std::string(QUADHAND_BIN_DIR) + "/quadhand-flightcheck " + task + " " + flown);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
}

// An estimate that jumps 2 cm mid-flight (faults.estimate of the simulator,
// docs/sim.md), followed (--follow-estimate-jumps), moves the real vehicle
// by minus the jump while its states say it is on track: the innovation
// gate catches the jump, and the flight is never called arrived (its
// clearance less the jump cannot be shown). The default, the setpoints
// shifted by the jump, is flown in latency_test.cc and in the fault
// campaign's smoke run.
TEST_F(OnlineCliTest, AFollowedEstimateJumpIsCaughtAndTheFlightNotCalledSafe) {
  const std::string task = WriteTask();
  const std::string config = (dir_ / "jump.yaml").string();
  {
    std::ofstream out(config);
    std::istringstream lines(ReadAll(kRoot + "/data/sim/quadhand_sim.yaml"));
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("robot:", 0) == 0) line = "robot: " + kRoot + "/meshes/quadhand/quadhand.urdf";
      out << line << "\n";
    }
    out << "faults: {estimate: {jump: {time: 3, offset: [0, 0.014, -0.014]}}}\n";
  }
  const int port = FreeUdpPort();
  const std::string vehicle = "udp://127.0.0.1:" + std::to_string(port);
  const std::string flown = (dir_ / "sim_flown.csv").string();
  sim_ = Spawn({kSim, "--udp", vehicle, "--realtime", "--start-task", task, "--duration", "120", "-q", "--config",
                config, "--log", flown},
               (dir_ / "sim").string());
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--max-duration", "80", "--follow-estimate-jumps"},
                       (dir_ / "online").string());
  const int code = Wait(&online, 100.0);
  const std::string out = ReadAll(online.out);
  Stop(&sim_);
  EXPECT_EQ(code, 6) << out << ReadAll(online.err);
  EXPECT_NE(out.find("CLEARANCE NOT VERIFIED"), std::string::npos) << out;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("the position estimate jumped 1 time\\(s\\), by ([0-9.]+) m")))
      << out;
  // 1.98 cm less what 4 m/s^2 explains over one telemetry period (0.8 mm).
  EXPECT_NEAR(std::stod(m[1]), 0.019, 0.001) << out;
  EXPECT_EQ(out.find("arrived after"), std::string::npos) << out;
}

// A flight not seen densely enough is not called safe: with a judged gap
// shorter than the telemetry period, every flight is "not verified".
TEST_F(OnlineCliTest, AFlightNotSeenDenselyEnoughExitsWithSix) {
  const std::string task = WriteTask();
  const std::string vehicle = StartVehicle(task);
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--max-judged-gap", "0.001", "--max-duration", "60"},
                       (dir_ / "online").string());
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out);
  EXPECT_EQ(code, 6) << out << ReadAll(online.err);
  // Not verified (the states it did see keep the clearance: the flight
  // margin leaves this task's flights about 6 mm above the safety distance
  // less the tolerance, docs/online.md), never "arrived".
  EXPECT_NE(out.find("CLEARANCE NOT VERIFIED"), std::string::npos) << out;
  EXPECT_EQ(out.find("arrived after"), std::string::npos) << out;
}

TEST_F(OnlineCliTest, TheLinkProxyRefusesBadFaultsInOneLine) {
  const std::string bad_yaml = (dir_ / "faults.yaml").string();
  std::ofstream(bad_yaml) << "both: {loss: 0.1, wind: 3}\n";
  const std::pair<std::string, std::string> cases[] = {
      {"--loss 1.5", "--loss"},
      {"--burst 0", "--burst"},
      {"--delay -1", "--delay"},
      {"--outage 3", "--outage"},
      {"--faults " + bad_yaml, "both.wind"},
      {"--faults " + (dir_ / "missing.yaml").string(), "missing.yaml"},
      {"--duration -2", "--duration"},
  };
  for (const auto& [args, expected] : cases) {
    const auto r = RunCommand(kProxy + " --listen udp://127.0.0.1:0 --vehicle udp://127.0.0.1:9 " + args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_EQ(CountLines(r.err), 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(expected), std::string::npos) << args << ": " << r.err;
  }
  const auto help = RunCommand(kProxy + " --help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* option : {"--listen", "--vehicle", "--faults", "--loss", "--burst", "--delay", "--jitter", "--fifo",
                             "--duplicate", "--corrupt", "--outage", "--seed", "--duration"}) {
    EXPECT_NE(help.out.find(option), std::string::npos) << option;
  }
}

// The log is written as the flight goes: killed in flight, quadhand-online
// leaves LOG.partial (its name says it is incomplete) with all but about the
// last second, readable as a plan file.
TEST_F(OnlineCliTest, AKilledOnlineModeLeavesItsLogSoFar) {
  const std::string task = WriteTask();
  const std::string vehicle = StartVehicle(task);
  const std::string log = (dir_ / "flight.csv").string();
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--log", log, "--max-duration", "60"},
                       (dir_ / "online").string());
  const auto start = Clock::now();
  while (ReadAll(online.out).find("flying the plan") == std::string::npos && Seconds(start) < 30.0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_NE(ReadAll(online.out).find("flying the plan"), std::string::npos) << ReadAll(online.out);
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  kill(online.pid, SIGKILL);
  Wait(&online, 5.0);
  EXPECT_FALSE(fs::exists(log));
  ASSERT_TRUE(fs::exists(log + ".partial"));
  auto robot = robot::RobotModel::LoadFromUrdfFile(kRoot + "/meshes/quadhand/quadhand.urdf");
  ASSERT_TRUE(robot.ok());
  auto rows = sim::LoadPlanCsv(log + ".partial", robot->ActuatedJointNames());
  ASSERT_TRUE(rows.ok()) << rows.status().message();
  // The rows reach into the flight: at least 1.5 s of the 2.5 s flown.
  std::smatch m;
  const std::string out = ReadAll(online.out);
  ASSERT_TRUE(std::regex_search(out, m, std::regex("\\[ *([0-9.]+) s\\] flying the plan"))) << out;
  EXPECT_GT(rows->rows.back().t, std::stod(m[1]) + 1.0) << "last row at " << rows->rows.back().t;
}

TEST_F(OnlineCliTest, ExitsWithThreeSoonAfterTheVehicleFallsSilent) {
  const std::string task = WriteTask();
  const std::string vehicle = StartVehicle(task);
  // (While flying, a silence is waited for as an outage up to
  // --outage-timeout: here as long as the vehicle time-out.)
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--vehicle-timeout", "0.5", "--outage-timeout", "0.5",
                        "--max-duration", "60"},
                       (dir_ / "online").string());
  // Kill the vehicle once the plan is being flown.
  const auto start = Clock::now();
  while (ReadAll(online.out).find("flying the plan") == std::string::npos && Seconds(start) < 30.0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_NE(ReadAll(online.out).find("flying the plan"), std::string::npos) << ReadAll(online.out);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  kill(sim_.pid, SIGKILL);
  Wait(&sim_, 5.0);
  const auto killed = Clock::now();
  const int code = Wait(&online, 10.0);
  const double after = Seconds(killed);
  const std::string out = ReadAll(online.out);
  EXPECT_EQ(code, 3) << out << ReadAll(online.err);
  EXPECT_NE(out.find("VEHICLE LOST"), std::string::npos) << out;
  EXPECT_NE(out.find("no position from the vehicle"), std::string::npos) << out;
  // Within the time-out, plus slack for process scheduling when the test
  // suite runs in parallel on a loaded machine (normally about 0.55 s).
  EXPECT_LT(after, 0.5 + 2.0) << out;
}

// The flight over a signed link while quadhand-mavlink-flood sends both
// ends 100 000 hostile frames/s (garbage, unsigned frames from a foreign
// system, frames signed with a wrong key, replays of genuinely signed
// frames): it still arrives, neither end accepts more frames than its real
// peer sent, and each hostile kind shows up in the drop counters. The
// setpoint rate is reported, not asserted (load); scripts/mavlink_flood.sh
// runs the 10 s version with the rate check.
TEST_F(OnlineCliTest, AFloodedSignedLinkStillFliesAndAcceptsNothingForged) {
  const std::string task = WriteTask();
  const std::string key = (dir_ / "link.key").string();
  std::ofstream(key) << std::string(64, 'a');
  const int sim_port = FreeUdpPort(), online_port = FreeUdpPort();
  const std::string vehicle = "udp://127.0.0.1:" + std::to_string(sim_port);
  const std::string bind = "udp://127.0.0.1:" + std::to_string(online_port);
  sim_ = Spawn({kSim, "--udp", vehicle, "--realtime", "--start-task", task, "--duration", "120", "--config",
                kRoot + "/data/sim/quadhand_sim.yaml", "--signing-key", key, "--require-signing"},
               (dir_ / "sim").string());
  Child online = Spawn({kOnline, task, "--vehicle", vehicle, "--bind", bind, "--signing-key", key,
                        "--require-signing", "--max-duration", "60"},
                       (dir_ / "online").string());
  // A sanitized build starts and checks every frame several times slower:
  // flooded at the full rate, or before it has settled into its stream, its
  // kernel buffer overflows and drops the vehicle's own positions too, until
  // the vehicle counts as lost (the safe reaction, but not what this test is
  // about). It gets 3 s to start and a hundredth of the rate.
  std::this_thread::sleep_for(std::chrono::milliseconds(kSanitizedBuild ? 3000 : 800));
  const long rate = kSanitizedBuild ? 1000 : 100000;
  Child flood = Spawn({std::string(QUADHAND_BIN_DIR) + "/quadhand-mavlink-flood", "--target", vehicle + ",1,191",
                       "--target", bind + ",1,1", "--key", key, "--rate", std::to_string(rate), "--seconds", "3"},
                      (dir_ / "flood").string());
  EXPECT_EQ(Wait(&flood, 30.0), 0) << ReadAll(flood.err);
  const int code = Wait(&online, 90.0);
  const std::string out = ReadAll(online.out);
  ASSERT_EQ(code, 0) << out << ReadAll(online.err);
  kill(sim_.pid, SIGTERM);
  Wait(&sim_, 10.0);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("link: ([0-9]+) frames accepted \\(([0-9]+) from other systems, "
                                                   "ignored\\), ([0-9]+) sent; dropped: [0-9]+ bad CRC, ([0-9]+) "
                                                   "unsigned, ([0-9]+) bad signature, ([0-9]+) replayed")))
      << out;
  const long online_accepted = std::stol(m[1]), online_sent = std::stol(m[3]);
  EXPECT_EQ(std::stol(m[2]), 0);
  EXPECT_GT(std::stol(m[4]), 0);  // the foreign system's unsigned frames
  EXPECT_GT(std::stol(m[5]), 0);  // forged
  EXPECT_GT(std::stol(m[6]), 0);  // replayed
  const std::string sim_err = ReadAll(sim_.err);
  ASSERT_TRUE(std::regex_search(sim_err, m, std::regex("frames received ([0-9]+), sent ([0-9]+) .*dropped: [0-9]+ bad "
                                                       "CRC, ([0-9]+) unsigned, ([0-9]+) bad signature, ([0-9]+) "
                                                       "replayed")))
      << sim_err;
  EXPECT_LE(std::stol(m[1]), online_sent) << "the simulator accepted frames quadhand-online never sent";
  EXPECT_LE(online_accepted, std::stol(m[2])) << "quadhand-online accepted frames the simulator never sent";
  for (int kind = 3; kind <= 5; ++kind) EXPECT_GT(std::stol(m[kind]), 0) << kind;
  const std::string flooded = ReadAll(flood.out);
  const std::regex frames_sent("([0-9]+) frames in");
  for (auto it = std::sregex_iterator(flooded.begin(), flooded.end(), frames_sent);
       it != std::sregex_iterator(); ++it) {
    EXPECT_GE(std::stol((*it)[1]), 29 * rate / 10) << flooded;  // the rate for 3 s, to each end
  }
  ASSERT_TRUE(std::regex_search(out, m, std::regex("setpoints at ([0-9.]+) Hz")));
  std::printf("setpoint rate under the flood: %s Hz\n", m[1].str().c_str());
}

TEST_F(OnlineCliTest, BadInputIsOneLineAndExitCodeTwo) {
  const std::string task = WriteTask();
  const std::string log = (dir_ / "flight.csv").string();
  const std::string vehicle = " --vehicle udp://127.0.0.1:14999";
  const std::pair<std::string, std::string> cases[] = {
      {task + vehicle + " --rate 0 --log " + log, "--rate"},
      {task + vehicle + " --hold-time 0.5 --log " + log, "--hold-time"},
      {task + vehicle + " --vehicle-timeout -1", "--vehicle-timeout"},
      {task + vehicle + " --vehicle-timeout 1e300", "--vehicle-timeout must be in (0, 60] s"},
      {task + vehicle + " --hold-time 1e300 --log " + log, "--hold-time must be in [1, 60] s"},
      {task + vehicle + " --arrival-hold 1e9", "--arrival-hold must be in [0, 60] s"},
      {task + vehicle + " --arrival-tolerance 0", "--arrival-tolerance must be in (0, 1] m"},
      {task + vehicle + " --arrival-tolerance nan", "--arrival-tolerance"},
      {task + vehicle + " --arrival-settle-speed 0", "--arrival-settle-speed must be in (0, 1] m/s"},
      {task + vehicle + " --arrival-settle-speed 2", "--arrival-settle-speed must be in (0, 1] m/s"},
      {task + vehicle + " --arrival-settle-speed inf", "--arrival-settle-speed"},
      {task + vehicle + " --max-state-age 0", "--max-state-age"},
      {task + vehicle + " --link-budget nan", "--link-budget"},
      {task + vehicle + " --max-blind-time -1", "--max-blind-time"},
      {task + vehicle + " --min-link-speed 0", "--min-link-speed"},
      {task + vehicle + " --clearance-tolerance 0.5", "--clearance-tolerance"},
      {task + vehicle + " --max-judged-gap 0", "--max-judged-gap"},
      {task + vehicle + " --arrival-hold 2 --arrival-timeout 1", "--arrival-timeout must be in [--arrival-hold, 60] s"},
      {task + vehicle + " --arrival-hold 20 --arrival-timeout 61", "--arrival-timeout must be in [--arrival-hold, 60] s"},
      {task + vehicle + " --replan-period -1", "--replan-period"},
      {task + vehicle + " --replan-threshold 0", "--replan-threshold"},
      {task + " --vehicle localhost:14999", "udp://"},
      {task + vehicle + " --bind udp://127.0.0.1", "--bind"},
      {task + vehicle + " --require-signing", "--signing-key"},
      {task + vehicle + " --signing-key " + (dir_ / "missing.key").string(), "missing.key"},
      {task, "--vehicle"},
      {task + " --dry-run --log " + log, "--log"},
      {task + vehicle + " --log " + (dir_ / "no" / "such" / "flight.csv").string(), "--log"},
      {(dir_ / "missing.yaml").string() + vehicle + " --log " + log, "missing.yaml"},
      {task + vehicle + " --no-such-option", "--no-such-option"},
      {task + vehicle + " --threads -1", "--threads"},
      {task + vehicle + " --package-path /nonexistent-quadhand-packages", "nonexistent-quadhand-packages"},
      {task + vehicle + " --threads 1000", "--threads"},
      {task + vehicle + " --tool-trim 0.5", "--tool-trim must be in [0, 0.1] m"},
      {task + vehicle + " --tool-trim nan", "--tool-trim"},
      {task + vehicle + " --setpoint-lead 0.5", "--setpoint-lead must be at most 0.1 s"},
      {task + vehicle + " --setpoint-lead nan", "--setpoint-lead"},
      {task + vehicle + " --ack-timeout 0", "--ack-timeout must be in (0, 10] s"},
      {task + vehicle + " --command-attempts 0", "--command-attempts must be in [1, 100]"},
      {task + vehicle + " --command-attempts 1000", "--command-attempts must be in [1, 100]"},
      {task + vehicle + " --target-acceleration-noise 0", "--target-acceleration-noise must be in (0, 100]"},
      {task + vehicle + " --target-noise nan", "--target-noise must be in (0, 1] m"},
      {task + vehicle + " --target-replan-threshold 1e400", "--target-replan-threshold must be in (0, 1] m"},
      {task + vehicle + " --target-timeout 0", "--target-timeout must be in (0, 60] s"},
      {task + vehicle + " --target-tolerance -1", "--target-tolerance must be in (0, 1] m"},
      {task + vehicle + " --perception --frames tcp://127.0.0.1:1", "--frames"},
      {task + vehicle + " --perception --sensor-timeout 0", "sensor_timeout"},
      {task + vehicle + " --perception --map-resolution nan", "--perception"},
      {task + vehicle + " --perception --local-max-speed -1", "--perception"},
      {task + " --perception --dry-run", "--dry-run"},
      {task + vehicle + " --no-prior", "--no-prior needs --perception"},
      // The default task's goal is a tool pose: not flown on the sensor yet.
      {task + vehicle + " --perception", "goal at rest"},
  };
  for (const auto& [args, fragment] : cases) {
    const auto r = RunCommand(kOnline + " " + args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.out << r.err;
    EXPECT_EQ(CountLines(r.err), 1) << args << "\n" << r.err;
    EXPECT_NE(r.err.find("quadhand-online: error"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << args << "\n" << r.err;
    EXPECT_TRUE(r.out.empty()) << args << "\n" << r.out;
    EXPECT_FALSE(fs::exists(log)) << args;
  }
}

TEST_F(OnlineCliTest, HelpListsEveryOption) {
  const auto r = RunCommand(kOnline + " --help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* option : {"--vehicle", "--bind", "--rate", "--signing-key", "--require-signing", "--log",
                             "--dry-run", "--vehicle-timeout", "--replan-threshold", "--hold-time", "--quiet",
                             "--max-duration", "--arrival-hold", "--arrival-tolerance", "--arrival-settle-speed", "--arrival-timeout", "--no-replan", "--target-system", "--system-id", "--threads", "--package-path",
                             "--no-timesync", "--max-state-age", "--link-budget", "--max-blind-time", "--min-link-speed",
                             "--clearance-tolerance", "--max-judged-gap", "--tool-trim", "--setpoint-lead", "--ack-timeout",
                             "--command-attempts", "--target-acceleration-noise", "--target-noise",
                             "--target-replan-threshold", "--target-timeout", "--target-tolerance", "--perception", "--frames",
                             "--map-resolution", "--sensor-timeout", "--max-frame-age", "--local-replan-period",
                             "--stuck-time", "--local-max-speed", "Exit codes"}) {
    EXPECT_NE(r.out.find(option), std::string::npos) << option;
  }
}

TEST_F(OnlineCliTest, DryRunPrintsWhatWouldBeStreamed) {
  // (A long --arrival-hold alone is accepted: the default --arrival-timeout grows with it.)
  const auto r = RunCommand(kOnline + " " + WriteTask() +
                            " --dry-run --rate 25 --arrival-hold 20 --threads 1 --arrival-settle-speed 0.02 --hold-time 2.5");
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("at 25.0 Hz"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("after >= 2.5 s of hold"), std::string::npos) << r.out;  // the --hold-time given
  EXPECT_NE(r.out.find("first setpoints"), std::string::npos) << r.out;
  // The task's start in NED: north 0.2, east 0.5, down -1.2; yaw pi (west) is -pi/2 from north.
  EXPECT_NE(r.out.find("NED p=(  0.200   0.500  -1.200)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("yaw=-1.571"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace quadhand
