// quadhand-sim --udp as a process, driven over loopback UDP with
// link::Connection the way quadhand-online drives PX4: heartbeat, arming and
// mode commands acknowledged, telemetry streamed, setpoints followed (in
// lockstep: each setpoint advances 20 ms of simulated time), signing, the
// flown log, a clean exit on SIGTERM; a sensor's frames streamed beside the
// link (and quadhand-map listening to them); and the --udp options' bad input.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "quadhand/link/connection.h"
#include "quadhand/link/frames.h"
#include "quadhand/link/sensor_stream.h"
#include "quadhand/scene/point_cloud.h"
#include "support/run_command.h"

namespace quadhand {
namespace {

namespace fs = std::filesystem;
using testing::CountLines;
using testing::ReadAll;
using testing::RunCommand;

const std::string kSim = std::string(QUADHAND_BIN_DIR) + "/quadhand-sim";
const std::string kConfig = std::string(QUADHAND_SOURCE_DIR) + "/data/sim/quadhand_sim.yaml";

// A port that was free a moment ago (the simulator binds it next).
uint16_t FreePort() {
  core::Result<link::UdpSocket> s = link::UdpSocket::Bind({"127.0.0.1", 0});
  EXPECT_TRUE(s.ok());
  return s.ok() ? s->local_port() : 0;
}

// The simulator as a child process; killed (and failed) if it outlives the test.
class SimProcess {
 public:
  SimProcess(const std::vector<std::string>& args, const std::string& stderr_path) {
    pid_ = fork();
    if (pid_ == 0) {
      std::freopen(stderr_path.c_str(), "w", stderr);
      std::vector<char*> argv;
      argv.push_back(const_cast<char*>(kSim.c_str()));
      for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      execv(kSim.c_str(), argv.data());
      _exit(127);
    }
  }
  ~SimProcess() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  // Sends SIGTERM and waits up to 10 s; the exit code, or -1.
  int Stop() {
    kill(pid_, SIGTERM);
    return Wait(10.0);
  }
  int Wait(double timeout_s) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (true) {  // (once at least: Wait(0) asks without waiting)
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      }
      if (std::chrono::steady_clock::now() >= deadline) return -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }

 private:
  pid_t pid_ = -1;
  bool exited_ = false;
};

// The ground side: a Connection to the simulator and what it has received.
class Ground {
 public:
  Ground(uint16_t sim_port, std::optional<link::SigningKey> key = std::nullopt) {
    core::Result<link::UdpSocket> socket = link::UdpSocket::Bind({"127.0.0.1", 0});
    EXPECT_TRUE(socket.ok());
    link::EncoderOptions encoder;
    encoder.system_id = 255;
    encoder.component_id = 190;
    encoder.signing_key = key;
    link::ParserOptions parser;
    parser.signing_key = key;
    parser.require_signing = key.has_value();
    connection_.emplace(std::move(*socket), encoder, parser, link::UdpEndpoint{"127.0.0.1", sim_port});
  }

  void Send(const link::Message& m) { ASSERT_TRUE(connection_->Send(m).ok()); }

