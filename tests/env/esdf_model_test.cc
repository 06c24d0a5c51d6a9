// ESDF baseline: the field against exact point-to-cloud distances, its build,
// the link wrench and the whole-body gradient against finite differences,
// surface sampling, and bad input.
#include "quadhand/env/esdf_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "quadhand/env/link_surface_samples.h"
#include "quadhand/opt/penalty.h"
#include "quadhand/robot/link_meshes.h"
#include "support/quadhand_fixture.h"

namespace quadhand::env {
namespace {

using testing::SmoothCentralDifference;

const robot::RobotModel& Robot() {
  static const robot::RobotModel robot = *robot::RobotModel::LoadFromUrdfFile(testing::QuadHandUrdfPath());
  return robot;
}

struct State {
  Vec3 position;
  Vec3 rotation_vector;
  VecX joints;
  Pose BasePose() const { return MakePose(position, ExpSO3(rotation_vector)); }
};

// A sphere (radius 0.15 at (0, 0, 1)) and a floor patch (z = 0.7), every 0.01 m.
std::vector<Vec3> SphereAndFloor() {
  std::vector<Vec3> points;
  const int rings = 48;
  for (int i = 0; i <= rings; ++i) {
    const double theta = M_PI * i / rings;
    const int around = std::max(1, static_cast<int>(std::round(2 * M_PI * 0.15 * std::sin(theta) / 0.01)));
    for (int j = 0; j < around; ++j) {
      const double phi = 2 * M_PI * j / around;
      points.emplace_back(0.15 * std::sin(theta) * std::cos(phi), 0.15 * std::sin(theta) * std::sin(phi),
                          1.0 + 0.15 * std::cos(theta));
    }
  }
  for (int i = -30; i <= 30; ++i) {
    for (int j = -30; j <= 30; ++j) points.emplace_back(0.01 * i, 0.01 * j, 0.7);
  }
  return points;
}

double ExactDistance(const std::vector<Vec3>& points, const Vec3& q) {
  double best = 1e300;
  for (const Vec3& p : points) best = std::min(best, (p - q).squaredNorm());
  return std::sqrt(best);
}

// Obstacle points scattered around the robot's links at `state`.
std::vector<Vec3> PointsAroundRobot(const State& state, int count, unsigned seed) {
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(Robot(), state.BasePose(), state.joints, &kinematics);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  std::vector<Vec3> points;
  const std::vector<int> links = Robot().CollisionLinks();
  for (int n = 0; n < count; ++n) {
    const int link = links[n % links.size()];
    points.push_back(kinematics.link_poses[link] * Vec3(0.1 + 0.6 * u(rng), u(rng), 0.3 * u(rng)));
  }
  return points;
}

TEST(LinkSurfaceSamplesTest, CoverEveryTriangleWithinTheSpacing) {
  geometry::TriangleMesh box;  // unit cube corner at the origin, two triangles per face
  for (int i = 0; i < 8; ++i) box.vertices.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    box.triangles.emplace_back(f[0], f[1], f[2]);
    box.triangles.emplace_back(f[0], f[2], f[3]);
  }
  const double spacing = 0.1;
  const LinkSurfaceSamples samples = SampleLinkSurface(box, spacing, 0.3);
  // About area / (spacing^2 sqrt(3)/2) = 693 samples, plus the rows' ends.
  EXPECT_GT(samples.points.size(), 600u);
  EXPECT_LT(samples.points.size(), 1200u);
  for (const Vec3& v : box.vertices) {
    double nearest = 1e300;
    for (const Vec3& p : samples.points) nearest = std::min(nearest, (p - v).norm());
    EXPECT_LT(nearest, 1e-12);
  }
  // Random surface points lie within `spacing` of a sample; clusters
  // partition the samples and bound them.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  for (int n = 0; n < 200; ++n) {
    Vec3 q(u(rng), u(rng), u(rng));
    q[n % 3] = (n / 3) % 2;
    double nearest = 1e300;
    for (const Vec3& p : samples.points) nearest = std::min(nearest, (p - q).norm());
    EXPECT_LE(nearest, spacing + 1e-12);
  }
  int covered = 0;
  for (const auto& cluster : samples.clusters) {
    EXPECT_EQ(cluster.begin, covered);
    for (int s = cluster.begin; s < cluster.end; ++s) {
      EXPECT_LE((samples.points[s] - cluster.center).norm(), cluster.radius + 1e-12);
    }
    covered = cluster.end;
  }
  EXPECT_EQ(covered, static_cast<int>(samples.points.size()));
}

