// MRC-SDF (paper Sec. V): the raw obstacle point cloud queried against one
// pre-generated SDF per robot link. For a link at pose X_WL, each nearby
// obstacle point x is moved into the link frame, x_L = R_WL^T (x - p_WL), and
// its distance is SDF_link(x_L); the penalty is the smoothed L1 of
// threshold - distance, summed over points.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/geometry/sdf_grid.h"
#include "quadhand/scene/point_grid.h"

namespace quadhand::env {

struct MrcSdfOptions {
  double cell_size = 0.05;  // spatial index cell, metres
  // Cell of the coarse distance grid that lets a link far from every point
  // skip the spatial index (see MrcSdfModel::FarFromEveryPoint), metres.
  double far_cell_size = 0.05;
  // How far beyond the points' bounding box that grid extends, metres;
  // beyond it the distance to the bounding box is the bound.
  double far_padding = 0.5;
  // The grid's distances are searched out to this many cells (1..252);
  // beyond, a cell only knows it is farther (a link there is looked up in
  // the index). A local plan of onboard perception builds its model at
  // every replan over a box full of points, where the whole search would
  // dominate the replan's time (docs/perception.md).
  int far_max_steps = 252;

  bool IsValid(std::string* why) const;
};

// Link SDF grids held by more than one user; grids[i] belongs to links[i].
using SharedSdfGrids = std::shared_ptr<const std::vector<geometry::SdfGrid>>;

// Loads `<sdf_dir>/<link>.qhsdf` for every collision link of `robot`,
// checking each file's link name; errors name the file (a missing one says
// how to make it). The links in `given` (robot link index and its grid: a
// held object's, made in memory) take that grid instead of a file; it is
// moved, not copied.
core::Status LoadLinkSdfGrids(const robot::RobotModel& robot, const std::string& sdf_dir, std::vector<int>* links,
                              std::vector<geometry::SdfGrid>* grids,
                              std::vector<std::pair<int, geometry::SdfGrid>> given = {});

class MrcSdfModel final : public CollisionModel {
 public:
  // Loads `<sdf_dir>/<link>.qhsdf` for every collision link of `robot`
  // (checking each file's link name) and indexes the points (finite, world frame).
  static core::Result<std::unique_ptr<MrcSdfModel>> Create(const robot::RobotModel& robot,
                                                           const std::string& sdf_dir,
                                                           const std::vector<Vec3>& points,
                                                           const MrcSdfOptions& options = {});
  // From grids already in memory; grids[i] belongs to robot link links[i].
  static core::Result<std::unique_ptr<MrcSdfModel>> Create(std::vector<int> links,
                                                           std::vector<geometry::SdfGrid> grids,
                                                           const std::vector<Vec3>& points,
                                                           const MrcSdfOptions& options = {});
  // Both of the above with the cloud already indexed and shared (with the
  // post-check's exact clearance, say): the index's own cell size is used,
  // not options.cell_size.
  static core::Result<std::unique_ptr<MrcSdfModel>> Create(const robot::RobotModel& robot,
                                                           const std::string& sdf_dir,
                                                           std::shared_ptr<const scene::PointGrid> index,
                                                           const MrcSdfOptions& options = {});
  static core::Result<std::unique_ptr<MrcSdfModel>> Create(std::vector<int> links,
                                                           std::vector<geometry::SdfGrid> grids,
                                                           std::shared_ptr<const scene::PointGrid> index,
                                                           const MrcSdfOptions& options = {});
  // With the grids shared too (with the self-collision term, say).
  static core::Result<std::unique_ptr<MrcSdfModel>> Create(std::vector<int> links, SharedSdfGrids grids,
                                                           std::shared_ptr<const scene::PointGrid> index,
                                                           const MrcSdfOptions& options = {});

  std::string name() const override { return "mrc_sdf"; }
  DistanceQuality distance_quality() const override { return DistanceQuality::kExact; }
  const std::vector<int>& links() const override { return links_; }

  double LinkPenalty(int link, const Pose& X_WL, const PenaltyParameters& parameters,
                     const QueryContext& context, LinkWrench* wrench) const override;
  double LinkClearance(int link, const Pose& X_WL, double search_radius,
                       const QueryContext& context) const override;

  const geometry::SdfGrid& grid_of_link(int link) const { return (*grids_)[slot_of_link_[link]]; }
  const scene::PointGrid& points() const { return *points_; }

 private:
  MrcSdfModel(std::vector<int> links, SharedSdfGrids grids, std::shared_ptr<const scene::PointGrid> points);

  // Calls visit(x_W, x_L, distance, gradient_L) for obstacle points whose
  // distance to the link is below `reach`.
  template <typename Visitor>
  void VisitNearbyPoints(int link, const Pose& X_WL, double reach, Visitor&& visit) const;

  // True when no obstacle point can lie in the link's query box (its
  // geometry box grown by `reach`, placed at X_WL), so the box query would
  // visit nothing: a sphere around the box is tested against a lower bound
  // of the distance to the nearest point. Most samples of a trajectory are
  // in free space, where this replaces five spatial-index queries.
  bool FarFromEveryPoint(const geometry::SdfGrid& grid, const Pose& X_WL, double reach) const;
  void BuildFarGrid(const std::vector<Vec3>& points, const MrcSdfOptions& options);

  std::vector<int> links_;
  std::vector<int> slot_of_link_;  // robot link index -> index into grids_ (-1 if none)
  SharedSdfGrids grids_;
  std::shared_ptr<const scene::PointGrid> points_;
  // Chebyshev distance, in cells (saturating at 253), from each cell of a
  // grid over the points' bounding box (plus padding; stored with a one-cell
  // border) to the nearest cell holding a point: a point in a cell k cells
  // away is at least (k - 1) cells far.
  std::vector<unsigned char> far_cells_;
  Eigen::Vector3i far_dims_ = Eigen::Vector3i::Zero();
  Vec3 far_origin_ = Vec3::Zero();
  double far_cell_ = 0.0;
  Vec3 points_min_ = Vec3::Zero(), points_max_ = Vec3::Zero();
};

}  // namespace quadhand::env