  // Polls until `done` holds for the messages received so far (or timeout).
  template <typename Pred>
  bool WaitFor(Pred done, double timeout_s = 5.0) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < deadline) {
      if (done()) return true;
      connection_->WaitReadable(0.01);
      for (link::ReceivedMessage& r : connection_->Poll()) received_.push_back(std::move(r));
    }
    return done();
  }

  template <typename M>
  std::vector<M> All() const {
    std::vector<M> found;
    for (const link::ReceivedMessage& r : received_) {
      if (const M* m = std::get_if<M>(&r.message)) found.push_back(*m);
    }
    return found;
  }

  std::optional<link::CommandAck> AckFor(uint16_t command) const {
    for (const link::CommandAck& a : All<link::CommandAck>()) {
      if (a.command == command) return a;
    }
    return std::nullopt;
  }

  // Sends a command and waits for its acknowledgement.
  std::optional<link::CommandAck> Command(uint16_t id, float param1, float param2 = 0) {
    std::vector<link::ReceivedMessage> keep;
    received_.erase(std::remove_if(received_.begin(), received_.end(),
                                   [&](const link::ReceivedMessage& r) {
                                     const auto* a = std::get_if<link::CommandAck>(&r.message);
                                     return a && a->command == id;
                                   }),
                    received_.end());
    link::CommandLong c;
    c.command = id;
    c.param1 = param1;
    c.param2 = param2;
    c.target_system = 1;
    c.target_component = 1;
    Send(c);
    WaitFor([&] { return AckFor(id).has_value(); });
    return AckFor(id);
  }

  uint32_t LastTelemetryMs() const {
    const auto positions = All<link::LocalPositionNed>();
    return positions.empty() ? 0 : positions.back().time_boot_ms;
  }

  // Lockstep: sends a setpoint and waits for the telemetry it causes.
  void Step(const link::SetPositionTargetLocalNed& sp) {
    const uint32_t before = LastTelemetryMs();
    Send(sp);
    ASSERT_TRUE(WaitFor([&] { return LastTelemetryMs() > before; }));
  }

  const std::vector<link::ReceivedMessage>& received() const { return received_; }

 private:
  std::optional<link::Connection> connection_;
  std::vector<link::ReceivedMessage> received_;
};

link::SetPositionTargetLocalNed Target(const Vec3& p_enu) {
  link::SetPositionTargetLocalNed sp;
  const Vec3 p = link::EnuToNed(p_enu);
  sp.x = static_cast<float>(p.x());
  sp.y = static_cast<float>(p.y());
  sp.z = static_cast<float>(p.z());
  sp.yaw = static_cast<float>(link::YawEnuToNed(0.0));
  sp.target_system = 1;
  return sp;
}

class SimUdpTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("quadhand_sim_udp_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// A wall across the way: x = 3 m, |y| <= 2 m, 0 <= z <= 3 m, every 2 cm.
std::string WriteWall(const fs::path& dir) {
  std::vector<Vec3> wall;
  for (double y = -2.0; y <= 2.0 + 1e-9; y += 0.02) {
    for (double z = 0.0; z <= 3.0 + 1e-9; z += 0.02) wall.emplace_back(3.0, y, z);
  }
  const std::string path = (dir / "wall.pcd").string();
  EXPECT_TRUE(scene::WritePcd(path, wall).ok());
  return path;
}

// With --world --sensor --frames-to, the hovering vehicle's depth camera
// streams frames beside the MAVLink link: whole, in order, stamped with the
// vehicle's clock at the sensor's rate, posed where the vehicle is, and
// showing the wall where it stands.
TEST_F(SimUdpTest, StreamsTheSensorsFramesBesideTheLink) {
  const std::string wall = WriteWall(dir_);
  auto receiver = link::UdpSocket::Bind({"127.0.0.1", 0});
  ASSERT_TRUE(receiver.ok());
  receiver->SetReceiveBuffer(16u << 20);
  const uint16_t port = FreePort();
  SimProcess sim({"--config", kConfig, "--udp", "udp://127.0.0.1:" + std::to_string(port), "--start", "0,0,1.2",
                  "--duration", "2", "--world", wall, "--sensor", "depth", "--frames-to",
                  "udp://127.0.0.1:" + std::to_string(receiver->local_port()), "-q"},
                 (dir_ / "stderr.txt").string());
  link::SensorFrameAssembler assembler;
  std::vector<perception::SensorFrame> frames;
  int exit_code = -1;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    receiver->WaitReadable(0.02);
    while (auto d = receiver->Receive()) {
      if (auto f = assembler.Add(d->bytes.data(), d->bytes.size())) frames.push_back(std::move(*f));
    }
    if (exit_code < 0) exit_code = sim.Wait(0.0);
    if (exit_code >= 0 && !receiver->WaitReadable(0.2)) break;
  }
  ASSERT_EQ(exit_code, 0) << ReadAll((dir_ / "stderr.txt").string());
  const link::SensorStreamCounts& c = assembler.counts();
  EXPECT_EQ(c.malformed + c.truncated + c.corrupted + c.inconsistent + c.duplicates, 0);
  ASSERT_GE(frames.size(), 40u) << "2 s at 30 Hz";  // (60 less any lost at start-up)
  std::vector<double> gaps;
  size_t with_misses = 0;
  for (size_t k = 0; k < frames.size(); ++k) {
    const perception::SensorFrame& f = frames[k];
    if (k > 0) gaps.push_back(f.t - frames[k - 1].t);
    EXPECT_EQ(perception::CheckPose(f.position, f.attitude, 1e-6), perception::FrameDrop::kNone);
    EXPECT_LT((f.position - Vec3(0.0, 0.0, 1.2)).norm(), 0.5) << "the camera rides on the hovering vehicle";
    ASSERT_GT(f.points.size(), 1000u);
    const Pose pose = perception::SensorPose(f);
    size_t on_wall = 0;
    for (const Vec3& p : f.points) on_wall += std::abs((pose * p).x() - 3.0) < 0.1 ? 1 : 0;
    EXPECT_GT(on_wall, 0.99 * f.points.size()) << "frame " << k;
    with_misses += f.misses.empty() ? 0 : 1;
  }
  for (double gap : gaps) EXPECT_GT(gap, 0.0);  // in order
  std::sort(gaps.begin(), gaps.end());
  EXPECT_NEAR(gaps[gaps.size() / 2], 1.0 / 30.0, 0.005);
  EXPECT_EQ(with_misses, frames.size()) << "the camera sees past the wall's ends";
}

