#include "quadhand/geometry/sdf_grid.h"

#include "quadhand/core/hash.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

namespace quadhand::geometry {
namespace {

// A grid sampling `f` on [origin, origin + (dims-1) * h].
template <typename F>
SdfGrid SampleGrid(const F& f, const Vec3& origin, double h, const Eigen::Vector3i& dims) {
  SdfGridInfo info;
  info.link_name = "test_link";
  info.frame = "test_link";
  info.source = "analytic";
  info.resolution = h;
  info.origin = origin;
  info.dims = dims;
  info.geometry_min = origin + Vec3::Constant(0.1);
  info.geometry_max = info.GridMax() - Vec3::Constant(0.1);
  std::vector<float> values;
  values.reserve(info.NumNodes());
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i) values.push_back(static_cast<float>(f(origin + h * Vec3(i, j, k))));
  return SdfGrid(info, values);
}

SdfGrid SphereGrid(double h) {
  return SampleGrid([](const Vec3& p) { return p.norm() - 0.1; }, Vec3::Constant(-0.25), h,
                    Eigen::Vector3i::Constant(static_cast<int>(std::round(0.5 / h)) + 1));
}

TEST(SdfGridTest, ReproducesAffineFunctionsExactly) {
  const Vec3 a(0.3, -0.7, 0.2);
  const SdfGrid grid = SampleGrid([&](const Vec3& p) { return a.dot(p) + 0.05; }, Vec3(-0.1, -0.2, 0.0),
                                  0.01, Eigen::Vector3i(21, 31, 11));
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int n = 0; n < 200; ++n) {
    const Vec3 p(-0.1 + 0.2 * u(rng), -0.2 + 0.3 * u(rng), 0.1 * u(rng));
    double d = 0;
    Vec3 g;
    ASSERT_TRUE(grid.Evaluate(p, &d, &g));
    EXPECT_NEAR(d, a.dot(p) + 0.05, 1e-6);  // float storage
    EXPECT_LT((g - a).norm(), 1e-5);
  }
}

TEST(SdfGridTest, GradientIsTheDerivativeOfTheInterpolant) {
  const SdfGrid grid = SphereGrid(0.01);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  const double step = 1e-7;
  for (int n = 0; n < 300; ++n) {
    const Vec3 p(u(rng), u(rng), u(rng));
    double d = 0;
    Vec3 g;
    ASSERT_TRUE(grid.Evaluate(p, &d, &g));
    Vec3 numeric;
    for (int axis = 0; axis < 3; ++axis) {
      double dp = 0, dm = 0;
      grid.Evaluate(p + step * Vec3::Unit(axis), &dp, nullptr);
      grid.Evaluate(p - step * Vec3::Unit(axis), &dm, nullptr);
      numeric[axis] = (dp - dm) / (2 * step);
    }
    // Central differences are exact for the (piecewise multilinear) interpolant
    // except within `step` of a cell face, where the one-sided slopes differ.
    const Vec3 cell = (p - grid.info().origin) / grid.info().resolution;
    const Vec3 frac = cell - cell.array().floor().matrix();
    if ((frac.array() < 1e-4).any() || (frac.array() > 1 - 1e-4).any()) continue;
    EXPECT_LT((numeric - g).norm(), 1e-6 * std::max(1.0, g.norm())) << "at " << p.transpose();
  }
}

TEST(SdfGridTest, SphereInterpolationErrorShrinksQuadratically) {
  // Away from the centre the field is smooth, so the error is O(h^2 / r).
  double previous_error = 0;
  for (double h : {0.01, 0.005}) {
    const SdfGrid grid = SphereGrid(h);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1, 1);
    double max_error = 0;
    for (int n = 0; n < 2000; ++n) {
      Vec3 dir(u(rng), u(rng), u(rng));
      dir.normalize();
      const double radius = 0.1 + 0.08 * (u(rng) + 1) / 2;
      double d = 0;
      ASSERT_TRUE(grid.Evaluate(radius * dir, &d, nullptr));
      max_error = std::max(max_error, std::abs(d - (radius - 0.1)));
    }
    EXPECT_LT(max_error, h * h / (8 * 0.1) * 3 + 1e-6);
    if (previous_error > 0) {
      EXPECT_LT(max_error, previous_error / 2.5);
    }
    previous_error = max_error;
  }
}

