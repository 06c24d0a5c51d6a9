// MeshDistanceQuery and GenerateSdf against the exact distances of primitives.
#include "quadhand/geometry/mesh_to_sdf.h"

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "quadhand/geometry/mesh_distance.h"
#include "quadhand/geometry/primitives.h"

namespace quadhand::geometry {
namespace {

constexpr double kTessellationTolerance = 1e-4;

struct Shape {
  std::string name;
  TriangleMesh mesh;
  std::function<double(const Vec3&)> exact;  // signed distance to the true primitive
  double tolerance;                          // how far the mesh is from the primitive
};

std::vector<Shape> TestShapes() {
  const Pose tilted = MakePose(Vec3(0.01, -0.02, 0.03),
                               Eigen::AngleAxisd(0.5, Vec3(1.0, 2.0, 3.0).normalized())
                                   .toRotationMatrix());
  const Box box{tilted, Vec3(0.2, 0.1, 0.06)};
  const Cylinder cylinder{tilted, 0.05, 0.1};
  const Sphere sphere{Vec3(0.01, 0.0, -0.01), 0.05};
  return {
      {"box", TessellateBox(box), [box](const Vec3& p) { return SignedDistance(box, p); }, 0.0},
      {"cylinder", TessellateCylinder(cylinder, kTessellationTolerance),
       [cylinder](const Vec3& p) { return SignedDistance(cylinder, p); }, kTessellationTolerance},
      {"sphere", TessellateSphere(sphere, kTessellationTolerance),
       [sphere](const Vec3& p) { return SignedDistance(sphere, p); }, kTessellationTolerance},
  };
}

SdfGenerationOptions CoarseOptions() {
  SdfGenerationOptions options;
  options.resolution = 0.008;
  options.padding = 0.016;
  options.num_threads = 2;
  return options;
}

Vec3 NodePosition(const SdfGridInfo& info, int i, int j, int k) {
  return info.origin + info.resolution * Vec3(i, j, k);
}

TEST(MeshDistanceQuery, MatchesExactBoxDistances) {
  const Box box{Pose::Identity(), Vec3(0.2, 0.1, 0.06)};
  auto query = MeshDistanceQuery::Create(TessellateBox(box), /*is_signed=*/true);
  ASSERT_TRUE(query.ok()) << query.status().message();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coordinate(-0.2, 0.2);
  for (int n = 0; n < 500; ++n) {
    const Vec3 p(coordinate(rng), coordinate(rng), coordinate(rng));
    const double exact = SignedDistance(box, p);
    EXPECT_NEAR((*query)->SignedDistance(p), exact, 1e-12);
    EXPECT_EQ((*query)->IsInside(p), exact < 0.0);
    Vec3 closest;
    const double unsigned_distance = (*query)->UnsignedDistance(p, &closest);
    EXPECT_NEAR(unsigned_distance, std::abs(exact), 1e-12);
    EXPECT_NEAR((p - closest).norm(), unsigned_distance, 1e-12);
    // Any hint gives the same answer, only faster when it is close.
    Vec3 closest_with_hint;
    EXPECT_NEAR((*query)->UnsignedDistanceWithHint(p, Vec3(0.1, 0.05, 0.03), &closest_with_hint),
                unsigned_distance, 1e-12);
  }
}

// CGAL's exact predicates abort the process on an infinite or NaN
// coordinate: such a point has no distance, and nothing crashes.
TEST(MeshDistanceQuery, ANonFinitePointHasNoDistance) {
  const Box box{Pose::Identity(), Vec3(0.2, 0.1, 0.06)};
  auto query = MeshDistanceQuery::Create(TessellateBox(box), /*is_signed=*/true);
  ASSERT_TRUE(query.ok()) << query.status().message();
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  for (const Vec3& p : {Vec3(inf, 0, 0), Vec3(0, -inf, 0), Vec3(0, 0, nan), Vec3(Vec3(1e300, 1e300, 1e300) * 1e10)}) {
    Vec3 closest;
    EXPECT_TRUE(std::isnan((*query)->UnsignedDistance(p, &closest)));
    EXPECT_TRUE(closest.array().isNaN().all());
    EXPECT_TRUE(std::isnan((*query)->SignedDistance(p)));
    EXPECT_FALSE((*query)->IsInside(p));
    EXPECT_TRUE(std::isnan((*query)->UnsignedDistanceWithHint(p, Vec3::Zero(), &closest)));
  }
  // A finite point with a non-finite hint is answered without the hint.
  Vec3 closest;
  EXPECT_NEAR((*query)->UnsignedDistanceWithHint(Vec3(0.3, 0, 0), Vec3(nan, 0, 0), &closest),
              SignedDistance(box, Vec3(0.3, 0, 0)), 1e-12);
}

TEST(MeshDistanceQuery, ConcurrentQueriesAgreeWithSerialOnes) {
  const Sphere sphere{Vec3::Zero(), 0.05};
  auto query = MeshDistanceQuery::Create(TessellateSphere(sphere, 1e-3), true);
  ASSERT_TRUE(query.ok());
  std::vector<Vec3> points;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> coordinate(-0.08, 0.08);
  for (int n = 0; n < 4000; ++n) points.emplace_back(coordinate(rng), coordinate(rng), coordinate(rng));
  std::vector<double> serial;
  for (const Vec3& p : points) serial.push_back((*query)->SignedDistance(p));
  // A fresh query object, so that nothing was built lazily by the serial pass.
  auto fresh = MeshDistanceQuery::Create(TessellateSphere(sphere, 1e-3), true);
  ASSERT_TRUE(fresh.ok());
  std::vector<double> parallel(points.size());
  std::vector<std::thread> threads;
  constexpr int kThreads = 4;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (size_t n = t; n < points.size(); n += kThreads) {
        parallel[n] = (*fresh)->SignedDistance(points[n]);
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(parallel, serial);
}

TEST(MeshDistanceQuery, SignedNeedsAClosedMeshUnsignedDoesNot) {
  TriangleMesh open = TessellateBox(Box{});
  open.triangles.pop_back();
  EXPECT_FALSE(MeshDistanceQuery::Create(open, true).ok());
  auto unsigned_query = MeshDistanceQuery::Create(open, false);
  ASSERT_TRUE(unsigned_query.ok());
  EXPECT_FALSE((*unsigned_query)->is_signed());
  EXPECT_FALSE((*unsigned_query)->IsInside(Vec3::Zero()));
  EXPECT_NEAR((*unsigned_query)->SignedDistance(Vec3(0.1, 0.0, 0.0)), 0.4, 1e-12);
  EXPECT_FALSE(MeshDistanceQuery::Create(TriangleMesh{}, false).ok());
}

TEST(GenerateSdf, GridLayoutFollowsTheBoundingBox) {
  const Shape shape = TestShapes()[0];
  const SdfGenerationOptions options = CoarseOptions();
  const auto grid = GenerateSdf(shape.mesh, "test_link", "box.stl", options);
  ASSERT_TRUE(grid.ok()) << grid.status().message();
  const SdfGridInfo& info = grid->info();
  const AxisAlignedBox box = BoundingBox(shape.mesh);
  EXPECT_EQ(info.link_name, "test_link");
  EXPECT_EQ(info.frame, "test_link");
  EXPECT_EQ(info.source, "box.stl");
  EXPECT_TRUE(info.is_signed);
  EXPECT_EQ(info.resolution, options.resolution);
  EXPECT_TRUE(info.geometry_min.isApprox(box.min));
  EXPECT_TRUE(info.geometry_max.isApprox(box.max));
  EXPECT_TRUE(info.origin.isApprox(box.min - Vec3::Constant(options.padding)));
  for (int axis = 0; axis < 3; ++axis) {
    const double extent = box.size()[axis] + 2.0 * options.padding;
    EXPECT_EQ(info.dims[axis], static_cast<int>(std::ceil(extent / options.resolution)) + 1);
    // The grid covers the padded box.
    EXPECT_GE(info.GridMax()[axis], box.max[axis] + options.padding - 1e-12);
  }
  EXPECT_EQ(static_cast<long>(grid->values().size()), info.NumNodes());
}

TEST(GenerateSdf, NodesAreExactDistancesToThePrimitives) {
  for (const Shape& shape : TestShapes()) {
    const auto grid = GenerateSdf(shape.mesh, shape.name, "test", CoarseOptions());
    ASSERT_TRUE(grid.ok()) << shape.name << ": " << grid.status().message();
    const SdfGridInfo& info = grid->info();
    double max_error = 0.0;
    int inside_nodes = 0;
    for (int k = 0; k < info.dims.z(); ++k) {
      for (int j = 0; j < info.dims.y(); ++j) {
        for (int i = 0; i < info.dims.x(); ++i) {
          const double exact = shape.exact(NodePosition(info, i, j, k));
          const double value = grid->NodeValue(i, j, k);
          max_error = std::max(max_error, std::abs(value - exact));
          // The sign is right wherever the surface is farther than the mesh deviation.
          if (std::abs(exact) > std::max(shape.tolerance, 1e-9)) {
            EXPECT_EQ(value < 0.0, exact < 0.0);
          }
          if (value < 0.0) ++inside_nodes;
        }
      }
    }
    // Exact point-triangle distances, stored as floats; the mesh itself lies
    // within `tolerance` of the primitive.
    EXPECT_LE(max_error, shape.tolerance + 1e-6) << shape.name;
    EXPECT_GT(inside_nodes, 100) << shape.name;
  }
}

TEST(GenerateSdf, InterpolatedValuesAreCloseToExactDistances) {
  // Trilinear interpolation reproduces planes exactly; its error comes from
  // the curvature of the field outside edges and corners (about 0.26 h at
  // worst, next to a box corner, falling as h^2 / d away from the surface) and
  // from the kinks of the medial axis inside: midway between two opposite
  // faces the field is |z| - c, whose interpolation is off by up to h / 2.
  for (const Shape& shape : TestShapes()) {
    const SdfGenerationOptions options = CoarseOptions();
    const double h = options.resolution;
    const auto grid = GenerateSdf(shape.mesh, shape.name, "test", options);
    ASSERT_TRUE(grid.ok()) << grid.status().message();
    const SdfGridInfo& info = grid->info();
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    double max_error = 0.0, max_error_outside = 0.0, max_error_far_outside = 0.0;
    for (int n = 0; n < 20000; ++n) {
      const Vec3 p = info.origin + (info.GridMax() - info.origin)
                                       .cwiseProduct(Vec3(unit(rng), unit(rng), unit(rng)));
      double value = 0.0;
      Vec3 gradient;
      ASSERT_TRUE(grid->Evaluate(p, &value, &gradient));
      const double exact = shape.exact(p);
      const double error = std::abs(value - exact);
      max_error = std::max(max_error, error);
      if (exact > 0.0) max_error_outside = std::max(max_error_outside, error);
      if (exact > 3.0 * h) max_error_far_outside = std::max(max_error_far_outside, error);
    }
    EXPECT_LE(max_error, 0.55 * h + shape.tolerance) << shape.name;
    EXPECT_LE(max_error_outside, 0.3 * h + shape.tolerance) << shape.name;
    EXPECT_LE(max_error_far_outside, 0.1 * h + shape.tolerance) << shape.name;
    // Inside is negative.
    double centre_value = 0.0;
    const Vec3 centre = 0.5 * (info.geometry_min + info.geometry_max);
    grid->Evaluate(centre, &centre_value, nullptr);
    EXPECT_LT(centre_value, 0.0) << shape.name;
  }
}

TEST(GenerateSdf, ThreadCountDoesNotChangeTheValues) {
  const Shape shape = TestShapes()[1];
  SdfGenerationOptions options = CoarseOptions();
  options.num_threads = 1;
  const auto one = GenerateSdf(shape.mesh, "link", "test", options);
  options.num_threads = 2;
  long last_done = 0, calls = 0, reported_total = 0;
  const auto two = GenerateSdf(shape.mesh, "link", "test", options, [&](long done, long total) {
    EXPECT_GT(done, last_done);
    last_done = done;
    reported_total = total;
    ++calls;
  });
  ASSERT_TRUE(one.ok() && two.ok());
  EXPECT_EQ(one->values(), two->values());
  EXPECT_EQ(calls, two->info().dims.z());  // once per slice
  EXPECT_EQ(last_done, two->info().NumNodes());
  EXPECT_EQ(reported_total, two->info().NumNodes());
}

TEST(GenerateSdf, OpenMeshNeedsAllowUnsigned) {
  TriangleMesh open = TessellateBox(Box{Pose::Identity(), Vec3(0.1, 0.1, 0.1)});
  open.triangles.pop_back();
  SdfGenerationOptions options = CoarseOptions();
  const auto rejected = GenerateSdf(open, "open_link", "open.stl", options);
  ASSERT_FALSE(rejected.ok());
  EXPECT_EQ(rejected.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(rejected.status().message().find("open_link"), std::string::npos);
  EXPECT_NE(rejected.status().message().find("not closed"), std::string::npos)
      << rejected.status().message();

  options.allow_unsigned = true;
  const auto accepted = GenerateSdf(open, "open_link", "open.stl", options);
  ASSERT_TRUE(accepted.ok()) << accepted.status().message();
  EXPECT_FALSE(accepted->info().is_signed);
  for (const float value : accepted->values()) EXPECT_GE(value, 0.0f);
}

TEST(GenerateSdf, RejectsEmptyMeshesAndInvalidOptions) {
  const TriangleMesh box = TessellateBox(Box{Pose::Identity(), Vec3(0.1, 0.1, 0.1)});
  EXPECT_FALSE(GenerateSdf(TriangleMesh{}, "l", "s", CoarseOptions()).ok());

  std::string why;
  EXPECT_TRUE(SdfGenerationOptions{}.IsValid(&why)) << why;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  auto with = [](std::function<void(SdfGenerationOptions*)> change) {
    SdfGenerationOptions options = CoarseOptions();
    change(&options);
    return options;
  };
  const std::vector<SdfGenerationOptions> invalid = {
      with([](auto* o) { o->resolution = 0.0; }),
      with([](auto* o) { o->resolution = -0.01; }),
      with([nan](auto* o) { o->resolution = nan; }),
      with([inf](auto* o) { o->resolution = inf; }),
      with([](auto* o) { o->padding = -0.01; }),
      with([nan](auto* o) { o->padding = nan; }),
      with([](auto* o) { o->num_threads = -1; }),
      with([](auto* o) { o->resolution = 1e-5; o->padding = 0.08; }),  // ~5e12 nodes
  };
  for (const SdfGenerationOptions& options : invalid) {
    why.clear();
    EXPECT_FALSE(options.IsValid(&why));
    EXPECT_FALSE(why.empty());
    const auto grid = GenerateSdf(box, "l", "s", options);
    ASSERT_FALSE(grid.ok());
    EXPECT_EQ(grid.status().code(), core::StatusCode::kInvalidArgument);
  }
  // Valid options whose grid over this mesh would still be too large.
  const TriangleMesh large = TessellateBox(Box{Pose::Identity(), Vec3(10.0, 10.0, 10.0)});
  SdfGenerationOptions fine = CoarseOptions();
  fine.resolution = 0.001;
  ASSERT_TRUE(fine.IsValid(&why));
  const auto too_large = GenerateSdf(large, "l", "s", fine);
  ASSERT_FALSE(too_large.ok());
  EXPECT_NE(too_large.status().message().find("nodes"), std::string::npos);
}

}  // namespace
}  // namespace quadhand::geometry