// quadhand-map --listen maps the live stream, and drops and counts the
// datagrams that are not good chunks.
TEST_F(SimUdpTest, QuadhandMapListensToTheStreamAndCountsBadDatagrams) {
  const std::string wall = WriteWall(dir_);
  const uint16_t map_port = FreePort(), port = FreePort();
  const std::string out = (dir_ / "occupied.pcd").string();
  SimProcess sim({"--config", kConfig, "--udp", "udp://127.0.0.1:" + std::to_string(port), "--start", "0,0,1.2",
                  "--duration", "3", "--world", wall, "--sensor", "depth", "--frames-to",
                  "udp://127.0.0.1:" + std::to_string(map_port), "-q"},
                 (dir_ / "stderr.txt").string());
  // Bad datagrams, while the map listens: garbage, a chunk cut short, a
  // chunk with a flipped bit.
  std::thread spoiler([&]() {
    std::this_thread::sleep_for(std::chrono::milliseconds(700));
    auto socket = link::UdpSocket::Bind({"127.0.0.1", 0});
    if (!socket.ok()) return;
    perception::SensorFrame frame;
    frame.points.assign(500, Vec3(1.0, 0.0, 0.0));
    const std::vector<uint8_t> chunk = link::EncodeSensorFrame(frame, 1u << 30)[0];
    std::vector<uint8_t> cut(chunk.begin(), chunk.begin() + 200), flipped = chunk;
    flipped[300] ^= 0x01;
    const link::UdpEndpoint to{"127.0.0.1", map_port};
    for (const auto& d : {std::vector<uint8_t>{'h', 'e', 'l', 'l', 'o'}, cut, flipped}) (void)socket->SendTo(d, to);
  });
  const auto r = RunCommand(std::string(QUADHAND_BIN_DIR) + "/quadhand-map --listen udp://127.0.0.1:" +
                            std::to_string(map_port) + " --idle 1 --max-duration 30 --json --out " + out);
  spoiler.join();
  EXPECT_EQ(sim.Wait(10.0), 0);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_GE(j["frames"].get<int>(), 40) << r.out;
  EXPECT_EQ(j["datagrams_malformed"].get<int>(), 1) << r.out;
  EXPECT_EQ(j["datagrams_truncated"].get<int>(), 1) << r.out;
  EXPECT_EQ(j["datagrams_corrupted"].get<int>(), 1) << r.out;
  auto occupied = scene::LoadPointCloud(out);
  ASSERT_TRUE(occupied.ok());
  ASSERT_FALSE(occupied->points.empty());
  for (const Vec3& p : occupied->points) ASSERT_LT(std::abs(p.x() - 3.0), 0.1) << p.transpose();
}