TEST(LinkSurfaceSamplesTest, TheEstimateMatchesTheSamplesAndAMeshInMillimetresIsRefused) {
  geometry::TriangleMesh box;  // a 0.3 m cube, two triangles per face
  for (int i = 0; i < 8; ++i) box.vertices.emplace_back(0.3 * (i & 1), 0.3 * ((i >> 1) & 1), 0.3 * ((i >> 2) & 1));
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    box.triangles.emplace_back(f[0], f[1], f[2]);
    box.triangles.emplace_back(f[0], f[2], f[3]);
  }
  const double spacing = 0.01;
  const double sampled = static_cast<double>(SampleLinkSurface(box, spacing).points.size());
  EXPECT_NEAR(EstimatedSurfaceSampleCount(box, spacing), sampled, 0.15 * sampled);
  EXPECT_TRUE(CheckSurfaceSampleCount(box, spacing, "link 'small'").ok());
  // The same cube read in millimetres: 300 m, 5.4e5 m^2.
  for (Vec3& v : box.vertices) v *= 1000.0;
  const core::Status refused = CheckSurfaceSampleCount(box, spacing, "link 'mm'");
  EXPECT_EQ(refused.code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(refused.message().find("link 'mm': the collision mesh is 300 x 300 x 300 m"), std::string::npos)
      << refused.message();
  EXPECT_NE(refused.message().find("scale=\"0.001\""), std::string::npos) << refused.message();
}

TEST(EsdfModelTest, DistancesMatchExactPointDistancesWithinAVoxel) {
  const std::vector<Vec3> points = SphereAndFloor();
  EsdfOptions options;
  options.resolution = 0.02;
  options.max_distance = 0.3;
  options.box_margin = 0.2;
  auto model = EsdfModel::Create(Robot(), points, options);
  ASSERT_TRUE(model.ok()) << model.status().message();
  const EsdfModel& esdf = **model;
  EXPECT_GT(esdf.build_seconds(), 0.0);
  EXPECT_GT(esdf.edt_seconds(), 0.0);
  EXPECT_GT(esdf.num_occupied_voxels(), 1000);
  EXPECT_LE(esdf.num_occupied_voxels(), static_cast<long>(points.size()));
  // The box is the cloud's box grown by the margin: (0.6 + 0.4) x (0.6 + 0.4) x (0.45 + 0.4) m.
  EXPECT_NEAR(esdf.dims().x(), 50, 1);
  EXPECT_NEAR(esdf.dims().z(), 43, 1);

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-0.35, 0.35), uz(0.6, 1.3);
  double max_error = 0.0, sum_squares = 0.0, sum = 0.0;
  int count = 0;
  for (int n = 0; n < 3000; ++n) {
    const Vec3 q(ux(rng), ux(rng), uz(rng));
    const double exact = ExactDistance(points, q);
    if (exact > options.max_distance - 2 * options.resolution) continue;
    const double error = esdf.Distance(q) - exact;
    max_error = std::max(max_error, std::abs(error));
    sum_squares += error * error;
    sum += error;
    ++count;
  }
  ASSERT_GT(count, 1000);
  EXPECT_LE(max_error, options.resolution) << "max error over " << count << " queries";
  EXPECT_LE(std::sqrt(sum_squares / count), 0.5 * options.resolution);
  std::printf("esdf vs exact: %d queries, max error %.4f m, rmse %.4f m, mean %.4f m\n", count, max_error,
              std::sqrt(sum_squares / count), sum / count);
  // Far from everything the field is clamped; outside the box it takes the
  // nearest box value.
  EXPECT_NEAR(esdf.Distance(Vec3(0.4, 0.4, 1.5)), options.max_distance, 1e-6);
  Vec3 gradient;
  EXPECT_NEAR(esdf.Distance(Vec3(0, 0, 5), &gradient), esdf.Distance(Vec3(0, 0, esdf.max_center().z())), 1e-12);
  EXPECT_EQ(gradient.z(), 0.0);
}

