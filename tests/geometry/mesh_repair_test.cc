// Mesh intake against exact primitives: every defect CAD exporters write,
// alone, repaired back to the primitive's own mesh (bit for bit where the
// repair removes what was added), and the defects that cannot be repaired
// refused with the true diagnosis.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/mesh_repair.h"
#include "quadhand/geometry/primitives.h"

namespace quadhand::geometry {
namespace {

TriangleMesh UnitBox(const Vec3& at = Vec3::Zero()) {
  Box box;
  box.pose.translation() = at;
  box.size = Vec3(0.1, 0.2, 0.3);
  return TessellateBox(box);
}

// The mesh with its vertices in triangle order (a soup's layout), for
// comparing results whatever the input's vertex numbering.
std::vector<std::array<double, 9>> Faces(const TriangleMesh& mesh) {
  std::vector<std::array<double, 9>> faces;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    std::array<double, 9> f{};
    for (int k = 0; k < 3; ++k) {
      for (int i = 0; i < 3; ++i) f[3 * k + i] = mesh.vertices[t[k]][i];
    }
    faces.push_back(f);
  }
  return faces;
}

RepairedMesh Repaired(const TriangleMesh& mesh, const MeshRepairOptions& options = {}) {
  auto repaired = RepairMesh(mesh, options);
  EXPECT_TRUE(repaired.ok()) << repaired.status().message();
  return repaired.ok() ? *repaired : RepairedMesh{};
}

TEST(MeshRepairTest, AClosedMeshIsUnchangedAndNothingIsReported) {
  const TriangleMesh box = UnitBox();
  const RepairedMesh r = Repaired(box);
  ASSERT_EQ(r.shells.size(), 1u);
  EXPECT_EQ(Faces(r.shells[0]), Faces(box));
  EXPECT_TRUE(r.report.Lines().empty());
}

TEST(MeshRepairTest, AReversedDuplicateFaceOnAnEdgeIsAFinAndGoesWithItsCopy) {
  // The exported-arm case: one triangle written twice, the second reversed,
  // standing on an edge of the solid (4 faces on that edge).
  TriangleMesh mesh = UnitBox();
  const int apex = static_cast<int>(mesh.vertices.size());
  const Eigen::Vector3i edge_face = mesh.triangles[0];
  mesh.vertices.push_back(0.5 * (mesh.vertices[edge_face[0]] + mesh.vertices[edge_face[1]]) + Vec3(0, 0, 1e-4) +
                          Vec3(1e-4, 0, 0));
  mesh.triangles.push_back(Eigen::Vector3i(edge_face[0], edge_face[1], apex));
  mesh.triangles.push_back(Eigen::Vector3i(edge_face[1], edge_face[0], apex));
  EXPECT_FALSE(CheckMesh(mesh).bounds_volume);
  const RepairedMesh r = Repaired(mesh);
  ASSERT_EQ(r.shells.size(), 1u);
  EXPECT_EQ(Faces(r.shells[0]), Faces(UnitBox()));  // bit for bit
  EXPECT_EQ(r.report.reversed_duplicate_pairs, 1);
  ASSERT_EQ(r.report.Lines().size(), 1u);
  EXPECT_NE(r.report.Lines()[0].find("reversed duplicate"), std::string::npos);
}

TEST(MeshRepairTest, AFaceOfTheSurfaceWrittenAgainReversedKeepsOneCopy) {
  // A face of the solid itself written a second time, reversed (3 faces on
  // each of its edges): removing both would open a hole; one copy, the one
  // its neighbours agree with, is the surface. Either order in the file.
  for (const bool reversed_first : {false, true}) {
    TriangleMesh mesh = UnitBox();
    const Eigen::Vector3i face = mesh.triangles[4];
    const Eigen::Vector3i reversed(face[0], face[2], face[1]);
    if (reversed_first) {
      mesh.triangles[4] = reversed;
      mesh.triangles.push_back(face);
    } else {
      mesh.triangles.push_back(reversed);
    }
    EXPECT_FALSE(CheckMesh(mesh).bounds_volume);
    const RepairedMesh r = Repaired(mesh);
    ASSERT_EQ(r.shells.size(), 1u);
    EXPECT_EQ(r.shells[0].triangles.size(), UnitBox().triangles.size());
    EXPECT_TRUE(CheckMesh(r.shells[0]).outward);
    EXPECT_NEAR(SignedVolume(r.shells[0]), 0.1 * 0.2 * 0.3, 1e-12);
    EXPECT_EQ(r.report.reversed_duplicate_faces, 1);
    EXPECT_EQ(r.report.reversed_duplicate_pairs, 0);
    EXPECT_EQ(r.report.flipped_faces, 0);  // the copy kept already agrees
    ASSERT_EQ(r.report.Lines().size(), 1u) << r.report.Lines()[0];
    EXPECT_NE(r.report.Lines()[0].find("reversed duplicate face"), std::string::npos);
  }
}

TEST(MeshRepairTest, DuplicatesDegenerateFacesAndSplitVerticesAreRemoved) {
  TriangleMesh mesh = UnitBox();
  mesh.triangles.push_back(mesh.triangles[3]);                                   // an exact duplicate
  mesh.triangles.push_back(Eigen::Vector3i(mesh.triangles[5][0], mesh.triangles[5][0], mesh.triangles[5][1]));
  // A vertex written twice, 0.5 um apart, used by one face: a crack closed by merging.
  const int split = static_cast<int>(mesh.vertices.size());
  mesh.vertices.push_back(mesh.vertices[mesh.triangles[7][2]] + Vec3(5e-7, 0, 0));
  mesh.triangles[7][2] = split;
  EXPECT_FALSE(CheckMesh(mesh).bounds_volume);
  const RepairedMesh r = Repaired(mesh);
  ASSERT_EQ(r.shells.size(), 1u);
  EXPECT_EQ(r.report.duplicate_faces, 1);
  EXPECT_EQ(r.report.degenerate_faces, 1);
  EXPECT_EQ(r.report.merged_vertices, 1);
  EXPECT_EQ(r.report.Lines().size(), 3u);
  EXPECT_EQ(r.shells[0].triangles.size(), 12u);
  EXPECT_NEAR(SignedVolume(r.shells[0]), 0.1 * 0.2 * 0.3, 1e-12);
}

TEST(MeshRepairTest, InconsistentAndInwardFacesAreTurned) {
  TriangleMesh mesh = UnitBox();
  std::swap(mesh.triangles[2][1], mesh.triangles[2][2]);  // one face against its neighbours
  RepairedMesh r = Repaired(mesh);
  ASSERT_EQ(r.shells.size(), 1u);
  EXPECT_EQ(r.report.flipped_faces, 1);
  EXPECT_NEAR(SignedVolume(r.shells[0]), 0.006, 1e-12);
  for (Eigen::Vector3i& t : mesh.triangles) std::swap(t[1], t[2]);  // now all but one inward
  r = Repaired(mesh);
  EXPECT_EQ(r.report.flipped_faces, 1);
  EXPECT_EQ(r.report.outward_shells, 1);
  EXPECT_NEAR(SignedVolume(r.shells[0]), 0.006, 1e-12);
}

TEST(MeshRepairTest, SeveralShellsOverlappingOrNotAreKeptAsTheirUnion) {
  // Two overlapping boxes in one file: self-intersecting as one surface,
  // two closed shells as meant.
  const TriangleMesh both = Concatenated({UnitBox(), UnitBox(Vec3(0.05, 0.05, 0.05))});
  EXPECT_FALSE(CheckMesh(both).bounds_volume);
  const RepairedMesh r = Repaired(both);
  ASSERT_EQ(r.shells.size(), 2u);
  EXPECT_EQ(Faces(r.shells[0]), Faces(UnitBox()));
  EXPECT_EQ(Faces(r.shells[1]), Faces(UnitBox(Vec3(0.05, 0.05, 0.05))));
  EXPECT_EQ(r.report.shells, 2);
}

TEST(MeshRepairTest, ARealHoleIsRefusedWithWhereAndHowLarge) {
  TriangleMesh mesh = UnitBox();
  mesh.triangles.erase(mesh.triangles.begin() + 4, mesh.triangles.begin() + 6);  // one whole side
  auto r = RepairMesh(mesh);
  ASSERT_FALSE(r.ok());
  const std::string message = r.status().message();
  EXPECT_NE(message.find("not closed: 1 hole"), std::string::npos) << message;
  EXPECT_NE(message.find("a border of 4 edges"), std::string::npos) << message;
  // A crack wider than the tolerance stays open, whatever the tolerance's default.
  TriangleMesh cracked = UnitBox();
  cracked.vertices.push_back(cracked.vertices[cracked.triangles[7][2]] + Vec3(9e-4, 0, 0));
  cracked.triangles[7][2] = static_cast<int>(cracked.vertices.size()) - 1;
  r = RepairMesh(cracked);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("not closed"), std::string::npos) << r.status().message();
  // ... and closes with a tolerance above its width.
  MeshRepairOptions loose;
  loose.tolerance = 1e-3;
  EXPECT_TRUE(RepairMesh(cracked, loose).ok());
}