TEST_F(SimUdpTest, BehavesLikeAnAutopilotInLockstep) {
  const uint16_t port = FreePort();
  const std::string log = (dir_ / "flown.csv").string();
  SimProcess sim({"--config", kConfig, "--udp", "udp://127.0.0.1:" + std::to_string(port), "--start", "0,0,1",
                  "--noise", "off", "--log", log},
                 (dir_ / "stderr.txt").string());
  Ground ground(port);
  // The simulator answers whoever speaks first: say hello until it does.
  link::Heartbeat gcs;
  gcs.type = 6;  // MAV_TYPE_GCS
  gcs.autopilot = link::mav::kAutopilotInvalid;
  ASSERT_TRUE(ground.WaitFor(
      [&] {
        ground.Send(gcs);
        return !ground.All<link::Heartbeat>().empty();
      },
      10.0))
      << ReadAll((dir_ / "stderr.txt").string());
  const link::Heartbeat hb = ground.All<link::Heartbeat>().front();
  EXPECT_EQ(hb.autopilot, link::mav::kAutopilotPx4);
  EXPECT_EQ(hb.custom_mode, link::mav::Px4CustomMode(link::mav::kPx4MainModePosition));
  EXPECT_EQ(ground.received().front().frame.system_id, 1);

  // Arm; offboard is refused until setpoints have streamed for a second.
  std::optional<link::CommandAck> ack = ground.Command(link::mav::kCmdComponentArmDisarm, 1);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->result, link::mav::kResultAccepted);
  ack = ground.Command(link::mav::kCmdDoSetMode, 1, 6);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->result, link::mav::kResultTemporarilyRejected);
  for (int i = 0; i < 55; ++i) ground.Step(Target(Vec3(0, 0, 1)));
  ack = ground.Command(link::mav::kCmdDoSetMode, 1, 6);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->result, link::mav::kResultAccepted);
  ack = ground.Command(1234, 0);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->result, link::mav::kResultUnsupported);

  // Fly 1 m east: 5 s of simulated time, 250 setpoints.
  for (int i = 0; i < 250; ++i) ground.Step(Target(Vec3(1, 0, 1)));
  const link::LocalPositionNed last = ground.All<link::LocalPositionNed>().back();
  EXPECT_NEAR(last.y, 1.0, 0.05);  // NED y is east
  EXPECT_NEAR(last.x, 0.0, 0.05);
  EXPECT_NEAR(last.z, -1.0, 0.05);
  EXPECT_FALSE(ground.All<link::AttitudeQuaternion>().empty());
  bool joints = false;
  for (const link::DebugFloatArray& a : ground.All<link::DebugFloatArray>()) joints |= a.name == "JOINTS";
  EXPECT_TRUE(joints);
  EXPECT_EQ(ground.All<link::Heartbeat>().back().custom_mode, link::mav::Px4CustomMode(link::mav::kPx4MainModeOffboard));

  EXPECT_EQ(sim.Stop(), 0) << ReadAll((dir_ / "stderr.txt").string());
  const std::string flown = ReadAll(log);
  EXPECT_EQ(flown.rfind("t,px,py,pz,vx,vy,vz,ax,ay,az,qw,qx,qy,qz,yaw,yaw_rate,joint1", 0), 0u);
  EXPECT_GT(CountLines(flown), 300);  // 50 Hz over more than 6 s
}

