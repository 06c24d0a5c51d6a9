// Command-line behaviour of quadhand-sim: bad input gives exit code 2, one
// line naming the file, and no output; --track and --figure8 write their files.
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include <sstream>

#include "quadhand/scene/point_cloud.h"
#include "quadhand/scene/ros_bag.h"

#include "support/run_command.h"

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using testing::CountLines;
using testing::ReadAll;
using testing::RunCommand;

const std::string kSim = std::string(QUADHAND_BIN_DIR) + "/quadhand-sim";
const std::string kConfig = std::string(QUADHAND_SOURCE_DIR) + "/data/sim/quadhand_sim.yaml";

const char* const kHeader =
    "t,px,py,pz,vx,vy,vz,ax,ay,az,qw,qx,qy,qz,yaw,yaw_rate,joint1,joint2,joint3,joint1_rate,joint2_rate,joint3_rate";

class SimCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("quadhand_sim_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }

  // Half a second hovering with joint1 moving.
  std::string ShortPlan() {
    std::string text = std::string(kHeader) + "\n";
    for (int k = 0; k <= 50; ++k) {
      text += std::to_string(0.01 * k) + ",0,0,1,0,0,0,0,0,0,1,0,0,0,0,0," + std::to_string(0.3 + 0.002 * k) +
              ",0.1,0,0.2,0,0\n";
    }
    return Write("plan.csv", text);
  }

  void ExpectBadInput(const std::string& args, const std::string& fragment) {
    const std::string out = (dir_ / "out.csv").string();
    const std::string config = args.find("--config") == std::string::npos ? " --config " + kConfig : "";
    const auto r = RunCommand(kSim + config + " --out " + out + " " + args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_EQ(CountLines(r.err), 1) << r.err;
    EXPECT_EQ(r.err.rfind("quadhand-sim: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
  }

  fs::path dir_;
};

TEST_F(SimCliTest, HelpListsEveryOption) {
  const auto r = RunCommand(kSim + " --help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* option : {"--track", "--figure8", "--out", "--config", "--pcgc", "--payload", "--seed", "--noise",
                             "--settle", "--package-path"}) {
    EXPECT_NE(r.out.find(option), std::string::npos) << option;
  }
}

TEST_F(SimCliTest, TracksAShortPlan) {
  const std::string plan = ShortPlan();
  const std::string out = (dir_ / "flown.csv").string();
  const auto r = RunCommand(kSim + " --config " + kConfig + " --track " + plan + " --out " + out +
                            " --pcgc off --payload 0.15 --seed 3 --settle 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("PCGC off, payload 0.150 kg"), std::string::npos) << r.out;
  const std::string flown = ReadAll(out);
  EXPECT_EQ(flown.rfind(std::string(kHeader) + ",err_x,err_y,err_z,err_pos", 0), 0u);
  EXPECT_EQ(CountLines(flown), 52);
  // Same seed, same flight; no temporary files left.
  const std::string again = (dir_ / "again.csv").string();
  ASSERT_EQ(RunCommand(kSim + " -q --config " + kConfig + " --track " + plan + " --out " + again +
                       " --pcgc off --payload 0.15 --seed 3 --settle 1")
                .exit_code,
            0);
  EXPECT_EQ(ReadAll(again), flown);
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) files += entry.is_regular_file();
  EXPECT_EQ(files, 3);
}

// What a depth camera on the vehicle sees of a hidden world while it flies
// (docs/sim.md, "Sensors"): a frame per 1/rate of the record, each a PCD in
// the sensor's frame, and frames.csv with each frame's time, file and pose;
// every return, placed by its pose, lies on the world's wall.
TEST_F(SimCliTest, WritesTheFramesASensorSeesAlongTheFlight) {
  std::string wall = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  std::string rows;
  int count = 0;
  for (int j = -100; j <= 100; ++j) {
    for (int k = 0; k <= 100; ++k) {
      rows += "2.5 " + std::to_string(0.02 * j) + " " + std::to_string(0.02 * k) + "\n";
      ++count;
    }
  }
  wall += "WIDTH " + std::to_string(count) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(count) +
          "\nDATA ascii\n" + rows;
  const std::string world = Write("wall.pcd", wall);
  const std::string plan = ShortPlan();
  const std::string frames = (dir_ / "frames").string(), out = (dir_ / "flown.csv").string();
  const auto r = RunCommand(kSim + " --config " + kConfig + " --track " + plan + " --out " + out + " --world " + world +
                            " --sensor depth --frames " + frames);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("sensor: 16 depth frames"), std::string::npos) << r.out;  // 0.5 s at 30 Hz, both ends
  const std::string index = ReadAll(frames + "/frames.csv");
  EXPECT_EQ(index.rfind("index,t,file,x,y,z,qw,qx,qy,qz\n", 0), 0u) << index;
  EXPECT_EQ(CountLines(index), 17);
  EXPECT_TRUE(fs::exists(frames + "/frame_000015.pcd"));
  EXPECT_FALSE(fs::exists(frames + ".partial"));
  // The first frame: its points, placed by its pose, on the wall at x = 2.5.
  std::istringstream lines(index);
  std::string line;
  std::getline(lines, line);
  std::getline(lines, line);
  std::vector<double> pose;
  std::stringstream cells(line);
  std::string cell;
  for (int c = 0; std::getline(cells, cell, ','); ++c) {
    if (c >= 3) pose.push_back(std::stod(cell));
  }
  ASSERT_EQ(pose.size(), 7u);
  const Pose sensor = MakePose(Vec3(pose[0], pose[1], pose[2]), Quat(pose[3], pose[4], pose[5], pose[6]).toRotationMatrix());
  auto cloud = scene::LoadPcd(frames + "/frame_000000.pcd");
  ASSERT_TRUE(cloud.ok()) << cloud.status().message();
  ASSERT_GT(cloud->points.size(), 1000u);
  // (Within 6 sigma of the depth noise there: 0.002 m at 1 m, times 2.5^2.)
  for (const Vec3& p : cloud->points) EXPECT_NEAR((sensor * p).x(), 2.5, 0.08) << p.transpose();
  // The same frames as a ROS 1 bag: a cloud per frame, placed by /tf where
  // frames.csv places it, with the same returns (both float32).
  const std::string bag = (dir_ / "frames.bag").string(), both = (dir_ / "both").string();
  const auto bagged = RunCommand(kSim + " -q --config " + kConfig + " --track " + plan + " --out " + out + "b --world " +
                                 world + " --sensor depth --frames " + both + " --bag " + bag);
  ASSERT_EQ(bagged.exit_code, 0) << bagged.err;
  std::vector<scene::BagCloud> clouds;
  scene::BagCloudSource source;
  source.path = bag;
  source.cloud_topic = "/quadhand/points";
  scene::BagCloudCounts counts;
  ASSERT_TRUE(scene::ForEachBagCloud(source, [&](scene::BagCloud& c) { clouds.push_back(c); return core::Status::Ok(); },
                                     &counts).ok());
  ASSERT_EQ(clouds.size(), 16u);
  EXPECT_LT((clouds[0].sensor_to_world.matrix() - sensor.matrix()).norm(), 1e-6);
  auto first = scene::LoadPcd(both + "/frame_000000.pcd");
  ASSERT_TRUE(first.ok());
  ASSERT_EQ(clouds[0].points.size(), first->points.size());
  for (size_t i = 0; i < first->points.size(); ++i) ASSERT_LT((clouds[0].points[i] - first->points[i]).norm(), 1e-6);
  ExpectBadInput("--track " + plan + " --world " + world + " --sensor depth --bag " + bag, "exists already");
  ExpectBadInput("--track " + plan + " --world " + world + " --sensor depth --bag " + (dir_ / "no" / "x.bag").string(),
                 "its folder does not exist");

  // The folder is new: given again, it is refused, and nothing is written.
  ExpectBadInput("--track " + plan + " --world " + world + " --sensor depth --frames " + frames, "exists already");
  ExpectBadInput("--track " + plan + " --world " + world + " --sensor depth", "go together");
  ExpectBadInput("--track " + plan + " --world " + world + " --sensor sonar --frames " + frames + "2", "--sensor");
  ExpectBadInput("--track " + plan + " --world " + (dir_ / "missing.pcd").string() + " --sensor lidar --frames " +
                     frames + "3",
                 "missing.pcd");
  EXPECT_FALSE(fs::exists(frames + "3"));

  // A task file's scene is a world too: its scans as they are placed (the
  // wall moved 0.5 m further away).
  const std::string task = Write("task.yaml", "robot: " + std::string(QUADHAND_SOURCE_DIR) +
                                                  "/meshes/quadhand/quadhand.urdf\nsdf_dir: " + dir_.string() +
                                                  "\nscene:\n  - file: " + world +
                                                  "\n    pose: {position: [0.5, 0, 0], orientation: [1, 0, 0, 0]}\n"
                                                  "start: {position: [0, 0, 1], yaw: 0, joints: [0.3, 0.1, 0]}\n"
                                                  "goal: {position: [0, 0, 1], yaw: 0, joints: [0.3, 0.1, 0]}\n");
  const std::string moved = (dir_ / "moved").string();
  const auto from_task = RunCommand(kSim + " -q --config " + kConfig + " --track " + plan + " --out " + out +
                                    "2 --world " + task + " --sensor depth --frames " + moved);
  ASSERT_EQ(from_task.exit_code, 0) << from_task.err;
  auto seen = scene::LoadPcd(moved + "/frame_000000.pcd");
  ASSERT_TRUE(seen.ok()) << seen.status().message();
  ASSERT_GT(seen->points.size(), 1000u);
  for (const Vec3& p : seen->points) EXPECT_NEAR((sensor * p).x(), 3.0, 0.1) << p.transpose();
}

TEST_F(SimCliTest, WritesTheFigureEightPlan) {
  const std::string out = (dir_ / "eight.csv").string();
  const auto r = RunCommand(kSim + " --config " + kConfig + " --figure8 --loops 1 --period 6 --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string text = ReadAll(out);
  EXPECT_EQ(text.rfind(std::string(kHeader) + "\n", 0), 0u);
  EXPECT_EQ(CountLines(text), 1 + 801);  // 8 s at 0.01 s, both ends
}

TEST_F(SimCliTest, RejectsBadInput) {
  const std::string plan = ShortPlan();
  ExpectBadInput("--track " + (dir_ / "missing.csv").string(), "missing.csv");
  ExpectBadInput("--track " + Write("bad.csv", std::string(kHeader) + "\n0,0,0,1\n"), "bad.csv: line 2");
  ExpectBadInput("--track " + Write("nojoint.csv", "t,px,py,pz\n0,0,0,1\n"), "nojoint.csv: missing column");
  ExpectBadInput("--track " + plan + " --pcgc maybe", "--pcgc");
  ExpectBadInput("--track " + plan + " --payload -1", "--payload");
  ExpectBadInput("--track " + plan + " --figure8", "exactly one");
  ExpectBadInput("", "exactly one");
  ExpectBadInput("--track " + plan + " --config " + Write("c.yaml", "step: 0.1\n"), "c.yaml");
  ExpectBadInput("--track " + plan + " --config " + Write("typo.yaml", "noise: {enabld: true}\n"),
                 "typo.yaml: noise.enabld: unknown key");
  ExpectBadInput("--track " + plan + " --config " + (dir_ / "none.yaml").string(), "none.yaml");
  // Sizes that crashed (bad_alloc, length_error) or ran for ever: refused
  // before anything is simulated or allocated.
  ExpectBadInput("--figure8 --dt 1e-12", "at most 1e7 rows");
  ExpectBadInput("--figure8 --loops 2000000000", "at most 1e7 rows");
  ExpectBadInput("--figure8 --period 1e300", "at most 1e7 rows");
  ExpectBadInput("--track " + plan + " --settle 1e12", "--settle must be in [0, 3600] s");
  ExpectBadInput("--track " + plan + " --payload 1e300", "--payload must be in [0, 100] kg");
  ExpectBadInput("--track " + Write("years.csv", std::string(kHeader) + "\n0,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.3,0.1,0,0,0,0\n"
                                                 "1e9,0,0,1,0,0,0,0,0,0,1,0,0,0,0,0,0.3,0.1,0,0,0,0\n"),
                 "at most 3600 s are simulated");
  ExpectBadInput("--track " + plan + " --config " + Write("heavy.yaml", "payload: {mass: 1e6}\n"),
                 "payload.mass must be in [0, 100] kg");
  // An unwritable output is bad input too, and leaves nothing behind.
  const auto r = RunCommand(kSim + " --config " + kConfig + " --track " + plan + " --out /nonexistent/dir/out.csv");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("/nonexistent/dir/out.csv"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace quadhand
