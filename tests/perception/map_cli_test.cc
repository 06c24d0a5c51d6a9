// quadhand-map (docs/perception.md): a folder of frames into the rolling
// map, the occupied voxels' raw returns and the unknown voxels written; the
// bad rows and clouds of a recording dropped and counted; bad input exit 2.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "quadhand/core/text.h"
#include "quadhand/scene/point_cloud.h"
#include "quadhand/scene/ros_bag.h"
#include "support/run_command.h"
#include "support/window_cup_task.h"

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using testing::RunCommand;

const std::string kMap = std::string(QUADHAND_BIN_DIR) + "/quadhand-map";

class MapCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("quadhand_map_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "frames");
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// Frames of a wall 3 m ahead of a sensor at the origin (sensor frame = world,
// identity pose), with every kind of bad row and cloud among them.
TEST_F(MapCliTest, MapsTheFramesAndCountsWhatItDrops) {
  std::vector<Vec3> wall;
  for (double y = -1.0; y <= 1.0 + 1e-9; y += 0.05) {
    for (double z = -1.0; z <= 1.0 + 1e-9; z += 0.05) wall.emplace_back(3.0, y, z);
  }
  const fs::path frames = dir_ / "frames";
  ASSERT_TRUE(scene::WritePcd((frames / "a.pcd").string(), wall).ok());
  ASSERT_TRUE(scene::WritePcd((frames / "b.pcd").string(), wall).ok());
  ASSERT_TRUE(scene::WritePcd((frames / "empty.pcd").string(), {}).ok());
  std::ofstream(frames / "truncated.pcd") << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
                                              "COUNT 1 1 1\nWIDTH 100\nHEIGHT 1\nPOINTS 100\nDATA binary\nabc";
  std::ofstream(frames / "frames.csv") << "index,t,file,x,y,z,qw,qx,qy,qz\n"
                                          "0,0.0,a.pcd,0,0,0,1,0,0,0\n"
                                          "1,0.1,b.pcd,0,0,0,1,0,0,0\n"
                                          "2,0.05,a.pcd,0,0,0,1,0,0,0\n"        // out of order
                                          "3,0.2,a.pcd,0,0,nan,1,0,0,0\n"       // malformed (NaN)
                                          "4,0.3,a.pcd,0,0,0,1,1,0,0\n"         // bad pose (not unit)
                                          "5,0.4,a.pcd,0,0\n"                    // malformed (short)
                                          "6,0.5,missing.pcd,0,0,0,1,0,0,0\n"   // unreadable
                                          "7,0.6,truncated.pcd,0,0,0,1,0,0,0\n" // unreadable
                                          "8,0.7,empty.pcd,0,0,0,1,0,0,0\n";    // empty: nothing seen
  const std::string out = (dir_ / "occupied.pcd").string(), unknown = (dir_ / "unknown.pcd").string();
  const auto r = RunCommand(kMap + " " + frames.string() + " --out " + out + " --unknown-out " + unknown +
                            " --unknown-box 1.5,-0.2,-0.2,4,0.2,0.2 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["frames"].get<int>(), 2);
  EXPECT_EQ(j["empty_frames"].get<int>(), 1);
  EXPECT_EQ(j["rows_out_of_order"].get<int>(), 1);
  EXPECT_EQ(j["rows_malformed"].get<int>(), 2);
  EXPECT_EQ(j["rows_bad_pose"].get<int>(), 1);
  EXPECT_EQ(j["clouds_unreadable"].get<int>(), 2);
  auto occupied = scene::LoadPcd(out);
  ASSERT_TRUE(occupied.ok()) << occupied.status().message();
  ASSERT_FALSE(occupied->points.empty());
  for (const Vec3& p : occupied->points) EXPECT_NEAR(p.x(), 3.0, 1e-6);
  // Unknown: only behind the wall, in this box straight ahead.
  auto behind = scene::LoadPcd(unknown);
  ASSERT_TRUE(behind.ok()) << behind.status().message();
  EXPECT_EQ(static_cast<long>(behind->points.size()), j["unknown_voxels"].get<long>());
  for (const Vec3& c : behind->points) EXPECT_GT(c.x(), 3.0);
}

// The same frames as a ROS 1 bag (--bag) and as a folder: the same map.
// The sensor sits on a base that moves and turns; the bag places each cloud
// by /tf (world <- base_link <- quadhand_sensor) or by the odometry and
// the extrinsic; the folder by each frame's pose.
TEST_F(MapCliTest, MapsABagAsItMapsTheSameFramesInAFolder) {
  std::vector<Vec3> wall;
  for (double y = -1.5; y <= 1.5 + 1e-9; y += 0.03) {
    for (double z = 0.0; z <= 2.0 + 1e-9; z += 0.03) wall.emplace_back(4.0, y, z);
  }
  const Pose sensor_to_base = MakePose(Vec3(0.1, 0.0, -0.05), Quat(0.98, 0.0, 0.15, 0.0).normalized().toRotationMatrix());
  const std::string bag = (dir_ / "frames.bag").string();
  auto writer = scene::BagWriter::Create(bag);
  ASSERT_TRUE(writer.ok());
  std::string index = "index,t,file,x,y,z,qw,qx,qy,qz\n";
  for (int i = 0; i < 4; ++i) {
    const Pose base = MakePose(Vec3(0.3 * i, 0.1 * i, 1.0), Quat(Eigen::AngleAxisd(0.1 * i, Vec3::UnitZ())).toRotationMatrix());
    const Pose sensor = base * sensor_to_base;
    std::vector<Vec3> seen;
    for (const Vec3& p : wall) seen.push_back(sensor.inverse() * p);
    ASSERT_TRUE((*writer)->Write(0.1 * i, base, sensor_to_base, seen).ok());
    const std::string file = "f" + std::to_string(i) + ".pcd";
    ASSERT_TRUE(scene::WritePcd((dir_ / "frames" / file).string(), seen).ok());
    const Quat q(sensor.linear());
    index += core::Format("%d,%.3f,%s,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", i, 0.1 * i, file.c_str(),
                          sensor.translation().x(), sensor.translation().y(), sensor.translation().z(), q.w(), q.x(),
                          q.y(), q.z());
  }
  ASSERT_TRUE((*writer)->Close().ok());
  std::ofstream(dir_ / "frames" / "frames.csv") << index;
  auto map = [&](const std::string& args, const std::string& out) {
    const auto r = RunCommand(kMap + " " + args + " --out " + out + " --json");
    EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.err;
    const auto points = scene::LoadPcd(out);
    EXPECT_TRUE(points.ok()) << out;
    return std::make_pair(r.exit_code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json(),
                          points.ok() ? points->points : std::vector<Vec3>{});
  };
  const auto [folder_json, folder] = map((dir_ / "frames").string(), (dir_ / "folder.pcd").string());
  const auto [tf_json, by_tf] = map("--bag " + bag + " --cloud-topic /quadhand/points", (dir_ / "tf.pcd").string());
  const Quat e(sensor_to_base.linear());
  const auto [odom_json, by_odom] =
      map("--bag " + bag + " --cloud-topic /quadhand/points --odom-topic /quadhand/odom --extrinsic " +
              core::Format("0.1,0,-0.05,%.17g,%.17g,%.17g,%.17g", e.w(), e.x(), e.y(), e.z()),
          (dir_ / "odom.pcd").string());
  ASSERT_FALSE(folder.empty());
  EXPECT_EQ(tf_json["frames"].get<int>(), 4);
  EXPECT_EQ(tf_json["bag_messages"].get<int>(), 4);
  EXPECT_EQ(tf_json["bag_poses"].get<int>(), 8);
  EXPECT_EQ(odom_json["bag_poses"].get<int>(), 4);
  EXPECT_EQ(by_tf.size(), folder.size());
  EXPECT_EQ(by_odom.size(), folder.size());
  EXPECT_EQ(tf_json["known_voxels"], folder_json["known_voxels"]);
  // Every return lands on the wall, whichever way it was placed.
  for (const auto* points : {&folder, &by_tf, &by_odom}) {
    for (const Vec3& p : *points) ASSERT_NEAR(p.x(), 4.0, 1e-5);
  }
}

TEST_F(MapCliTest, BadInputIsOneLineAndNoOutput) {
  const std::string out = (dir_ / "occupied.pcd").string();
  auto expect_bad = [&](const std::string& args, const std::string& fragment) {
    const auto r = RunCommand(kMap + " " + args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.out << r.err;
    EXPECT_EQ(testing::CountLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
  };
  const std::string frames = (dir_ / "frames").string();
  expect_bad(frames + " --out " + out, "frames.csv");  // no index at all
  std::ofstream(dir_ / "frames" / "frames.csv") << "index,t,file,x,y,z,qw,qx,qy\n0,0,a.pcd,0,0,0,1,0,0\n";
  expect_bad(frames + " --out " + out, "no column 'qz'");
  std::ofstream(dir_ / "frames" / "frames.csv", std::ios::trunc) << "index,t,file,x,y,z,qw,qx,qy,qz\n0,0,gone.pcd,0,0,0,1,0,0,0\n";
  expect_bad(frames + " --out " + out, "no usable frame");
  expect_bad(frames + " --out " + out + " --resolution 0", "resolution");
  expect_bad(frames + " --out " + out + " --unknown-box 0,0,0,1,1,1", "go together");
  expect_bad(frames + " --out " + out + " --unknown-out u.pcd --unknown-box 0,0,0,1,1", "6 comma-separated");
  expect_bad(frames + " --out " + (dir_ / "nowhere" / "o.pcd").string(), "folder does not exist");
  expect_bad("--out " + out, "one of them");
  expect_bad(frames + " --listen udp://127.0.0.1:0 --out " + out, "one of them");
  expect_bad("--listen tcp://127.0.0.1:5 --out " + out, "--listen");
  expect_bad("--listen udp://127.0.0.1:0 --idle 0 --out " + out, "--idle");
  // Nothing arrives: no map, one line, no file.
  expect_bad("--listen udp://127.0.0.1:0 --max-duration 0.3 --json --out " + out, "no usable frame");
  // Bags.
  const std::string bag = (dir_ / "one.bag").string();
  {
    auto writer = scene::BagWriter::Create(bag);
    ASSERT_TRUE(writer.ok());
    ASSERT_TRUE((*writer)->Write(0.0, Pose::Identity(), Pose::Identity(), {Vec3(2, 0, 0)}).ok());
    ASSERT_TRUE((*writer)->Close().ok());
  }
  expect_bad("--bag " + bag + " --out " + out, "needs --cloud-topic");
  expect_bad("--bag " + bag + " --cloud-topic /points --out " + out,
             bag + ": no topic /points (the bag has /quadhand/odom [nav_msgs/Odometry], /quadhand/points "
                   "[sensor_msgs/PointCloud2], /tf [tf2_msgs/TFMessage])");
  expect_bad("--bag " + bag + " --cloud-topic /quadhand/odom --out " + out, "is nav_msgs/Odometry, not");
  expect_bad("--bag " + bag + " --cloud-topic /quadhand/points --odom-topic /quadhand/odom --world-frame map --out " + out,
             "give one");
  expect_bad("--bag " + bag + " --cloud-topic /quadhand/points --extrinsic 0,0,0,1,0,0,0 --out " + out,
             "only used with --odom-topic");
  expect_bad("--bag " + bag + " --cloud-topic /quadhand/points --odom-topic /quadhand/odom --extrinsic 0,0,0,2,0,0,0 --out " +
                 out,
             "unit quaternion");
  expect_bad("--bag " + bag + " --cloud-topic /quadhand/points --world-frame map --out " + out,
             "no usable cloud on /quadhand/points (1 messages: 0 malformed, 1 without a pose");
  expect_bad("--bag " + frames + "/frames.csv --cloud-topic /p --out " + out, "not a readable ROS 1 bag");
  expect_bad("--bag " + bag + " " + frames + " --cloud-topic /quadhand/points --out " + out, "one of them");
  expect_bad(frames + " --cloud-topic /quadhand/points --out " + out, "only used with --bag");
  const auto help = RunCommand(kMap + " --help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* option : {"--out", "--unknown-out", "--unknown-box", "--resolution", "--window", "--max-range", "--json",
                             "--listen", "--idle", "--max-duration", "--bag", "--cloud-topic", "--odom-topic",
                             "--extrinsic", "--world-frame", "--max-pose-gap"}) {
    EXPECT_NE(help.out.find(option), std::string::npos) << option;
  }
}

// --plan: replanning over a recording, open loop. The recording: a sensor
// on the base (--mount identity) moving along x at 0.5 m/s for 2 s, ten
// frames a second, each the points of a wall at x = 4 in the sensor's
// frame; the task's goal lies behind the wall. A replan every 0.5 s of the
// frames' time, from where the base was, each to a local target before the
// wall; the report says so. Bad --plan input: exit 2, one line, no output.
TEST_F(MapCliTest, ReplansOverTheRecordingToTheTasksGoal) {
  std::vector<Vec3> wall;
  for (double y = -3.0; y <= 3.0 + 1e-9; y += 0.04) {
    for (double z = 0.0; z <= 3.0 + 1e-9; z += 0.04) wall.emplace_back(4.0, y, z);
  }
  const fs::path frames = dir_ / "frames";
  std::string index = "index,t,file,x,y,z,qw,qx,qy,qz\n";
  for (int k = 0; k <= 20; ++k) {
    const double t = 0.1 * k;
    const Vec3 base(0.5 * t, 0.0, 1.2);
    std::vector<Vec3> seen;
    for (const Vec3& p : wall) seen.push_back(p - base);
    const std::string name = core::Format("f%02d.pcd", k);
    ASSERT_TRUE(scene::WritePcd((frames / name).string(), seen).ok());
    index += core::Format("%d,%g,%s,%g,%g,%g,1,0,0,0\n", k, t, name.c_str(), base.x(), base.y(), base.z());
  }
  std::ofstream(frames / "frames.csv") << index;
  const std::string task = (dir_ / "task.yaml").string();
  std::ofstream(task) << "robot: " << QUADHAND_SOURCE_DIR << "/meshes/quadhand/quadhand.urdf\n"
                      << "sdf_dir: " << testing::CoarseSdfDir() << "\n"
                      << "start: {position: [0.0, 0.0, 1.2], yaw: 0.0, joints: [0.3, -0.2, 0.0]}\n"
                      << "goal: {position: [8.0, 0.0, 1.2], yaw: 0.0, joints: [0.3, -0.2, 0.0]}\n"
                      << "limits: {v_max: 2.0, a_max: 4.0, yaw_rate_max: 1.5, body_rate_xy_max: 3.0}\n"
                      << "safety_distance: 0.03\n";
  const std::string out = (dir_ / "occupied.pcd").string(), report = (dir_ / "replans.json").string();
  const std::string run = kMap + " " + frames.string() + " --out " + out;
  const auto r = RunCommand(run + " --plan " + task + " --report " + report + " --mount 0,0,0,1,0,0,0 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const nlohmann::json line = nlohmann::json::parse(r.out);
  EXPECT_EQ(line["frames"].get<int>(), 21);
  EXPECT_EQ(line["replans"].get<int>(), 5);
  const nlohmann::json j = nlohmann::json::parse(testing::ReadAll(report));
  ASSERT_EQ(j["replan_log"].size(), 5u);
  int certified = 0;
  for (size_t n = 0; n < 5; ++n) {
    const nlohmann::json& e = j["replan_log"][n];
    EXPECT_NEAR(e["t"].get<double>(), 0.5 * static_cast<double>(n), 1e-9);
    EXPECT_NEAR(e["position"][0].get<double>(), 0.25 * static_cast<double>(n), 1e-9);
    EXPECT_NEAR(e["position"][2].get<double>(), 1.2, 1e-9);
    EXPECT_NEAR(e["speed"].get<double>(), n == 0 ? 0.0 : 0.5, 1e-9);
    if (e["status"] == "to_local_target") {
      ++certified;
      EXPECT_LT(e["target"][0].get<double>(), 4.0);  // before the wall: nothing behind it is seen
    }
    EXPECT_NE(e["status"], "to_goal");
  }
  EXPECT_EQ(j["replans_certified"].get<int>(), certified);
  EXPECT_EQ(line["replans_certified"].get<int>(), certified);
  EXPECT_GE(certified, 3);

  // Bad input: nothing written.
  fs::remove(out);
  fs::remove(report);
  for (const std::string& bad :
       {" --plan " + (dir_ / "missing.yaml").string(), " --report " + report,
        " --plan " + task + " --mount 0,0,0,2,0,0,0", " --plan " + task + " --replan-period 0",
        " --plan " + task + " --report " + out}) {
    const auto e = RunCommand(run + bad);
    EXPECT_EQ(e.exit_code, 2) << bad << "\n" << e.out << e.err;
    EXPECT_EQ(std::count(e.err.begin(), e.err.end(), '\n'), 1) << e.err;
    EXPECT_FALSE(fs::exists(out)) << bad;
    EXPECT_FALSE(fs::exists(report)) << bad;
  }
  EXPECT_NE(RunCommand(run + " --plan " + (dir_ / "missing.yaml").string()).err.find("missing.yaml"), std::string::npos);
  // A tool goal is not flown under perception: refused, naming the task.
  const std::string tool_task = (dir_ / "tool_task.yaml").string();
  std::ofstream(tool_task) << testing::WindowCupTaskText();
  const auto tool = RunCommand(run + " --plan " + tool_task);
  EXPECT_EQ(tool.exit_code, 2) << tool.out << tool.err;
  EXPECT_EQ(tool.err.rfind("quadhand-map: error: " + tool_task + ": under perception", 0), 0u) << tool.err;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace quadhand