TEST(SdfGridTest, OutsideTheGridReturnsALowerBoundWithoutReadingOutOfBounds) {
  const SdfGrid grid = SphereGrid(0.01);
  const SdfGridInfo& info = grid.info();
  for (const Vec3& p : {Vec3(1.0, 0, 0), Vec3(-0.3, 0.3, 0.0), Vec3(0, 0, -5), Vec3(0.25, 0.0, 0.0)}) {
    double d = 0;
    Vec3 g;
    EXPECT_FALSE(grid.Evaluate(p, &d, &g));
    const Vec3 closest = p.cwiseMax(info.geometry_min).cwiseMin(info.geometry_max);
    EXPECT_NEAR(d, (p - closest).norm(), 1e-12);
    EXPECT_LE(d, p.norm() - 0.1 + 1e-9);  // below the true sphere distance
    EXPECT_NEAR(g.norm(), 1.0, 1e-12);
  }
  double d = 0;
  Vec3 g;
  EXPECT_FALSE(grid.Evaluate(Vec3(std::nan(""), 0, 0), &d, &g));
  EXPECT_FALSE(grid.Evaluate(Vec3(1e300, -1e300, 0), &d, &g));
  EXPECT_TRUE(std::isfinite(d));
}

// EvaluateBelow gives Evaluate's numbers bit for bit whenever it evaluates,
// and skips a point only when its distance is >= the cutoff; on a grid whose
// dimensions are not multiples of the block size (a short last block) and
// with points near every face, inside and outside the grid.
TEST(SdfGridTest, EvaluateBelowSkipsOnlyPointsAtOrBeyondTheCutoff) {
  const SdfGrid grid = SampleGrid([](const Vec3& p) { return (p - Vec3(0.02, -0.01, 0.03)).norm() - 0.05; },
                                  Vec3(-0.13, -0.11, -0.09), 0.01, Eigen::Vector3i(27, 23, 30));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.16, 0.23);
  int skipped = 0, evaluated = 0;
  for (int n = 0; n < 20000; ++n) {
    const Vec3 p(u(rng), u(rng), u(rng));
    for (double cutoff : {-0.02, 0.0, 0.03, 0.08}) {
      double d = 0, d_below = -1;
      Vec3 g, g_below = Vec3::Constant(-1);
      const bool inside = grid.Evaluate(p, &d, &g);
      if (grid.EvaluateBelow(p, cutoff, &d_below, &g_below)) {
        ++evaluated;
        EXPECT_EQ(d_below, d);
        EXPECT_EQ(g_below, g);
      } else {
        ++skipped;
        EXPECT_TRUE(inside);  // outside the grid the cheap box distance is always returned
        EXPECT_GE(d, cutoff) << "skipped a point at distance " << d << " below the cutoff " << cutoff;
        EXPECT_EQ(d_below, -1.0);  // untouched
      }
    }
  }
  // Both branches are exercised.
  EXPECT_GT(skipped, 10000);
  EXPECT_GT(evaluated, 10000);
  // A point right at a block face whose neighbouring block holds the minimum.
  const SdfGrid ramp = SampleGrid([](const Vec3& p) { return p.x(); }, Vec3::Zero(), 0.01, Eigen::Vector3i(9, 5, 5));
  double d = 0;
  Vec3 g;
  ASSERT_TRUE(ramp.EvaluateBelow(Vec3(0.0401, 0.02, 0.02), 0.0405, &d, &g));
  EXPECT_NEAR(d, 0.0401, 1e-6);
  EXPECT_FALSE(ramp.EvaluateBelow(Vec3(0.0401, 0.02, 0.02), 0.039, &d, &g));
  // Decreasing: the minimum of block 0 is its upper face node (x = 0.04).
  const SdfGrid down = SampleGrid([](const Vec3& p) { return -p.x(); }, Vec3::Zero(), 0.01, Eigen::Vector3i(9, 5, 5));
  ASSERT_TRUE(down.EvaluateBelow(Vec3(0.0399, 0.02, 0.02), -0.0395, &d, &g));
  EXPECT_NEAR(d, -0.0399, 1e-6);
  EXPECT_GT(grid.MemoryBytes(), grid.values().size() * sizeof(float));
}

