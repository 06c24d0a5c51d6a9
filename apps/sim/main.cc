// quadhand-sim: the vehicle simulator (docs/sim.md).
//   --track plan.csv --out flown.csv   fly a plan (contracts.md) with the
//                                      geometric controller, write the flown states
//     [--world FILE --sensor depth|lidar --frames DIR]   and what a sensor on
//                                      the vehicle saw of the world (sim/sensor.h)
//   --figure8 --out plan.csv           write the paper's figure-eight plan
//   --udp udp://ADDR:PORT              behave like a PX4 autopilot over MAVLink
//                                      (udp_mode.h, sim/autopilot.h)
//     [--world FILE --sensor depth|lidar --frames-to udp://HOST:PORT]   and
//                                      stream a sensor's frames beside it
//                                      (link/sensor_stream.h)
// Exit codes: 0 success, 1 the simulation diverged, 2 bad input (one line on stderr).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>

#include <CLI/CLI.hpp>

#include "app_options.h"
#include "sensor_world.h"
#include "quadhand/core/file_util.h"
#include "quadhand/core/log.h"
#include "quadhand/core/text.h"
#include "quadhand/link/frame.h"
#include "quadhand/link/sensor_stream.h"
#include "quadhand/link/udp.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/planner/task.h"
#include "quadhand/scene/point_cloud.h"
#include "quadhand/scene/ros_bag.h"
#include "quadhand/sim/sensor.h"
#include "quadhand/sim/autopilot.h"
#include "quadhand/sim/config.h"
#include "quadhand/sim/figure_eight.h"
#include "quadhand/sim/plan_io.h"
#include "quadhand/sim/simulator.h"
#include "udp_mode.h"

