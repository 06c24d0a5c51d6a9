#include "quadhand/planner/representation.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/planning_context.h"
#include "support/window_cup_task.h"

namespace quadhand::planner {
namespace {

robot::RobotModel QuadHand() {
  return *robot::RobotModel::LoadFromUrdfFile(std::string(QUADHAND_SOURCE_DIR) + "/meshes/quadhand/quadhand.urdf");
}

std::vector<Vec3> Floor() {
  std::vector<Vec3> points;
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 20; ++j) points.emplace_back(0.1 * i - 1.0, 0.1 * j - 1.0, 0.0);
  }
  return points;
}

TEST(RepresentationRegistryTest, TheBuiltInsComeFirstAndUnknownNamesAreListed) {
  const std::vector<std::string> names = RepresentationNames();
  ASSERT_GE(names.size(), 3u);
  EXPECT_EQ(std::vector<std::string>(names.begin(), names.begin() + 3),
            (std::vector<std::string>{"mrc_sdf", "esdf", "sfc"}));
  EXPECT_TRUE(CheckRepresentationName("esdf").ok());
  const core::Status unknown = CheckRepresentationName("voxels");
  EXPECT_EQ(unknown.code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(unknown.message().rfind("unknown representation 'voxels' (known: mrc_sdf, esdf, sfc", 0), 0u)
      << unknown.message();
  EXPECT_FALSE(MakeRepresentation("voxels", QuadHand(), "", Floor()).ok());
}

TEST(RepresentationRegistryTest, ARegisteredRepresentationIsBuiltByNameWithItsOptions) {
  double seen_resolution = 0.0;
  ASSERT_TRUE(RegisterRepresentation("coarse_esdf", [&seen_resolution](const RepresentationInputs& in) {
                seen_resolution = in.options.esdf.resolution;
                RepresentationOptions coarse = in.options;
                coarse.esdf.resolution = 0.05;
                return MakeRepresentation("esdf", in.robot, in.sdf_dir, in.points, coarse);
              }).ok());
  EXPECT_FALSE(RegisterRepresentation("coarse_esdf", [](const RepresentationInputs&) {
                 return core::Result<Representation>(core::Status::Internal("unused"));
               }).ok());
  EXPECT_FALSE(RegisterRepresentation("", nullptr).ok());
  const std::vector<std::string> names = RepresentationNames();
  EXPECT_EQ(names.back(), "coarse_esdf");
  EXPECT_TRUE(CheckRepresentationName("coarse_esdf").ok());

  const robot::RobotModel robot = QuadHand();
  const std::vector<Vec3> points = Floor();
  RepresentationOptions options;
  options.esdf.resolution = 0.03;
  auto built = MakeRepresentation("coarse_esdf", robot, "", points, options);
  ASSERT_TRUE(built.ok()) << built.status().message();
  EXPECT_EQ(built->name, "coarse_esdf");
  ASSERT_NE(built->scene_model, nullptr);
  EXPECT_EQ(built->scene_model->name(), "esdf");
  EXPECT_EQ(seen_resolution, 0.03);

  options.esdf.resolution = -1.0;  // invalid options never reach a factory
  seen_resolution = 0.0;
  EXPECT_FALSE(MakeRepresentation("coarse_esdf", robot, "", points, options).ok());
  EXPECT_EQ(seen_resolution, 0.0);
}

// A representation registered from outside the library reads its own
// section of the configuration file: the file is parsed, the section passed
// on as YAML text, and written back by --print-config and into the report.
TEST(RepresentationRegistryTest, ARegisteredRepresentationGetsItsOwnConfigurationSection) {
  std::string seen;
  ASSERT_TRUE(RegisterRepresentation("plugin_floor", [&seen](const RepresentationInputs& in) {
                seen = in.own_options;
                return MakeRepresentation("mrc_sdf", in.robot, in.sdf_dir, in.points, in.options, in.index);
              }).ok());
  auto config = ParsePlannerConfig(
      "representations:\n  plugin_floor:\n    radius: 0.2\n    levels: [1, 2]\n  esdf: {resolution: 0.03}\n",
      "cfg.yaml");
  ASSERT_TRUE(config.ok()) << config.status().message();
  EXPECT_EQ(config->representations.esdf.resolution, 0.03);
  ASSERT_EQ(config->representations.registered.count("plugin_floor"), 1u);
  EXPECT_EQ(config->representations.registered.at("plugin_floor"), "{radius: 0.2, levels: [1, 2]}");

  // Round trip through the printed configuration, and the report's entries.
  auto again = ParsePlannerConfig(PlannerConfigYaml(*config), "printed.yaml");
  ASSERT_TRUE(again.ok()) << again.status().message() << "\n" << PlannerConfigYaml(*config);
  EXPECT_EQ(again->representations.registered, config->representations.registered);
  const auto entries = PlannerConfigEntries(*config);
  EXPECT_EQ(entries.back().first, "representations.plugin_floor");
  EXPECT_EQ(std::get<std::string>(entries.back().second), "{radius: 0.2, levels: [1, 2]}");

  const robot::RobotModel robot = QuadHand();
  const std::vector<Vec3> points = Floor();
  // The test's own coarse SDFs: data/sdf is made by the quick start, not by a clean checkout.
  const std::string sdf_dir = testing::CoarseSdfDir();
  auto built = MakeRepresentation("plugin_floor", robot, sdf_dir, points, config->representations);
  ASSERT_TRUE(built.ok()) << built.status().message();
  EXPECT_EQ(seen, "{radius: 0.2, levels: [1, 2]}");
  seen = "unset";
  ASSERT_TRUE(MakeRepresentation("plugin_floor", robot, sdf_dir, points).ok());
  EXPECT_EQ(seen, "");  // no section: no options

  // A section for a name nobody registered is an error naming it; a built-in
  // cannot be given as text.
  auto unknown = ParsePlannerConfig("representations: {voxels: {size: 1}}\n", "cfg.yaml");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.status().message().rfind("cfg.yaml: representations.voxels: unknown representation 'voxels'", 0),
            0u)
      << unknown.status().message();
  RepresentationOptions text_for_builtin;
  text_for_builtin.registered["esdf"] = "{resolution: 0.03}";
  EXPECT_FALSE(text_for_builtin.IsValid(nullptr));
}