TEST(SdfGridTest, SerializationRoundTrips) {
  const SdfGrid grid = SphereGrid(0.02);
  auto loaded = SdfGrid::Deserialize(grid.Serialize(), "mem");
  ASSERT_TRUE(loaded.ok()) << loaded.status().message();
  EXPECT_EQ(loaded->info().link_name, "test_link");
  EXPECT_EQ(loaded->info().frame, "test_link");
  EXPECT_EQ(loaded->info().source, "analytic");
  EXPECT_EQ(loaded->info().dims, grid.info().dims);
  EXPECT_EQ(loaded->info().resolution, grid.info().resolution);
  EXPECT_EQ(loaded->info().origin, grid.info().origin);
  EXPECT_TRUE(loaded->info().is_signed);
  EXPECT_EQ(loaded->values(), grid.values());
}

TEST(SdfGridTest, RejectsTruncatedCorruptedAndForeignFiles) {
  const std::string bytes = SphereGrid(0.02).Serialize();
  auto expect_error = [](const std::string& data, const std::string& fragment) {
    auto result = SdfGrid::Deserialize(data, "file.qhsdf");
    ASSERT_FALSE(result.ok());
    EXPECT_NE(result.status().message().find("file.qhsdf"), std::string::npos);
    EXPECT_NE(result.status().message().find(fragment), std::string::npos) << result.status().message();
  };
  expect_error(bytes.substr(0, bytes.size() - 1), "truncated");
  expect_error(bytes.substr(0, 30), "truncated");
  expect_error(bytes + "x", "trailing bytes");
  expect_error("", "magic");
  expect_error("solid ascii stl\n", "magic");
  std::string corrupted = bytes;
  corrupted[bytes.size() / 2] ^= 0x40;
  expect_error(corrupted, "checksum");
  std::string other_version = bytes;
  const uint32_t version = 3;
  std::memcpy(&other_version[8], &version, sizeof(version));
  expect_error(other_version, "format version 3");
}

TEST(SdfGridTest, ReadsVersionOneFilesWithTheirByteWiseChecksum) {
  const SdfGrid grid = SphereGrid(0.02);
  std::string old_bytes = grid.Serialize();
  const uint32_t version = 1;
  std::memcpy(&old_bytes[8], &version, sizeof(version));
  const uint64_t checksum = core::Fnv1a64(old_bytes.data(), old_bytes.size() - sizeof(uint64_t));
  std::memcpy(&old_bytes[old_bytes.size() - sizeof(uint64_t)], &checksum, sizeof(checksum));
  auto loaded = SdfGrid::Deserialize(old_bytes, "old.qhsdf");
  ASSERT_TRUE(loaded.ok()) << loaded.status().message();
  EXPECT_EQ(loaded->values(), grid.values());
  // A version-1 file with the new checksum is corrupted, not new.
  std::string mixed = grid.Serialize();
  std::memcpy(&mixed[8], &version, sizeof(version));
  auto refused = SdfGrid::Deserialize(mixed, "mixed.qhsdf");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("checksum"), std::string::npos);
}

TEST(SdfGridTest, LoadReportsMissingFile) {
  auto result = SdfGrid::Load("/nonexistent/dir/link.qhsdf");
  ASSERT_FALSE(result.ok());
  EXPECT_NE(result.status().message().find("/nonexistent/dir/link.qhsdf"), std::string::npos);
}

}  // namespace
}  // namespace quadhand::geometry
