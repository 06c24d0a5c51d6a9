// ESDF baseline (paper Sec. "Simulation and Benchmark Comparisons"): the
// obstacle cloud voxelised into an OctoMap occupancy tree, a Euclidean
// distance field computed on it by DynamicEDT3D, and the robot approximated by
// points sampled on its link surfaces (link_surface_samples.h).
//
// Distances: the EDT gives, at every voxel centre of the scene box, the
// distance to the nearest occupied voxel centre (0 in occupied voxels,
// clamped at max_distance). It is copied into a dense grid once, and a query
// at p returns the trilinear interpolation of those values and its analytic
// gradient (piecewise: one-sided on cell faces). So a distance is the
// distance to the voxelised cloud, not to the points: it can be off by about
// a voxel (half a voxel diagonal from quantisation, plus interpolation; it is
// never negative, so a point inside the cloud reads as "near", not "inside").
// Outside the box the value at the nearest box point is returned (the box
// extends box_margin beyond the cloud, so that value is about box_margin or
// more).
//
// Penalty of a link: sum over its surface samples x of
// SmoothedL1(threshold - d(x), mu), the same form and threshold as MRC-SDF;
// the wrench is the sum of dcost/dx (force) and of (x - p_WL) x dcost/dx
// (torque about the link origin). Clusters of samples are skipped when the
// field at their centre proves them beyond the threshold (the interpolated
// field changes by at most sqrt(3) per metre; 2 is used).
//
// OctoMap and DynamicEDT3D are used only inside esdf_model.cc; the model
// keeps only the dense grid, so it is immutable and thread-safe after Create.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/env/link_surface_samples.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::env {

struct EsdfOptions {
  double resolution = 0.02;       // OctoMap voxel edge, m (the paper's 0.02)
  // EDT propagation limit, m; distances are clamped to it. Only distances
  // below the penalty threshold matter to the penalty, and the cluster test
  // needs about threshold + 0.1 m; larger values only cost build time
  // (0.2 m: about half the build time of 0.5 m on the benchmark scene).
  double max_distance = 0.2;
  double box_margin = 0.25;       // the field's box: cloud bounding box grown by this, m (>= 0)
  double surface_spacing = 0.01;  // robot surface sampling, m (link_surface_samples.h)
  long max_cells = 40'000'000;    // largest field box in voxels (DynamicEDT3D needs ~30 bytes each while building)

  // False (with a reason in `why`, which may be null) for non-positive or
  // non-finite sizes, max_distance below two voxels, or a negative margin.
  bool IsValid(std::string* why) const;
};

class EsdfModel final : public CollisionModel {
 public:
  // Samples the collision mesh of every collision link of `robot`
  // (robot::LinkCollisionMesh) and builds the field from `points` (world
  // frame, finite, at least one). InvalidArgument for bad options, a
  // non-finite point, an empty cloud or a box larger than max_cells; errors
  // of LinkCollisionMesh are passed on.
  static core::Result<std::unique_ptr<EsdfModel>> Create(const robot::RobotModel& robot,
                                                         const std::vector<Vec3>& points,
                                                         const EsdfOptions& options = {});
  // Same with the link meshes given: meshes[i] (link frame) belongs to robot link links[i].
  static core::Result<std::unique_ptr<EsdfModel>> Create(std::vector<int> links,
                                                         const std::vector<geometry::TriangleMesh>& meshes,
                                                         const std::vector<Vec3>& points,
                                                         const EsdfOptions& options = {});

  std::string name() const override { return "esdf"; }
  DistanceQuality distance_quality() const override { return DistanceQuality::kApproximate; }
  const std::vector<int>& links() const override { return links_; }

  // See the header comment; `context` is ignored.
  double LinkPenalty(int link, const Pose& X_WL, const PenaltyParameters& parameters,
                     const QueryContext& context, LinkWrench* wrench) const override;
  // Smallest field value over the link's surface samples, at most search_radius.
  double LinkClearance(int link, const Pose& X_WL, double search_radius,
                       const QueryContext& context) const override;

  // Interpolated field at a world point, m; `gradient` (may be null) gets its
  // gradient (zero along an axis where p is outside the box).
  double Distance(const Vec3& p_W, Vec3* gradient = nullptr) const;

  const LinkSurfaceSamples& samples_of_link(int link) const { return samples_[slot_of_link_[link]]; }
  const EsdfOptions& options() const { return options_; }
  // Grid box: voxel centres from min_center() to max_center(), dims() per axis.
  const Vec3& min_center() const { return origin_; }
  Vec3 max_center() const { return origin_ + (dims_.cast<double>() - Vec3::Ones()) * options_.resolution; }
  Eigen::Vector3i dims() const { return dims_; }
  long num_occupied_voxels() const { return num_occupied_; }

  // Wall times of Create, s: OctoMap insertion, EDT initialisation and update
  // (DynamicEDT3D, the paper's "ESDF update"), copy into the dense grid, and
  // their sum (build_seconds; surface sampling not included).
  double octomap_seconds() const { return octomap_seconds_; }
  double edt_seconds() const { return edt_seconds_; }
  double grid_seconds() const { return grid_seconds_; }
  double build_seconds() const { return octomap_seconds_ + edt_seconds_ + grid_seconds_; }

 private:
  EsdfModel() = default;

  float Value(int i, int j, int k) const {
    return values_[(static_cast<long>(i) * dims_.y() + j) * dims_.z() + k];
  }

  EsdfOptions options_;
  std::vector<int> links_;
  std::vector<int> slot_of_link_;  // robot link index -> index into samples_ (-1 if none)
  std::vector<LinkSurfaceSamples> samples_;
  Vec3 origin_ = Vec3::Zero();  // centre of voxel (0, 0, 0)
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  std::vector<float> values_;  // z fastest (DynamicEDT3D's order)
  long num_occupied_ = 0;
  double octomap_seconds_ = 0.0;
  double edt_seconds_ = 0.0;
  double grid_seconds_ = 0.0;
};

}  // namespace quadhand::env
