// quadhand-map: builds the rolling map (perception/rolling_map.h) from a
// folder of recorded sensor frames (scene/frame_folder.h: quadhand-sim
// --frames writes one), from a ROS 1 bag's clouds (--bag; scene/ros_bag.h),
// or from frames arriving on UDP (--listen;
// link/sensor_stream.h: quadhand-sim --udp --frames-to sends them), the
// window following the sensor, and writes what it
// holds at the end: the raw returns of its occupied voxels (a scene
// quadhand-plan reads) and, if asked, the centres of the unknown voxels of
// a box. Prints the frames used and dropped (and why) and the map update's
// cost per frame. With --plan TASK it also replans over the recording
// (explore/recorded_replans.h): every --replan-period of the frames' time,
// a local plan from where the recording's vehicle was to the task's goal,
// each reported with its latency and whether it was certified.
// docs/perception.md.
//
// Exit codes: 0 success; 2 bad input (one line on stderr naming the file).
#include <algorithm>
#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "local_plan_report.h"
#include "quadhand/core/file_util.h"
#include "quadhand/core/log.h"
#include "quadhand/core/statistics.h"
#include "quadhand/core/text.h"
#include "quadhand/explore/local_planner.h"
#include "quadhand/explore/recorded_replans.h"
#include "quadhand/link/sensor_stream.h"
#include "quadhand/link/udp.h"
#include "quadhand/scene/frame_folder.h"
#include "quadhand/perception/rolling_map.h"
#include "quadhand/perception/sensor_frame.h"
#include "quadhand/opt/solver_registry.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/sim/sensor.h"
#include "quadhand/solvers/builtin_solvers.h"
#include "quadhand/scene/point_cloud.h"
#include "quadhand/scene/ros_bag.h"

