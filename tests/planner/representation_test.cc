#include "quadhand/planner/representation.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "quadhand/planner/planning_context.h"

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

}  // namespace
}  // namespace quadhand::planner
