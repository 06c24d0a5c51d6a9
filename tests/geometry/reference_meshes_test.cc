// The committed reference robot meshes (meshes/quadhand, made by
// quadhand-meshgen) against robot.md. The primitives below are transcribed
// from robot.md independently of the generator, and the volumes are computed
// by exact line-primitive intersections, not from any mesh.
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "quadhand/core/file_util.h"
#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/primitives.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::geometry {
namespace {

constexpr double kPi = 3.14159265358979323846;
// robot.md: curved surfaces within 0.2 mm of the true primitives.
constexpr double kRobotMdTolerance = 2e-4;
// Binary STL stores 32-bit floats: about 1e-8 m at these sizes.
constexpr double kFloatSlack = 1e-7;

const std::string kMeshDir = std::string(QUADHAND_SOURCE_DIR) + "/meshes/quadhand/";

// A primitive as robot.md describes it: a box (centre, full size, yaw about
// z) or a cylinder (centre, unit axis, radius, full length).
struct ReferencePrimitive {
  bool is_box = true;
  Vec3 centre = Vec3::Zero();
  Vec3 size = Vec3::Zero();
  double yaw = 0.0;
  Vec3 axis = Vec3::UnitZ();
  double radius = 0.0, length = 0.0;

  Pose pose() const {
    Mat3 rotation = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
    if (!is_box) rotation = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), axis).toRotationMatrix();
    return MakePose(centre, rotation);
  }
  double SignedDistanceTo(const Vec3& p) const {
    if (is_box) return SignedDistance(Box{pose(), size}, p);
    return SignedDistance(Cylinder{pose(), radius, length}, p);
  }

  // The parameter interval [t0, t1] where the line origin + t * direction is
  // inside the primitive; empty (t0 > t1) if it misses.
  std::pair<double, double> LineInterval(const Vec3& origin, const Vec3& direction) const {
    const Pose inverse = pose().inverse();
    const Vec3 o = inverse * origin;
    const Vec3 d = inverse.linear() * direction;
    double t0 = -1e300, t1 = 1e300;
    auto clip_slab = [&](double o_a, double d_a, double half) {
      if (std::abs(d_a) < 1e-15) {
        if (std::abs(o_a) > half) t0 = 1.0, t1 = 0.0;
        return;
      }
      double a = (-half - o_a) / d_a, b = (half - o_a) / d_a;
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a);
      t1 = std::min(t1, b);
    };
    if (is_box) {
      for (int axis_index = 0; axis_index < 3; ++axis_index) {
        clip_slab(o[axis_index], d[axis_index], 0.5 * size[axis_index]);
      }
      return {t0, t1};
    }
    clip_slab(o.z(), d.z(), 0.5 * length);
    // |o_xy + t d_xy|^2 <= r^2.
    const double a = d.head<2>().squaredNorm();
    const double b = 2.0 * o.head<2>().dot(d.head<2>());
    const double c = o.head<2>().squaredNorm() - radius * radius;
    if (a < 1e-15) {
      if (c > 0.0) t0 = 1.0, t1 = 0.0;
      return {t0, t1};
    }
    const double discriminant = b * b - 4.0 * a * c;
    if (discriminant < 0.0) return {1.0, 0.0};
    const double root = std::sqrt(discriminant);
    t0 = std::max(t0, (-b - root) / (2.0 * a));
    t1 = std::min(t1, (-b + root) / (2.0 * a));
    return {t0, t1};
  }
};

ReferencePrimitive BoxBetween(const Vec3& min, const Vec3& max) {
  ReferencePrimitive box;
  box.centre = 0.5 * (min + max);
  box.size = max - min;
  return box;
}

ReferencePrimitive CentredBox(const Vec3& size, double yaw) {
  ReferencePrimitive box;
  box.size = size;
  box.yaw = yaw;
  return box;
}

ReferencePrimitive CylinderAt(const Vec3& centre, const Vec3& axis, double radius, double length) {
  ReferencePrimitive cylinder;
  cylinder.is_box = false;
  cylinder.centre = centre;
  cylinder.axis = axis;
  cylinder.radius = radius;
  cylinder.length = length;
  return cylinder;
}

struct ReferenceLink {
  std::string name;
  std::vector<ReferencePrimitive> primitives;
  Vec3 bbox_min, bbox_max;  // of the true solid, from robot.md's numbers
};

