#include "quadhand/planner/planner_config.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace quadhand::planner {
namespace {

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string WithoutComments(const std::string& text) {
  std::istringstream in(text);
  std::string out, line;
  while (std::getline(in, line)) {
    if (line.rfind("#", 0) != 0) out += line + "\n";
  }
  return out;
}

std::string Error(const std::string& yaml) {
  auto config = ParsePlannerConfig(yaml, "cfg.yaml");
  EXPECT_FALSE(config.ok()) << yaml;
  return config.ok() ? "" : config.status().message();
}

TEST(PlannerConfigTest, TheShippedDefaultFileIsTheBuiltInDefaults) {
  const std::string path = std::string(QUADHAND_SOURCE_DIR) + "/data/config/default.yaml";
  const std::string text = ReadFile(path);
  EXPECT_EQ(WithoutComments(text), PlannerConfigYaml(DefaultPlannerConfig()))
      << "regenerate the file's body with: quadhand-plan --print-config";
  auto loaded = LoadPlannerConfig(path);
  ASSERT_TRUE(loaded.ok()) << loaded.status().message();
  EXPECT_EQ(PlannerConfigYaml(*loaded), PlannerConfigYaml(DefaultPlannerConfig()));
}

TEST(PlannerConfigTest, TheDefaultsAreThoseThePlannerHadBeforeTheFile) {
  const PlannerConfig config = DefaultPlannerConfig();
  const PlannerOptions planner = DefaultPlannerOptions();
  EXPECT_EQ(config.planner.solver.max_iterations, planner.solver.max_iterations);
  EXPECT_EQ(config.planner.solver.memory_size, 48);
  EXPECT_EQ(config.replan.solver.max_iterations, DefaultReplanOptions().solver.max_iterations);
  EXPECT_EQ(config.planner.cost.samples_per_piece, WholeBodyCostOptions{}.samples_per_piece);
  EXPECT_EQ(config.front_end.voxel_size, FrontEndOptions{}.voxel_size);
  std::string why;
  EXPECT_TRUE(config.IsValid(&why)) << why;
}

TEST(PlannerConfigTest, EveryKeyRoundTripsExactly) {
  PlannerConfig config = DefaultPlannerConfig();
  config.planner.cost.weight_collision = 1.0 / 3.0;
  config.planner.cost.samples_per_piece = 23;
  config.planner.stow_joints_in_transit = false;
  config.planner.solver.max_time_seconds = std::numeric_limits<double>::infinity();
  config.front_end.bounds_margin = Vec3(0.1, 0.2, 0.30000000000000004);
  config.front_end.max_expansions = 123456789012;
  config.representations.esdf.resolution = 0.025;
  config.replan.solver.gradient_tolerance = 2.5e-7;
  const std::string yaml = PlannerConfigYaml(config);
  auto parsed = ParsePlannerConfig(yaml, "round trip");
  ASSERT_TRUE(parsed.ok()) << parsed.status().message();
  EXPECT_EQ(PlannerConfigYaml(*parsed), yaml);
  EXPECT_EQ(parsed->planner.cost.weight_collision, 1.0 / 3.0);
  EXPECT_EQ(parsed->front_end.bounds_margin.z(), 0.30000000000000004);
  EXPECT_TRUE(std::isinf(parsed->planner.solver.max_time_seconds));
  EXPECT_FALSE(parsed->planner.stow_joints_in_transit);
  EXPECT_EQ(parsed->front_end.max_expansions, 123456789012);
}

TEST(PlannerConfigTest, KeysLeftOutKeepTheirDefaults) {
  auto config = ParsePlannerConfig("cost:\n  weight_collision: 250000\nrepresentations: {esdf: {resolution: 0.03}}\n",
                                   "cfg.yaml");
  ASSERT_TRUE(config.ok()) << config.status().message();
  EXPECT_EQ(config->planner.cost.weight_collision, 250000.0);
  EXPECT_EQ(config->representations.esdf.resolution, 0.03);
  PlannerConfig expected = DefaultPlannerConfig();
  expected.planner.cost.weight_collision = 250000.0;
  expected.representations.esdf.resolution = 0.03;
  EXPECT_EQ(PlannerConfigYaml(*config), PlannerConfigYaml(expected));
  auto commented = ParsePlannerConfig("# cost:\n#   weight_collision: 1\n", "commented.yaml");
  ASSERT_TRUE(commented.ok()) << commented.status().message();
  EXPECT_EQ(PlannerConfigYaml(*commented), PlannerConfigYaml(DefaultPlannerConfig()));
  for (const std::string empty : {"", "\n  \n"}) {
    auto refused = ParsePlannerConfig(empty, "empty.yaml");
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.status().message().rfind("empty.yaml: the planner configuration is empty", 0), 0u);
  }
}