TEST(EsdfModelTest, FieldGradientMatchesFiniteDifferencesInsideCells) {
  auto model = EsdfModel::Create(Robot(), SphereAndFloor());
  ASSERT_TRUE(model.ok());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  for (int n = 0; n < 200; ++n) {
    const Vec3 q(u(rng), u(rng), 1.0 + u(rng));
    Vec3 gradient;
    (*model)->Distance(q, &gradient);
    for (int axis = 0; axis < 3; ++axis) {
      // Trilinear interpolation is linear along an axis inside a cell.
      const double h = 1e-6;
      const double numeric =
          ((*model)->Distance(q + h * Vec3::Unit(axis)) - (*model)->Distance(q - h * Vec3::Unit(axis))) / (2 * h);
      const double cell = (q[axis] - (*model)->min_center()[axis]) / 0.02;
      if (std::abs(cell - std::round(cell)) < 1e-3) continue;  // on a cell face
      EXPECT_NEAR(gradient[axis], numeric, 1e-6) << q.transpose() << " axis " << axis;
    }
  }
}

TEST(EsdfModelTest, LinkWrenchMatchesFiniteDifferences) {
  const State state{Vec3(0.3, -0.2, 1.1), Vec3(0.1, -0.2, 0.3), Vec3(0.7, -0.4, 0.5)};
  auto model = EsdfModel::Create(Robot(), PointsAroundRobot(state, 600, 1));
  ASSERT_TRUE(model.ok()) << model.status().message();
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(Robot(), state.BasePose(), state.joints, &kinematics);
  const PenaltyParameters parameters{0.03, 0.01};
  int checked = 0, skipped = 0;
  for (int link : (*model)->links()) {
    const Pose X_WL = kinematics.link_poses[link];
    LinkWrench wrench;
    const double cost = (*model)->LinkPenalty(link, X_WL, parameters, {}, &wrench);
    ASSERT_GT(cost, 0.0) << "link " << link << " has no nearby points";
    EXPECT_NEAR((*model)->LinkPenalty(link, X_WL, parameters, {}, nullptr), cost, 1e-12 * cost);
    for (int axis = 0; axis < 6; ++axis) {
      auto moved = [&](double s) {
        Pose X = X_WL;
        if (axis < 3) X.translation() += s * Vec3::Unit(axis);
        else X.linear() = ExpSO3(s * Vec3::Unit(axis - 3)) * X_WL.linear();
        return (*model)->LinkPenalty(link, X, parameters, {}, nullptr);
      };
      double numeric;
      if (!SmoothCentralDifference(moved, 1e-8, &numeric)) {
        ++skipped;
        continue;
      }
      const double analytic = axis < 3 ? wrench.force[axis] : wrench.torque[axis - 3];
      EXPECT_LE(std::abs(analytic - numeric), 1e-5 * std::max(1.0, std::abs(numeric)))
          << "link " << link << " axis " << axis << " analytic " << analytic << " numeric " << numeric;
      ++checked;
    }
  }
  EXPECT_GE(checked, 25);
  EXPECT_LE(skipped, 5);
}

TEST(EsdfModelTest, WholeBodyGradientMatchesFiniteDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  const VecX lower = Robot().LowerLimits(), upper = Robot().UpperLimits();
  int checked = 0, skipped = 0;
  for (int trial = 0; trial < 3; ++trial) {
    State state{Vec3(u(rng), u(rng), 1 + u(rng)), 0.4 * Vec3(u(rng), u(rng), u(rng)), VecX(3)};
    for (int k = 0; k < 3; ++k) state.joints[k] = lower[k] + (upper[k] - lower[k]) * (0.5 + 0.45 * u(rng));
    auto model = EsdfModel::Create(Robot(), PointsAroundRobot(state, 600, trial));
    ASSERT_TRUE(model.ok());
    robot::KinematicsState kinematics;
    robot::ComputeKinematics(Robot(), state.BasePose(), state.joints, &kinematics);
    const PenaltyParameters parameters{0.03, 0.01};
    StateGradient gradient;
    gradient.SetZero(3);
    const double cost = WholeBodyPenalty(Robot(), kinematics, **model, parameters, {}, &gradient);
    ASSERT_GT(cost, 0.0);
    for (int coordinate = 0; coordinate < 9; ++coordinate) {
      auto moved = [&](double s) {
        State perturbed = state;
        Pose base = state.BasePose();
        if (coordinate < 3) base.translation() += s * Vec3::Unit(coordinate);
        else if (coordinate < 6) base.linear() = ExpSO3(s * Vec3::Unit(coordinate - 3)) * base.linear();
        else perturbed.joints[coordinate - 6] += s;
        robot::KinematicsState k;
        robot::ComputeKinematics(Robot(), base, perturbed.joints, &k);
        return WholeBodyPenalty(Robot(), k, **model, parameters, {}, nullptr);
      };
      double numeric;
      if (!SmoothCentralDifference(moved, 1e-8, &numeric)) {
        ++skipped;
        continue;
      }
      const double analytic = coordinate < 3   ? gradient.position[coordinate]
                              : coordinate < 6 ? gradient.rotation[coordinate - 3]
                                               : gradient.joints[coordinate - 6];
      EXPECT_LE(std::abs(analytic - numeric), 1e-5 * std::max(1.0, std::abs(numeric)))
          << "trial " << trial << " coordinate " << coordinate << " analytic " << analytic << " numeric " << numeric;
      ++checked;
    }
  }
  EXPECT_GE(checked, 22);
  EXPECT_LE(skipped, 5);
}

