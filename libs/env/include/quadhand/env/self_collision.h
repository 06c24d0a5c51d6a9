// Self-collision: the pairs of a robot's collision links that must keep
// apart (the arm from the airframe, its rotors and its own links), and a
// certified lower bound on the distance between the two links of a pair.
//
// Pairs. Every two collision links, except
//   - links that no actuated joint moves apart (rigidly joined by fixed
//     joints: their distance is the robot's design, no plan changes it);
//   - adjacent links: joined by one joint (links without collision geometry
//     in between are skipped, so a wrist made of two joints through a
//     massless link counts as adjacent);
//   - disabled pairs: those of an SRDF's <disable_collisions> when one is
//     given (robot/srdf.h, MoveIt's convention), else the pairs closer than
//     the safety distance at the zero configuration (each joint at 0, or at
//     the limit nearest 0), which no plan could keep apart.
//
// Distance. The surface of the pair's smaller link (A) is sampled at most
// `sample_spacing` apart (env/link_surface_samples.h) and each sample is
// queried against the other link's exact elements (B, env::ExactMeshModel).
// Signed distance is 1-Lipschitz, so
//   min over samples of d_B(s) - sample_spacing
// is a lower bound of the distance between the two solids; any negative
// value means they overlap (it is not a penetration depth). One vertex of each of B's elements is also tested inside A,
// so B wholly inside A is not missed. The bound is never above the truth and
// at most sample_spacing below it: a check built on it can reject a pair
// that is slightly farther apart than needed, never accept one that is not.
// Clusters of samples are skipped with their bounding spheres.
//
// Penalty. For the optimiser: coarser surface samples of the sampled link
// (`penalty_spacing`) looked up in the queried link's SDF grid, the paper's
// smoothed L1 of (threshold - d) summed, with its gradient w.r.t. both links'
// motions carried through both kinematic chains. The post-check, not the
// penalty, decides whether a plan keeps the distance.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/env/exact_mesh_model.h"
#include "quadhand/env/link_surface_samples.h"
#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::env {

struct SelfCollisionOptions {
  // Distance the pairs keep, metres (the task's self_safety_distance); pairs
  // closer than it at the zero configuration are not checked (without SRDF).
  double safety_distance = 0.01;
  // Surface sample spacing of the sampled link, metres: the lower bound is
  // within it of the true distance.
  double sample_spacing = 0.003;
  // Surface sample spacing of the penalty's samples, metres.
  double penalty_spacing = 0.01;
  // A folder of cached surface samples (surface_sample_cache.h) read before
  // sampling an element; empty: none. The planner gives the SDF folder's
  // `meshes/`, where quadhand-sdfgen writes them at the default spacings.
  std::string sample_cache_dir;
  bool IsValid(std::string* why) const;
};

// Why a pair of collision links is not checked.
enum class PairExclusion { kRigid, kAdjacent, kSrdf, kCloseAtZero };
const char* PairExclusionName(PairExclusion exclusion);  // "rigid", "adjacent", "srdf", "close_at_zero"

struct LinkPair {
  int sampled_link = -1;  // A: its surface is sampled
  int queried_link = -1;  // B: its exact elements are queried
};

struct ExcludedPair {
  int link_a = -1, link_b = -1;  // robot link indices, a < b
  PairExclusion why = PairExclusion::kAdjacent;
};

class SelfCollisionModel {
 public:
  // `exact` must hold every collision link of `robot` and outlive the model.
  // `srdf_disabled`: the pairs an SRDF disables (robot/srdf.h), or nullopt
  // for none given (then pairs close at the zero configuration are dropped).
  static core::Result<std::unique_ptr<SelfCollisionModel>> Create(
      const robot::RobotModel& robot, const ExactMeshModel& exact,
      const std::optional<std::vector<std::pair<int, int>>>& srdf_disabled, const SelfCollisionOptions& options);

  const std::vector<LinkPair>& pairs() const { return pairs_; }
  const std::vector<ExcludedPair>& excluded() const { return excluded_; }
  const SelfCollisionOptions& options() const { return options_; }

  // Lower bound of the distance between the solids of pair `pair` (see
  // above; negative: they overlap), or `reach` when that is at least reach.
  double PairDistanceLowerBound(int pair, const robot::KinematicsState& kinematics, double reach) const;
  // The smallest over all pairs; `closest_pair` gets its index (-1 if none
  // is closer than reach).
  double MinDistanceLowerBound(const robot::KinematicsState& kinematics, double reach,
                               int* closest_pair = nullptr) const;

  // The link SDFs the penalty looks up (one per collision link of the robot,
  // in robot.CollisionLinks() order, as env::LoadLinkSdfGrids loads them).
  core::Status AttachSdfGrids(SharedSdfGrids grids);
  bool has_penalty() const { return grids_ != nullptr && !pairs_.empty(); }
  // Sum over pairs and penalty samples of SmoothedL1(threshold - d, mu), d the
  // sample's distance in the queried link's SDF; when `gradient` is not null
  // (sized), the gradient is ADDED to it. 0 without grids.
  double Penalty(const robot::RobotModel& robot, const robot::KinematicsState& kinematics,
                 const PenaltyParameters& parameters, StateGradient* gradient) const;

 private:
  struct SampledLink {
    LinkSurfaceSamples samples;
    Vec3 center = Vec3::Zero();  // bounding sphere of the samples, link frame
    double radius = 0.0;
  };
  SelfCollisionModel(const ExactMeshModel& exact, SelfCollisionOptions options) : exact_(exact), options_(options) {}
  double BoxLowerBound(int link, const Vec3& x_L) const;

  const ExactMeshModel& exact_;
  SelfCollisionOptions options_;
  std::vector<LinkPair> pairs_;
  std::vector<ExcludedPair> excluded_;
  std::vector<int> collision_links_;
  std::vector<SampledLink> sampled_;        // per robot link (empty for links not sampled)
  std::vector<SampledLink> penalty_samples_;  // per robot link, at penalty_spacing
  SharedSdfGrids grids_;
  std::vector<int> grid_slot_;              // per robot link: its grid in grids_, -1 if none
  std::vector<std::vector<Vec3>> anchors_;  // per robot link: one vertex of each element
  std::vector<std::pair<Vec3, Vec3>> boxes_;
};

}  // namespace quadhand::env
