// quadhand-replan-latency: latency of warm-started replanning (planner/replan.h)
// on a task. Plans once (cold), then replans --trials times from states taken
// on the plan at random times (before the insertion piece) and moved by a
// random offset of --min-offset..--max-offset metres in a random direction,
// as an online controller would after a disturbance. Prints the success rate
// and the wall time of each replan (median, p95, max: solve plus post-check),
// and the same figures for cold plans (front end and all) from the same states.
// A task whose target moves (docs/moving_targets.md) is replanned against a
// new prediction at each state's time: the target where the plan's motion
// has it then, its velocity off by up to --target-velocity-noise m/s (a
// tracker's error), the moving part of the scene rebuilt for it (not
// timed). docs/online.md and docs/moving_targets.md report its output.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "quadhand/opt/solver_registry.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/planner/replan.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/solvers/builtin_solvers.h"

namespace quadhand {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point since) { return std::chrono::duration<double, std::milli>(Clock::now() - since).count(); }

double Quantile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double x = p * (v.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(x));
  const size_t j = std::min(i + 1, v.size() - 1);
  return v[i] + (x - i) * (v[j] - v[i]);
}

void PrintStats(const char* name, const std::vector<double>& ms, int successes, int trials) {
  std::printf("%-28s success %3d/%-3d  median %7.2f ms  p95 %7.2f ms  max %7.2f ms\n", name, successes, trials,
              Quantile(ms, 0.5), Quantile(ms, 0.95), ms.empty() ? 0.0 : *std::max_element(ms.begin(), ms.end()));
}

}  // namespace
}  // namespace quadhand

