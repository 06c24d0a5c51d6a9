// The repaired-mesh cache: an entry gives back exactly what was written for
// its key, and nothing for another key, a corrupted file or no file.
#include "quadhand/geometry/repaired_mesh_cache.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "quadhand/core/file_util.h"
#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/primitives.h"

namespace quadhand::geometry {
namespace {

class RepairedMeshCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("quadhand_mesh_cache_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    mesh_path_ = (dir_ / "box.stl").string();
    ASSERT_TRUE(WriteMesh(mesh_path_, TessellateBox(Box{Pose::Identity(), Vec3(0.1, 0.2, 0.3)})).ok());
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  RepairedMesh Repaired() const {
    RepairedMesh repaired;
    Pose placement = Pose::Identity();
    placement.translation() = Vec3(0.5, 0.0, -0.25);
    repaired.shells.push_back(TessellateBox(Box{placement, Vec3(0.1, 0.2, 0.3)}));
    repaired.report.duplicate_faces = 2;
    repaired.report.merged_vertices = 3;
    repaired.report.shells = 1;
    return repaired;
  }

  std::filesystem::path dir_;
  std::string mesh_path_;
};

TEST_F(RepairedMeshCacheTest, AnEntryReadsBackExactlyForItsKeyOnly) {
  auto key = RepairedMeshCacheKeyOf(mesh_path_, MeshRepairOptions{});
  ASSERT_TRUE(key.ok()) << key.status().message();
  key->placement.translation() = Vec3(0.5, 0.0, -0.25);
  const std::string path = RepairedMeshCachePath((dir_ / "meshes").string(), *key);
  EXPECT_EQ(std::filesystem::path(path).extension(), ".qhmesh");
  EXPECT_EQ(ReadRepairedMeshCache(path, *key).status().code(), core::StatusCode::kNotFound);

  const RepairedMesh written = Repaired();
  ASSERT_TRUE(WriteRepairedMeshCache(path, *key, written).ok());
  auto read = ReadRepairedMeshCache(path, *key);
  ASSERT_TRUE(read.ok()) << read.status().message();
  ASSERT_EQ(read->shells.size(), 1u);
  EXPECT_EQ(read->shells[0].vertices, written.shells[0].vertices);
  EXPECT_EQ(read->shells[0].triangles, written.shells[0].triangles);
  EXPECT_EQ(read->report.Lines(), written.report.Lines());
  EXPECT_TRUE(read->report.problem.empty());

  // Every part of the key tells entries apart, and names a different file.
  auto other_tolerance = *key;
  other_tolerance.options.tolerance = 2e-6;
  auto other_scale = *key;
  other_scale.scale = Vec3(1.0, 1.0, -1.0);
  auto other_placement = *key;
  other_placement.placement.translation().x() += 1e-9;
  auto other_source = *key;
  other_source.source_hash ^= 1;
  for (const RepairedMeshCacheKey& other : {other_tolerance, other_scale, other_placement, other_source}) {
    EXPECT_NE(RepairedMeshCachePath((dir_ / "meshes").string(), other), path);
    auto refused = ReadRepairedMeshCache(path, other);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.status().message().find("written for another"), std::string::npos) << refused.status().message();
  }
}

TEST_F(RepairedMeshCacheTest, TheKeyFollowsTheMeshFileBytes) {
  auto before = RepairedMeshCacheKeyOf(mesh_path_, MeshRepairOptions{});
  ASSERT_TRUE(before.ok());
  ASSERT_TRUE(WriteMesh(mesh_path_, TessellateBox(Box{Pose::Identity(), Vec3(0.1, 0.2, 0.31)})).ok());
  auto after = RepairedMeshCacheKeyOf(mesh_path_, MeshRepairOptions{});
  ASSERT_TRUE(after.ok());
  EXPECT_NE(before->source_hash, after->source_hash);
  EXPECT_FALSE(RepairedMeshCacheKeyOf((dir_ / "missing.stl").string(), MeshRepairOptions{}).ok());
}

TEST_F(RepairedMeshCacheTest, CorruptedOrTruncatedEntriesAndOpenShellsAreRefused) {
  auto key = RepairedMeshCacheKeyOf(mesh_path_, MeshRepairOptions{});
  ASSERT_TRUE(key.ok());
  const std::string path = RepairedMeshCachePath(dir_.string(), *key);
  ASSERT_TRUE(WriteRepairedMeshCache(path, *key, Repaired()).ok());
  auto bytes = core::ReadFileToString(path);
  ASSERT_TRUE(bytes.ok());
  auto refuse = [&](const std::string& contents, const std::string& fragment) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << contents;
    auto read = ReadRepairedMeshCache(path, *key);
    ASSERT_FALSE(read.ok());
    EXPECT_NE(read.status().message().find(path), std::string::npos);
    EXPECT_NE(read.status().message().find(fragment), std::string::npos) << read.status().message();
  };
  std::string flipped = *bytes;
  flipped[bytes->size() / 2] ^= 0x01;
  refuse(flipped, "checksum");
  refuse(bytes->substr(0, bytes->size() - 9), "checksum");
  refuse("", "magic");
  refuse("QHSDF\n\x1a", "magic");

  RepairedMesh open = Repaired();
  open.report.problem = "not closed";
  EXPECT_FALSE(WriteRepairedMeshCache(path + ".open", *key, open).ok());
  EXPECT_FALSE(std::filesystem::exists(path + ".open"));
}

}  // namespace
}  // namespace quadhand::geometry