TEST(PlannerConfigTest, ErrorsNameTheFileAndTheKey) {
  // A memory of 10^8 pairs allocated gigabytes and aborted (found by probing).
  EXPECT_NE(Error("solver: {memory_size: 100000000}\n").find("memory_size must be in [1, 1000]"), std::string::npos);
  EXPECT_EQ(Error("cost:\n  weight_colision: 1\n"),
            "cfg.yaml: cost.weight_colision: unknown key (docs/configuration.md lists every key)");
  EXPECT_EQ(Error("colour: red\n"), "cfg.yaml: colour: unknown key (docs/configuration.md lists every key)");
  EXPECT_EQ(Error("cost: 5\n"), "cfg.yaml: cost: expected a mapping of keys");
  EXPECT_EQ(Error("cost: {samples_per_piece: many}\n"),
            "cfg.yaml: cost.samples_per_piece: expected a number, got 'many'");
  EXPECT_EQ(Error("cost: {samples_per_piece: 2.5}\n"),
            "cfg.yaml: cost.samples_per_piece: expected a whole number in range, got '2.5'");
  EXPECT_EQ(Error("front_end: {max_expansions: 1e300}\n"),
            "cfg.yaml: front_end.max_expansions: expected a whole number in range, got '1e300'");
  EXPECT_EQ(Error("cost: {weight_velocity: .nan}\n"), "cfg.yaml: cost.weight_velocity: must be a finite number");
  EXPECT_EQ(Error("cost: {weight_velocity: .inf}\n"), "cfg.yaml: cost.weight_velocity: must be a finite number");
  EXPECT_EQ(Error("plan: {stow_joints_in_transit: maybe}\n"),
            "cfg.yaml: plan.stow_joints_in_transit: expected true or false, got 'maybe'");
  EXPECT_EQ(Error("front_end: {bounds_margin: [1, 2]}\n"),
            "cfg.yaml: front_end.bounds_margin: expected a list of 3 numbers");
  EXPECT_EQ(Error("cost: {weight_velocity: -1}\n"),
            "cfg.yaml: plan: weights and tolerances must be finite and non-negative");
  EXPECT_EQ(Error("representations: {esdf: {resolution: 0}}\n").rfind("cfg.yaml: representations: esdf: ", 0), 0u);
  EXPECT_EQ(Error("[1, 2]\n"), "cfg.yaml: expected a YAML mapping of configuration keys");
  EXPECT_EQ(Error("cost: {a: [\n").rfind("cfg.yaml: not valid YAML: line ", 0), 0u);
  auto missing = LoadPlannerConfig("/nonexistent/quadhand.yaml");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("/nonexistent/quadhand.yaml"), std::string::npos);
}

TEST(PlannerConfigTest, EntriesListEveryKeyOnce) {
  const auto entries = PlannerConfigEntries(DefaultPlannerConfig());
  std::set<std::string> keys;
  for (const auto& [key, value] : entries) EXPECT_TRUE(keys.insert(key).second) << key;
  EXPECT_TRUE(keys.count("cost.flatness.gravity"));
  EXPECT_TRUE(keys.count("replan.solver.max_iterations"));
  EXPECT_EQ(entries.front().first, "plan.collision_margin");
  EXPECT_EQ(std::get<double>(entries.front().second), 0.01);
  EXPECT_EQ(std::get<long long>(entries[3].second), 4);  // plan.min_pieces
  EXPECT_EQ(std::get<bool>(entries[6].second), true);    // plan.stow_joints_in_transit
}

TEST(PlannerConfigTest, RunOptionsApplyTheFlags) {
  PlannerConfig config = DefaultPlannerConfig();
  const PlannerOptions options = RunPlannerOptions(config, 0.005, 7, true);
  EXPECT_EQ(options.post_check.dt, 0.005);
  EXPECT_EQ(options.terminal_state.seed, 7u);
  EXPECT_EQ(options.solver.verbosity, 1);
  EXPECT_EQ(RunPlannerOptions(config, 0.5, 0, false).post_check.dt, config.planner.post_check.dt);
  config.representations.esdf.resolution = 0.04;
  const PlanningContextOptions context = ContextOptions(config, {"esdf"});
  EXPECT_EQ(context.representations, std::vector<std::string>{"esdf"});
  EXPECT_EQ(context.representation_options.esdf.resolution, 0.04);
}

TEST(PlannerConfigTest, OneWorkerCountSetsTheCostsAndThePostChecks) {
  PlannerConfig config = DefaultPlannerConfig();
  SetWorkerThreads(3, &config);
  EXPECT_EQ(config.planner.cost.threads, 3);
  EXPECT_EQ(config.planner.post_check.threads, 3);
  std::string why;
  EXPECT_TRUE(config.IsValid(&why)) << why;
}

}  // namespace
}  // namespace quadhand::planner
