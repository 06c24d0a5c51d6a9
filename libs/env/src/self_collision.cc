#include "quadhand/env/self_collision.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>
#include <set>

#include "quadhand/core/worker_pool.h"
#include "quadhand/env/surface_sample_cache.h"
#include "quadhand/opt/penalty.h"
#include "quadhand/robot/link_meshes.h"

namespace quadhand::env {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Union-find root of a link over the fixed joints.
int Root(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// The samples of a link's elements (each sampled on its own, in element
// order) as one set, with their bounding sphere.
void MergeElementSamples(std::vector<LinkSurfaceSamples>& parts, LinkSurfaceSamples* samples, Vec3* center,
                         double* radius) {
  for (LinkSurfaceSamples& part : parts) {
    const int offset = static_cast<int>(samples->points.size());
    samples->points.insert(samples->points.end(), part.points.begin(), part.points.end());
    for (LinkSurfaceSamples::Cluster c : part.clusters) {
      c.begin += offset;
      c.end += offset;
      samples->clusters.push_back(c);
    }
    part = LinkSurfaceSamples{};
  }
  *center = Vec3::Zero();
  *radius = 0.0;
  if (samples->points.empty()) return;
  Vec3 lo = samples->points.front(), hi = lo;
  for (const Vec3& p : samples->points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  *center = 0.5 * (lo + hi);
  for (const Vec3& p : samples->points) *radius = std::max(*radius, (p - *center).norm());
}

// Distance of `x` outside the box [lo, hi]; -inf inside it (a point inside
// the box may be inside the link: no bound).
double OutsideBox(const Vec3& lo, const Vec3& hi, const Vec3& x) {
  const double outside = (lo - x).cwiseMax(x - hi).cwiseMax(0.0).norm();
  return outside > 0.0 ? outside : -kInf;
}

}  // namespace

bool SelfCollisionOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(safety_distance) && safety_distance >= 0.0)) {
    if (why != nullptr) *why = "self_safety_distance must be finite and non-negative";
    return false;
  }
  if (!(std::isfinite(sample_spacing) && sample_spacing > 0.0 && sample_spacing <= 0.05 &&
        std::isfinite(penalty_spacing) && penalty_spacing > 0.0 && penalty_spacing <= 0.1)) {
    if (why != nullptr) *why = "self-collision sample spacings must be in (0, 0.05] m (check) and (0, 0.1] m (penalty)";
    return false;
  }
  return true;
}

const char* PairExclusionName(PairExclusion exclusion) {
  switch (exclusion) {
    case PairExclusion::kRigid: return "rigid";
    case PairExclusion::kAdjacent: return "adjacent";
    case PairExclusion::kSrdf: return "srdf";
    case PairExclusion::kCloseAtZero: return "close_at_zero";
  }
  return "?";
}