std::vector<ReferenceLink> ReferenceLinks() {
  std::vector<ReferenceLink> links;
  {
    ReferenceLink base{"base_link", {}, Vec3(-0.1817, -0.1817, -0.025), Vec3(0.1817, 0.1817, 0.035)};
    base.primitives.push_back(CentredBox(Vec3(0.18, 0.12, 0.05), 0.0));
    base.primitives.push_back(CentredBox(Vec3(0.33, 0.025, 0.015), kPi / 4.0));
    base.primitives.push_back(CentredBox(Vec3(0.33, 0.025, 0.015), -kPi / 4.0));
    for (const double x : {0.1167, -0.1167}) {
      for (const double y : {0.1167, -0.1167}) {
        base.primitives.push_back(CylinderAt(Vec3(x, y, 0.025), Vec3::UnitZ(), 0.065, 0.02));
      }
    }
    links.push_back(base);
  }
  links.push_back({"battery",
                   {BoxBetween(Vec3(-0.15, -0.025, -0.018), Vec3(-0.02, 0.025, 0.018))},
                   Vec3(-0.15, -0.025, -0.018),
                   Vec3(-0.02, 0.025, 0.018)});
  links.push_back({"link1",
                   {BoxBetween(Vec3(0.0, -0.015, -0.015), Vec3(0.20, 0.015, 0.015)),
                    CylinderAt(Vec3::Zero(), Vec3::UnitY(), 0.02, 0.05)},
                   Vec3(-0.02, -0.025, -0.02),
                   Vec3(0.20, 0.025, 0.02)});
  links.push_back({"link2",
                   {BoxBetween(Vec3(0.0, -0.0125, -0.0125), Vec3(0.16, 0.0125, 0.0125)),
                    CylinderAt(Vec3::Zero(), Vec3::UnitY(), 0.017, 0.04)},
                   Vec3(-0.017, -0.02, -0.017),
                   Vec3(0.16, 0.02, 0.017)});
  links.push_back({"link3",
                   {BoxBetween(Vec3(0.0, -0.095, -0.015), Vec3(0.03, 0.095, 0.015)),
                    BoxBetween(Vec3(0.03, 0.075, -0.01), Vec3(0.11, 0.085, 0.01)),
                    BoxBetween(Vec3(0.03, -0.085, -0.01), Vec3(0.11, -0.075, 0.01))},
                   Vec3(0.0, -0.095, -0.015),
                   Vec3(0.11, 0.095, 0.015)});
  return links;
}

// Volume of the union: for a fine grid of vertical lines, the exact length of
// the union of the line's intervals through the primitives (midpoint rule
// across lines, exact along them).
double UnionVolume(const ReferenceLink& link, double spacing) {
  double volume = 0.0;
  const Vec3 up = Vec3::UnitZ();
  for (double x = link.bbox_min.x() + 0.5 * spacing; x < link.bbox_max.x(); x += spacing) {
    for (double y = link.bbox_min.y() + 0.5 * spacing; y < link.bbox_max.y(); y += spacing) {
      std::vector<std::pair<double, double>> intervals;
      for (const ReferencePrimitive& primitive : link.primitives) {
        const auto interval = primitive.LineInterval(Vec3(x, y, 0.0), up);
        if (interval.first < interval.second) intervals.push_back(interval);
      }
      std::sort(intervals.begin(), intervals.end());
      double covered_until = -1e300, length = 0.0;
      for (const auto& [start, end] : intervals) {
        const double from = std::max(start, covered_until);
        if (end > from) length += end - from;
        covered_until = std::max(covered_until, end);
      }
      volume += length;
    }
  }
  return volume * spacing * spacing;
}

double UnionSignedDistanceBound(const ReferenceLink& link, const Vec3& p) {
  double distance = 1e300;
  for (const ReferencePrimitive& primitive : link.primitives) {
    distance = std::min(distance, primitive.SignedDistanceTo(p));
  }
  return distance;
}

class ReferenceMesh : public ::testing::TestWithParam<int> {
 protected:
  ReferenceLink link() const { return ReferenceLinks()[GetParam()]; }
};

TEST_P(ReferenceMesh, IsClosedOutwardAndFreeOfSelfIntersections) {
  const auto mesh = ReadMesh(kMeshDir + link().name + ".stl");
  ASSERT_TRUE(mesh.ok()) << mesh.status().message();
  const MeshCheck check = CheckMesh(*mesh);
  EXPECT_TRUE(check.closed) << check.problem;
  EXPECT_FALSE(check.self_intersecting) << check.problem;
  EXPECT_TRUE(check.bounds_volume) << check.problem;
  EXPECT_TRUE(check.outward) << check.problem;
}

