// Every tunable of planning in one place: the planner pipeline, the cost, the
// solver, the post-check, the terminal-state search, the front end, the
// replanner and the collision representations, read from one YAML file
// (--planner-config of quadhand-plan, quadhand-bench and quadhand-online,
// `config=` of the Python module). docs/configuration.md lists every key;
// data/config/default.yaml is PlannerConfigYaml(DefaultPlannerConfig()).
//
// Left out on purpose, because the task or a command-line flag sets them:
// the collision thresholds (safety distance + the margins here), the
// terminal-state seed (--seed), solver verbosity (--verbose), the
// post-check's recovery time (set by replans from replan.recovery_time) and
// its stop_at_first_failure (set per solve: every solve but the last).
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/planner/front_end.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/planner/replan.h"
#include "quadhand/planner/representation.h"

namespace quadhand::planner {

struct PlannerConfig {
  PlannerOptions planner = DefaultPlannerOptions();
  FrontEndOptions front_end;
  ReplanOptions replan = DefaultReplanOptions();
  RepresentationOptions representations;
  // meshes.repair_tolerance: PlanningContextOptions::mesh_repair_tolerance.
  double mesh_repair_tolerance = 1e-6;
  // mission.payload_limit: PlanningContextOptions::payload_limit.
  double payload_limit = 0.3;

  // Every part's own IsValid, the failing one named ("cost: ...").
  bool IsValid(std::string* why) const;
};

PlannerConfig DefaultPlannerConfig();

// Reads a configuration file: every key is optional (a missing key keeps its
// default), an unknown key, a value of the wrong type and a value the
// options reject are errors naming the file and the key
// ("cfg.yaml: cost.weight_collision: must be finite and non-negative").
core::Result<PlannerConfig> LoadPlannerConfig(const std::string& path);
// The defaults for an empty path (no --planner-config given), else LoadPlannerConfig(path).
core::Result<PlannerConfig> LoadPlannerConfigOrDefaults(const std::string& path);
// The same from YAML text; errors name `name`.
core::Result<PlannerConfig> ParsePlannerConfig(const std::string& text, const std::string& name);

// The whole configuration as the YAML LoadPlannerConfig() reads back exactly
// (each number with the fewest digits that read back to the same double).
std::string PlannerConfigYaml(const PlannerConfig& config);

// What one plan uses of a configuration, with the run's own settings: the
// plan-file step `dt` also bounds the post-check's step, `seed` seeds the
// terminal-state search, `verbose` prints solver progress (quadhand-plan's
// --dt, --seed, --verbose; the Python module's arguments of those names).
PlannerOptions RunPlannerOptions(const PlannerConfig& config, double dt, unsigned seed, bool verbose);

// One worker count for the cost's and the post-check's samples
// (cost.threads and post_check.threads; 0: one per core): what
// quadhand-plan's and quadhand-online's --threads set.
void SetWorkerThreads(int threads, PlannerConfig* config);

// The context options of a configuration: its front end and representation
// options, building `representations`.
PlanningContextOptions ContextOptions(const PlannerConfig& config, std::vector<std::string> representations);

// Every key with its value, in file order ("cost.samples_per_piece", 16):
// for reports.
// (A registered representation's options are one string: their YAML text.)
using ConfigValue = std::variant<bool, long long, double, std::vector<double>, std::string>;
std::vector<std::pair<std::string, ConfigValue>> PlannerConfigEntries(const PlannerConfig& config);

}  // namespace quadhand::planner