// A context builds its front-end map beside its representations (on a
// second core). The map is the one FrontEndMap::Build makes alone, and
// when both fail the front end's error is the one reported, as when the
// front end was built first.
TEST(RepresentationRegistryTest, AContextsFrontEndIsBuiltBesideItsRepresentations) {
  ASSERT_TRUE(RegisterRepresentation("always_fails", [](const RepresentationInputs&) {
                return core::Result<Representation>(core::Status::Internal("always_fails: refused"));
              }).ok());
  const std::string dir = ::testing::TempDir() + "/context_front_end_" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  const std::string task_path = dir + "/task.yaml";
  // A goal at rest (no tool pose): the front end then contains just the
  // start and the goal, which the map built alone below is given too.
  std::ofstream(task_path) << testing::WindowCupTaskText(
      {{"  tool:", ""}, {"    position:", ""}, {"    orientation:", ""}, {"    insertion:", ""}});

  PlanningContextOptions options;
  auto context = PlanningContext::Load(task_path, options);
  ASSERT_TRUE(context.ok()) << context.status().message();
  // The same map as built alone: every third voxel's freedom, the blocked
  // count, the storage, and segments' clearance.
  const FrontEndMap& beside = (*context)->front_end();
  const Task& task = (*context)->task();
  ASSERT_FALSE(task.tool.has_value());
  ASSERT_TRUE(task.terminal.has_value());
  FrontEndOptions alone_options = beside.options();
  alone_options.size_from_robot = false;
  auto alone = FrontEndMap::Build((*context)->points(), alone_options, {task.start.position, task.terminal->position});
  ASSERT_TRUE(alone.ok()) << alone.status().message();
  ASSERT_EQ(alone->dims(), beside.dims());
  ASSERT_EQ(alone->min_corner(), beside.min_corner());
  EXPECT_EQ(alone->num_blocked(), beside.num_blocked());
  EXPECT_EQ(alone->grid_bytes(), beside.grid_bytes());
  int compared = 0, free = 0;
  for (int i = 0; i < beside.dims().x(); i += 3) {
    for (int j = 0; j < beside.dims().y(); j += 3) {
      for (int k = 0; k < beside.dims().z(); k += 3) {
        const Vec3 p = beside.min_corner() + (Vec3(i, j, k) + Vec3::Constant(0.5)) * beside.options().voxel_size;
        ASSERT_EQ(alone->IsFree(p), beside.IsFree(p)) << p.transpose();
        ++compared;
        free += beside.IsFree(p) ? 1 : 0;
      }
    }
  }
  EXPECT_GT(compared, 1000);
  EXPECT_GT(free, 0);
  EXPECT_LT(free, compared);
  const std::vector<Vec3>& points = (*context)->points();
  for (size_t n = 0; n < points.size(); n += std::max<size_t>(1, points.size() / 200)) {
    const Vec3 a = points[n] + Vec3(0.0, 0.0, 0.3), b = task.start.position;
    ASSERT_EQ(alone->SegmentIsClear(a, b), beside.SegmentIsClear(a, b)) << a.transpose();
  }

  // A representation's error alone is reported as it is ...
  options.representations = {"mrc_sdf", "always_fails"};
  auto refused = PlanningContext::Load(task_path, options);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().message(), "always_fails: refused");
  // ... but a scene too large for the front end is what the user hears of.
  options.front_end.max_voxels = 1000;
  options.representations = {"always_fails"};
  auto too_large = PlanningContext::Load(task_path, options);
  ASSERT_FALSE(too_large.ok());
  EXPECT_NE(too_large.status().message().find("max_voxels"), std::string::npos) << too_large.status().message();
  options.representations = {"mrc_sdf"};
  auto too_large_alone = PlanningContext::Load(task_path, options);
  ASSERT_FALSE(too_large_alone.ok());
  EXPECT_EQ(too_large_alone.status().message(), too_large.status().message());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace quadhand::planner