TEST_P(ReferenceMesh, BoundingBoxMatchesRobotMd) {
  const auto mesh = ReadMesh(kMeshDir + link().name + ".stl");
  ASSERT_TRUE(mesh.ok()) << mesh.status().message();
  const AxisAlignedBox box = BoundingBox(*mesh);
  for (int axis = 0; axis < 3; ++axis) {
    // Inscribed tessellation: never outside the true box, and within tolerance of it.
    EXPECT_GE(box.min[axis], link().bbox_min[axis] - kFloatSlack) << link().name << " " << axis;
    EXPECT_LE(box.min[axis], link().bbox_min[axis] + kRobotMdTolerance) << link().name << " " << axis;
    EXPECT_LE(box.max[axis], link().bbox_max[axis] + kFloatSlack) << link().name << " " << axis;
    EXPECT_GE(box.max[axis], link().bbox_max[axis] - kRobotMdTolerance) << link().name << " " << axis;
  }
}

TEST_P(ReferenceMesh, SurfaceLiesWithinToleranceOfThePrimitives) {
  // Every point of the mesh surface is inside or on the true solid (the
  // tessellation is inscribed) and at most the tolerance deep: it lies on, or
  // outside, each tessellated part, and each part is within tolerance of its primitive.
  const auto mesh = ReadMesh(kMeshDir + link().name + ".stl");
  ASSERT_TRUE(mesh.ok()) << mesh.status().message();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  double highest = -1e300, deepest = 1e300;
  for (const Eigen::Vector3i& t : mesh->triangles) {
    const Vec3 &a = mesh->vertices[t[0]], &b = mesh->vertices[t[1]], &c = mesh->vertices[t[2]];
    for (int s = 0; s < 8; ++s) {
      double u = uniform(rng), v = uniform(rng);
      if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
      const double d = UnionSignedDistanceBound(link(), a + u * (b - a) + v * (c - a));
      highest = std::max(highest, d);
      deepest = std::min(deepest, d);
    }
  }
  EXPECT_LE(highest, kFloatSlack) << link().name;
  EXPECT_GE(deepest, -kRobotMdTolerance) << link().name;
}

TEST_P(ReferenceMesh, VolumeMatchesTheUnionOfPrimitives) {
  const auto mesh = ReadMesh(kMeshDir + link().name + ".stl");
  ASSERT_TRUE(mesh.ok()) << mesh.status().message();
  const double exact = UnionVolume(link(), 5e-4);
  const double meshed = SignedVolume(*mesh);
  // An inscribed tessellation loses a little volume on curved parts (about
  // 0.2 % of a rotor guard at 0.1 mm; 0.1-0.2 % of the links here); the grid
  // of lines adds its own few 0.01 %.
  EXPECT_NEAR(meshed / exact, 1.0, 0.005) << link().name << ": mesh " << meshed << " m3, exact "
                                         << exact << " m3";
}

TEST_P(ReferenceMesh, IsNamedInTheUrdf) {
  const auto urdf = core::ReadFileToString(kMeshDir + "quadhand.urdf");
  ASSERT_TRUE(urdf.ok()) << urdf.status().message();
  EXPECT_NE(urdf->find("<link name=\"" + link().name + "\">"), std::string::npos);
  EXPECT_NE(urdf->find("<mesh filename=\"" + link().name + ".stl\"/>"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Links, ReferenceMesh, ::testing::Range(0, 5),
                         [](const ::testing::TestParamInfo<int>& param_info) {
                           return ReferenceLinks()[param_info.param].name;
                         });

TEST(ReferenceUnionVolume, AgreesWithClosedFormsOnSimpleLinks) {
  // The line-intersection volume itself, on links whose volume is known in closed form.
  const std::vector<ReferenceLink> links = ReferenceLinks();
  EXPECT_NEAR(UnionVolume(links[1], 5e-4), 0.13 * 0.05 * 0.036, 1e-9);  // battery
  EXPECT_NEAR(UnionVolume(links[4], 5e-4), 0.03 * 0.19 * 0.03 + 2 * 0.08 * 0.01 * 0.02, 1e-8);
  ReferenceLink hub_only{"hub", {CylinderAt(Vec3::Zero(), Vec3::UnitY(), 0.02, 0.05)},
                         Vec3(-0.02, -0.025, -0.02), Vec3(0.02, 0.025, 0.02)};
  EXPECT_NEAR(UnionVolume(hub_only, 5e-4) / (kPi * 0.02 * 0.02 * 0.05), 1.0, 1e-3);
}

}  // namespace
}  // namespace quadhand::geometry