TEST(MeshRepairTest, BadMeshesAndTolerancesAreRefusedByName) {
  TriangleMesh sliver;
  sliver.vertices = {Vec3(0, 0, 0), Vec3(1e-7, 0, 0), Vec3(0, 1e-7, 0)};
  sliver.triangles = {Eigen::Vector3i(0, 1, 2), Eigen::Vector3i(0, 2, 1)};
  auto r = RepairMesh(sliver);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("degenerate"), std::string::npos) << r.status().message();
  EXPECT_FALSE(RepairMesh(TriangleMesh{}).ok());
  for (double tolerance : {0.0, -1e-5, std::nan(""), 0.01}) {
    MeshRepairOptions options;
    options.tolerance = tolerance;
    r = RepairMesh(UnitBox(), options);
    ASSERT_FALSE(r.ok()) << tolerance;
    EXPECT_NE(r.status().message().find("tolerance"), std::string::npos) << r.status().message();
  }
  // Three faces on one edge: not a surface, and said where.
  TriangleMesh fan = UnitBox();
  fan.vertices.push_back(Vec3(1, 1, 1));
  fan.triangles.push_back(Eigen::Vector3i(fan.triangles[0][0], fan.triangles[0][1], 8));
  r = RepairMesh(fan);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("shared by more than two faces"), std::string::npos) << r.status().message();
}

}  // namespace
}  // namespace quadhand::geometry

namespace quadhand::geometry {
namespace {

TEST(MeshRepairTest, ARepairToleranceMustBePositiveAtMostAMillimetreAndTheResolution) {
  EXPECT_TRUE(CheckRepairTolerance(1e-6, 0.002).ok());
  EXPECT_TRUE(CheckRepairTolerance(0.001, 0.001).ok());
  EXPECT_FALSE(CheckRepairTolerance(0.0, 0.002).ok());
  EXPECT_FALSE(CheckRepairTolerance(-1e-6, 0.002).ok());
  EXPECT_FALSE(CheckRepairTolerance(std::nan(""), 0.002).ok());
  EXPECT_FALSE(CheckRepairTolerance(0.002, 0.005).ok());  // over 1 mm
  const core::Status coarse = CheckRepairTolerance(0.0008, 0.0005);
  ASSERT_FALSE(coarse.ok());
  EXPECT_NE(coarse.message().find("larger than the SDF resolution 0.0005 m"), std::string::npos) << coarse.message();
}

}  // namespace
}  // namespace quadhand::geometry
