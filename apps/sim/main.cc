// quadhand-sim: the vehicle simulator (docs/sim.md).
//   --track plan.csv --out flown.csv   fly a plan (contracts.md) with the
//                                      geometric controller, write the flown states
//   --figure8 --out plan.csv           write the paper's figure-eight plan
// Exit codes: 0 success, 1 the simulation diverged, 2 bad input (one line on stderr).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "quadhand/core/file_util.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/sim/config.h"
#include "quadhand/sim/figure_eight.h"
#include "quadhand/sim/plan_io.h"
#include "quadhand/sim/simulator.h"

namespace {

using namespace quadhand;

constexpr int kExitDiverged = 1;
constexpr int kExitBadInput = 2;

int Fail(const std::string& message, int code = kExitBadInput) {
  std::fprintf(stderr, "quadhand-sim: error: %s\n", message.c_str());
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "quadhand-sim: simulate the QuadHand vehicle (base, arm, PCGC battery, rotors, servos) under a\n"
      "geometric tracking controller; see docs/sim.md.\n"
      "  quadhand-sim --track plan.csv --out flown.csv [--pcgc on|off] [--payload KG] [--seed N]\n"
      "  quadhand-sim --figure8 --out plan.csv [--loops N] [--period S]\n"
      "Exit codes: 0 success, 1 the simulation diverged, 2 bad input."};
  std::string track_path, out_path, config_path = "data/sim/quadhand_sim.yaml", pcgc, noise;
  bool figure8 = false, quiet = false;
  double payload = -1.0, settle = 0.0;
  uint64_t seed = 0;
  sim::FigureEightOptions eight;
  app.add_option("--track", track_path, "Plan file to fly (CSV, contracts.md)");
  app.add_flag("--figure8", figure8, "Write the figure-eight plan of the paper's experiment to --out instead");
  app.add_option("--out", out_path, "Output file (CSV): the flown states, or the figure-eight plan")->required();
  app.add_option("--config", config_path, "Simulator configuration (YAML, docs/sim.md)")->capture_default_str();
  app.add_option("--pcgc", pcgc, "Passive CoG compensation: on (battery on its mimic joint) or off (battery locked)")
      ->check(CLI::IsMember({"on", "off"}));
  app.add_option("--payload", payload, "Payload at the tool frame, kg (0: none; default: the configuration's)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--seed", seed, "Seed of the sensor noise")->capture_default_str();
  app.add_option("--noise", noise, "Sensor noise: on or off (default: the configuration's)")
      ->check(CLI::IsMember({"on", "off"}));
  app.add_option("--settle", settle, "Seconds of hover at the first setpoint before the plan starts (not recorded)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--loops", eight.loops, "--figure8: loops")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--period", eight.period, "--figure8: seconds per loop")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--dt", eight.dt, "--figure8: row spacing, s")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_flag("-q,--quiet", quiet, "Print nothing on success");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }
  if (figure8 == !track_path.empty()) return Fail("give exactly one of --track PLAN and --figure8");

  auto config = sim::LoadSimConfig(config_path);
  if (!config.ok()) return Fail(config.status().message());
  if (!pcgc.empty()) config->pcgc = pcgc == "on";
  if (payload >= 0.0) {
    config->payload.attached = payload > 0.0;
    config->payload.mass = payload;
  }
  if (!noise.empty()) config->noise.enabled = noise == "on";
  if (config->robot_path.empty()) return Fail(config_path + ": robot: missing (the URDF to simulate)");
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
  if (!quiet) {
    const sim::TrackingErrorStats& e = result->error;
    std::printf(
        "flown: %zu samples, %.2f s simulated in %.2f s (%.0fx real time), PCGC %s, payload %.3f kg\n"
        "3-D tracking error (m): mean %.4f, median %.4f, p95 %.4f, max %.4f\n"
        "out: %s\n",
        result->samples.size(), result->simulated_s, wall, result->simulated_s / std::max(wall, 1e-9),
        config->pcgc ? "on" : "off", config->payload.attached ? config->payload.mass : 0.0, e.mean, e.median, e.p95,
        e.max, out_path.c_str());
  }
  return 0;
}
