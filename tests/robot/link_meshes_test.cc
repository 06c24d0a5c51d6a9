// One closed mesh per collision link: primitives tessellated and merged,
// mesh files read, scaled and placed; errors for links without geometry and
// for missing mesh files.
#include "quadhand/robot/link_meshes.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/primitives.h"
#include "quadhand/geometry/repaired_mesh_cache.h"
#include "robot/robot_test_util.h"

namespace quadhand::robot {
namespace {

using testing::FixturePath;
using testing::kPi;

RobotModel Load(const std::string& path) {
  auto model = RobotModel::LoadFromUrdfFile(path);
  EXPECT_TRUE(model.ok()) << model.status().message();
  return std::move(model).value();
}

void ExpectClosedOutward(const geometry::TriangleMesh& mesh) {
  const geometry::MeshCheck check = geometry::CheckMesh(mesh);
  EXPECT_TRUE(check.closed) << check.problem;
  EXPECT_TRUE(check.bounds_volume) << check.problem;
  EXPECT_TRUE(check.outward) << check.problem;
}

TEST(LinkMeshesTest, BoxAndCylinderUnionIsClosedWithTheRightVolume) {
  const RobotModel model = Load(FixturePath("box_cylinder.urdf"));
  auto mesh = LinkCollisionMesh(model, model.LinkIndex("body"));
  ASSERT_TRUE(mesh.ok()) << mesh.status().message();
  ExpectClosedOutward(*mesh);

  // Box 0.2 x 0.1 x 0.1 plus the half of the cylinder (r 0.03, length 0.1)
  // outside it. The tessellated circle is inscribed: chords lie inside, at most
  // `tol` from the arc, so the polygon area is within 2 tol / r of the disc's.
  const double r = 0.03, length = 0.1, tol = kPrimitiveTessellationTolerance;
  const double half_cylinder = 0.5 * kPi * r * r * length;
  const double exact = 0.2 * 0.1 * 0.1 + half_cylinder;
  const double volume = geometry::SignedVolume(*mesh);
  EXPECT_LE(volume, exact + 1e-12);
  EXPECT_GE(volume, exact - 2.0 * tol / r * half_cylinder - 1e-12);

  // Placed by the collision origins: x from the box's back face to the
  // cylinder's far side, y and z the box's.
  const geometry::AxisAlignedBox box = geometry::BoundingBox(*mesh);
  EXPECT_NEAR(box.min.x(), -0.1, 1e-12);
  EXPECT_NEAR(box.max.x(), 0.1 + r, tol + 1e-12);
  EXPECT_GE(box.max.x(), 0.1 + r - tol);
  EXPECT_NEAR(box.min.y(), -0.05, 1e-12);
  EXPECT_NEAR(box.max.y(), 0.05, 1e-12);
  EXPECT_NEAR(box.min.z(), -0.05, 1e-12);
  EXPECT_NEAR(box.max.z(), 0.05, 1e-12);
}

TEST(LinkMeshesTest, SingleSphereIsPlacedAndWithinTolerance) {
  const RobotModel model = Load(FixturePath("box_cylinder.urdf"));
  auto mesh = LinkCollisionMesh(model, model.LinkIndex("ball"));
  ASSERT_TRUE(mesh.ok()) << mesh.status().message();
  ExpectClosedOutward(*mesh);
  const double r = 0.05, tol = kPrimitiveTessellationTolerance;
  const double exact = 4.0 / 3.0 * kPi * r * r * r;
  const double volume = geometry::SignedVolume(*mesh);
  // Inscribed: every surface point within tol of the sphere, inside it, so the
  // volume lies between the spheres of radius r - tol and r.
  EXPECT_LE(volume, exact + 1e-12);
  EXPECT_GE(volume, 4.0 / 3.0 * kPi * std::pow(r - tol, 3) - 1e-12);
  for (const Vec3& v : mesh->vertices) {
    EXPECT_NEAR((v - Vec3(0.01, 0.02, 0.03)).norm(), r, 1e-12);  // in the link frame
  }
}

TEST(LinkMeshesTest, MeshFileIsScaledAndPlaced) {
  const RobotModel model = Load(testing::Arm2Path());
  // flap: the corner tetrahedron (volume 1/6) scaled by 0.1, via package://.
  auto flap = LinkCollisionMesh(model, model.LinkIndex("flap"));
  ASSERT_TRUE(flap.ok()) << flap.status().message();
  ExpectClosedOutward(*flap);
  EXPECT_NEAR(geometry::SignedVolume(*flap), 0.1 * 0.1 * 0.1 / 6.0, 1e-15);
  const geometry::AxisAlignedBox box = geometry::BoundingBox(*flap);
  EXPECT_LT(box.min.norm(), 1e-12);
  EXPECT_TRUE(box.max.isApprox(Vec3::Constant(0.1), 1e-12));
}

TEST(LinkMeshesTest, MirroringScaleKeepsTheMeshOutward) {
  const RobotModel model = Load(FixturePath("box_cylinder.urdf"));
  auto mesh = LinkCollisionMesh(model, model.LinkIndex("mirrored"));
  ASSERT_TRUE(mesh.ok()) << mesh.status().message();
  ExpectClosedOutward(*mesh);
  EXPECT_NEAR(geometry::SignedVolume(*mesh), 0.001 / 6.0, 1e-15);
  EXPECT_NEAR(geometry::BoundingBox(*mesh).min.x(), -0.1, 1e-12);
}

// A mesh scale far from any unit conversion is refused when the URDF is read
// (1e-300 flattened a link into a sheet, 1e300 overflowed CGAL's exact
// distances and aborted the process), and a scaled, placed mesh reaching
// beyond 1000 m when its link's meshes are built.
TEST(LinkMeshesTest, ScalesAndPlacementsOutOfRangeAreRefused) {
  const std::string tetra = FixturePath("qh_fixture_pkg/meshes/tetra.off");
  auto urdf = [&](const std::string& scale, const std::string& xyz) {
    return "<robot name='r'><link name='base'><collision><origin xyz='" + xyz + "'/><geometry><mesh filename='" +
           tetra + "' scale='" + scale + "'/></geometry></collision></link></robot>";
  };
  for (const char* scale : {"1e-300 1 1", "1 1e300 1", "1 1 -1e7"}) {
    SCOPED_TRACE(scale);
    auto model = RobotModel::LoadFromUrdfString(urdf(scale, "0 0 0"), FixturePath(""));
    ASSERT_FALSE(model.ok());
    EXPECT_NE(model.status().message().find("scale entries must be within [1e-6, 1e6]"), std::string::npos)
        << model.status().message();
  }
  auto far = RobotModel::LoadFromUrdfString(urdf("1e5 1 1", "0 0 0"), FixturePath(""));
  ASSERT_TRUE(far.ok()) << far.status().message();
  auto mesh = LinkCollisionMesh(*far, far->LinkIndex("base"));
  ASSERT_FALSE(mesh.ok());
  EXPECT_NE(mesh.status().message().find("more than 1000 m from the link frame"), std::string::npos)
      << mesh.status().message();
  auto mirrored_mm = RobotModel::LoadFromUrdfString(urdf("-0.001 0.001 0.001", "0 0 0"), FixturePath(""));
  ASSERT_TRUE(mirrored_mm.ok()) << mirrored_mm.status().message();
  EXPECT_TRUE(LinkCollisionMesh(*mirrored_mm, mirrored_mm->LinkIndex("base")).ok());
}

TEST(LinkMeshesTest, BoxAndMeshFileUnion) {
  const RobotModel model = Load(testing::Arm2Path());
  // forearm: a box 0.1 x 0.04 x 0.04 and a tetrahedron (edge 0.05) poking out of it.
  auto mesh = LinkCollisionMesh(model, model.LinkIndex("forearm"));
  ASSERT_TRUE(mesh.ok()) << mesh.status().message();
  ExpectClosedOutward(*mesh);
  const double box = 0.1 * 0.04 * 0.04, tetra = 0.05 * 0.05 * 0.05 / 6.0;
  const double volume = geometry::SignedVolume(*mesh);
  EXPECT_GT(volume, box + 1e-9);          // the tip outside adds volume
  EXPECT_LT(volume, box + tetra - 1e-9);  // the part inside is not counted twice
  EXPECT_NEAR(geometry::BoundingBox(*mesh).max.x(), 0.13, 1e-12);
}

TEST(LinkMeshesTest, EveryArm2CollisionLinkGivesAClosedMesh) {
  const RobotModel model = Load(testing::Arm2Path());
  for (int link : model.CollisionLinks()) {
    auto mesh = LinkCollisionMesh(model, link);
    ASSERT_TRUE(mesh.ok()) << model.link(link).name << ": " << mesh.status().message();
    EXPECT_TRUE(geometry::CheckMesh(*mesh).bounds_volume) << model.link(link).name;
    EXPECT_GT(geometry::SignedVolume(*mesh), 0.0) << model.link(link).name;
  }
}

TEST(LinkMeshesTest, LinkWithoutCollisionGeometryFails) {
  const RobotModel model = Load(FixturePath("box_cylinder.urdf"));
  auto mesh = LinkCollisionMesh(model, model.LinkIndex("bare"));
  ASSERT_FALSE(mesh.ok());
  EXPECT_EQ(mesh.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(mesh.status().message().find("bare"), std::string::npos);
  EXPECT_FALSE(LinkCollisionMesh(model, -1).ok());
  EXPECT_FALSE(LinkCollisionMesh(model, model.num_links()).ok());
}

TEST(LinkMeshesTest, MissingMeshFileFailsNamingIt) {
  const RobotModel model = Load(FixturePath("missing_mesh.urdf"));
  auto mesh = LinkCollisionMesh(model, 0);
  ASSERT_FALSE(mesh.ok());
  const std::string& message = mesh.status().message();
  EXPECT_NE(message.find("does_not_exist.stl"), std::string::npos) << message;
  EXPECT_NE(message.find("link 'base'"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

// The half-width the front end inflates by: a 0.2 m sphere body with a box
// guard at y 0.3 (0.05 m edge) and an arm that stows along x within its
// limits (the slide's limits [0.1, 0.5] put it at 0.1): largest |x| 0.1 +
// 0.3 + 0.05 = 0.45, largest |y| 0.325; the narrower is y.
TEST(LinkMeshesTest, StowedHalfWidthIsTheNarrowerHorizontalReach) {
  auto robot = RobotModel::LoadFromUrdfString(R"(<robot name="w">
    <link name="base"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
    <link name="guard"><collision><geometry><box size="0.05 0.05 0.05"/></geometry></collision></link>
    <link name="arm"><collision><origin xyz="0.3 0 0"/><geometry><sphere radius="0.05"/></geometry></collision></link>
    <joint name="mount" type="fixed"><parent link="base"/><child link="guard"/><origin xyz="0 0.3 0"/></joint>
    <joint name="slide" type="prismatic"><parent link="base"/><child link="arm"/><axis xyz="1 0 0"/>
      <limit lower="0.1" upper="0.5" effort="1" velocity="1"/></joint></robot>)", ".");
  ASSERT_TRUE(robot.ok()) << robot.status().message();
  auto half_width = StowedHalfWidth(*robot);
  ASSERT_TRUE(half_width.ok());
  EXPECT_NEAR(*half_width, 0.325, 1e-9);
  // Each axis (the spheres are tessellated: their vertices lie on the
  // sphere, not always on its extreme points): x 0.45, y 0.325, and the
  // height the body sphere's 0.1 (the guard and the arm reach 0.05).
  auto extents = StowedHalfExtents(*robot);
  ASSERT_TRUE(extents.ok());
  EXPECT_NEAR(extents->x(), 0.45, 1e-3);
  EXPECT_NEAR(extents->y(), 0.325, 1e-9);
  EXPECT_NEAR(extents->z(), 0.1, 1e-3);
  auto bare = RobotModel::LoadFromUrdfString(R"(<robot name="bare"><link name="base"/></robot>)", ".");
  ASSERT_TRUE(bare.ok());
  EXPECT_EQ(*StowedHalfWidth(*bare), 0.0);
}

}  // namespace
}  // namespace quadhand::robot

namespace quadhand::robot {
namespace {

// A robot whose one link is a mesh file, written in a fresh folder.
struct MeshRobot {
  std::filesystem::path dir;
  std::string mesh_path;
  std::string urdf_path;
};

MeshRobot WriteMeshRobot(const std::string& name, const Vec3& box_size) {
  MeshRobot robot;
  robot.dir = std::filesystem::temp_directory_path() / ("quadhand_link_meshes_" + std::to_string(getpid()) + "_" + name);
  std::filesystem::remove_all(robot.dir);
  std::filesystem::create_directories(robot.dir);
  robot.mesh_path = (robot.dir / "body.stl").string();
  EXPECT_TRUE(geometry::WriteMesh(robot.mesh_path, geometry::TessellateBox(geometry::Box{Pose::Identity(), box_size})).ok());
  robot.urdf_path = (robot.dir / "robot.urdf").string();
  std::ofstream(robot.urdf_path) << "<robot name='r'><link name='base'><collision><origin xyz='0.1 0 0'/><geometry>"
                                    "<mesh filename='body.stl'/></geometry></collision></link></robot>\n";
  return robot;
}

TEST(LinkMeshesTest, TheRepairCacheIsWrittenAndReadForTheSameFileAndIgnoredForAChangedOne) {
  const MeshRobot files = WriteMeshRobot("cache", Vec3(0.1, 0.2, 0.3));
  const std::string cache_dir = MeshCacheDirOf(files.dir.string());
  RobotModel model = Load(files.urdf_path);
  auto repaired = LinkCollisionElements(model, 0);
  ASSERT_TRUE(repaired.ok()) << repaired.status().message();
  auto saved = SaveMeshRepairCache(cache_dir);
  ASSERT_TRUE(saved.ok()) << saved.status().message();
  EXPECT_GE(*saved, 1);

  // The entry written is the placed repair: forge it with another solid,
  // and a fresh read of the same file (the process memo misses on the new
  // modification time) returns the forgery, proof that the cache is read.
  auto key = geometry::RepairedMeshCacheKeyOf(files.mesh_path, geometry::MeshRepairOptions{});
  ASSERT_TRUE(key.ok());
  key->placement.translation() = Vec3(0.1, 0.0, 0.0);
  const std::string entry = geometry::RepairedMeshCachePath(cache_dir, *key);
  ASSERT_TRUE(std::filesystem::exists(entry)) << entry;
  auto cached = geometry::ReadRepairedMeshCache(entry, *key);
  ASSERT_TRUE(cached.ok()) << cached.status().message();
  ASSERT_EQ(cached->shells.size(), repaired->size());
  EXPECT_EQ(cached->shells[0].vertices, (*repaired)[0].vertices);
  geometry::RepairedMesh forged = *cached;
  forged.shells[0] = geometry::TessellateBox(geometry::Box{Pose::Identity(), Vec3::Constant(0.05)});
  ASSERT_TRUE(geometry::WriteRepairedMeshCache(entry, *key, forged).ok());
  std::filesystem::last_write_time(files.mesh_path,
                                   std::filesystem::last_write_time(files.mesh_path) + std::chrono::seconds(2));
  model.set_mesh_cache_dir(cache_dir);
  auto from_cache = LinkCollisionElements(model, 0);
  ASSERT_TRUE(from_cache.ok());
  EXPECT_EQ((*from_cache)[0].vertices, forged.shells[0].vertices);

  // A changed mesh file misses the entry and is repaired afresh.
  ASSERT_TRUE(geometry::WriteMesh(files.mesh_path,
                                  geometry::TessellateBox(geometry::Box{Pose::Identity(), Vec3(0.1, 0.2, 0.4)}))
                  .ok());
  auto changed = LinkCollisionElements(model, 0);
  ASSERT_TRUE(changed.ok());
  const geometry::AxisAlignedBox box = geometry::BoundingBox((*changed)[0]);
  EXPECT_NEAR(box.size().z(), 0.4, 1e-6);  // STL stores single precision
  EXPECT_NEAR(box.min.x(), 0.05, 1e-6);
  std::filesystem::remove_all(files.dir);
}

}  // namespace
}  // namespace quadhand::robot
