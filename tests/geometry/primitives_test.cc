#include "quadhand/geometry/primitives.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::geometry {
namespace {

constexpr double kPi = 3.14159265358979323846;

Pose RotatedAbout(const Vec3& axis, double angle, const Vec3& translation) {
  return MakePose(translation, Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix());
}

// Uniform random points on the triangles of `mesh` (plus their vertices).
std::vector<Vec3> SurfaceSamples(const TriangleMesh& mesh, int per_triangle, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Vec3> samples = mesh.vertices;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int s = 0; s < per_triangle; ++s) {
      double u = uniform(rng), v = uniform(rng);
      if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
      samples.push_back(mesh.vertices[t[0]] + u * (mesh.vertices[t[1]] - mesh.vertices[t[0]]) +
                        v * (mesh.vertices[t[2]] - mesh.vertices[t[0]]));
    }
  }
  return samples;
}

TEST(BoxDistance, FaceEdgeCornerAndInside) {
  const Box box{Pose::Identity(), Vec3(2.0, 4.0, 6.0)};  // half sizes 1, 2, 3
  EXPECT_DOUBLE_EQ(SignedDistance(box, Vec3(3.0, 0.0, 0.0)), 2.0);           // face
  EXPECT_DOUBLE_EQ(SignedDistance(box, Vec3(0.0, -2.5, 0.0)), 0.5);          // face
  EXPECT_DOUBLE_EQ(SignedDistance(box, Vec3(4.0, 6.0, 0.0)), 5.0);           // edge: (3, 4)
  EXPECT_DOUBLE_EQ(SignedDistance(box, Vec3(2.0, 3.0, 4.0)), std::sqrt(3.0));  // corner
  EXPECT_DOUBLE_EQ(SignedDistance(box, Vec3(0.0, 0.0, 0.0)), -1.0);          // nearest face x
  EXPECT_DOUBLE_EQ(SignedDistance(box, Vec3(0.5, 1.8, 0.0)), -0.2);          // nearest face y
  EXPECT_DOUBLE_EQ(SignedDistance(box, Vec3(1.0, 0.0, 0.0)), 0.0);           // on the surface
}

TEST(BoxDistance, FollowsThePose) {
  const Pose pose = RotatedAbout(Vec3::UnitZ(), kPi / 4.0, Vec3(1.0, 2.0, 3.0));
  const Box box{pose, Vec3(2.0, 2.0, 2.0)};
  // Along the box's rotated x axis, 1.5 from its centre: 0.5 outside.
  const Vec3 p = pose * Vec3(1.5, 0.0, 0.0);
  EXPECT_NEAR(SignedDistance(box, p), 0.5, 1e-12);
  // Its corner direction (x and y of the box) from the centre: distance to the edge.
  const Vec3 q = pose * Vec3(2.0, 2.0, 0.0);
  EXPECT_NEAR(SignedDistance(box, q), std::sqrt(2.0), 1e-12);
}

TEST(CylinderDistance, SideCapRimAndInside) {
  const Cylinder cylinder{Pose::Identity(), 1.0, 4.0};  // z in [-2, 2]
  EXPECT_DOUBLE_EQ(SignedDistance(cylinder, Vec3(3.0, 0.0, 0.0)), 2.0);  // side
  EXPECT_DOUBLE_EQ(SignedDistance(cylinder, Vec3(0.0, 0.0, 2.5)), 0.5);  // cap
  EXPECT_DOUBLE_EQ(SignedDistance(cylinder, Vec3(0.0, 4.0, 6.0)), 5.0);  // rim: (3, 4)
  EXPECT_DOUBLE_EQ(SignedDistance(cylinder, Vec3(0.0, 0.0, 0.0)), -1.0);  // side is nearest
  EXPECT_DOUBLE_EQ(SignedDistance(cylinder, Vec3(0.0, 0.0, 1.75)), -0.25);  // cap is nearest
  EXPECT_DOUBLE_EQ(SignedDistance(cylinder, Vec3(0.6, 0.8, 0.0)), 0.0);
}

TEST(CylinderDistance, AxisAlongY) {
  // The rotation that robot.md's hub cylinders use (z axis onto y).
  const Pose pose = RotatedAbout(Vec3::UnitX(), kPi / 2.0, Vec3(0.1, 0.0, 0.0));
  const Cylinder cylinder{pose, 0.02, 0.05};
  EXPECT_NEAR(SignedDistance(cylinder, Vec3(0.1, 0.045, 0.0)), 0.02, 1e-12);
  EXPECT_NEAR(SignedDistance(cylinder, Vec3(0.1, 0.0, 0.05)), 0.03, 1e-12);
  EXPECT_NEAR(SignedDistance(cylinder, Vec3(0.1, 0.0, 0.0)), -0.02, 1e-12);
}

TEST(SphereDistance, OutsideInside) {
  const Sphere sphere{Vec3(1.0, 0.0, 0.0), 0.5};
  EXPECT_DOUBLE_EQ(SignedDistance(sphere, Vec3(1.0, 2.0, 0.0)), 1.5);
  EXPECT_DOUBLE_EQ(SignedDistance(sphere, Vec3(1.0, 0.0, 0.0)), -0.5);
}