core::Result<std::unique_ptr<SelfCollisionModel>> SelfCollisionModel::Create(
    const robot::RobotModel& robot, const ExactMeshModel& exact,
    const std::optional<std::vector<std::pair<int, int>>>& srdf_disabled, const SelfCollisionOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) return core::Status::InvalidArgument(why);
  std::unique_ptr<SelfCollisionModel> model(new SelfCollisionModel(exact, options));
  const int num_links = robot.num_links();
  const std::vector<int> collision_links = robot.CollisionLinks();
  std::vector<bool> has_collision(num_links, false);
  for (int link : collision_links) has_collision[link] = true;

  // Rigid groups: links joined by fixed joints only.
  std::vector<int> group(num_links);
  std::iota(group.begin(), group.end(), 0);
  for (int j = 0; j < robot.num_joints(); ++j) {
    const robot::Joint& joint = robot.joint(j);
    if (joint.type == robot::JointType::kFixed) group[Root(group, joint.child_link)] = Root(group, joint.parent_link);
  }
  std::vector<bool> group_has_collision(num_links, false);
  for (int link : collision_links) group_has_collision[Root(group, link)] = true;
  // Adjacent groups: a moving joint from the nearest ancestor group with
  // collision geometry (links before the child are in topological order).
  std::set<std::pair<int, int>> adjacent;
  for (int link = 1; link < num_links; ++link) {
    const robot::Joint& joint = robot.joint(robot.link(link).parent_joint);
    if (joint.type == robot::JointType::kFixed) continue;
    int ancestor = joint.parent_link;
    while (!group_has_collision[Root(group, ancestor)] && robot.link(ancestor).parent_joint >= 0) {
      ancestor = robot.joint(robot.link(ancestor).parent_joint).parent_link;
    }
    // A child group without collision geometry passes adjacency on to the
    // groups below it.
    std::vector<int> below = {link};
    while (!below.empty()) {
      const int child = below.back();
      below.pop_back();
      const int a = Root(group, ancestor), b = Root(group, child);
      if (group_has_collision[b]) {
        adjacent.insert({std::min(a, b), std::max(a, b)});
        continue;
      }
      for (int j = 0; j < robot.num_joints(); ++j) {
        if (robot.joint(j).parent_link == child) below.push_back(robot.joint(j).child_link);
      }
    }
  }

  std::set<std::pair<int, int>> disabled;
  if (srdf_disabled) disabled.insert(srdf_disabled->begin(), srdf_disabled->end());

  model->collision_links_ = collision_links;
  model->sampled_.resize(num_links);
  model->penalty_samples_.resize(num_links);
  model->anchors_.resize(num_links);
  model->boxes_.resize(num_links);
  std::vector<size_t> sample_count(num_links, 0);
  std::vector<std::vector<geometry::TriangleMesh>> link_elements(num_links);
  for (int link : collision_links) {
    auto elements = robot::LinkCollisionElements(robot, link);
    if (!elements.ok()) return elements.status();
    for (const geometry::TriangleMesh& mesh : *elements) {
      const core::Status fits =
          CheckSurfaceSampleCount(mesh, std::min(options.sample_spacing, options.penalty_spacing),
                                  "self-collision: link '" + robot.link(link).name + "'");
      if (!fits.ok()) return fits;
    }
    for (const geometry::TriangleMesh& mesh : *elements) {
      if (!mesh.vertices.empty()) model->anchors_[link].push_back(mesh.vertices.front());
    }
    link_elements[link] = std::move(*elements);
    exact.LinkBox(link, &model->boxes_[link].first, &model->boxes_[link].second);
  }
  // Sampling a CAD link's hundreds of thousands of triangles takes tens of
  // milliseconds per spacing: every element at both spacings in parallel
  // (elements rather than links: one link often holds most of the
  // triangles). Each job writes only its own part, and the parts are merged
  // in element order, so the result does not depend on the threads.
  struct Job {
    int link, element;
    bool penalty;
  };
  std::vector<Job> jobs;
  std::vector<std::vector<LinkSurfaceSamples>> check_parts(num_links), penalty_parts(num_links);
  for (int link : collision_links) {
    const int elements = static_cast<int>(link_elements[link].size());
    check_parts[link].resize(elements);
    penalty_parts[link].resize(elements);
    for (int e = 0; e < elements; ++e) {
      jobs.push_back({link, e, false});
      jobs.push_back({link, e, true});
    }
  }
  // The largest elements first, so that no thread is left with one at the end.
  std::stable_sort(jobs.begin(), jobs.end(), [&](const Job& a, const Job& b) {
    return link_elements[a.link][a.element].triangles.size() > link_elements[b.link][b.element].triangles.size();
  });
  std::atomic<size_t> next{0};
  core::WorkerPool pool(core::WorkerCount(0, std::max<int>(1, static_cast<int>(jobs.size()))));
  pool.Run([&](int) {
    for (size_t i = next++; i < jobs.size(); i = next++) {
      const Job& job = jobs[i];
      auto& parts = job.penalty ? penalty_parts : check_parts;
      parts[job.link][job.element] =
          CachedLinkSurfaceSamples(link_elements[job.link][job.element],
                                   job.penalty ? options.penalty_spacing : options.sample_spacing, options.sample_cache_dir);
    }
  });
  for (int link : collision_links) {
    SampledLink& s = model->sampled_[link];
    MergeElementSamples(check_parts[link], &s.samples, &s.center, &s.radius);
    SampledLink& p = model->penalty_samples_[link];
    MergeElementSamples(penalty_parts[link], &p.samples, &p.center, &p.radius);
  }
  for (int link : collision_links) sample_count[link] = model->sampled_[link].samples.points.size();

  // The zero configuration, within the limits.
  VecX q(robot.num_actuated());
  for (int i = 0; i < robot.num_actuated(); ++i) {
    const robot::Joint& joint = robot.joint(robot.actuated_joints()[i]);
    q[i] = std::clamp(0.0, joint.lower, joint.upper);
  }
  robot::KinematicsState zero;
  robot::ComputeKinematics(robot, Pose::Identity(), q, &zero);

  for (size_t i = 0; i < collision_links.size(); ++i) {
    for (size_t k = i + 1; k < collision_links.size(); ++k) {
      const int a = collision_links[i], b = collision_links[k];
      const int ga = Root(group, a), gb = Root(group, b);
      if (ga == gb) {
        model->excluded_.push_back({a, b, PairExclusion::kRigid});
        continue;
      }
      if (adjacent.count({std::min(ga, gb), std::max(ga, gb)}) != 0) {
        model->excluded_.push_back({a, b, PairExclusion::kAdjacent});
        continue;
      }
      if (disabled.count({a, b}) != 0) {
        model->excluded_.push_back({a, b, PairExclusion::kSrdf});
        continue;
      }
      // The link with fewer samples is sampled, the other queried.
      const LinkPair pair = sample_count[a] <= sample_count[b] ? LinkPair{a, b} : LinkPair{b, a};
      model->pairs_.push_back(pair);
      if (!srdf_disabled) {
        const int index = static_cast<int>(model->pairs_.size()) - 1;
        const double reach = options.safety_distance + options.sample_spacing;
        if (model->PairDistanceLowerBound(index, zero, reach) < options.safety_distance) {
          model->pairs_.pop_back();
          model->excluded_.push_back({a, b, PairExclusion::kCloseAtZero});
        }
      }
    }
  }
  return model;
}

