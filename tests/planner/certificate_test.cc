// The post-check's continuous-time certificate (docs/certificate.md): the
// motion bound against the robot's real motion, the certified clearance
// against a brute-force check at 1 ms, and a plan whose links graze an
// obstacle point between two samples (the certificate must reject it where
// the samples alone would not).
#include <gtest/gtest.h>

#include <algorithm>

#include "quadhand/planner/motion_bound.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/planner/post_check.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/link_meshes.h"
#include "support/window_cup_plan.h"

namespace quadhand::planner {
namespace {

using testing::WindowCup;

const PlanResult& DefaultPlan() { return testing::WindowCupPlan(); }

robot::KinematicsState KinematicsAt(const WholeBodyTrajectory& trajectory, double t) {
  const WholeBodySample s = trajectory.Sample(t);
  robot::KinematicsState kinematics;
  robot::ComputeKinematics(WindowCup().robot(), s.BasePose(), s.joints, &kinematics);
  return kinematics;
}

// Every collision vertex of the robot in the world frame, tagged with its link.
std::vector<std::pair<int, Vec3>> WorldVertices(const robot::KinematicsState& kinematics) {
  static const std::vector<std::pair<int, std::vector<Vec3>>> local = [] {
    std::vector<std::pair<int, std::vector<Vec3>>> out;
    for (int link : WindowCup().robot().CollisionLinks()) {
      out.emplace_back(link, robot::LinkCollisionMesh(WindowCup().robot(), link)->vertices);
    }
    return out;
  }();
  std::vector<std::pair<int, Vec3>> world;
  for (const auto& [link, vertices] : local) {
    for (const Vec3& v : vertices) world.emplace_back(link, kinematics.link_poses[link] * v);
  }
  return world;
}

// The robot's collision vertex farthest along `direction`.
Vec3 OutermostVertex(const robot::KinematicsState& kinematics, const Vec3& direction) {
  Vec3 outermost = Vec3::Zero();
  double extent = -1e9;
  for (const auto& [link, v] : WorldVertices(kinematics)) {
    if (v.dot(direction) > extent) {
      extent = v.dot(direction);
      outermost = v;
    }
  }
  return outermost;
}

// The verdict on a plan that grazes a point between two samples `step`
// apart: failed, not certified, its clearance check first and failed, the
// certified clearance no higher than the brute-force `truth` at `at`, and
// the refinement found the graze itself, near where it is.
void ExpectTheGrazeFound(const PostCheckReport& report, double truth, double at, double bound, double step) {
  EXPECT_FALSE(report.passed);
  EXPECT_FALSE(report.certified);
  EXPECT_LE(report.certified_clearance, truth);
  ASSERT_FALSE(report.checks.empty());
  EXPECT_EQ(report.checks[0].kind, CheckKind::kClearance);
  EXPECT_FALSE(report.checks[0].passed) << report.checks[0].detail;
  EXPECT_LT(report.min_clearance_exact, bound);
  EXPECT_NEAR(report.checks[0].time, at, step / 2);
}

PostCheckReport Check(const env::ExactMeshModel& exact, double dt, double clearance_dt) {
  const PlanResult& plan = DefaultPlan();
  PostCheckOptions options = DefaultPlannerOptions().post_check;
  options.dt = dt;
  options.clearance_dt = clearance_dt;
  return PostCheck(*plan.trajectory, WindowCup().robot(), WindowCup().task, plan.terminal, plan.insertion,
                   *WindowCup().model, exact, nullptr, options);
}

// The smallest exact clearance over samples every `step` seconds.
double SampledClearance(const env::ExactMeshModel& exact, double step, double* at = nullptr) {
  const WholeBodyTrajectory& trajectory = *DefaultPlan().trajectory;
  const int n = static_cast<int>(std::ceil(trajectory.duration() / step));
  double least = 1e9;
  for (int i = 0; i <= n; ++i) {
    const double t = std::min(trajectory.duration(), i * trajectory.duration() / n);
    const double d = env::WholeBodyClearance(KinematicsAt(trajectory, t), exact, 0.2, {});
    if (d < least) {
      least = d;
      if (at != nullptr) *at = t;
    }
  }
  return least;
}

TEST(MotionBoundTest, NoPointOfTheRobotMovesFasterThanTheBound) {
  const WholeBodyTrajectory& trajectory = *DefaultPlan().trajectory;
  const RobotMotionBound bound(WindowCup().robot(), *WindowCup().exact);
  double tightest = 0.0;  // the largest displacement / bound ratio seen
  for (double h : {0.01, 0.1}) {
    for (double t0 = 0.0; t0 + h <= trajectory.duration(); t0 += 0.37) {
      const PointSpeedBound speed = bound.Over(trajectory, t0, t0 + h);
      ASSERT_TRUE(std::isfinite(speed.world) && std::isfinite(speed.relative)) << t0;
      const auto start = WorldVertices(KinematicsAt(trajectory, t0));
      for (int k = 1; k <= 10; ++k) {
        const double t = t0 + k * h / 10;
        const auto now = WorldVertices(KinematicsAt(trajectory, t));
        double moved = 0.0, moved_apart = 0.0;
        for (size_t i = 0; i < now.size(); ++i) moved = std::max(moved, (now[i].second - start[i].second).norm());
        // Relative motion of two vertices on different links.
        for (size_t i = 0; i < now.size(); i += 97) {
          for (size_t j = 0; j < now.size(); j += 89) {
            if (now[i].first == now[j].first) continue;
            moved_apart = std::max(moved_apart, ((now[i].second - now[j].second) -
                                                 (start[i].second - start[j].second)).norm());
          }
        }
        EXPECT_LE(moved, speed.world * (t - t0)) << "t0 " << t0 << ", t " << t;
        EXPECT_LE(moved_apart, speed.relative * (t - t0)) << "t0 " << t0 << ", t " << t;
        tightest = std::max(tightest, moved / (speed.world * (t - t0)));
      }
    }
  }
  // A bound a hundred times the motion would make the certificate useless.
  EXPECT_GT(tightest, 0.05);
}

TEST(CertificateTest, IsNeverAboveABruteForceCheckAtOneMillisecond) {
  const double truth = SampledClearance(*WindowCup().exact, 0.001);
  const double bound = WindowCup().task.safety_distance - DefaultPlannerOptions().post_check.clearance_tolerance;
  // (regular spacing, clearance spacing)
  for (const auto& [dt, clearance_dt] : std::vector<std::pair<double, double>>{
           {0.01, 0.01}, {0.01, 0.04}, {0.01, 0.3}, {0.1, 0.1}, {0.3, 0.3}}) {
    const PostCheckReport report = Check(*WindowCup().exact, dt, clearance_dt);
    SCOPED_TRACE(::testing::Message() << dt << ", " << clearance_dt);
    EXPECT_LE(report.certified_clearance, truth);
    // A certified plan keeps the bound at every millisecond too.
    EXPECT_TRUE(report.certified) << report.FirstFailure();
    EXPECT_GE(truth, bound);
    EXPECT_LE(report.certified_clearance, report.min_clearance_exact);
    if (clearance_dt >= 0.1) {  // coarse samples need refining near the cup
      EXPECT_GT(report.certificate_samples, 0);
    }
  }
}

// The per-stretch certificate a rejoining replan keeps (replan.h): the
// stretches tile the trajectory in order, and each one's bound holds at
// every millisecond inside it.
TEST(CertificateTest, EachCertifiedIntervalBoundsTheClearanceWithinIt) {
  const WholeBodyTrajectory& trajectory = *DefaultPlan().trajectory;
  const PostCheckReport report = Check(*WindowCup().exact, 0.01, 0.04);
  const std::vector<CertifiedInterval>& intervals = report.certified_intervals;
  ASSERT_FALSE(intervals.empty());
  EXPECT_EQ(intervals.front().t0, 0.0);
  EXPECT_NEAR(intervals.back().t1, trajectory.duration(), 1e-12);
  for (size_t i = 0; i < intervals.size(); ++i) {
    EXPECT_LT(intervals[i].t0, intervals[i].t1);
    if (i > 0) {
      EXPECT_EQ(intervals[i].t0, intervals[i - 1].t1);
    }
  }
  const int n = static_cast<int>(std::ceil(trajectory.duration() / 0.001));
  size_t interval = 0;
  double least_margin = 1e9;
  for (int i = 0; i <= n; ++i) {
    const double t = std::min(trajectory.duration(), i * trajectory.duration() / n);
    while (interval + 1 < intervals.size() && intervals[interval].t1 < t) ++interval;
    const double d = env::WholeBodyClearance(KinematicsAt(trajectory, t), *WindowCup().exact, 0.2, {});
    EXPECT_LE(intervals[interval].clearance_lower, d + 1e-12) << "t = " << t;
    least_margin = std::min(least_margin, d - intervals[interval].clearance_lower);
  }
  EXPECT_LT(least_margin, 0.01);  // tight somewhere, not a vacuous bound
  for (const CertifiedInterval& c : intervals) {
    EXPECT_LE(c.clearance_lower, c.clearance_sampled);
    EXPECT_LE(c.clearance_sampled, c.clearance_at_t1);
  }
}

TEST(CertificateTest, TheSelfDistanceIsNeverAboveABruteForceCheckAtOneMillisecond) {
  const WholeBodyTrajectory& trajectory = *DefaultPlan().trajectory;
  env::SelfCollisionOptions self_options;
  self_options.safety_distance = WindowCup().task.self_safety_distance;
  const auto self = env::SelfCollisionModel::Create(WindowCup().robot(), *WindowCup().exact, std::nullopt, self_options);
  ASSERT_TRUE(self.ok()) << self.status().message();
  ASSERT_FALSE((*self)->pairs().empty());
  const double reach = WindowCup().task.self_safety_distance + 0.02;
  double truth = reach;
  for (double t = 0.0; t <= trajectory.duration(); t += 0.001) {
    truth = std::min(truth, (*self)->MinDistanceLowerBound(KinematicsAt(trajectory, t), reach));
  }
  const PlanResult& plan = DefaultPlan();
  for (double dt : {0.01, 0.3}) {
    PostCheckOptions options = DefaultPlannerOptions().post_check;
    options.dt = options.clearance_dt = dt;
    const PostCheckReport report = PostCheck(trajectory, WindowCup().robot(), WindowCup().task, plan.terminal,
                                             plan.insertion, *WindowCup().model, *WindowCup().exact, self->get(),
                                             options);
    SCOPED_TRACE(dt);
    EXPECT_LE(report.certified_self_distance, truth);
    EXPECT_LE(report.certified_self_distance, report.min_self_distance);
    EXPECT_TRUE(report.certified) << report.FirstFailure();
  }
}

// An obstacle point the robot passes 1 cm from between two samples 0.2 s
// apart, while both samples keep the safety distance from it: placed beside
// the robot's outermost vertex, perpendicular to its motion, at the middle of
// a sample interval.
TEST(CertificateTest, RejectsAPlanThatGrazesAPointBetweenSamples) {
  const WholeBodyTrajectory& trajectory = *DefaultPlan().trajectory;
  const double dt = 0.2, graze = 0.01;
  const double bound = WindowCup().task.safety_distance - DefaultPlannerOptions().post_check.clearance_tolerance;
  const int n = static_cast<int>(std::ceil(trajectory.duration() / dt));
  const double step = trajectory.duration() / n;
  bool found = false;
  for (int i = 0; i < n && !found; ++i) {
    const double mid = (i + 0.5) * step;
    const WholeBodySample s = trajectory.Sample(mid);
    Vec3 across = Vec3::UnitZ().cross(s.velocity);
    if (across.norm() < 0.3) continue;  // moving too slowly to pass by far between samples
    across.normalize();
    for (double side : {1.0, -1.0}) {
      const Vec3 direction = side * across;
      const Vec3 outermost = OutermostVertex(KinematicsAt(trajectory, mid), direction);
      const Vec3 point = outermost + graze * direction;
      const auto lone = env::ExactMeshModel::Create(WindowCup().robot(), std::vector<Vec3>{point});
      ASSERT_TRUE(lone.ok());
      auto clearance_at = [&](double t) { return env::WholeBodyClearance(KinematicsAt(trajectory, t), **lone, 0.2, {}); };
      if (clearance_at(i * step) < bound + 0.005 || clearance_at((i + 1) * step) < bound + 0.005) continue;
      if (SampledClearance(**lone, dt) < bound + 0.005) continue;  // another sample comes close: not a graze
      // The scene and the point: the samples keep the distance, the motion does not.
      std::vector<Vec3> points = WindowCup().points;
      points.push_back(point);
      const auto grazed = env::ExactMeshModel::Create(WindowCup().robot(), points);
      ASSERT_TRUE(grazed.ok());
      double at = 0.0;
      const double truth = SampledClearance(**grazed, 0.001, &at);
      ASSERT_LT(truth, bound) << "the point is not grazed";
      if (SampledClearance(**grazed, step) < bound) continue;
      found = true;
      // Clearance samples 0.2 s apart, whether the limits are checked as
      // often or every 10 ms.
      const PostCheckReport report = Check(**grazed, dt, dt);
      EXPECT_EQ(Check(**grazed, 0.01, dt).checks[0].passed, false);
      ExpectTheGrazeFound(report, truth, at, bound, step);
    }
  }
  EXPECT_TRUE(found) << "no place for a graze between samples on this plan: the test proves nothing";
}

// The same with a point that moves (a moving target's point: moving_scene.h):
// it crosses the robot's side fast, vertically, between two clearance
// samples, and the samples see it far away at both. The certificate adds
// its speed to the robot's and must find it; a brute-force check at 1 ms
// against the point where it is then says it came too close.
TEST(CertificateTest, RejectsAPlanThatAMovingPointGrazesBetweenSamples) {
  const WholeBodyTrajectory& trajectory = *DefaultPlan().trajectory;
  const double dt = 0.2, graze = 0.01, speed = 1.5;
  const double bound = WindowCup().task.safety_distance - DefaultPlannerOptions().post_check.clearance_tolerance;
  const int n = static_cast<int>(std::ceil(trajectory.duration() / dt));
  const double step = trajectory.duration() / n;
  PostCheckOptions options = DefaultPlannerOptions().post_check;
  options.dt = dt;
  options.clearance_dt = dt;
  const InsertionGoal no_insertion;  // the line would be judged in the point's frame
  bool found = false;
  for (int i = 1; i < n && !found; ++i) {
    const double mid = (i + 0.5) * step;
    const WholeBodySample s = trajectory.Sample(mid);
    Vec3 across = Vec3::UnitZ().cross(s.velocity);
    if (across.norm() < 0.1) continue;
    across.normalize();
    for (double side : {1.0, -1.0}) {
      for (double up : {1.0, -1.0}) {
        if (found) break;
        const Vec3 direction = side * across;
        const Vec3 outermost = OutermostVertex(KinematicsAt(trajectory, mid), direction);
        // At `mid` the point is `graze` beside the robot; at t = 0 it was
        // speed * mid below (or above) that.
        const Vec3 velocity = up * speed * Vec3::UnitZ();
        const Vec3 at_zero = outermost + graze * direction - velocity * mid;
        const TargetMotion motion = TargetMotion::Constant(at_zero, velocity, Vec3::Zero(), 0.0);
        const auto lone = env::ExactMeshModel::Create(WindowCup().robot(), std::vector<Vec3>{at_zero});
        ASSERT_TRUE(lone.ok());
        auto clearance_at = [&](double t) {
          return env::WholeBodyClearance(InTargetFrameAtZero(KinematicsAt(trajectory, t), motion, t), **lone, 0.5, {});
        };
        double truth = 1e9, at = 0.0, sampled = 1e9;
        for (double t = 0.0; t <= trajectory.duration(); t += 0.001) {
          const double d = clearance_at(t);
          if (d < truth) {
            truth = d;
            at = t;
          }
        }
        for (int k = 0; k <= n; ++k) sampled = std::min(sampled, clearance_at(std::min(k * step, trajectory.duration())));
        if (!(truth < bound) || sampled < bound + 0.005) continue;  // no graze, or a sample sees it
        found = true;
        MovingScene moving;
        moving.motion = &motion;
        moving.exact = lone->get();
        const PostCheckReport report = PostCheck(trajectory, WindowCup().robot(), WindowCup().task,
                                                 DefaultPlan().terminal, no_insertion, *WindowCup().model,
                                                 *WindowCup().exact, nullptr, options, &moving);
        ExpectTheGrazeFound(report, truth, at, bound, step);
        // The same point standing still where it is at t = 0 is far from
        // the plan: the moving check, not another point, failed it.
        const TargetMotion still = TargetMotion::Constant(at_zero, Vec3::Zero(), Vec3::Zero(), 0.0);
        moving.motion = &still;
        const PostCheckReport calm = PostCheck(trajectory, WindowCup().robot(), WindowCup().task,
                                               DefaultPlan().terminal, no_insertion, *WindowCup().model,
                                               *WindowCup().exact, nullptr, options, &moving);
        EXPECT_TRUE(calm.certified) << calm.FirstFailure();
      }
    }
  }
  EXPECT_TRUE(found) << "no place for a moving graze between samples on this plan: the test proves nothing";
}

// PostCheckOptions::stop_at_first_failure: on a plan that passes, the same
// report as the full check; on one that fails early (an obstacle point on
// the robot at t = 1 s), the same verdict and limit checks, and the same
// certified stretches up to a little (at most 8 of them) after the first
// that fails, none later.
TEST(CertificateTest, StoppingAtTheFirstFailureKeepsTheVerdict) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& trajectory = *plan.trajectory;
  auto check = [&](const env::ExactMeshModel& exact, bool stop) {
    PostCheckOptions options = DefaultPlannerOptions().post_check;
    options.stop_at_first_failure = stop;
    return PostCheck(trajectory, WindowCup().robot(), WindowCup().task, plan.terminal, plan.insertion,
                     *WindowCup().model, exact, nullptr, options);
  };
  {
    const PostCheckReport full = check(*WindowCup().exact, false), stopping = check(*WindowCup().exact, true);
    ASSERT_TRUE(full.passed) << full.FirstFailure();
    EXPECT_TRUE(stopping.passed) << stopping.FirstFailure();
    EXPECT_EQ(stopping.certified_clearance, full.certified_clearance);
    EXPECT_EQ(stopping.min_clearance_exact, full.min_clearance_exact);
    EXPECT_EQ(stopping.certified_intervals.size(), full.certified_intervals.size());
    EXPECT_EQ(stopping.clearance_checked_until, trajectory.duration());
    EXPECT_EQ(full.clearance_checked_until, trajectory.duration());
  }
  const double hit = 1.0;
  std::vector<Vec3> points = WindowCup().points;
  points.push_back(WorldVertices(KinematicsAt(trajectory, hit)).front().second);
  const auto struck = env::ExactMeshModel::Create(WindowCup().robot(), points);
  ASSERT_TRUE(struck.ok());
  const PostCheckReport full = check(**struck, false), stopping = check(**struck, true);
  ASSERT_FALSE(full.passed);
  const double bound = WindowCup().task.safety_distance - DefaultPlannerOptions().post_check.clearance_tolerance;
  size_t first_failing = 0;
  while (first_failing < full.certified_intervals.size() &&
         full.certified_intervals[first_failing].clearance_lower >= bound) {
    ++first_failing;
  }
  ASSERT_LT(first_failing, full.certified_intervals.size());
  ASSERT_GT(first_failing + 8, stopping.certified_intervals.size() - 1);
  ASSERT_LE(first_failing, stopping.certified_intervals.size() - 1);
  for (size_t i = 0; i < stopping.certified_intervals.size(); ++i) {
    EXPECT_EQ(stopping.certified_intervals[i].t1, full.certified_intervals[i].t1);
    EXPECT_EQ(stopping.certified_intervals[i].clearance_lower, full.certified_intervals[i].clearance_lower);
  }
  EXPECT_FALSE(stopping.passed);
  EXPECT_FALSE(stopping.certified);
  ASSERT_EQ(stopping.checks.size(), full.checks.size());
  EXPECT_EQ(stopping.checks[0].kind, CheckKind::kClearance);
  EXPECT_FALSE(stopping.checks[0].passed);
  EXPECT_NE(stopping.checks[0].detail.find("stopped at the first failure"), std::string::npos)
      << stopping.checks[0].detail;
  EXPECT_LE(stopping.checks[0].time, hit + 0.05);
  EXPECT_LT(stopping.clearance_checked_until, hit + 0.5);  // well before the end (duration above 5 s)
  EXPECT_LT(stopping.certified_intervals.size(), full.certified_intervals.size() / 2);
  EXPECT_EQ(stopping.certified_intervals.back().t1, stopping.clearance_checked_until);
  for (size_t i = 1; i < full.checks.size(); ++i) {  // every limit, state and insertion check
    SCOPED_TRACE(full.checks[i].name);
    EXPECT_EQ(stopping.checks[i].passed, full.checks[i].passed);
    EXPECT_EQ(stopping.checks[i].value, full.checks[i].value);
  }
}


// The via check (Task::vias) against a brute-force search at 10 us: the
// distance and time of the base's closest approach to points beside the
// default plan's path, between its samples; a via farther than its
// tolerance fails, and vias are passed in order.
TEST(ViaCheckTest, FindsTheClosestApproachBetweenSamplesAndKeepsTheOrder) {
  const PlanResult& plan = DefaultPlan();
  const WholeBodyTrajectory& trajectory = *plan.trajectory;
  auto via_beside = [&](double t, double offset) {
    const WholeBodySample s = trajectory.Sample(t);
    const Vec3 side = s.velocity.cross(Vec3::UnitZ()).normalized();
    return Vec3(s.position + offset * side);
  };
  auto brute_force = [&](const Vec3& point, double* at) {
    double least = 1e9;
    for (double t = 0.0; t <= trajectory.duration(); t += 1e-5) {
      const double d = (trajectory.Sample(t).position - point).norm();
      if (d < least) {
        least = d;
        *at = t;
      }
    }
    return least;
  };
  auto check = [&](const std::vector<ViaPoint>& vias, PostCheckReport* report) {
    Task task = WindowCup().task;
    task.vias = vias;
    *report = PostCheck(trajectory, WindowCup().robot(), task, plan.terminal, plan.insertion, *WindowCup().model,
                        *WindowCup().exact, nullptr, DefaultPlannerOptions().post_check);
    for (const CheckResult& c : report->checks) {
      if (c.kind == CheckKind::kVia) return c;
    }
    ADD_FAILURE() << "no via check";
    return CheckResult{};
  };
  const Vec3 first = via_beside(2.345, 0.03), second = via_beside(4.567, 0.02);
  double first_at = 0.0, second_at = 0.0;
  const double first_distance = brute_force(first, &first_at), second_distance = brute_force(second, &second_at);
  ASSERT_GT(first_distance, 0.02);
  PostCheckReport report;
  CheckResult via = check({{first, 0.04}, {second, 0.04}}, &report);
  EXPECT_TRUE(via.passed) << via.detail;
  ASSERT_EQ(report.via_times.size(), 2u);
  EXPECT_NEAR(report.via_times[0], first_at, 1e-4);
  EXPECT_NEAR(report.via_times[1], second_at, 1e-4);
  EXPECT_NEAR(via.value, std::max(first_distance, second_distance), 1e-7);
  // Tighter than the distance: failed, with the measured distance.
  via = check({{first, 0.5 * first_distance}}, &report);
  EXPECT_FALSE(via.passed);
  EXPECT_NEAR(via.value, first_distance, 1e-7);
  EXPECT_FALSE(report.passed);
  // The later point first: the earlier one is then sought after it, where
  // the base never comes back near it.
  via = check({{second, 0.04}, {first, 0.04}}, &report);
  EXPECT_FALSE(via.passed) << via.detail;
  EXPECT_GT(via.value, 0.5);
}

}  // namespace
}  // namespace quadhand::planner