TEST(SidesForTolerance, SmallestPolygonWithinTolerance) {
  for (const double radius : {0.017, 0.02, 0.065, 1.0}) {
    for (const double tolerance : {1e-5, 1e-4, 2e-4, 1e-3}) {
      const int n = SidesForTolerance(radius, tolerance);
      ASSERT_GE(n, 3);
      EXPECT_LE(radius * (1.0 - std::cos(kPi / n)), tolerance) << radius << " " << tolerance;
      if (n > 3) {
        EXPECT_GT(radius * (1.0 - std::cos(kPi / (n - 1))), tolerance) << radius << " " << tolerance;
      }
    }
  }
  EXPECT_EQ(SidesForTolerance(1.0, 10.0), 3);  // coarse tolerance: a triangle suffices
}

TEST(TessellateBox, ClosedOutwardExactVolume) {
  const Box box{RotatedAbout(Vec3(1.0, 2.0, 3.0), 0.7, Vec3(0.3, -0.2, 0.1)), Vec3(0.2, 0.3, 0.4)};
  const TriangleMesh mesh = TessellateBox(box);
  EXPECT_EQ(mesh.num_triangles(), 12);
  const MeshCheck check = CheckMesh(mesh);
  EXPECT_TRUE(check.closed);
  EXPECT_TRUE(check.bounds_volume);
  EXPECT_TRUE(check.outward) << check.problem;
  EXPECT_NEAR(SignedVolume(mesh), 0.2 * 0.3 * 0.4, 1e-15);
  for (const Vec3& p : SurfaceSamples(mesh, 20, 1)) {
    EXPECT_NEAR(SignedDistance(box, p), 0.0, 1e-12);
  }
}

TEST(TessellateCylinder, ClosedOutwardWithinTolerance) {
  const double tolerance = 1e-4;
  const Cylinder cylinder{RotatedAbout(Vec3(1.0, -1.0, 0.5), 1.1, Vec3(0.1, 0.2, 0.3)), 0.065,
                          0.02};
  const TriangleMesh mesh = TessellateCylinder(cylinder, tolerance);
  const MeshCheck check = CheckMesh(mesh);
  EXPECT_TRUE(check.bounds_volume) << check.problem;
  EXPECT_TRUE(check.outward) << check.problem;
  for (const Vec3& v : mesh.vertices) EXPECT_NEAR(SignedDistance(cylinder, v), 0.0, 1e-12);
  double deepest = 0.0;
  for (const Vec3& p : SurfaceSamples(mesh, 10, 2)) {
    const double d = SignedDistance(cylinder, p);
    EXPECT_LE(d, 1e-12);  // chords stay inside
    deepest = std::min(deepest, d);
  }
  EXPECT_GE(deepest, -tolerance);
  // The volume of the inscribed prism, exactly.
  const int sides = (mesh.num_triangles()) / 4;
  EXPECT_GE(sides, SidesForTolerance(cylinder.radius, tolerance));
  const double prism = 0.5 * sides * cylinder.radius * cylinder.radius *
                       std::sin(2.0 * kPi / sides) * cylinder.length;
  EXPECT_NEAR(SignedVolume(mesh), prism, 1e-12);
  const double exact = kPi * cylinder.radius * cylinder.radius * cylinder.length;
  EXPECT_NEAR(SignedVolume(mesh) / exact, 1.0, 2.0 * tolerance / cylinder.radius);
}

TEST(TessellateSphere, ClosedOutwardWithinTolerance) {
  const double tolerance = 2e-4;
  const Sphere sphere{Vec3(0.1, -0.2, 0.3), 0.05};
  const TriangleMesh mesh = TessellateSphere(sphere, tolerance);
  const MeshCheck check = CheckMesh(mesh);
  EXPECT_TRUE(check.bounds_volume) << check.problem;
  EXPECT_TRUE(check.outward) << check.problem;
  for (const Vec3& v : mesh.vertices) EXPECT_NEAR(SignedDistance(sphere, v), 0.0, 1e-12);
  double deepest = 0.0;
  for (const Vec3& p : SurfaceSamples(mesh, 10, 3)) {
    const double d = SignedDistance(sphere, p);
    EXPECT_LE(d, 1e-12);
    deepest = std::min(deepest, d);
  }
  EXPECT_GE(deepest, -tolerance);
  // Inscribed, so the volume is a little less than the sphere's, by at most
  // the shell of thickness `tolerance`.
  const double exact = 4.0 / 3.0 * kPi * std::pow(sphere.radius, 3);
  const double shell = exact - 4.0 / 3.0 * kPi * std::pow(sphere.radius - tolerance, 3);
  EXPECT_LT(SignedVolume(mesh), exact);
  EXPECT_GT(SignedVolume(mesh), exact - shell);
}

TEST(TriangleMesh, TransformedKeepsOrientationUnderMirroring) {
  const TriangleMesh box = TessellateBox(Box{Pose::Identity(), Vec3(1.0, 2.0, 3.0)});
  const TriangleMesh mirrored = Transformed(box, Pose::Identity(), Vec3(-1.0, 1.0, 2.0));
  EXPECT_NEAR(SignedVolume(mirrored), 12.0, 1e-12);
  const TriangleMesh moved = Transformed(box, RotatedAbout(Vec3::UnitY(), 0.3, Vec3(5, 0, 0)));
  EXPECT_NEAR(SignedVolume(moved), 6.0, 1e-12);
  const AxisAlignedBox bounds = BoundingBox(moved);
  EXPECT_NEAR(0.5 * (bounds.min + bounds.max).x(), 5.0, 1e-12);
  const TriangleMesh both = Concatenated({box, moved});
  EXPECT_EQ(both.num_triangles(), 24);
  EXPECT_NEAR(SignedVolume(both), 12.0, 1e-12);
}

}  // namespace
}  // namespace quadhand::geometry
