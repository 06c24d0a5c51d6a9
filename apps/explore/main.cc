// quadhand-explore: a flight into a scene the planner has never seen,
// simulated in lockstep (explore/exploration_flight.h): a simulated depth
// camera or LiDAR renders the hidden world, the rolling map takes each frame,
// and the local planner replans from the map alone. Writes the flown record
// (the plan file's columns, as quadhand-sim writes it) and judges it against
// the hidden world with the exact link meshes, as quadhand-flightcheck does.
// docs/perception.md, "Flying on the sensor".
//
// Exit codes: 0 arrived and kept the safety distance (less --tolerance) at
// every recorded state; 1 did not arrive (time limit, stuck, the simulation
// diverged) but kept it; 6 lost the clearance; 2 bad input.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "app_options.h"
#include "local_plan_report.h"
#include "sensor_world.h"
#include "quadhand/core/file_util.h"
#include "quadhand/core/log.h"
#include "quadhand/core/statistics.h"
#include "quadhand/core/text.h"
#include "quadhand/explore/exploration_flight.h"
#include "quadhand/explore/local_planner.h"
#include "quadhand/opt/solver_registry.h"
#include "quadhand/planner/flight_verdict.h"
#include "quadhand/planner/mission_plan.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/sim/config.h"
#include "quadhand/sim/sensor.h"
#include "quadhand/sim/simulator.h"
#include "quadhand/solvers/builtin_solvers.h"