namespace {

using namespace quadhand;

constexpr int kExitDiverged = 1;
constexpr int kExitBadInput = 2;

int Fail(const std::string& message, int code = kExitBadInput) {
  core::PrintError("quadhand-sim", message);
  return code;
}

// What the sensor saw along the flight (docs/sim.md, "Sensors"): a frame
// at every 1/rate of the flown record (the vehicle's own states), each a
// binary PCD of the returns in the sensor's frame, and DIR/frames.csv with
// each frame's time, file and sensor pose in the world; and/or the same
// frames as a ROS 1 bag (scene/ros_bag.h). The folder is made by renaming
// a finished temporary one, and the bag likewise: all there or not at all.
// `link` is the robot's link the sensor is mounted on (sensor.link).
core::Status WriteFrames(const std::vector<sim::FlownSample>& samples, const robot::RobotModel& robot, int link,
                         const sim::SensorConfig& sensor, sim::SensorRenderer* renderer, const std::string& dir,
                         const std::string& bag_path, int* frames) {
  const std::string partial = dir.empty() ? std::string() : dir + ".partial";
  std::error_code ec;
  if (!dir.empty()) {
    std::filesystem::remove_all(partial, ec);
    if (!std::filesystem::create_directory(partial, ec)) {
      return core::Status::InvalidArgument("--frames " + dir + ": cannot make " + partial + " (" + ec.message() + ")");
    }
  }
  std::unique_ptr<scene::BagWriter> bag;
  if (!bag_path.empty()) {
    auto created = scene::BagWriter::Create(bag_path);
    if (!created.ok()) return core::Status::InvalidArgument("--bag " + created.status().message());
    bag = std::move(*created);
  }
  std::string index = "index,t,file,x,y,z,qw,qx,qy,qz\n";
  const double period = 1.0 / sensor.rate();
  double next = samples.empty() ? 0.0 : samples.front().flown.t;
  *frames = 0;
  for (const sim::FlownSample& sample : samples) {
    if (sample.flown.t + 1e-9 < next) continue;
    next += period * std::max(1.0, std::floor((sample.flown.t + 1e-9 - next) / period) + 1.0);
    const Pose base = MakePose(sample.flown.position, sample.flown.attitude.toRotationMatrix());
    const Pose pose = robot::LinkPose(robot, base, sample.flown.joints, link) * sensor.Mount();
    const std::string file = core::Format("frame_%06d.pcd", *frames);
    const std::vector<Vec3> returns = renderer->Render(pose);
    if (!dir.empty()) QUADHAND_RETURN_IF_ERROR(scene::WritePcd(partial + "/" + file, returns, scene::PcdEncoding::kBinary));
    if (bag != nullptr) QUADHAND_RETURN_IF_ERROR(bag->Write(sample.flown.t, base, base.inverse() * pose, returns));
    const Quat q(pose.linear());
    const Vec3 p = pose.translation();
    index += core::Format("%d,%.6f,%s,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", *frames, sample.flown.t, file.c_str(),
                          p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z());
    ++*frames;
  }
  if (bag != nullptr) QUADHAND_RETURN_IF_ERROR(bag->Close());
  if (dir.empty()) return core::Status::Ok();
  QUADHAND_RETURN_IF_ERROR(core::WriteFileAtomically(partial + "/frames.csv", index));
  std::filesystem::rename(partial, dir, ec);
  if (ec) return core::Status::InvalidArgument("--frames " + dir + ": " + ec.message());
  return core::Status::Ok();
}

// Why `path`, a new output of `option` (a folder or a file, never
// overwritten), cannot be made; empty when it can, or when not asked for.
std::string NewOutputProblem(const std::string& option, const std::string& path, const std::string& kind) {
  if (path.empty()) return "";
  std::error_code ec;
  if (std::filesystem::exists(path, ec)) return option + " " + path + ": exists already (give a new " + kind + ")";
  const std::string parent = core::DirectoryOf(path);
  if (!std::filesystem::is_directory(parent.empty() ? "." : parent, ec)) {
    return option + " " + path + ": its folder does not exist";
  }
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "quadhand-sim: simulate the QuadHand vehicle (base, arm, PCGC battery, rotors, servos) under a\n"
      "geometric tracking controller; see docs/sim.md.\n"
      "  quadhand-sim --track plan.csv --out flown.csv [--pcgc on|off] [--payload KG] [--seed N]\n"
      "  quadhand-sim --figure8 --out plan.csv [--loops N] [--period S]\n"
      "  quadhand-sim --udp udp://127.0.0.1:14540 [--realtime] [--duration S] [--start X,Y,Z[,YAW] | --start-task\n"
      "               TASK [--target-rate HZ [--target-noise M] [--target-walk M/S] [--target-pass-time S]]] [--log flown.csv]\n"
      "               [--signing-key FILE [--require-signing]] [--system-id N]\n"
      "Exit codes: 0 success, 1 the simulation diverged, 2 bad input."};
  std::string track_path, out_path, config_path = core::FindBundledFile("data/sim/quadhand_sim.yaml", QUADHAND_SOURCE_DIR), pcgc, noise;
  bool figure8 = false, quiet = false;
  double payload = -1.0, settle = 0.0;
  uint64_t seed = 0;
  sim::FigureEightOptions eight;
  app.add_option("--track", track_path, "Plan file to fly (CSV, contracts.md)");
  std::string world_path, sensor_name, frames_dir, frames_to_url, bag_path;
  size_t frame_datagram = link::kDefaultSensorDatagramBytes;
  app.add_option("--world", world_path, "--track, --udp: the hidden true scene a sensor sees: a PCD or PLY cloud (world frame), "
                                        "or a task file (YAML) whose scene: it is");
  app.add_option("--sensor", sensor_name, "--track, --udp with --world: depth or lidar (options: the configuration's sensor:)")
      ->check(CLI::IsMember({"depth", "lidar"}));
  app.add_option("--frames", frames_dir, "--track with --world: write the sensor's frames to this new folder "
                                         "(PCD per frame and frames.csv; docs/sim.md, Sensors)");
  app.add_option("--bag", bag_path, "--track with --world: write the sensor's frames to this new ROS 1 bag "
                                    "(PointCloud2, Odometry and /tf; docs/sim.md, Sensors)");
  app.add_flag("--figure8", figure8, "Write the figure-eight plan of the paper's experiment to --out instead");
  app.add_option("--frames-to", frames_to_url,
                 "--udp with --world: send the sensor's frames to this address (udp://HOST:PORT; docs/link.md, "
                 "Sensor frames on UDP), rendered from the true state at the sensor's rate");
  app.add_option("--frame-datagram", frame_datagram, "--frames-to: bytes per datagram at most (110 to 65507)")
      ->capture_default_str();
  app.add_option("--out", out_path, "Output file (CSV): the flown states, or the figure-eight plan (not with --udp)");
  app.add_option("--config", config_path, "Simulator configuration (YAML, docs/sim.md)")->capture_default_str();
  app.add_option("--pcgc", pcgc, "Passive CoG compensation: on (battery on its mimic joint) or off (battery locked)")
      ->check(CLI::IsMember({"on", "off"}));
  app.add_option("--payload", payload, "Payload at the tool frame, kg, in [0, 100] (0: none; default: the configuration's)");
  app.add_option("--seed", seed, "Seed of the sensor noise")->capture_default_str();
  app.add_option("--noise", noise, "Sensor noise: on or off (default: the configuration's)")
      ->check(CLI::IsMember({"on", "off"}));
  app.add_option("--settle", settle, "Seconds of hover at the first setpoint before the plan starts (not recorded)")
      ->capture_default_str();
  app.add_option("--loops", eight.loops, "--figure8: loops")->capture_default_str();
  app.add_option("--period", eight.period, "--figure8: seconds per loop")->capture_default_str();
  app.add_option("--dt", eight.dt, "--figure8: row spacing, s, in (0, 0.1]")->capture_default_str();
  app.add_flag("-q,--quiet", quiet, "Print nothing on success (--udp: no status lines)");
  // MAVLink mode (docs/sim.md, "MAVLink mode").
  std::string udp_url, remote_url, start_text, start_task, log_path, key_path;
  bool realtime = false, require_signing = false;
  double duration = 0.0;
  int system_id = 1;
  app.add_option("--udp", udp_url,
                 "Act as a PX4-like autopilot over MAVLink 2 on this local UDP address (udp://ADDR:PORT); replies go "
                 "to the sender of the first accepted frame");
  app.add_option("--remote", remote_url, "--udp: send to this address (udp://HOST:PORT) from the start instead");
  app.add_flag("--realtime", realtime,
               "--udp: pace simulated time to the wall clock (default: lockstep, 20 ms of simulated time per "
               "SET_POSITION_TARGET_LOCAL_NED, the wall clock while none arrive)");
  app.add_option("--duration", duration,
                 "--udp: exit after this many simulated seconds, at most 1e6 (0: until SIGINT/SIGTERM)")
      ->capture_default_str();
  app.add_option("--start", start_text, "--udp: hover start X,Y,Z[,YAW] (ENU m, rad; joints at mid-range; default 0,0,1)");
  app.add_option("--start-task", start_task,
                 "--udp: start at a task file's start state (position, yaw, joints); a mission's grasps are what the "
                 "gripper picks up (MAV_CMD_DO_GRIPPER)");
  app.add_option("--log", log_path,
                 "--udp: write the flown states (plan CSV columns, 50 Hz) here: to LOG.partial every second,\n"
                 "renamed to LOG at the end");
  app.add_option("--signing-key", key_path, "--udp: MAVLink 2 signing key (64 hex digits or 32 raw bytes): signs what is sent, verifies what is received");
  app.add_flag("--require-signing", require_signing,
               "--udp: drop unsigned, wrongly signed and replayed frames (needs --signing-key)");
  app.add_option("--system-id", system_id, "--udp: MAVLink system id of the vehicle")
      ->check(CLI::Range(1, 255))
      ->capture_default_str();
  // A moving target (docs/sim.md, "A moving target").
  sim::SimTargetOptions target_options;
  double target_rate = 0.0;
  app.add_option("--target-rate", target_rate,
                 "--udp with --start-task: move the task's target (goal.tool.motion) and send its measured pose as "
                 "LANDING_TARGET this many times a second of simulated time, in (0, 1000] (default: no target)");
  app.add_option("--target-noise", target_options.noise, "--target-rate: measured position noise, m (one sigma per axis)")
      ->capture_default_str();
  app.add_option("--target-yaw-noise", target_options.yaw_noise, "--target-rate: measured heading noise, rad")
      ->capture_default_str();
  app.add_option("--target-walk", target_options.random_walk,
                 "--target-rate: random walk of the target's velocity on top of its motion, m/s per sqrt(s)")
      ->capture_default_str();
  app.add_option("--target-pass-time", target_options.pass_time,
                 "--target-rate: simulated time (s) at which the target is at its pose in the task (its motion's "
                 "t = 0; a constant motion is extrapolated backwards before it)")
      ->capture_default_str();
  std::vector<std::string> package_path;
  quadhand::apps::AddPackagePathOption(&app, &package_path);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }
  const bool udp = !udp_url.empty();
  if (int{figure8} + int{!track_path.empty()} + int{udp} != 1) {
    return Fail("give exactly one of --track PLAN, --figure8 and --udp URL");
  }
  if (udp && !out_path.empty()) return Fail("--out is not used with --udp (use --log for the flown states)");
  if (udp && app.count("--settle") > 0) return Fail("--settle is only used with --track");
  const int sensing = int{!world_path.empty()} + int{!sensor_name.empty()} +
                      int{!frames_dir.empty() || !bag_path.empty() || !frames_to_url.empty()};
  if (!frames_dir.empty() && track_path.empty()) return Fail("--frames is only used with --track (--udp: --frames-to)");
  if (!bag_path.empty() && track_path.empty()) return Fail("--bag is only used with --track");
  if (!frames_to_url.empty() && !udp) return Fail("--frames-to is only used with --udp (--track: --frames)");
  if (sensing > 0 && (figure8 || sensing < 3)) {
    return Fail("--world, --sensor and --frames or --bag (--track) or --frames-to (--udp) go together");
  }
  if (std::string why = NewOutputProblem("--frames", frames_dir, "folder"); !why.empty()) return Fail(why);
  if (std::string why = NewOutputProblem("--bag", bag_path, "file"); !why.empty()) return Fail(why);
  if (!udp && out_path.empty()) return Fail("--out is required with --track and --figure8");
  if (!udp) {
    const std::vector<std::pair<bool, const char*>> udp_only = {
        {!remote_url.empty(), "--remote"},     {realtime, "--realtime"},
        {app.count("--duration") > 0, "--duration"}, {!start_text.empty(), "--start"},
        {!start_task.empty(), "--start-task"}, {!log_path.empty(), "--log"},
        {!key_path.empty(), "--signing-key"},  {require_signing, "--require-signing"},
        {app.count("--system-id") > 0, "--system-id"}, {app.count("--target-rate") > 0, "--target-rate"}};
    for (const auto& [given, name] : udp_only) {
      if (given) return Fail(std::string(name) + " is only used with --udp");
    }
  }

  // One message per option, with its range (CLI11's own range checks print
  // the largest double in full).
  if (app.count("--payload") > 0 && !(payload >= 0.0 && payload <= 100.0)) {
    return Fail("--payload must be in [0, 100] kg");
  }
  if (!(settle >= 0.0 && settle <= sim::kMaxSimulatedSeconds)) return Fail("--settle must be in [0, 3600] s");
  if (!(duration >= 0.0 && duration <= 1e6)) return Fail("--duration must be in [0, 1e6] s");
  auto config = sim::LoadSimConfig(config_path);
  if (!config.ok()) return Fail(config.status().message());
  if (!pcgc.empty()) config->pcgc = pcgc == "on";
  if (payload >= 0.0) {
    config->payload.attached = payload > 0.0;
    config->payload.mass = payload;
  }
  if (!noise.empty()) config->noise.enabled = noise == "on";
  if (config->robot_path.empty()) return Fail(config_path + ": robot: missing (the URDF to simulate)");
  robot::PrependRosPackagePath(package_path);
  auto robot = robot::RobotModel::LoadFromUrdfFile(config->robot_path);
  if (!robot.ok()) return Fail(robot.status().message());
  const std::vector<std::string> joints = robot->ActuatedJointNames();

  if (figure8) {
    eight.gravity = config->gravity;
    auto plan = sim::MakeFigureEightPlan(eight, joints, robot->LowerLimits(), robot->UpperLimits(),
                                         robot->VelocityLimits());
    if (!plan.ok()) return Fail(plan.status().message());
    if (core::Status s = core::WriteFileAtomically(out_path, sim::WritePlanCsv(*plan)); !s.ok()) {
      return Fail(s.message());
    }
    if (!quiet) std::printf("figure-eight plan: %zu rows, %.2f s: %s\n", plan->rows.size(), plan->end_time(), out_path.c_str());
    return 0;
  }

  auto model = sim::VehicleModel::Create(*robot, *config);
  if (!model.ok()) return Fail(config_path + ": " + model.status().message());
  const bool pcgc_acts = model->pcgc();

  std::unique_ptr<sim::SensorRenderer> renderer;
  sim::SensorConfig sensor = config->sensor;
  if (!world_path.empty()) {
    auto kind = sim::ParseSensorKind(sensor_name);
    if (!kind.ok()) return Fail("--sensor: " + kind.status().message());
    sensor.kind = *kind;
    if (robot->LinkIndex(sensor.link) < 0) {
      return Fail(config_path + ": sensor.link: the robot has no link '" + sensor.link + "'");
    }
    auto world = planner::LoadWorldPoints(world_path);
    if (!world.ok()) return Fail(world.status().message());
    if (world->empty()) return Fail("--world " + world_path + ": no finite points");
    if (!quiet) apps::WarnWhenTheSensorSeesThrough("quadhand-sim", world_path, *world, sensor);
    auto made = sim::SensorRenderer::Create(*world, sensor, seed ^ 0x73656e73ull);
    if (!made.ok()) return Fail(config_path + ": " + made.status().message());
    renderer = std::move(*made);
  }

  if (udp) {
    sim_app::UdpModeOptions options;
    if (renderer != nullptr) {
      auto to = link::ParseUdpUrl(frames_to_url);
      if (!to.ok()) return Fail("--frames-to " + to.status().message());
      if (frame_datagram < 110 || frame_datagram > link::kMaxSensorDatagramBytes) {
        return Fail("--frame-datagram must be in [110, 65507] bytes");
      }
      options.frames_to = *to;
      options.renderer = renderer.get();
      options.sensor = sensor;
      options.robot = &*robot;
      options.frame_datagram = frame_datagram;
    }
    auto bind = link::ParseUdpUrl(udp_url);
    if (!bind.ok()) return Fail("--udp " + bind.status().message());
    options.bind = *bind;
    if (!remote_url.empty()) {
      auto remote = link::ParseUdpUrl(remote_url);
      if (!remote.ok()) return Fail("--remote " + remote.status().message());
      options.remote = *remote;
    }
    if (!start_text.empty() && !start_task.empty()) return Fail("give at most one of --start and --start-task");
    sim::StartPose start;
    if (!start_text.empty()) {
      auto parsed = sim::ParseStartPose(start_text);
      if (!parsed.ok()) return Fail(parsed.status().message());
      start = *parsed;
    }
    std::vector<sim::GripperLoad> gripper_loads;
    if (!start_task.empty()) {
      auto loaded = sim::LoadTaskStartPose(start_task);
      if (!loaded.ok()) return Fail(loaded.status().message());
      start = *loaded;
      // A mission's grasps: what the gripper picks up (MAV_CMD_DO_GRIPPER).
      auto loads = sim::LoadTaskGripperLoads(start_task);
      if (!loads.ok()) return Fail(loads.status().message());
      gripper_loads = std::move(*loads);
    }
    if (require_signing && key_path.empty()) return Fail("--require-signing needs --signing-key FILE");
    if (!key_path.empty()) {
      auto key = link::LoadSigningKey(key_path);
      if (!key.ok()) return Fail("--signing-key " + key.status().message());
      options.signing_key = *key;
    }
    if (!log_path.empty()) {
      std::error_code ec;
      if (!std::filesystem::is_directory(core::DirectoryOf(log_path), ec)) {
        return Fail("--log " + log_path + ": its folder does not exist");
      }
    }
    options.log_path = log_path;
    options.realtime = realtime;
    options.duration = duration;
    options.require_signing = require_signing;
    options.system_id = static_cast<uint8_t>(system_id);
    options.quiet = quiet;
    sim::AutopilotOptions autopilot_options;
    autopilot_options.system_id = options.system_id;
    if (app.count("--target-rate") > 0) {
      if (start_task.empty()) return Fail("--target-rate needs --start-task TASK (the task's goal.tool.motion moves the target)");
      target_options.rate = target_rate;
      target_options.seed = seed ^ 0x7a6e7467ull;  // its own stream, from --seed
      if (std::string why; !target_options.IsValid(&why)) return Fail("--target-*: " + why);
      auto target = sim::LoadTaskTarget(start_task);
      if (!target.ok()) return Fail(target.status().message());
      autopilot_options.target.emplace(target->pose, target->motion, target_options);
    } else if (app.count("--target-noise") + app.count("--target-yaw-noise") + app.count("--target-walk") +
                   app.count("--target-pass-time") > 0) {
      return Fail("--target-noise, --target-yaw-noise, --target-walk and --target-pass-time need --target-rate");
    }
    autopilot_options.record_flown = !log_path.empty();
    autopilot_options.gripper_loads = std::move(gripper_loads);
    auto autopilot = sim::Autopilot::Create(sim::Simulator(std::move(*model), seed), start, autopilot_options);
    if (!autopilot.ok()) {
      return Fail((start_task.empty() ? std::string("--start") : start_task) + ": " + autopilot.status().message());
    }
    return sim_app::RunUdpMode(std::move(*autopilot), options, joints);
  }

  auto plan = sim::LoadPlanCsv(track_path, joints);
  if (!plan.ok()) return Fail(plan.status().message());
  const auto start = std::chrono::steady_clock::now();
  sim::Simulator simulator(std::move(*model), seed);
  sim::TrackOptions options;
  options.settle = settle;
  auto result = sim::TrackPlan(&simulator, *plan, options);
  if (!result.ok()) {
    const bool diverged = result.status().code() == core::StatusCode::kInfeasible;
    return Fail(track_path + ": " + result.status().message(), diverged ? kExitDiverged : kExitBadInput);
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (core::Status s = core::WriteFileAtomically(out_path, sim::FlownCsv(result->samples, joints)); !s.ok()) {
    return Fail(s.message());
  }
  int frames = 0;
  if (renderer != nullptr) {
    if (core::Status s = WriteFrames(result->samples, *robot, robot->LinkIndex(sensor.link), sensor, renderer.get(),
                                     frames_dir, bag_path, &frames);
        !s.ok()) {
      return Fail(s.message());
    }
    if (!quiet) {
      const std::string to = frames_dir + (!frames_dir.empty() && !bag_path.empty() ? ", " : "") + bag_path;
      std::printf("sensor: %d %s frames of %s: %s\n", frames, sensor_name.c_str(), world_path.c_str(), to.c_str());
    }
  }
  if (!quiet) {
    const sim::TrackingErrorStats& e = result->error;
    std::printf(
        "flown: %zu samples, %.2f s simulated in %.2f s (%.0fx real time), PCGC %s, payload %.3f kg\n"
        "3-D tracking error (m): mean %.4f, median %.4f, p95 %.4f, max %.4f\n"
        "out: %s\n",
        result->samples.size(), result->simulated_s, wall, result->simulated_s / std::max(wall, 1e-9),
        pcgc_acts ? "on" : "off", config->payload.attached ? config->payload.mass : 0.0, e.mean, e.median, e.p95,
        e.max, out_path.c_str());
  }
  return 0;
}