double SelfCollisionModel::BoxLowerBound(int link, const Vec3& x_L) const {
  return OutsideBox(boxes_[link].first, boxes_[link].second, x_L);
}

double SelfCollisionModel::PairDistanceLowerBound(int pair_index, const robot::KinematicsState& kinematics,
                                                  double reach) const {
  const LinkPair& pair = pairs_[pair_index];
  const SampledLink& a = sampled_[pair.sampled_link];
  const Pose& X_WA = kinematics.link_poses[pair.sampled_link];
  const Pose& X_WB = kinematics.link_poses[pair.queried_link];
  const Pose X_BA = X_WB.inverse() * X_WA;
  const double h = options_.sample_spacing;
  double bound = reach;
  if (BoxLowerBound(pair.queried_link, X_BA * a.center) - a.radius - h >= bound) return bound;
  for (const LinkSurfaceSamples::Cluster& cluster : a.samples.clusters) {
    const Vec3 center = X_BA * cluster.center;
    if (BoxLowerBound(pair.queried_link, center) - cluster.radius - h >= bound) continue;
    if (exact_.LinkSignedDistance(pair.queried_link, center) - cluster.radius - h >= bound) continue;
    for (int i = cluster.begin; i < cluster.end; ++i) {
      const Vec3 x = X_BA * a.samples.points[i];
      if (BoxLowerBound(pair.queried_link, x) - h >= bound) continue;
      bound = std::min(bound, exact_.LinkSignedDistance(pair.queried_link, x) - h);
    }
  }
  if (bound > 0.0) {
    // B wholly inside A leaves every sample of A outside B.
    const Pose X_AB = X_BA.inverse();
    for (const Vec3& anchor : anchors_[pair.queried_link]) {
      const Vec3 x = X_AB * anchor;
      if (BoxLowerBound(pair.sampled_link, x) > 0.0) continue;
      const double d = exact_.LinkSignedDistance(pair.sampled_link, x);
      if (d < 0.0) bound = std::min(bound, d);
    }
  }
  return bound;
}

double SelfCollisionModel::MinDistanceLowerBound(const robot::KinematicsState& kinematics, double reach,
                                                 int* closest_pair) const {
  double best = reach;
  if (closest_pair != nullptr) *closest_pair = -1;
  for (size_t i = 0; i < pairs_.size(); ++i) {
    const double d = PairDistanceLowerBound(static_cast<int>(i), kinematics, best);
    if (d < best) {
      best = d;
      if (closest_pair != nullptr) *closest_pair = static_cast<int>(i);
    }
  }
  return best;
}