TEST_F(SimUdpTest, RequiresSignedFramesWhenAsked) {
  const uint16_t port = FreePort();
  link::SigningKey key;
  for (size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(3 * i + 1);
  const std::string key_path = (dir_ / "key.hex").string();
  {
    std::ofstream out(key_path);
    for (uint8_t b : key) out << "0123456789abcdef"[b >> 4] << "0123456789abcdef"[b & 15];
    out << "\n";
  }
  const std::string err = (dir_ / "stderr.txt").string();
  SimProcess sim({"--config", kConfig, "--udp", "udp://127.0.0.1:" + std::to_string(port), "--signing-key", key_path,
                  "--require-signing", "--duration", "0"},
                 err);
  // An unsigned ground station is ignored: no heartbeat ever comes back.
  Ground unsigned_ground(port);
  link::Heartbeat gcs;
  gcs.type = 6;
  EXPECT_FALSE(unsigned_ground.WaitFor(
      [&] {
        unsigned_ground.Send(gcs);
        return !unsigned_ground.received().empty();
      },
      1.5));
  // A signed one is answered, with signed frames.
  Ground signed_ground(port, key);
  ASSERT_TRUE(signed_ground.WaitFor(
      [&] {
        signed_ground.Send(gcs);
        return !signed_ground.All<link::Heartbeat>().empty();
      },
      10.0))
      << ReadAll(err);
  EXPECT_TRUE(signed_ground.received().front().frame.is_signed);
  const std::optional<link::CommandAck> ack = signed_ground.Command(link::mav::kCmdComponentArmDisarm, 1);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->result, link::mav::kResultAccepted);
  EXPECT_EQ(sim.Stop(), 0);
  const std::string log = ReadAll(err);
  EXPECT_EQ(log.find(" 0 unsigned"), std::string::npos) << log;  // the unsigned frames were counted
}

const std::string kMovingCup = std::string(QUADHAND_SOURCE_DIR) + "/data/tasks/moving_cup.yaml";

TEST_F(SimUdpTest, RejectsBadUdpOptions) {
  const std::string base = kSim + " --config " + kConfig + " ";
  const std::string key = (dir_ / "short.key").string();
  std::ofstream(key) << "abcd\n";
  core::Result<link::UdpSocket> taken = link::UdpSocket::Bind({"127.0.0.1", 0});
  ASSERT_TRUE(taken.ok());
  const std::string taken_url = "udp://127.0.0.1:" + std::to_string(taken->local_port());
  const std::string ok_url = "udp://127.0.0.1:" + std::to_string(FreePort());
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--udp 127.0.0.1:14540", "udp://HOST:PORT"},
      {"--udp udp://127.0.0.1:0", "port"},
      {"--udp " + taken_url, taken_url},
      {"--udp " + ok_url + " --out x.csv", "--out"},
      {"--udp " + ok_url + " --track x.csv", "exactly one"},
      {"--udp " + ok_url + " --start 1,2", "--start"},
      {"--udp " + ok_url + " --start 1,2,3 --start-task t.yaml", "at most one"},
      {"--udp " + ok_url + " --start-task " + (dir_ / "none.yaml").string(), "none.yaml"},
      {"--udp " + ok_url + " --require-signing", "--signing-key"},
      {"--udp " + ok_url + " --signing-key " + key, "short.key"},
      {"--udp " + ok_url + " --system-id 0", "--system-id"},
      {"--udp " + ok_url + " --duration -1", "--duration"},
      {"--udp " + ok_url + " --log /nonexistent/dir/flown.csv", "/nonexistent/dir"},
      {"--udp " + ok_url + " --settle 1", "--settle"},
      {"--figure8 --out " + (dir_ / "e.csv").string() + " --realtime", "--realtime"},
      {"--udp " + ok_url + " --target-rate 30", "--target-rate needs --start-task"},
      {"--udp " + ok_url + " --target-noise 0.01", "need --target-rate"},
      {"--udp " + ok_url + " --target-rate 0 --start-task " + kMovingCup, "--target-*: target rate must be in (0, 1000]"},
      {"--udp " + ok_url + " --target-rate 30 --target-noise -1 --start-task " + kMovingCup, "target noise"},
      {"--udp " + ok_url + " --target-rate 30 --start-task " + std::string(QUADHAND_SOURCE_DIR) +
           "/data/tasks/window_cup.yaml", "window_cup.yaml: goal.tool.motion: missing"},
      {"--figure8 --out " + (dir_ / "e.csv").string() + " --target-rate 30", "--target-rate is only used with --udp"},
  };
  for (const auto& [args, fragment] : cases) {
    const auto r = RunCommand(base + args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_EQ(CountLines(r.err), 1) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "e.csv"));
  const auto help = RunCommand(kSim + " --help");
  for (const char* option : {"--udp", "--remote", "--realtime", "--duration", "--start", "--start-task", "--log",
                             "--signing-key", "--require-signing", "--system-id", "--target-rate", "--target-noise",
                             "--target-yaw-noise", "--target-walk"}) {
    EXPECT_NE(help.out.find(option), std::string::npos) << option;
  }
}