int main(int argc, char** argv) {
  using namespace quadhand;
  CLI::App app{"quadhand-replan-latency: latency of warm-started replanning from perturbed states"};
  std::string task_path = std::string(QUADHAND_SOURCE_DIR) + "/data/tasks/window_cup.yaml";
  std::string planner_config_path;
  // 100 replans by default: about 10 % of the states need several solves,
  // so the first 50 of a seed can put the p95 anywhere from 9 to 50 ms.
  int trials = 100, max_iterations = -1, cold_trials = 5, attempts = -1;
  unsigned seed = 1;
  double min_offset = 0.05, max_offset = 0.20, velocity_noise = 0.1;
  double relative_tolerance = -1.0, horizon = -1.0, target_velocity_noise = 0.02;
  int horizon_attempts = -1;
  bool profile_post_check = false, each = false;
  app.add_option("--task", task_path, "Task file")->capture_default_str();
  app.add_option("--planner-config", planner_config_path,
                 "Planner configuration (YAML, docs/configuration.md; its replan: keys set the replans), as "
                 "quadhand-online reads it; the options below override it");
  app.add_option("--trials", trials, "Replans to time")->capture_default_str();
  app.add_option("--cold-trials", cold_trials, "Cold plans from the same states, for comparison")->capture_default_str();
  app.add_option("--seed", seed, "Seed of the random times and offsets")->capture_default_str();
  app.add_option("--min-offset", min_offset, "Smallest position offset from the plan, m")->capture_default_str();
  app.add_option("--max-offset", max_offset, "Largest position offset from the plan, m")->capture_default_str();
  app.add_option("--velocity-noise", velocity_noise, "Largest velocity offset, m/s")->capture_default_str();
  app.add_option("--max-iterations", max_iterations, "Override the replan solver's max_iterations");
  app.add_option("--relative-tolerance", relative_tolerance, "Override the replan solver's relative cost tolerance");
  app.add_option("--attempts", attempts, "Override the replan's max_attempts (solves with post-checks)");
  app.add_option("--horizon", horizon, "Override the replan's rejoining horizon, s (0: never rejoin)");
  app.add_option("--horizon-attempts", horizon_attempts, "Override the solves of the new part before the fallback");
  app.add_option("--target-velocity-noise", target_velocity_noise,
                 "A moving target: the largest error of the new prediction's velocity, m/s")
      ->capture_default_str();
  app.add_flag("--each", each, "Print one line per replan (time, offset, rejoined, attempts, outcome, ms)");
  app.add_flag("--profile-post-check", profile_post_check, "Also time the parts of the post-check over the initial plan");
  CLI11_PARSE(app, argc, argv);

  if (core::Status s = solvers::RegisterBuiltinSolvers(); !s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 2;
  }
  auto solver = opt::CreateSolver("lbfgs");
  auto config = planner::LoadPlannerConfigOrDefaults(planner_config_path);
  if (!config.ok()) {
    std::fprintf(stderr, "quadhand-replan-latency: error: %s\n", config.status().message().c_str());
    return 2;
  }
  auto context = planner::PlanningContext::Load(task_path, planner::ContextOptions(*config, {"mrc_sdf"}));
  if (!context.ok()) {
    std::fprintf(stderr, "quadhand-replan-latency: error: %s\n", context.status().message().c_str());
    return 2;
  }
  const planner::PlanningScene scene = (*context)->Scene();
  const planner::Task& task = (*context)->task();
  const planner::PlannerOptions options = config->planner;
  planner::ReplanOptions replan = config->replan;
  if (max_iterations >= 0) replan.solver.max_iterations = max_iterations;
  if (relative_tolerance >= 0) replan.solver.relative_cost_tolerance = relative_tolerance;
  if (attempts >= 1) replan.max_attempts = attempts;
  if (horizon >= 0) replan.horizon = horizon;
  if (horizon_attempts >= 1) replan.horizon_attempts = horizon_attempts;

  const auto plan_start = Clock::now();
  auto plan = planner::Plan(scene, task, options, **solver);
  if (!plan.ok() || !plan->success) {
    std::fprintf(stderr, "the initial plan failed: %s\n", plan.ok() ? plan->message.c_str() : plan.status().message().c_str());
    return 1;
  }
  std::printf("initial plan: %.1f ms, duration %.2f s, %d pieces\n", Ms(plan_start), plan->trajectory->duration(),
              plan->trajectory->num_pieces());

  const planner::WholeBodyTrajectory& trajectory = *plan->trajectory;
  if (profile_post_check) {
    robot::KinematicsState kin;
    double exact_ms = 0, model_ms = 0, fk_ms = 0;
    for (double t = 0; t <= trajectory.duration(); t += 0.01) {
      const planner::WholeBodySample s = trajectory.Sample(t);
      auto a = Clock::now();
      robot::ComputeKinematics(scene.robot, s.BasePose(), s.joints, &kin);
      fk_ms += Ms(a);
      a = Clock::now();
      int link;
      volatile double d = env::WholeBodyClearance(kin, scene.exact, 0.08, {}, &link);
      exact_ms += Ms(a);
      a = Clock::now();
      volatile double e = env::WholeBodyClearance(kin, scene.collision, 0.08, env::QueryContext{0, 0.0});
      model_ms += Ms(a);
      (void)d; (void)e;
    }
    std::printf("post-check parts over the initial plan (every 10 ms): kinematics %.1f ms, exact clearance %.1f ms, "
                "model clearance %.1f ms\n", fk_ms, exact_ms, model_ms);
  }
  const VecX& durations = trajectory.position().durations();
  const double insertion_start = trajectory.duration() - (plan->insertion.enabled ? durations[durations.size() - 1] : 0.0);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  auto random_unit = [&]() {
    Vec3 d(normal(rng), normal(rng), normal(rng));
    return Vec3(d.normalized());
  };

  int rejoined = 0;
  std::vector<double> rejoined_ms;
  std::vector<double> replan_ms, solve_ms, post_check_ms, other_ms, iterations, attempts_used;
  std::vector<planner::BoundaryState> starts;
  std::vector<double> times;
  int successes = 0, refused = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const double t = uniform(rng) * (insertion_start - 0.3);
    const planner::WholeBodySample s = trajectory.Sample(t);
    planner::BoundaryState start = s.State();
    start.position += (min_offset + uniform(rng) * (max_offset - min_offset)) * random_unit();
    start.velocity += velocity_noise * uniform(rng) * random_unit();
    // A moving target: the new prediction at t (its clock starting there).
    planner::PlanningScene replan_scene = scene;
    std::unique_ptr<planner::MovingSceneModels> prediction;
    if (const planner::MovingScene* moving = scene.moving) {
      const Pose moved = moving->motion->Displacement(t);
      const Vec3 at = moved * task.tool->position;
      Vec3 velocity = moving->motion->PointVelocity(at, t);
      velocity.head<2>() += target_velocity_noise * uniform(rng) * Vec3(random_unit()).head<2>();
      auto built = (*context)->MovingSceneFor(
          planner::TargetMotion::Constant(at, velocity, Vec3::Zero(), moving->motion->YawRate(t)), moved);
      if (!built.ok()) {
        std::fprintf(stderr, "replan error: %s\n", built.status().message().c_str());
        return 1;
      }
      prediction = std::move(*built);
      replan_scene.moving = &prediction->scene;
    }
    const auto begin = Clock::now();
    auto result = planner::Replan(replan_scene, task, options, replan, **solver, *plan, t, start);
    const double ms = Ms(begin);
    if (!result.ok()) {
      std::fprintf(stderr, "replan error: %s\n", result.status().message().c_str());
      return 1;
    }
    if (result->status == planner::PlanStatus::kStartInCollision ||
        result->status == planner::PlanStatus::kInsertionInProgress) {
      ++refused;
      continue;
    }
    starts.push_back(start);
    times.push_back(t);
    replan_ms.push_back(ms);
    solve_ms.push_back(result->solve_ms);
    post_check_ms.push_back(result->post_check_ms);
    other_ms.push_back(ms - result->solve_ms - result->post_check_ms);
    attempts_used.push_back(static_cast<double>(result->attempts.size()));
    iterations.push_back(result->iterations);
    successes += result->success;
    if (result->rejoined_at >= 0.0) {
      ++rejoined;
      rejoined_ms.push_back(ms);
    }
    if (each) {
      std::printf("  trial %3d  t = %5.2f s  %-9s  attempts %d  %-8s %7.2f ms (solve %.2f, post-check %.2f)\n", trial,
                  t, result->rejoined_at >= 0.0 ? "rejoined" : "remainder", static_cast<int>(result->attempts.size()),
                  result->success ? "success" : "failed", ms, result->solve_ms, result->post_check_ms);
      if (result->attempts.size() > 1) {
        for (size_t a = 0; a < result->attempts.size(); ++a) {
          const planner::PlanAttempt& attempt = result->attempts[a];
          std::printf("      solve %zu: %d iterations, %.2f ms, post-check %.2f ms: %s\n", a + 1, attempt.iterations,
                      attempt.solve_ms, attempt.post_check_ms,
                      attempt.post_check_failure.empty() ? "passed" : attempt.post_check_failure.c_str());
        }
      }
    }
    if (!result->success) std::printf("  t = %.2f s: %s\n", t, result->message.c_str());
  }
  std::printf("replan options: max_iterations %d, relative cost tolerance %g (window %d), memory %d, attempts %d\n",
              replan.solver.max_iterations, replan.solver.relative_cost_tolerance, replan.solver.relative_cost_window,
              replan.solver.memory_size, replan.max_attempts);
  std::printf("offsets %.2f-%.2f m, velocity offsets up to %.2f m/s; %d states refused (in collision or insertion)\n",
              min_offset, max_offset, velocity_noise, refused);
  PrintStats("warm replan (total)", replan_ms, successes, static_cast<int>(replan_ms.size()));
  PrintStats("  of which solve", solve_ms, successes, static_cast<int>(replan_ms.size()));
  PrintStats("  of which post-check", post_check_ms, successes, static_cast<int>(replan_ms.size()));
  PrintStats("  of which the rest", other_ms, successes, static_cast<int>(replan_ms.size()));
  PrintStats("  rejoined the plan", rejoined_ms, rejoined, rejoined);
  std::printf("rejoined the current plan %d times (horizon %.2f s, %d attempts before the whole remainder)\n",
              rejoined, replan.horizon, replan.horizon_attempts);
  std::printf("attempts (solves with a post-check): median %.0f, max %.0f\n", Quantile(attempts_used, 0.5),
              Quantile(attempts_used, 1.0));
  std::printf("iterations: median %.0f, max %.0f\n", Quantile(iterations, 0.5), Quantile(iterations, 1.0));

  std::vector<double> cold_ms;
  int cold_successes = 0;
  // (A moving target's cold plan from a state mid-flight would need the
  // prediction at that time as its task: not compared here.)
  if (scene.moving != nullptr) cold_trials = 0;
  for (int i = 0; i < std::min<int>(cold_trials, static_cast<int>(starts.size())); ++i) {
    planner::Task cold_task = task;
    cold_task.start = starts[i];
    const auto begin = Clock::now();
    auto result = planner::Plan(scene, cold_task, options, **solver);
    cold_ms.push_back(Ms(begin));
    cold_successes += result.ok() && result->success;
    if (each) {
      std::printf("  cold from the state at t = %5.2f s: %-8s %7.2f ms%s%s\n", times[i],
                  result.ok() && result->success ? "success" : "failed", cold_ms.back(),
                  result.ok() && !result->success ? ": " : "", result.ok() && !result->success ? result->message.c_str() : "");
    }
  }
  PrintStats("cold plan (same states)", cold_ms, cold_successes, static_cast<int>(cold_ms.size()));
  return 0;
}