core::Status SelfCollisionModel::AttachSdfGrids(SharedSdfGrids grids) {
  const std::vector<int> links = collision_links_;
  if (grids == nullptr || grids->size() != links.size()) {
    return core::Status::InvalidArgument("self-collision: need one SDF per collision link");
  }
  grid_slot_.assign(sampled_.size(), -1);
  for (size_t i = 0; i < links.size(); ++i) grid_slot_[links[i]] = static_cast<int>(i);
  grids_ = std::move(grids);
  return core::Status::Ok();
}

double SelfCollisionModel::Penalty(const robot::RobotModel& robot, const robot::KinematicsState& kinematics,
                                   const PenaltyParameters& parameters, StateGradient* gradient) const {
  if (grids_ == nullptr) return 0.0;
  const double threshold = parameters.threshold;
  double cost = 0.0;
  for (const LinkPair& pair : pairs_) {
    const SampledLink& a = penalty_samples_[pair.sampled_link];
    const geometry::SdfGrid& grid = (*grids_)[grid_slot_[pair.queried_link]];
    const Pose& X_WA = kinematics.link_poses[pair.sampled_link];
    const Pose& X_WB = kinematics.link_poses[pair.queried_link];
    const double slack = std::sqrt(3.0) * grid.info().resolution;
    // Most pairs are far apart at most samples: the sampled link's sphere
    // against the queried link's box first (its true distance is at most
    // the SDF's, so this prunes no more than the tests below).
    const Vec3 center_B = X_WB.linear().transpose() * (X_WA * a.center - X_WB.translation());
    const auto& box = boxes_[pair.queried_link];
    const double box_reach = threshold + a.radius + slack;
    if ((box.first - center_B).cwiseMax(center_B - box.second).cwiseMax(0.0).squaredNorm() >= box_reach * box_reach) {
      continue;
    }
    const Pose X_BA = X_WB.inverse() * X_WA;
    double d = 0.0;
    Vec3 g;
    // The grid's nodes hold exact distances, which are 1-Lipschitz, and the
    // trilinear interpolant is within sqrt(3)/2 resolutions of them (the
    // weighted mean distance to the cell's nodes); outside the grid the
    // value is the distance to its box, also 1-Lipschitz. So a sphere whose
    // centre's value is its radius plus two such errors beyond the
    // threshold holds no penalised sample.
    // EvaluateBelow may also answer true for a value at or above the cutoff.
    auto below = [&](const Vec3& x_B, double cutoff) {
      return grid.EvaluateBelow(x_B, cutoff, &d, &g) && d < cutoff;
    };
    if (!below(X_BA * a.center, threshold + a.radius + slack)) continue;
    LinkWrench on_a, on_b;
    bool any = false;
    for (const LinkSurfaceSamples::Cluster& cluster : a.samples.clusters) {
      if (!below(X_BA * cluster.center, threshold + cluster.radius + slack)) continue;
      for (int i = cluster.begin; i < cluster.end; ++i) {
        const Vec3 x_B = X_BA * a.samples.points[i];
        if (!below(x_B, threshold)) continue;
        double slope = 0.0;
        cost += opt::SmoothedL1(threshold - d, parameters.mu, &slope);
        if (gradient == nullptr || slope == 0.0) continue;
        // d cost / d d = -slope. Moving A moves the sample (d d / d p_A =
        // g_W, about A's origin (x - p_A) x g_W); moving B moves the field
        // the other way (-g_W, -(x - p_B) x g_W).
        const Vec3 g_W = X_WB.linear() * g;
        const Vec3 x_W = X_WB * x_B;
        on_a.force -= slope * g_W;
        on_a.torque -= slope * (x_W - X_WA.translation()).cross(g_W);
        on_b.force += slope * g_W;
        on_b.torque += slope * (x_W - X_WB.translation()).cross(g_W);
        any = true;
      }
    }
    if (any) {
      AccumulateLinkWrench(robot, kinematics, pair.sampled_link, on_a, gradient);
      AccumulateLinkWrench(robot, kinematics, pair.queried_link, on_b, gradient);
    }
  }
  return cost;
}

}  // namespace quadhand::env
