#include "quadhand/env/mrc_sdf_model.h"

#include <cmath>

#include "quadhand/opt/penalty.h"

namespace quadhand::env {

bool MrcSdfOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(cell_size) && cell_size > 0.0)) {
    if (why != nullptr) *why = "mrc_sdf cell_size must be a positive number of metres";
    return false;
  }
  return true;
}

MrcSdfModel::MrcSdfModel(std::vector<int> links, std::vector<geometry::SdfGrid> grids, scene::PointGrid points)
    : links_(std::move(links)), slot_of_link_(SlotsOfLinks(links_)), grids_(std::move(grids)), points_(std::move(points)) {}

core::Result<std::unique_ptr<MrcSdfModel>> MrcSdfModel::Create(std::vector<int> links,
                                                               std::vector<geometry::SdfGrid> grids,
                                                               const std::vector<Vec3>& points,
                                                               const MrcSdfOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(why);
  if (links.size() != grids.size() || links.empty()) {
    return core::Status::InvalidArgument("mrc_sdf: need one SDF per collision link");
  }
  for (int link : links) {
    if (link < 0) return core::Status::InvalidArgument("mrc_sdf: negative link index");
  }
  for (const Vec3& p : points) {
    if (!p.allFinite()) return core::Status::InvalidArgument("mrc_sdf: obstacle points must be finite");
  }
  return std::unique_ptr<MrcSdfModel>(
      new MrcSdfModel(std::move(links), std::move(grids), scene::PointGrid(points, options.cell_size)));
}

core::Result<std::unique_ptr<MrcSdfModel>> MrcSdfModel::Create(const robot::RobotModel& robot,
                                                               const std::string& sdf_dir,
                                                               const std::vector<Vec3>& points,
                                                               const MrcSdfOptions& options) {
  std::vector<int> links = robot.CollisionLinks();
  std::vector<geometry::SdfGrid> grids;
  for (int link : links) {
    const std::string& name = robot.link(link).name;
    const std::string path = sdf_dir + "/" + name + ".qhsdf";
    auto grid = geometry::SdfGrid::Load(path);
    if (!grid.ok()) {
      if (grid.status().code() == core::StatusCode::kNotFound) {
        return core::Status::NotFound(path + ": missing link SDF (generate it with quadhand-sdfgen --urdf)");
      }
      return grid.status();
    }
    if (grid->info().link_name != name) {
      return core::Status::InvalidArgument(path + ": holds the SDF of link '" + grid->info().link_name +
                                           "', expected '" + name + "'");
    }
    grids.push_back(std::move(*grid));
  }
  return Create(std::move(links), std::move(grids), points, options);
}

template <typename Visitor>
void MrcSdfModel::VisitNearbyPoints(int link, const Pose& X_WL, double reach, Visitor&& visit) const {
  const geometry::SdfGrid& grid = grids_[slot_of_link_[link]];
  const Vec3 box_lo = grid.info().geometry_min - Vec3::Constant(reach);
  const Vec3 box_hi = grid.info().geometry_max + Vec3::Constant(reach);
  // World-frame bounding box of the link-frame box, for the spatial index.
  const Mat3& R = X_WL.linear();
  const Vec3 center_W = X_WL * (0.5 * (box_lo + box_hi));
  const Vec3 half_W = R.cwiseAbs() * (0.5 * (box_hi - box_lo));
  const Vec3& t = X_WL.translation();
  points_.VisitBox(center_W - half_W, center_W + half_W, [&](const Vec3& x_W) {
    const Vec3 x_L = R.transpose() * (x_W - t);
    if ((x_L.array() < box_lo.array()).any() || (x_L.array() > box_hi.array()).any()) return;
    double distance;
    Vec3 gradient_L;
    // Most points in the box are farther than `reach`; the block minima of
    // the grid reject them without touching the full-resolution values.
    if (grid.EvaluateBelow(x_L, reach, &distance, &gradient_L) && distance < reach) visit(x_W, distance, gradient_L);
  });
}

double MrcSdfModel::LinkPenalty(int link, const Pose& X_WL, const PenaltyParameters& parameters,
                                const QueryContext& /*context*/, LinkWrench* wrench) const {
  double cost = 0.0;
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
  const Mat3& R = X_WL.linear();
  const Vec3& t = X_WL.translation();
  VisitNearbyPoints(link, X_WL, parameters.threshold, [&](const Vec3& x_W, double distance, const Vec3& gradient_L) {
    double slope;
    cost += opt::SmoothedL1(parameters.threshold - distance, parameters.mu, &slope);
    if (wrench == nullptr || slope == 0.0) return;
    // d distance / d(link translation) = -g_W and / d(link rotation) = g_W x (x - t),
    // and d cost / d distance = -slope.
    const Vec3 gradient_W = R * gradient_L;
    force += slope * gradient_W;
    torque -= slope * gradient_W.cross(x_W - t);
  });
  if (wrench != nullptr) {
    wrench->force += force;
    wrench->torque += torque;
  }
  return cost;
}

double MrcSdfModel::LinkClearance(int link, const Pose& X_WL, double search_radius,
                                  const QueryContext& /*context*/) const {
  double clearance = search_radius;
  VisitNearbyPoints(link, X_WL, search_radius,
                    [&](const Vec3&, double distance, const Vec3&) { clearance = std::min(clearance, distance); });
  return clearance;
}

}  // namespace quadhand::env