// With a moving target (--target-rate), the log carries the target's true
// pose in the target_* columns: the task's tool goal moved with it.
TEST_F(SimUdpTest, TheLogRecordsTheMovingTargetsTruePose) {
  const uint16_t port = FreePort();
  const auto r = RunCommand(kSim + " --config " + kConfig + " --udp udp://127.0.0.1:" + std::to_string(port) +
                            " --duration 0.5 -q --start-task " + kMovingCup + " --target-rate 30 --log " +
                            (dir_ / "target.csv").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::istringstream lines(ReadAll((dir_ / "target.csv").string()));
  std::string header;
  std::getline(lines, header);
  const size_t at = header.find(",target_x,target_y,target_z,target_qw,target_qx,target_qy,target_qz");
  ASSERT_NE(at, std::string::npos) << header;
  EXPECT_EQ(at + std::string(",target_x,target_y,target_z,target_qw,target_qx,target_qy,target_qz").size(),
            header.size());
  int rows = 0;
  for (std::string line; std::getline(lines, line);) {
    std::vector<double> values;
    std::istringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) values.push_back(std::stod(cell));
    const size_t n = values.size();
    // The cup at 0.15 m/s along y from (-3.2, 0, 0.86), the tool goal's orientation.
    EXPECT_NEAR(values[n - 7], -3.2, 1e-9);
    EXPECT_NEAR(values[n - 6], 0.15 * values[0], 1e-9);
    EXPECT_NEAR(values[n - 5], 0.86, 1e-9);
    EXPECT_NEAR(std::abs(values[n - 3]), 0.7071068, 1e-6);
    ++rows;
  }
  EXPECT_EQ(rows, 26);
}

TEST_F(SimUdpTest, RealTimeRunEndsAfterItsDuration) {
  const uint16_t port = FreePort();
  const auto start = std::chrono::steady_clock::now();
  const auto r = RunCommand(kSim + " --config " + kConfig + " --udp udp://127.0.0.1:" + std::to_string(port) +
                            " --realtime --duration 0.5 -q --start-task " + QUADHAND_SOURCE_DIR +
                            "/data/tasks/window_cup.yaml --log " + (dir_ / "rt.csv").string());
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;  // --quiet
  EXPECT_GE(wall, 0.5);                 // paced to the wall clock (a lower bound, not a speed assertion)
  const std::string flown = ReadAll((dir_ / "rt.csv").string());
  EXPECT_EQ(CountLines(flown), 1 + 26);  // 50 Hz over [0, 0.5]
  EXPECT_NE(flown.find("\n0,0.5,0.2,1.2,"), std::string::npos) << flown.substr(0, 300);  // the task's start
}

// The record is written as the run goes: a simulator killed after 2.5 s
// leaves rt.csv.partial with at least the first 1.5 s, and no rt.csv.
TEST_F(SimUdpTest, AKilledSimulatorLeavesItsRecordSoFar) {
  const uint16_t port = FreePort();
  const std::string log = (dir_ / "rt.csv").string();
  const auto r = RunCommand("timeout -s KILL 2.5 " + kSim + " --config " + kConfig + " --udp udp://127.0.0.1:" +
                            std::to_string(port) + " --realtime --duration 10 -q --start-task " + QUADHAND_SOURCE_DIR +
                            "/data/tasks/window_cup.yaml --log " + log);
  EXPECT_NE(r.exit_code, 0);  // killed
  EXPECT_FALSE(std::filesystem::exists(log));
  const std::string partial = ReadAll(log + ".partial");
  EXPECT_GE(CountLines(partial), 1 + 75) << partial.substr(0, 200);  // header, then >= 1.5 s at 50 Hz
  EXPECT_EQ(partial.rfind("t,", 0), 0u);
}

}  // namespace
}  // namespace quadhand