namespace {

using namespace quadhand;

volatile std::sig_atomic_t g_stop = 0;
extern "C" void OnSignal(int) { g_stop = 1; }

int Fail(const std::string& message) {
  core::PrintError("quadhand-map", message);
  return 2;
}

core::Result<std::vector<double>> Numbers(const std::string& text, size_t count, const std::string& option) {
  std::vector<double> values;
  for (const std::string& cell : core::SplitCommas(text)) {
    char* end = nullptr;
    const double value = std::strtod(cell.c_str(), &end);
    if (cell.empty() || end != cell.c_str() + cell.size() || !std::isfinite(value)) {
      return core::Status::InvalidArgument(option + ": '" + cell + "' is not a finite number");
    }
    values.push_back(value);
  }
  if (values.size() != count) {
    return core::Status::InvalidArgument(option + core::Format(": expected %zu comma-separated numbers", count));
  }
  return values;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "quadhand-map: build the rolling map of sensor frames and write what it holds.\n"
      "  quadhand-map FRAMES_DIR --out occupied.pcd [--unknown-out unknown.pcd --unknown-box x0,y0,z0,x1,y1,z1]\n"
      "               [--resolution 0.1] [--window 15,15,5] [--max-range 6] [--json]\n"
      "  quadhand-map --listen udp://ADDR:PORT --out occupied.pcd [--idle 2] [--max-duration S] [...]\n"
      "  quadhand-map --bag FILE.bag --cloud-topic /points [--odom-topic /odom [--extrinsic x,y,z,qw,qx,qy,qz]\n"
      "               | --world-frame world] --out occupied.pcd [...]\n"
      "  quadhand-map SOURCE --out occupied.pcd --plan TASK.yaml [--report R.json] [--mount x,y,z,qw,qx,qy,qz]\n"
      "FRAMES_DIR: frames.csv and one cloud per frame (docs/sim.md, \"The frames folder\").\n"
      "--bag: a ROS 1 bag's sensor_msgs/PointCloud2 on --cloud-topic, placed by nav_msgs/Odometry on --odom-topic\n"
      "or by /tf and /tf_static (docs/perception.md, \"Recorded data\").\n"
      "--listen: frames on UDP (docs/link.md, \"Sensor frames on UDP\"), until --idle s without a datagram\n"
      "after the first frame, --max-duration, or SIGINT/SIGTERM.\n"
      "--plan: replan over the recording, open loop: every --replan-period s of the frames' time, a local plan\n"
      "from where the recording's vehicle was to the task's goal (docs/perception.md, \"Replanning over recorded\n"
      "frames\").\n"
      "Exit codes: 0 success; 2 bad input."};
  std::string dir, out_path, unknown_path, unknown_box_text, window_text, listen_url, extrinsic_text;
  scene::BagCloudSource bag;
  double idle = 2.0, max_duration = 0.0;
  perception::RollingMapOptions options;
  bool json = false;
  app.add_option("frames", dir, "Folder of frames (frames.csv and the clouds it names)");
  app.add_option("--listen", listen_url, "Receive frames on this local address instead (udp://ADDR:PORT)");
  app.add_option("--bag", bag.path, "Read the clouds of this ROS 1 bag instead");
  app.add_option("--cloud-topic", bag.cloud_topic, "--bag: the sensor_msgs/PointCloud2 topic");
  app.add_option("--odom-topic", bag.odom_topic, "--bag: place each cloud by this nav_msgs/Odometry topic's pose");
  app.add_option("--extrinsic", extrinsic_text,
                 "--odom-topic: the cloud's frame in the odometry's child frame, x,y,z,qw,qx,qy,qz (default identity)");
  app.add_option("--world-frame", bag.world_frame, "--bag without --odom-topic: place each cloud by /tf in this frame")
      ->capture_default_str();
  app.add_option("--max-pose-gap", bag.max_pose_gap, "--odom-topic: no pose between odometry messages farther apart, s")
      ->capture_default_str();
  app.add_option("--idle", idle, "--listen: stop after this many seconds without a datagram, once a frame is mapped")
      ->capture_default_str();
  app.add_option("--max-duration", max_duration, "--listen: stop after this many seconds (0: no limit)")
      ->capture_default_str();
  app.add_option("--out", out_path, "Write the occupied voxels' raw returns here (PCD, world frame)")->required();
  app.add_option("--unknown-out", unknown_path, "Write the centres of the unknown voxels of --unknown-box here (PCD)");
  app.add_option("--unknown-box", unknown_box_text, "x0,y0,z0,x1,y1,z1: the box for --unknown-out (world, m)");
  app.add_option("--resolution", options.resolution, "Voxel edge, m")->capture_default_str();
  app.add_option("--window", window_text, "Half-extents of the window about the sensor, m (x,y,z; default 15,15,5)");
  app.add_option("--max-range", options.max_range, "Returns farther than this free their ray and occupy nothing, m")
      ->capture_default_str();
  app.add_option("--ray-threads", options.ray_threads, "Threads that walk each frame's rays")->capture_default_str();
  app.add_option("--stop-ray-after", options.stop_ray_after_crossed,
                 "Walk each ray back from its end and stop it after this many voxels in a row that earlier rays of the frame crossed (0: whole rays; docs/perception.md)")
      ->capture_default_str();
  app.add_flag("--json", json, "Print one JSON line instead of words");
  std::string plan_task_path, report_path, mount_text, config_path, solver_name = "lbfgs";
  explore::RecordedReplanOptions replan_options;
  replan_options.mount = sim::DefaultMount(sim::SensorKind::kDepth);
  app.add_option("--plan", plan_task_path,
                 "Replan over the recording to this task's goal (a goal at rest; its scene is not read)");
  app.add_option("--report", report_path, "--plan: a JSON report of every replan");
  app.add_option("--mount", mount_text,
                 "--plan: the sensor's pose in the robot's base link, x,y,z,qw,qx,qy,qz (default: the simulator's "
                 "depth camera, 0.1 m ahead looking along x)");
  app.add_option("--replan-period", replan_options.replan_period, "--plan: seconds of the frames' time between replans")
      ->capture_default_str();
  app.add_option("--config", config_path, "--plan: planner configuration (YAML, docs/config.md; default: built-in)");
  app.add_option("--solver", solver_name, "--plan: optimiser back-end (docs/solvers.md)")->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }
  if (int{!dir.empty()} + int{!listen_url.empty()} + int{!bag.path.empty()} != 1) {
    return Fail("give a frames folder, --bag FILE or --listen udp://ADDR:PORT (one of them)");
  }
  const bool bag_options = !bag.cloud_topic.empty() || !bag.odom_topic.empty() || !extrinsic_text.empty() ||
                           app.count("--world-frame") > 0 || app.count("--max-pose-gap") > 0;
  if (bag.path.empty() && bag_options) return Fail("--cloud-topic, --odom-topic, --extrinsic, --world-frame and --max-pose-gap are only used with --bag");
  if (!bag.path.empty()) {
    if (bag.cloud_topic.empty()) return Fail("--bag needs --cloud-topic (quadhand-map --bag FILE --cloud-topic /points ...)");
    if (!bag.odom_topic.empty() && app.count("--world-frame") > 0) {
      return Fail("--odom-topic and --world-frame are two ways to place the clouds: give one");
    }
    if (!extrinsic_text.empty()) {
      if (bag.odom_topic.empty()) return Fail("--extrinsic is only used with --odom-topic (/tf gives the sensor's frame)");
      auto e = Numbers(extrinsic_text, 7, "--extrinsic");
      if (!e.ok()) return Fail(e.status().message());
      const Eigen::Vector4d q((*e)[3], (*e)[4], (*e)[5], (*e)[6]);
      if (std::abs(q.norm() - 1.0) > 1e-3) return Fail("--extrinsic: qw,qx,qy,qz must be a unit quaternion");
      bag.extrinsic = MakePose(Vec3((*e)[0], (*e)[1], (*e)[2]), Quat(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix());
    }
    if (std::string why; !bag.IsValid(&why)) return Fail(bag.path + ": " + why);
  }
  if (!(std::isfinite(idle) && idle > 0.0 && idle <= 3600.0)) return Fail("--idle must be in (0, 3600] s");
  if (!(std::isfinite(max_duration) && max_duration >= 0.0)) return Fail("--max-duration must be >= 0 s");
  if (!window_text.empty()) {
    auto window = Numbers(window_text, 3, "--window");
    if (!window.ok()) return Fail(window.status().message());
    options.window_half_extent = Vec3((*window)[0], (*window)[1], (*window)[2]);
  }
  if (std::string why; !options.IsValid(&why)) return Fail(why);
  if (unknown_path.empty() != unknown_box_text.empty()) return Fail("--unknown-out and --unknown-box go together");
  Vec3 box_lo = Vec3::Zero(), box_hi = Vec3::Zero();
  if (!unknown_box_text.empty()) {
    auto box = Numbers(unknown_box_text, 6, "--unknown-box");
    if (!box.ok()) return Fail(box.status().message());
    box_lo = Vec3((*box)[0], (*box)[1], (*box)[2]);
    box_hi = Vec3((*box)[3], (*box)[4], (*box)[5]);
    if (!(box_lo.array() < box_hi.array()).all()) return Fail("--unknown-box: min must be below max on every axis");
  }
  const bool planning = !plan_task_path.empty();
  if (!planning && (!report_path.empty() || !mount_text.empty() || !config_path.empty() ||
                    app.count("--replan-period") > 0 || app.count("--solver") > 0)) {
    return Fail("--report, --mount, --replan-period, --config and --solver are only used with --plan");
  }
  if (!mount_text.empty()) {
    auto m = Numbers(mount_text, 7, "--mount");
    if (!m.ok()) return Fail(m.status().message());
    const Eigen::Vector4d q((*m)[3], (*m)[4], (*m)[5], (*m)[6]);
    if (std::abs(q.norm() - 1.0) > 1e-3) return Fail("--mount: qw,qx,qy,qz must be a unit quaternion");
    replan_options.mount =
        MakePose(Vec3((*m)[0], (*m)[1], (*m)[2]), Quat(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix());
  }
  if (std::string why; !replan_options.IsValid(&why)) return Fail("--replan-period: " + why);
  for (const std::string& path : {out_path, unknown_path, report_path}) {
    if (path.empty()) continue;
    const std::filesystem::path parent = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!parent.empty() && !std::filesystem::is_directory(parent, ec)) return Fail(path + ": its folder does not exist");
    for (const std::string& input : {dir, bag.path, plan_task_path, config_path}) {
      if (!input.empty() && core::SameFile(path, input)) return Fail(path + ": is an input of this run");
    }
  }
  if (!report_path.empty() && (core::SameFile(report_path, out_path) || core::SameFile(report_path, unknown_path))) {
    return Fail("--report " + report_path + ": names another output of this run");
  }

  // --plan: the local planner of the task, as quadhand-explore builds it.
  std::unique_ptr<planner::PlanningContext> base;
  std::unique_ptr<opt::Solver> solver;
  std::unique_ptr<explore::LocalPlanner> local_planner;
  std::optional<explore::RecordedReplanner> replanner;
  std::vector<explore::RecordedReplan> replans;
  if (planning) {
    auto config = planner::LoadPlannerConfigOrDefaults(config_path);
    if (!config.ok()) return Fail(config.status().message());
    if (config_path.empty()) explore::UseLocalPlanningDefaults(&*config, options.resolution);
    auto base_context = explore::BaseContextOfTaskFile(plan_task_path, *config);
    if (!base_context.ok()) return Fail(base_context.status().message());
    base = std::move(*base_context);
    if (core::Status s = solvers::RegisterBuiltinSolvers(); !s.ok()) return Fail(s.message());
    auto created = opt::CreateSolver(solver_name);
    if (!created.ok()) return Fail("--solver: " + created.status().message());
    solver = std::move(*created);
    auto local = explore::LocalPlanner::Create(*base, planner::RunPlannerOptions(*config, 0.01, 1, false), *solver,
                                               explore::LocalPlannerOptions{});
    if (!local.ok()) return Fail(local.status().message());  // (it names the task file)
    local_planner = std::move(*local);
    auto made = explore::RecordedReplanner::Create(*local_planner, base->task(), replan_options);
    if (!made.ok()) return Fail(made.status().message());
    replanner.emplace(std::move(*made));
  }

  auto map = perception::RollingMap::Create(options);
  if (!map.ok()) return Fail(map.status().message());
  long unreadable = 0, empty_frames = 0;
  std::vector<double> update_ms;
  // One frame into the map, in the world frame; with --plan, then a replan
  // when its period has passed.
  auto map_frame = [&](double t, const std::vector<Vec3>& points, const Pose& sensor_to_world,
                       const std::vector<Vec3>& misses) -> core::Status {
    if (replanner) replanner->BeforeFrame(map->get(), sensor_to_world);
    const auto start = std::chrono::steady_clock::now();
    (*map)->MoveWindow(sensor_to_world.translation());
    QUADHAND_RETURN_IF_ERROR((*map)->Insert(points, sensor_to_world.translation(), misses));
    update_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    if (!replanner) return core::Status::Ok();
    if (auto replan = replanner->AfterFrame(**map, t, sensor_to_world)) {
      if (!json) {
        std::fprintf(stderr, "\r  t %8.2f s: replan %-15s %7.1f ms, %6zu boundary voxels   ", replan->t,
                     explore::LocalPlanStatusName(replan->result.status), replan->result.total_ms,
                     replan->result.scene_points);
      }
      replans.push_back(std::move(*replan));
    }
    return core::Status::Ok();
  };

  scene::FrameIndex index;
  std::string source = dir;
  link::SensorFrameAssembler assembler;
  // The frames' stamps are the sender's clock, which this program does not
  // know: the gate judges their poses and order, not their age.
  perception::FrameGateOptions gate_options;
  gate_options.max_age = std::numeric_limits<double>::infinity();
  perception::FrameGate gate(gate_options);
  scene::BagCloudCounts bag_counts;
  if (!bag.path.empty()) {
    source = bag.path;
    const core::Status read = scene::ForEachBagCloud(
        bag,
        [&](scene::BagCloud& cloud) -> core::Status {
          perception::SensorFrame frame;
          frame.t = cloud.t;
          perception::SetSensorPose(cloud.sensor_to_world, &frame);
          if (gate.Admit(frame, frame.t) != perception::FrameDrop::kNone) return core::Status::Ok();
          if (cloud.points.empty()) {
            ++empty_frames;
            return core::Status::Ok();
          }
          for (Vec3& p : cloud.points) p = cloud.sensor_to_world * p;
          const core::Status s = map_frame(cloud.t, cloud.points, cloud.sensor_to_world, {});
          return s.ok() ? s : core::Status::InvalidArgument(bag.path + ": " + s.message());
        },
        &bag_counts);
    if (!read.ok()) return Fail(read.message());
  } else if (listen_url.empty()) {
    auto read = scene::ReadFrameIndex(dir);
    if (!read.ok()) return Fail(read.status().message());
    index = std::move(*read);
    // A frame missing, truncated or malformed is dropped and counted; one
    // that saw nothing in range teaches nothing.
    scene::FrameCloudCounts read_counts;
    const core::Status mapped = scene::ForEachFrameCloud(
        index,
        [&](const scene::FrameRecord& frame, std::vector<Vec3>& points) {
          const core::Status s = map_frame(frame.t, points, frame.sensor_to_world, {});
          return s.ok() ? s : core::Status::InvalidArgument(frame.path + ": " + s.message());
        },
        &read_counts);
    unreadable += read_counts.unreadable;
    empty_frames += read_counts.empty;
    if (!mapped.ok()) return Fail(mapped.message());
  } else {
    source = listen_url;
    auto bind = link::ParseUdpUrl(listen_url, true);
    if (!bind.ok()) return Fail("--listen " + bind.status().message());
    auto socket = link::UdpSocket::Bind(*bind);
    if (!socket.ok()) return Fail("--listen " + listen_url + ": " + socket.status().message());
    socket->SetReceiveBuffer(16u << 20);
    std::signal(SIGINT, OnSignal);
    std::signal(SIGTERM, OnSignal);
    if (!json) std::fprintf(stderr, "quadhand-map: listening on udp://%s:%u\n", bind->host.c_str(), socket->local_port());
    const auto begin = std::chrono::steady_clock::now();
    auto last_datagram = begin;
    auto seconds_since = [](std::chrono::steady_clock::time_point t) {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    };
    while (!g_stop) {
      if (max_duration > 0.0 && seconds_since(begin) >= max_duration) break;
      if (!update_ms.empty() && seconds_since(last_datagram) >= idle) break;
      if (!socket->WaitReadable(0.05)) continue;
      while (auto datagram = socket->Receive()) {
        last_datagram = std::chrono::steady_clock::now();
        auto frame = assembler.Add(datagram->bytes.data(), datagram->bytes.size());
        if (!frame || gate.Admit(*frame, frame->t) != perception::FrameDrop::kNone) continue;
        if (frame->points.empty()) {
          ++empty_frames;
          continue;
        }
        const Pose pose = perception::SensorPose(*frame);
        for (Vec3& p : frame->points) p = pose * p;
        for (Vec3& p : frame->misses) p = pose * p;
        if (core::Status s = map_frame(frame->t, frame->points, pose, frame->misses); !s.ok()) {
          return Fail(listen_url + ": " + s.message());
        }
      }
    }
    assembler.Flush();
  }
  const link::SensorStreamCounts& stream = assembler.counts();
  const perception::FrameCounts& gated = gate.counts();
  if (update_ms.empty()) {
    if (!listen_url.empty()) {
      return Fail(listen_url + core::Format(": no usable frame (%ld datagrams, %ld frames, %ld dropped by the gate, "
                                            "%ld empty)",
                                            stream.datagrams, stream.frames, gated.dropped(), empty_frames));
    }
    if (!bag.path.empty()) {
      return Fail(bag.path + core::Format(": no usable cloud on %s (%ld messages: %ld malformed, %ld without a pose, "
                                          "%ld dropped by the gate, %ld empty)",
                                          bag.cloud_topic.c_str(), bag_counts.messages, bag_counts.malformed,
                                          bag_counts.no_pose, gated.dropped(), empty_frames));
    }
    return Fail(dir + ": no usable frame (" + std::to_string(index.dropped()) + " rows dropped, " +
                std::to_string(unreadable) + " clouds unreadable, " + std::to_string(empty_frames) + " empty)");
  }
  const std::vector<Vec3> occupied = (*map)->OccupiedPoints();
  if (occupied.empty()) return Fail(source + ": the frames show no occupied voxel inside the last window");
  if (core::Status s = scene::WritePcd(out_path, occupied); !s.ok()) return Fail(s.message());
  long unknown = -1;
  if (!unknown_path.empty()) {
    const std::vector<Vec3> centres = (*map)->UnknownVoxelCentres(box_lo, box_hi);
    unknown = static_cast<long>(centres.size());
    if (!centres.empty()) {
      if (core::Status s = scene::WritePcd(unknown_path, centres); !s.ok()) return Fail(s.message());
    }
  }
  // --plan: the replans' summary, and the report.
  std::vector<double> replan_ms;
  int certified = 0, to_goal = 0, recoveries = 0;
  nlohmann::json replan_log = nlohmann::json::array();
  for (const explore::RecordedReplan& r : replans) {
    const explore::LocalPlanResult& p = r.result;
    replan_ms.push_back(p.total_ms);
    const bool ok = explore::IsCertified(p.status);
    certified += ok ? 1 : 0;
    to_goal += p.status == explore::LocalPlanStatus::kToGoal ? 1 : 0;
    recoveries += ok && p.recovery ? 1 : 0;
    nlohmann::json entry = apps::LocalPlanSummaryJson(p);
    entry["t"] = r.t;
    entry["position"] = {r.start.position.x(), r.start.position.y(), r.start.position.z()};
    entry["speed"] = r.start.velocity.norm();
    if (ok) {
      entry["target"] = {p.target.x(), p.target.y(), p.target.z()};
      entry["duration_s"] = p.plan.trajectory ? p.plan.trajectory->duration() : 0.0;
    }
    replan_log.push_back(entry);
  }
  if (!report_path.empty()) {
    const nlohmann::json report = {{"source", source},
                                   {"task", plan_task_path},
                                   {"frames", update_ms.size()},
                                   {"map_update_ms", apps::CountMedianP95Max(update_ms)},
                                   {"replan_period_s", replan_options.replan_period},
                                   {"planned_safety_distance_m", local_planner->PlannedSafetyDistance(options.resolution)},
                                   {"replans", replans.size()},
                                   {"replans_certified", certified},
                                   {"replans_to_goal", to_goal},
                                   {"recoveries", recoveries},
                                   {"replan_latency_ms", apps::CountMedianP95Max(replan_ms)},
                                   {"replan_log", replan_log}};
    if (core::Status s = core::WriteFileAtomically(report_path, report.dump(2) + "\n"); !s.ok()) return Fail(s.message());
  }
  const double median = core::RankQuantile(update_ms, 0.5), p95 = core::RankQuantile(update_ms, 0.95);
  const double worst = *std::max_element(update_ms.begin(), update_ms.end());
  const std::string stream_json =
      listen_url.empty()
          ? std::string()
          : core::Format(", \"datagrams\": %ld, \"frames_received\": %ld, \"datagrams_malformed\": %ld, "
                         "\"datagrams_truncated\": %ld, \"datagrams_corrupted\": %ld, \"datagrams_inconsistent\": %ld, "
                         "\"datagrams_duplicate\": %ld, \"frames_incomplete\": %ld, \"frames_malformed\": %ld, "
                         "\"frames_bad_pose\": %ld, \"frames_out_of_order\": %ld",
                         stream.datagrams, stream.frames, stream.malformed, stream.truncated, stream.corrupted,
                         stream.inconsistent, stream.duplicates, stream.incomplete_frames, gated.malformed,
                         gated.bad_pose, gated.out_of_order);
  const std::string bag_json =
      bag.path.empty()
          ? std::string()
          : core::Format(", \"bag_messages\": %ld, \"bag_malformed\": %ld, \"bag_no_pose\": %ld, "
                         "\"bag_non_finite_points\": %ld, \"bag_poses\": %ld, \"bag_bad_poses\": %ld, "
                         "\"frames_bad_pose\": %ld, \"frames_out_of_order\": %ld",
                         bag_counts.messages, bag_counts.malformed, bag_counts.no_pose, bag_counts.non_finite_points,
                         bag_counts.poses, bag_counts.bad_poses, gated.bad_pose, gated.out_of_order);
  if (json) {
    std::printf("{\"frames\": %zu, \"empty_frames\": %ld, \"rows_malformed\": %ld, \"rows_bad_pose\": %ld, \"rows_out_of_order\": %ld, "
                "\"clouds_unreadable\": %ld, \"update_ms_median\": %.3f, \"update_ms_p95\": %.3f, "
                "\"update_ms_max\": %.3f, \"known_voxels\": %zu, \"memory_mb\": %.2f, \"occupied_points\": %zu, "
                "\"unknown_voxels\": %ld%s%s}\n",
                update_ms.size(), empty_frames, index.malformed, index.bad_pose, index.out_of_order, unreadable,
                median, p95, worst,
                (*map)->num_known_voxels(), (*map)->memory_bytes() / 1e6, occupied.size(), unknown,
                (stream_json + bag_json).c_str(),
                planning ? core::Format(", \"replans\": %zu, \"replans_certified\": %d, \"replans_to_goal\": %d, "
                                        "\"replan_ms_median\": %.3f, \"replan_ms_p95\": %.3f",
                                        replans.size(), certified, to_goal, core::RankQuantile(replan_ms, 0.5),
                                        core::RankQuantile(replan_ms, 0.95))
                                .c_str()
                         : "");
  } else {
    if (!bag.path.empty()) {
      std::printf("%zu clouds mapped, %ld empty, of %ld on %s (dropped: %ld malformed, %ld without a pose, %ld bad "
                  "poses, %ld out of order; %ld non-finite returns; poses: %ld, %ld unusable)\n",
                  update_ms.size(), empty_frames, bag_counts.messages, bag.cloud_topic.c_str(), bag_counts.malformed,
                  bag_counts.no_pose, gated.bad_pose, gated.out_of_order, bag_counts.non_finite_points,
                  bag_counts.poses, bag_counts.bad_poses);
    } else if (!listen_url.empty()) {
      std::printf("%zu frames mapped, %ld empty, from %ld datagrams and %ld frames received (dropped: datagrams %ld "
                  "malformed, %ld truncated, %ld corrupted, %ld inconsistent, %ld duplicate; frames %ld incomplete, "
                  "%ld malformed, %ld bad poses, %ld out of order)\n",
                  update_ms.size(), empty_frames, stream.datagrams, stream.frames, stream.malformed, stream.truncated,
                  stream.corrupted, stream.inconsistent, stream.duplicates, stream.incomplete_frames, gated.malformed,
                  gated.bad_pose, gated.out_of_order);
    } else {
      std::printf("%zu frames mapped, %ld empty (dropped: %ld malformed rows, %ld bad poses, %ld out of order, %ld "
                  "unreadable clouds)\n",
                  update_ms.size(), empty_frames, index.malformed, index.bad_pose, index.out_of_order, unreadable);
    }
    std::printf("map update per frame: median %.2f ms, p95 %.2f ms, max %.2f ms; %zu known voxels, %.1f MB\n", median,
                p95, worst, (*map)->num_known_voxels(), (*map)->memory_bytes() / 1e6);
    std::printf("occupied: %zu raw returns -> %s\n", occupied.size(), out_path.c_str());
    if (unknown >= 0) {
      std::printf("unknown: %ld voxel centres in the box%s\n", unknown,
                  unknown > 0 ? (" -> " + unknown_path).c_str() : " (none: no file written)");
    }
    if (planning) {
      std::fprintf(stderr, "\n");
      std::printf("replans: %zu every %g s of the frames' time, %d certified (%d to the goal, %d recoveries), %zu "
                  "without a plan; latency median %.1f ms, p95 %.1f ms, max %.1f ms%s\n",
                  replans.size(), replan_options.replan_period, certified, to_goal, recoveries,
                  replans.size() - static_cast<size_t>(certified), core::RankQuantile(replan_ms, 0.5),
                  core::RankQuantile(replan_ms, 0.95),
                  replan_ms.empty() ? 0.0 : *std::max_element(replan_ms.begin(), replan_ms.end()),
                  report_path.empty() ? "" : (" -> " + report_path).c_str());
    }
  }
  return 0;
}