TEST(EsdfModelTest, PenaltyAndClearanceFollowTheField) {
  // One obstacle point below the battery's bottom face (z = -0.018 in its
  // frame), axis-aligned state: the clearance is the field's reading there.
  const State state{Vec3(0, 0, 1), Vec3::Zero(), VecX::Zero(3)};
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(Robot(), state.BasePose(), state.joints, &kinematics);
  const int battery = Robot().LinkIndex("battery");
  const Vec3 point = kinematics.link_poses[battery] * Vec3(-0.085, 0.0, -0.018 - 0.025);
  auto model = EsdfModel::Create(Robot(), {point});
  ASSERT_TRUE(model.ok());
  int closest = -1;
  const double clearance = WholeBodyClearance(kinematics, **model, 0.1, {}, &closest);
  EXPECT_EQ(closest, battery);
  EXPECT_NEAR(clearance, 0.025, 0.02);  // within a voxel
  EXPECT_GT(WholeBodyPenalty(Robot(), kinematics, **model, {0.03, 0.01}, {}, nullptr), 0.0);
  // Moved 20 cm away, nothing is within the threshold.
  State far = state;
  far.position.z() += 0.2;
  robot::ComputeKinematics(Robot(), far.BasePose(), far.joints, &kinematics);
  EXPECT_EQ(WholeBodyPenalty(Robot(), kinematics, **model, {0.03, 0.01}, {}, nullptr), 0.0);
  EXPECT_GT(WholeBodyClearance(kinematics, **model, 0.5, {}), 0.15);
}

TEST(EsdfModelTest, CreateRejectsBadInput) {
  const std::vector<Vec3> points{Vec3::Zero()};
  std::string why;
  EsdfOptions bad;
  bad.resolution = 0;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_FALSE(EsdfModel::Create(Robot(), points, bad).ok());
  bad = EsdfOptions();
  bad.max_distance = 0.03;  // below two voxels
  EXPECT_FALSE(bad.IsValid(&why));
  bad = EsdfOptions();
  bad.box_margin = -0.1;
  EXPECT_FALSE(bad.IsValid(&why));
  bad = EsdfOptions();
  bad.surface_spacing = std::nan("");
  EXPECT_FALSE(bad.IsValid(&why));
  bad = EsdfOptions();
  bad.max_cells = 1000;
  auto too_big = EsdfModel::Create(Robot(), {Vec3::Zero(), Vec3(1, 1, 1)}, bad);
  ASSERT_FALSE(too_big.ok());
  EXPECT_NE(too_big.status().message().find("max_cells"), std::string::npos);
  EXPECT_TRUE(EsdfOptions().IsValid(&why));
  EXPECT_FALSE(EsdfModel::Create(Robot(), {}).ok());
  EXPECT_FALSE(EsdfModel::Create(Robot(), {Vec3(std::nan(""), 0, 0)}).ok());
  EXPECT_FALSE(EsdfModel::Create({1, 2}, {geometry::TriangleMesh()}, points).ok());
}

}  // namespace
}  // namespace quadhand::env
