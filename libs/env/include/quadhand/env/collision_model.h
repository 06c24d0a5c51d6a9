// The collision-model interface shared by every geometric representation
// (MRC-SDF on raw points, OctoMap ESDF, safe-flight corridors), and the
// whole-body layer that sums link penalties and maps their gradients through
// the kinematic chain.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/types.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::env {

// What a model's distances are, so post-checks know how far to trust them.
enum class DistanceQuality {
  kExact,        // exact up to interpolation (MRC-SDF: within ~1 mm)
  kApproximate,  // discretised (ESDF voxels, surface samples)
  kLowerBound,   // never more than the true distance (corridors)
};
const char* DistanceQualityName(DistanceQuality quality);

struct PenaltyParameters {
  double threshold = 0.03;  // d_thr: distances below it are penalised, metres
  double mu = 0.01;         // smoothing of the smoothed L1, metres
};

// Gradient of a scalar w.r.t. a rigid motion of one link: `force` w.r.t. a
// world-frame translation of the link origin, `torque` w.r.t. a world-frame
// rotation vector about the link origin (R_WL -> exp([dphi]x) R_WL).
struct LinkWrench {
  Vec3 force = Vec3::Zero();
  Vec3 torque = Vec3::Zero();
};

// Where along the trajectory a query is made (corridor models pick their
// polytope by piece; the others ignore it).
struct QueryContext {
  int piece = -1;
  double time = 0.0;
};

class CollisionModel {
 public:
  virtual ~CollisionModel() = default;

  virtual std::string name() const = 0;
  virtual DistanceQuality distance_quality() const = 0;

  // Robot link indices this model has geometry for.
  virtual const std::vector<int>& links() const = 0;

  // Penalty of link `link` (a robot link index from links()) at pose X_WL:
  // sum over obstacle points j of SmoothedL1(threshold - d_j, mu). When
  // `wrench` is not null, the gradient w.r.t. the link's rigid motion is ADDED to it.
  virtual double LinkPenalty(int link, const Pose& X_WL, const PenaltyParameters& parameters,
                             const QueryContext& context, LinkWrench* wrench) const = 0;

  // Smallest obstacle distance of link `link` at pose X_WL as this model
  // measures it; `search_radius` if nothing is closer than that.
  virtual double LinkClearance(int link, const Pose& X_WL, double search_radius,
                               const QueryContext& context) const = 0;
};

// Gradient of a scalar w.r.t. the whole-body state: base translation (world),
// base rotation as a world-frame rotation vector, actuated joints (the
// column layout of robot/kinematics.h).
struct StateGradient {
  Vec3 position = Vec3::Zero();
  Vec3 rotation = Vec3::Zero();
  VecX joints;
  void SetZero(int num_joints);
};

// Sum of LinkPenalty over the model's links at the state described by
// `kinematics`; when `gradient` is not null its terms are ADDED to it (it must
// be sized). Mimic joints contribute to their source coordinate.
double WholeBodyPenalty(const robot::RobotModel& robot, const robot::KinematicsState& kinematics,
                        const CollisionModel& model, const PenaltyParameters& parameters,
                        const QueryContext& context, StateGradient* gradient);

// Adds to `gradient` the state gradient of a wrench applied to link `link`.
void AccumulateLinkWrench(const robot::RobotModel& robot, const robot::KinematicsState& kinematics,
                          int link, const LinkWrench& wrench, StateGradient* gradient);

// For models that keep per-link data in `links` order: slot[link] is the
// position of robot link `link` in `links`, -1 for links not in it.
std::vector<int> SlotsOfLinks(const std::vector<int>& links);

// Smallest LinkClearance over the model's links; `closest_link` gets the link.
double WholeBodyClearance(const robot::KinematicsState& kinematics, const CollisionModel& model,
                          double search_radius, const QueryContext& context, int* closest_link = nullptr);

}  // namespace quadhand::env