namespace {

using namespace quadhand;

constexpr int kExitArrived = 0, kExitNotArrived = 1, kExitBadInput = 2, kExitLost = 6;

int Fail(const std::string& message) {
  core::PrintError("quadhand-explore", message);
  return kExitBadInput;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "quadhand-explore: fly a task into a scene the planner has never seen (simulated, lockstep).\n"
      "  quadhand-explore TASK.yaml --out FLOWN.csv [--world FILE] [--sensor depth|lidar] [--report R.json]\n"
      "The task's scene (or --world) is the hidden true world: only the simulated sensor sees it; the\n"
      "planner plans from the rolling map of its frames, never through space it has not seen free.\n"
      "Exit codes: 0 arrived and kept the safety distance (less --tolerance) against the true world;\n"
      "1 did not arrive (the report says why) but kept it; 6 lost it; 2 bad input."};
  std::string task_path, out_path, report_path, world_path, sensor_name = "depth", config_path, prior_path;
  std::string sim_config_path = core::FindBundledFile("data/sim/quadhand_sim.yaml", QUADHAND_SOURCE_DIR);
  std::string solver_name = "lbfgs";
  std::vector<std::string> package_path;
  unsigned seed = 1;
  double tolerance = 0.002;
  bool quiet = false;
  explore::ExplorationOptions options;
  explore::LocalPlannerOptions local;
  std::vector<std::string> silences;
  std::string appear_path;
  double appear_at = 0.0;
  app.add_option("task", task_path,
                 "Task file (YAML): robot, start, a goal at rest or a mission of reaches at rest (and a grasp: its "
                 "reach with a state, a tool pose and an insertion, then moves and holds), safety distance; "
                 "its scene is the hidden world")
      ->required();
  app.add_option("--out", out_path, "The flown record (CSV, the plan file's columns)")->required();
  app.add_option("--report", report_path, "A JSON report: outcome, clearance, replans and their latency, map costs");
  app.add_option("--world", world_path, "The hidden world instead of the task's scene: a PCD or PLY cloud, or a task file");
  app.add_option("--prior", prior_path,
                 "A prior map: obstacles known before take-off (a PCD or PLY cloud, or a task file's scene). It "
                 "occupies what the sensor has not seen and frees nothing (docs/perception.md, \"A prior map\")");
  app.add_option("--sensor", sensor_name, "depth or lidar (options: the simulator configuration's sensor:)")
      ->capture_default_str();
  app.add_option("--sim-config", sim_config_path, "Simulator configuration (YAML, docs/sim.md)")->capture_default_str();
  app.add_option("--config", config_path, "Planner configuration (YAML, docs/config.md; default: built-in)");
  app.add_option("--solver", solver_name, "Optimiser back-end (docs/solvers.md)")->capture_default_str();
  app.add_option("--seed", seed, "Seed of the simulator's and the sensor's noise")->capture_default_str();
  app.add_option("--resolution", options.map.resolution, "Rolling map voxel edge, m")->capture_default_str();
  std::vector<double> map_window;
  app.add_option("--window", map_window,
                 "Half extents of the rolling map's window about the sensor, m (x,y,z; default 15,15,5; finer "
                 "voxels need a smaller one)")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--ray-threads", options.map.ray_threads, "Threads that walk each frame's rays into the map")
      ->capture_default_str();
  app.add_option("--stop-ray-after", options.map.stop_ray_after_crossed,
                 "Walk each ray back from its end and stop it after this many voxels in a row that earlier rays of the frame crossed (0: whole rays; docs/perception.md)")
      ->capture_default_str();
  app.add_option("--replan-period", options.replan_period, "Seconds of flight between replans")->capture_default_str();
  app.add_option("--plan-ahead", options.plan_ahead, "A new plan starts this long after its request, s")
      ->capture_default_str();
  app.add_option("--horizon", local.horizon, "A local target lies within this of the start, m")->capture_default_str();
  app.add_option("--guide-cell", local.guide_cell,
                 "Local targets are ranked by the way to the goal round what was seen occupied, on cells of this "
                 "edge, m, e.g. 0.4 (0: by the straight distance)")
      ->capture_default_str();
  app.add_option("--max-speed", local.max_speed, "Local plans fly at most this fast (and the task's v_max), m/s")
      ->capture_default_str();
  app.add_option("--max-acceleration", local.max_acceleration,
                 "Local plans accelerate at most this much (and the task's a_max), m/s^2; a brake asks half")
      ->capture_default_str();
  app.add_option("--tracking-margin", local.tracking_margin,
                 "Added to the planned safety distance for the tracking error, m")
      ->capture_default_str();
  app.add_option("--start-free-radius", options.start_free_radius,
                 "The space within this of the start is taken as free (the vehicle stands there), m")
      ->capture_default_str();
  bool no_look_round = false;
  app.add_flag("--no-look-round", no_look_round,
               "At rest with no target, hold instead of turning in place to look along headings not yet seen");
  app.add_option("--miss-stride", options.miss_stride,
                 "Rays with no return free the map along every this-many-th pixel of each image axis (1-64)")
      ->capture_default_str();
  app.add_option("--time-limit", options.time_limit, "Simulated seconds before giving up (0: from the distance)")
      ->capture_default_str();
  app.add_option("--stuck-time", options.stuck_time,
                 "Simulated seconds without a new plan, the last one ended, before the flight ends stuck")
      ->capture_default_str();
  app.add_option("--sensor-timeout", options.sensor_timeout,
                 "Seconds without a good frame before the vehicle brakes along its plan and holds")
      ->capture_default_str();
  app.add_option("--max-frame-age", options.frame_gate.max_age, "A frame older than this on arrival is dropped, s")
      ->capture_default_str();
  app.add_option("--silence", silences,
                 "Fault: no frame arrives from FROM to TO s of the flight (FROM-TO; repeatable)");
  app.add_option("--appear", appear_path,
                 "Fault: these points (a PCD or PLY cloud, or a task file) join the hidden world at --appear-at");
  app.add_option("--appear-at", appear_at, "When --appear's points appear, s")->capture_default_str();
  app.add_option("--bad-frames", options.sensor_faults.bad_frame_probability,
                 "Fault: each frame is spoiled with this probability (NaN pose, unnormalised attitude, stamp 1 s "
                 "ahead, delivered late, or a tenth of its returns NaN)")
      ->capture_default_str();
  explore::GraspOptions grasp_options;
  app.add_option("--grasp-resolution", grasp_options.resolution,
                 "A mission's grasp is flown on a map of this voxel edge about its work, m")
      ->capture_default_str();
  app.add_option("--grasp-approach", grasp_options.approach,
                 "The grasp's last metres before the insertion are flown on the grasp map, m")
      ->capture_default_str();
  app.add_option("--tolerance", tolerance, "The verdict accepts the safety distance less this, m")->capture_default_str();
  apps::AddPackagePathOption(&app, &package_path);
  app.add_flag("--quiet", quiet, "Print only errors");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }
  if (!(std::isfinite(tolerance) && tolerance >= 0.0 && tolerance <= 0.1)) return Fail("--tolerance must be in [0, 0.1] m");
  for (const std::string& text : silences) {
    explore::SensorFaultOptions::Window window;
    if (!explore::ParseSilence(text, &window)) return Fail("--silence " + text + ": expected FROM-TO in s, 0 <= FROM < TO");
    options.sensor_faults.silences.push_back(window);
  }
  options.fault_seed = seed ^ 0x6661756c74ull;
  options.look_round = !no_look_round;
  if (!(std::isfinite(appear_at) && appear_at >= 0.0)) return Fail("--appear-at must be a time >= 0 s");
  if (!map_window.empty()) options.map.window_half_extent = Vec3(map_window[0], map_window[1], map_window[2]);
  if (std::string why; !options.IsValid(&why)) return Fail(why);
  if (std::string why; !local.IsValid(&why)) return Fail(why);
  if (std::string why; !grasp_options.IsValid(&why)) return Fail(why);
  for (const auto& [option, path] : {std::pair<std::string, std::string>{"--out", out_path}, {"--report", report_path}}) {
    if (path.empty()) continue;
    if (core::Status s = core::CheckOutputPathAndFolder(path); !s.ok()) return Fail(option + ": " + s.message());
    for (const std::string& input : {task_path, world_path, sim_config_path, config_path, appear_path, prior_path}) {
      if (!input.empty() && core::SameFile(path, input)) return Fail(option + " " + path + ": is an input of this run");
    }
  }
  if (!report_path.empty() && core::SameFile(out_path, report_path)) return Fail("--out and --report name the same file");
  robot::PrependRosPackagePath(package_path);

  auto config = planner::LoadPlannerConfigOrDefaults(config_path);
  if (!config.ok()) return Fail(config.status().message());
  // (explore::UseLocalPlanningDefaults, unless a configuration file is given.)
  if (config_path.empty()) explore::UseLocalPlanningDefaults(&*config, options.map.resolution);
  auto sim_config = sim::LoadSimConfig(sim_config_path);
  if (!sim_config.ok()) return Fail(sim_config.status().message());
  auto task = planner::LoadTask(task_path);
  if (!task.ok()) return Fail(task.status().message());
  if (world_path.empty()) world_path = task_path;
  auto world = planner::LoadWorldPoints(world_path);
  if (!world.ok()) return Fail(world.status().message());
  if (world->empty()) return Fail(world_path + ": the world has no finite points");
  if (!prior_path.empty()) {
    auto prior = planner::LoadWorldPoints(prior_path);
    if (!prior.ok()) return Fail("--prior " + prior.status().message());
    if (prior->empty()) return Fail("--prior " + prior_path + ": the prior map has no finite points");
    options.prior = std::make_shared<const std::vector<Vec3>>(std::move(*prior));
  }
  auto robot = robot::RobotModel::LoadFromUrdfFile(task->robot_path);
  if (!robot.ok()) return Fail(robot.status().message());

  // What appears later: the world with it (rendered and judged from then on).
  std::vector<Vec3> changed_world;
  if (!appear_path.empty()) {
    auto appearing = planner::LoadWorldPoints(appear_path);
    if (!appearing.ok()) return Fail(appearing.status().message());
    if (appearing->empty()) return Fail(appear_path + ": no finite points to appear");
    changed_world = *world;
    changed_world.insert(changed_world.end(), appearing->begin(), appearing->end());
  }

  // The judge: the exact model of the hidden world (never planned against).
  auto judge = planner::PlanningContext::Create(*task, *robot, std::make_shared<const std::vector<Vec3>>(*world), 0,
                                                planner::ContextOptions(*config, {}));
  if (!judge.ok()) return Fail(task_path + ": " + judge.status().message());
  core::Result<std::unique_ptr<planner::PlanningContext>> judge_after(nullptr);
  if (!changed_world.empty()) {
    judge_after = planner::PlanningContext::Create(*task, *robot,
                                                   std::make_shared<const std::vector<Vec3>>(changed_world), 0,
                                                   planner::ContextOptions(*config, {}));
    if (!judge_after.ok()) return Fail(appear_path + ": " + judge_after.status().message());
  }
  // Each leg's base context (the robot and its SDFs, the leg's goal) and
  // local planner: a goal at rest is one leg, a mission of reaches one per reach.
  auto grasp_work = explore::GraspWorkOfTask(*task, *robot, grasp_options);
  if (!grasp_work.ok()) return Fail(grasp_work.status().message());
  auto legs = explore::LegsOfTask(*task, grasp_work->has_value() ? &**grasp_work : nullptr);
  if (!legs.ok()) return Fail(legs.status().message());
  if (core::Status s = solvers::RegisterBuiltinSolvers(); !s.ok()) return Fail(s.message());
  auto solver = opt::CreateSolver(solver_name);
  if (!solver.ok()) return Fail("--solver: " + solver.status().message());
  const planner::PlannerOptions planner_options = planner::RunPlannerOptions(*config, 0.01, seed, false);
  std::vector<std::unique_ptr<planner::PlanningContext>> bases;
  std::vector<std::unique_ptr<explore::LocalPlanner>> planners;
  std::vector<const explore::LocalPlanner*> leg_planners;
  for (planner::Task& leg : *legs) {
    auto base = explore::BaseContext(std::move(leg), *robot, *config);
    if (!base.ok()) return Fail(task_path + ": " + base.status().message());
    auto planner = explore::LocalPlanner::Create(**base, planner_options, **solver, local);
    if (!planner.ok()) return Fail(planner.status().message());
    bases.push_back(std::move(*base));
    planners.push_back(std::move(*planner));
    leg_planners.push_back(planners.back().get());
  }

  sim::SensorConfig sensor = sim_config->sensor;
  auto kind = sim::ParseSensorKind(sensor_name);
  if (!kind.ok()) return Fail("--sensor: " + kind.status().message());
  sensor.kind = *kind;
  if (robot->LinkIndex(sensor.link) < 0) return Fail(sim_config_path + ": sensor.link: the robot has no link '" + sensor.link + "'");
  if (!quiet) {
    apps::WarnWhenTheSensorSeesThrough("quadhand-explore", world_path, *world, sensor);
    apps::WarnWhenTheStartBallHoldsTheWorld("quadhand-explore", world_path, *world, task->start.position,
                                            options.start_free_radius);
  }
  auto renderer = sim::SensorRenderer::Create(*world, sensor, seed ^ 0x73656e73ull);
  if (!renderer.ok()) return Fail(sim_config_path + ": " + renderer.status().message());
  explore::HiddenWorld hidden{renderer->get(), {}};
  core::Result<std::unique_ptr<sim::SensorRenderer>> changed_renderer(nullptr);
  if (!changed_world.empty()) {
    changed_renderer = sim::SensorRenderer::Create(changed_world, sensor, seed ^ 0x73656e73ull);
    if (!changed_renderer.ok()) return Fail(sim_config_path + ": " + changed_renderer.status().message());
    hidden.changes.emplace_back(appear_at, changed_renderer->get());
  }
  sim_config->robot_path = task->robot_path;
  auto model = sim::VehicleModel::Create(*robot, *sim_config);
  if (!model.ok()) return Fail(sim_config_path + ": " + model.status().message());
  sim::Simulator simulator(std::move(*model), seed);

  // A grasp is planned on the grasp map with the whole task's mission.
  std::optional<explore::GraspPlanner> grasp_planner;
  explore::GraspFlight grasp;
  if (grasp_work->has_value()) {
    grasp_planner.emplace(*bases.front(), *task, **grasp_work, planner_options, **solver, local.tracking_margin);
    grasp.work = &**grasp_work;
    grasp.planner = &*grasp_planner;
    grasp.options = grasp_options;
  }
  const auto wall_start = std::chrono::steady_clock::now();
  auto flown = explore::FlyExploration(
      &simulator, sensor, hidden, leg_planners, bases.front()->task(), options, grasp, [&](const explore::ReplanRecord& r) {
        if (quiet) return;
        std::fprintf(stderr, "\r  t %6.2f s: leg %d/%zu, replan %-15s %6.1f ms, %6zu boundary voxels   ", r.t,
                     r.leg + 1, leg_planners.size(), explore::LocalPlanStatusName(r.status), r.total_ms,
                     r.scene_points);
      });
  if (!quiet) std::fprintf(stderr, "\n");
  if (!flown.ok()) return Fail(task_path + ": " + flown.status().message());
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  // The verdict on the vehicle's own (true) states, against the true world.
  // A grasp changes the world where the flown tool closed on the object
  // (it leaves the scene, and is judged as held: never into it), as
  // quadhand-flightcheck replays it.
  auto verdict = planner::FlightJudge::Create(**judge, config->planner.mission,
                                             changed_world.empty() ? nullptr : judge_after->get(), appear_at);
  if (!verdict.ok()) return Fail(verdict.status().message());
  for (const sim::FlownSample& s : flown->samples) {
    planner::FlownState state;
    state.t = s.flown.t;
    state.base = MakePose(s.flown.position, s.flown.attitude.toRotationMatrix());
    state.joints = s.flown.joints;
    state.gripper = s.flown.gripper;
    if (core::Status added = (*verdict)->Add(state); !added.ok()) return Fail(added.message());
  }
  const double least = (*verdict)->least(), least_t = (*verdict)->least_t();
  const double least_held = (*verdict)->least_held();
  const std::string& closest = (*verdict)->closest_link();
  const double accepted = planner::AcceptedClearance(*task, tolerance);
  const bool kept = least >= accepted && least_held >= -tolerance;
  const bool arrived = flown->outcome == explore::ExplorationOutcome::kArrived;

  if (core::Status s = core::WriteFileAtomically(out_path, sim::FlownCsv(flown->samples, robot->ActuatedJointNames()));
      !s.ok()) {
    return Fail(s.message());
  }
  std::vector<double> latency, planned_latency, scene_points;
  int certified = 0, turns = 0;
  for (const explore::ReplanRecord& r : flown->replans) {
    latency.push_back(r.total_ms);
    scene_points.push_back(static_cast<double>(r.scene_points));
    certified += explore::IsCertified(r.status) ? 1 : 0;
    turns += r.status == explore::LocalPlanStatus::kTurnInPlace ? 1 : 0;
  }
  const perception::FrameCounts& counts = flown->frame_counts;
  const nlohmann::json frames_dropped = {{"malformed", counts.malformed},
                                         {"bad_pose", counts.bad_pose},
                                         {"from_the_future", counts.from_the_future},
                                         {"out_of_order", counts.out_of_order},
                                         {"stale", counts.stale}};
  nlohmann::json injected = {{"silenced", flown->injected.silenced}};
  for (int k = 0; k < explore::kNumSensorFaultKinds; ++k) {
    injected[explore::SensorFaultKindName(static_cast<explore::SensorFaultKind>(k))] = flown->injected.spoiled[k];
  }
  nlohmann::json silence_log = nlohmann::json::array();
  for (const explore::SilenceRecord& r : flown->silences) {
    silence_log.push_back(
        {{"from", r.from}, {"to", r.to}, {"ended", r.ended}, {"braked_from_speed", r.speed}, {"brake_s", r.brake_s}});
  }
  nlohmann::json invalidation_log = nlohmann::json::array();
  for (const explore::InvalidationRecord& r : flown->invalidations) {
    invalidation_log.push_back({{"t", r.t},
                                {"flown_plan", r.flown},
                                {"grasp_plan", r.grasp},
                                {"conflict_in_s", r.conflict_in},
                                {"stop_margin_s", r.stop_margin},
                                {"new_obstacle_voxels", r.new_obstacles}});
  }
  if (!report_path.empty()) {
    nlohmann::json report = {
        {"task", task_path},
        {"world", world_path},
        {"prior", prior_path},
        {"prior_points", flown->prior_points},
        {"sensor", sensor_name},
        {"seed", seed},
        {"outcome", explore::ExplorationOutcomeName(flown->outcome)},
        {"arrived", arrived},
        {"kept_clearance", kept},
        {"success", arrived && kept},
        {"flight_s", flown->flight_s},
        {"goal_distance_m", flown->goal_distance},
        {"min_clearance_m", least},
        {"min_clearance_t", least_t},
        {"min_clearance_link", closest},
        {"accepted_clearance_m", accepted},
        {"legs", flown->legs},
        {"legs_arrived", flown->legs_arrived},
        {"planned_safety_distance_m", planners.front()->PlannedSafetyDistance(options.map.resolution)},
        {"replans", flown->replans.size()},
        {"replans_certified", certified},
        {"turns_in_place", turns},
        {"replan_latency_ms", apps::CountMedianP95Max(latency)},
        {"boundary_voxels", apps::CountMedianP95Max(scene_points)},
        {"frames", flown->frames},
        {"empty_frames", flown->empty_frames},
        {"map_update_ms", apps::CountMedianP95Max(flown->map_update_ms)},
        {"peak_map_bytes", flown->peak_map_bytes},
        {"frames_dropped", frames_dropped},
        {"returns_dropped", flown->dropped_points},
        {"faults_injected", injected},
        {"silences", silence_log},
        {"invalidations", invalidation_log},
        {"wall_s", wall_s}};
    nlohmann::json replans = nlohmann::json::array();
    for (const explore::ReplanRecord& r : flown->replans) {
      nlohmann::json entry = apps::LocalPlanSummaryJson(r);
      entry["t"] = r.t;
      entry["leg"] = r.leg;
      replans.push_back(entry);
    }
    report["replan_log"] = replans;
    if (grasp.work != nullptr) {
      nlohmann::json attempts = nlohmann::json::array();
      for (const explore::GraspAttempt& a : flown->grasp_attempts) {
        attempts.push_back({{"t", a.t}, {"certified", a.certified}, {"message", a.message},
                            {"obstacles", a.obstacles}, {"ms", a.ms}});
      }
      const bool closed = std::isfinite(flown->grasp_closed_t);
      report["grasp"] = {{"resolution_m", grasp_options.resolution},
                         {"approach_m", grasp_options.approach},
                         {"box_min", {grasp.work->box_lo.x(), grasp.work->box_lo.y(), grasp.work->box_lo.z()}},
                         {"box_max", {grasp.work->box_hi.x(), grasp.work->box_hi.y(), grasp.work->box_hi.z()}},
                         {"planned_safety_distance_m", grasp.planner->PlannedSafetyDistance(grasp_options.resolution)},
                         {"attempts", attempts},
                         {"closed", closed},
                         {"closed_t", closed ? nlohmann::json(flown->grasp_closed_t) : nlohmann::json(nullptr)},
                         {"tool_error_m", closed ? nlohmann::json(flown->grasp_tool_error) : nlohmann::json(nullptr)},
                         {"held_object_min_clearance_m",
                          std::isfinite(least_held) ? nlohmann::json(least_held) : nlohmann::json(nullptr)},
                         {"map_update_ms", apps::CountMedianP95Max(flown->grasp_map_update_ms)}};
    }
    if (core::Status s = core::WriteFileAtomically(report_path, report.dump(2) + "\n"); !s.ok()) return Fail(s.message());
  }
  if (!quiet) {
    std::printf(
        "%s after %.2f s simulated (%.1f s wall), %.2f m from the goal\n"
        "clearance against the true world: least %.4f m at t %.2f s (%s), accepted %.4f m: %s\n"
        "replans: %zu, %d certified (%d turns in place to look round); latency median %.1f ms, p95 %.1f ms, max %.1f ms\n"
        "map: %ld frames (%ld empty), update median %.2f ms, p95 %.2f ms; peak %.1f MB\n"
        "frames dropped: %ld (malformed %ld, bad pose %ld, from the future %ld, out of order %ld, stale %ld); "
        "returns dropped: %ld; sensor silences (braked and held): %zu; plans crossed by new obstacles: %zu\n"
        "out: %s\n",
        explore::ExplorationOutcomeName(flown->outcome), flown->flight_s, wall_s, flown->goal_distance, least, least_t,
        closest.c_str(), accepted, kept ? "kept" : "CLEARANCE LOST", flown->replans.size(), certified, turns,
        core::RankQuantile(latency, 0.5), core::RankQuantile(latency, 0.95),
        latency.empty() ? 0.0 : *std::max_element(latency.begin(), latency.end()), flown->frames, flown->empty_frames,
        core::RankQuantile(flown->map_update_ms, 0.5), core::RankQuantile(flown->map_update_ms, 0.95), flown->peak_map_bytes / 1e6,
        counts.dropped(), counts.malformed, counts.bad_pose, counts.from_the_future, counts.out_of_order, counts.stale,
        flown->dropped_points, flown->silences.size(), flown->invalidations.size(), out_path.c_str());
    if (grasp.work != nullptr) {
      const size_t plans = flown->grasp_attempts.size();
      if (std::isfinite(flown->grasp_closed_t)) {
        std::printf("grasp: closed at t %.2f s with the tool %.1f mm from the reach's tool point (%zu plan%s of it); "
                    "held object: least %.4f m\n",
                    flown->grasp_closed_t, 1e3 * flown->grasp_tool_error, plans, plans == 1 ? "" : "s", least_held);
      } else {
        const auto braked = std::find_if(flown->invalidations.begin(), flown->invalidations.end(),
                                         [](const explore::InvalidationRecord& r) { return r.grasp; });
        if (braked != flown->invalidations.end()) {
          std::printf("grasp: not closed; a plan of it braked at t %.2f s for %zu voxels the grasp map saw in its "
                      "way (%zu plan%s of it; the last: %s)\n",
                      braked->t, braked->new_obstacles, plans, plans == 1 ? "" : "s",
                      flown->grasp_attempts.back().message.c_str());
        } else {
          std::printf("grasp: not closed (%zu plan%s of it%s%s)\n", plans, plans == 1 ? "" : "s",
                      plans > 0 ? "; the last: " : "", plans > 0 ? flown->grasp_attempts.back().message.c_str() : "");
        }
      }
    }
  }
  if (!kept) return kExitLost;
  return arrived ? kExitArrived : kExitNotArrived;
}
