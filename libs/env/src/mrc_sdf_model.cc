#include "quadhand/env/mrc_sdf_model.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <optional>

#include "quadhand/core/worker_pool.h"
#include "quadhand/opt/penalty.h"
#include "quadhand/robot/link_sdfs.h"

namespace quadhand::env {

bool MrcSdfOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(cell_size) && cell_size > 0.0 && std::isfinite(far_cell_size) && far_cell_size > 0.0)) {
    if (why != nullptr) *why = "mrc_sdf cell_size and far_cell_size must be positive numbers of metres";
    return false;
  }
  if (far_max_steps < 1 || far_max_steps > 252) {
    if (why != nullptr) *why = "mrc_sdf far_max_steps must be in [1, 252]";
    return false;
  }
  if (!(std::isfinite(far_padding) && far_padding >= 0.0)) {
    if (why != nullptr) *why = "mrc_sdf far_padding must be >= 0";
    return false;
  }
  return true;
}

MrcSdfModel::MrcSdfModel(std::vector<int> links, SharedSdfGrids grids, std::shared_ptr<const scene::PointGrid> points)
    : links_(std::move(links)), slot_of_link_(SlotsOfLinks(links_)), grids_(std::move(grids)), points_(std::move(points)) {}

void MrcSdfModel::BuildFarGrid(const std::vector<Vec3>& points, const MrcSdfOptions& options) {
  far_cells_.clear();
  if (points.empty()) return;
  points_min_ = points_max_ = points.front();
  for (const Vec3& p : points) {
    points_min_ = points_min_.cwiseMin(p);
    points_max_ = points_max_.cwiseMax(p);
  }
  // A cloud with far outliers must not make the grid explode: coarsen.
  far_cell_ = options.far_cell_size;
  const Vec3 extent = (points_max_ - points_min_).array() + 2.0 * options.far_padding;
  auto cells = [&](int axis) { return std::floor(extent[axis] / far_cell_) + 1; };
  while (cells(0) * cells(1) * cells(2) > double(1 << 24)) far_cell_ *= 2.0;
  far_origin_ = points_min_ - Vec3::Constant(options.far_padding);
  for (int axis = 0; axis < 3; ++axis) far_dims_[axis] = static_cast<int>(cells(axis));
  // The grid is stored with a one-cell border on every side, so that the
  // search below needs no bounds checks; the border is never expanded.
  const long nx = far_dims_.x() + 2, ny = far_dims_.y() + 2, nz = far_dims_.z() + 2;
  constexpr unsigned char kUnvisited = 255, kBorder = 254;
  far_cells_.assign(nx * ny * nz, kUnvisited);
  for (long z = 0; z < nz; ++z)
    for (long y = 0; y < ny; ++y)
      for (long x = 0; x < nx; ++x) {
        if (x == 0 || y == 0 || z == 0 || x == nx - 1 || y == ny - 1 || z == nz - 1) {
          far_cells_[x + nx * (y + ny * z)] = kBorder;
        }
      }
  // Multi-source breadth-first search over the 26 neighbours: the number of
  // steps is the Chebyshev distance in cells.
  std::vector<long> frontier, next;
  for (const Vec3& p : points) {
    const Eigen::Vector3i c = ((p - far_origin_) / far_cell_).array().floor().cast<int>().max(0).min(
        far_dims_.array() - 1).matrix();
    const long index = (c.x() + 1) + nx * ((c.y() + 1) + ny * static_cast<long>(c.z() + 1));
    if (far_cells_[index] != 0) {
      far_cells_[index] = 0;
      frontier.push_back(index);
    }
  }
  std::vector<long> offsets;
  for (long dz = -1; dz <= 1; ++dz)
    for (long dy = -1; dy <= 1; ++dy)
      for (long dx = -1; dx <= 1; ++dx)
        if (dx != 0 || dy != 0 || dz != 0) offsets.push_back(dx + nx * (dy + ny * dz));
  for (int step = 1; step <= options.far_max_steps && !frontier.empty(); ++step) {
    next.clear();
    for (long index : frontier) {
      for (long offset : offsets) {
        unsigned char& neighbour = far_cells_[index + offset];
        if (neighbour == kUnvisited) {
          neighbour = static_cast<unsigned char>(step);
          next.push_back(index + offset);
        }
      }
    }
    frontier.swap(next);
  }
  // Cells never reached are more than far_max_steps cells away (saturated).
  const auto beyond = static_cast<unsigned char>(options.far_max_steps + 1);
  for (unsigned char& c : far_cells_) {
    if (c == kUnvisited) c = beyond;
  }
}

bool MrcSdfModel::FarFromEveryPoint(const geometry::SdfGrid& grid, const Pose& X_WL, double reach) const {
  if (far_cells_.empty()) return points_->num_points() == 0;
  // The query box (geometry box +- reach, link frame) lies in this sphere.
  const Vec3 half = 0.5 * (grid.info().geometry_max - grid.info().geometry_min) + Vec3::Constant(reach);
  const double radius = half.norm();
  const Vec3 center = X_WL * (0.5 * (grid.info().geometry_min + grid.info().geometry_max));
  const Vec3 u = (center - far_origin_) / far_cell_;
  if (!(u.array() >= 0.0).all() || !(u.array() < far_dims_.cast<double>().array()).all()) {
    // Outside the grid (or not finite): the distance to the points' bounding box.
    const Vec3 outside = (points_min_ - center).cwiseMax(center - points_max_).cwiseMax(0.0);
    return outside.norm() > radius;  // false for NaN
  }
  const long nx = far_dims_.x() + 2, ny = far_dims_.y() + 2;  // with the border
  const long index = (static_cast<long>(u.x()) + 1) +
                     nx * ((static_cast<long>(u.y()) + 1) + ny * (static_cast<long>(u.z()) + 1));
  return (far_cells_[index] - 1.0) * far_cell_ > radius;
}

core::Result<std::unique_ptr<MrcSdfModel>> MrcSdfModel::Create(std::vector<int> links,
                                                               std::vector<geometry::SdfGrid> grids,
                                                               const std::vector<Vec3>& points,
                                                               const MrcSdfOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(why);
  for (const Vec3& p : points) {
    if (!p.allFinite()) return core::Status::InvalidArgument("mrc_sdf: obstacle points must be finite");
  }
  return Create(std::move(links), std::move(grids), std::make_shared<const scene::PointGrid>(points, options.cell_size),
                options);
}

core::Result<std::unique_ptr<MrcSdfModel>> MrcSdfModel::Create(std::vector<int> links,
                                                               std::vector<geometry::SdfGrid> grids,
                                                               std::shared_ptr<const scene::PointGrid> index,
                                                               const MrcSdfOptions& options) {
  return Create(std::move(links), std::make_shared<const std::vector<geometry::SdfGrid>>(std::move(grids)),
                std::move(index), options);
}

core::Result<std::unique_ptr<MrcSdfModel>> MrcSdfModel::Create(std::vector<int> links, SharedSdfGrids grids,
                                                               std::shared_ptr<const scene::PointGrid> index,
                                                               const MrcSdfOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(why);
  if (grids == nullptr || links.size() != grids->size() || links.empty()) {
    return core::Status::InvalidArgument("mrc_sdf: need one SDF per collision link");
  }
  for (int link : links) {
    if (link < 0) return core::Status::InvalidArgument("mrc_sdf: negative link index");
  }
  if (index == nullptr) return core::Status::InvalidArgument("mrc_sdf: no indexed cloud");
  std::unique_ptr<MrcSdfModel> model(new MrcSdfModel(std::move(links), std::move(grids), index));
  model->BuildFarGrid(index->points(), options);
  return model;
}

core::Status LoadLinkSdfGrids(const robot::RobotModel& robot, const std::string& sdf_dir, std::vector<int>* links_out,
                              std::vector<geometry::SdfGrid>* grids_out,
                              std::vector<std::pair<int, geometry::SdfGrid>> given) {
  std::vector<int> links = robot.CollisionLinks();
  auto given_grid = [&given](int link) -> geometry::SdfGrid* {
    for (auto& [index, grid] : given) {
      if (index == link) return &grid;
    }
    return nullptr;
  };
  std::vector<std::string> paths;
  for (int link : links) {
    if (given_grid(link) != nullptr) {
      paths.emplace_back();
      continue;
    }
    auto sdf_path = robot::LinkSdfPath(sdf_dir, robot.link(link).name);
    if (!sdf_path.ok()) return sdf_path.status();
    paths.push_back(*sdf_path);
  }
  // The files are read and verified in parallel (tens of megabytes each for
  // a CAD robot); errors are reported in link order, whatever the threads.
  std::vector<std::optional<core::Result<geometry::SdfGrid>>> loaded(links.size());
  std::atomic<size_t> next{0};
  core::WorkerPool pool(core::WorkerCount(0, static_cast<int>(std::max<size_t>(1, links.size()))));
  pool.Run([&](int) {
    for (size_t i = next++; i < links.size(); i = next++) {
      geometry::SdfGrid* grid = given_grid(links[i]);  // each link's own: no two threads share one
      loaded[i].emplace(grid != nullptr ? core::Result<geometry::SdfGrid>(std::move(*grid))
                                        : geometry::SdfGrid::Load(paths[i]));
    }
  });
  std::vector<geometry::SdfGrid> grids;
  for (size_t i = 0; i < links.size(); ++i) {
    const std::string& name = robot.link(links[i]).name;
    const std::string& path = paths[i];
    core::Result<geometry::SdfGrid>& grid = *loaded[i];
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
  *links_out = std::move(links);
  *grids_out = std::move(grids);
  return core::Status::Ok();
}

core::Result<std::unique_ptr<MrcSdfModel>> MrcSdfModel::Create(const robot::RobotModel& robot,
                                                               const std::string& sdf_dir,
                                                               const std::vector<Vec3>& points,
                                                               const MrcSdfOptions& options) {
  std::vector<int> links;
  std::vector<geometry::SdfGrid> grids;
  QUADHAND_RETURN_IF_ERROR(LoadLinkSdfGrids(robot, sdf_dir, &links, &grids));
  return Create(std::move(links), std::move(grids), points, options);
}

core::Result<std::unique_ptr<MrcSdfModel>> MrcSdfModel::Create(const robot::RobotModel& robot,
                                                               const std::string& sdf_dir,
                                                               std::shared_ptr<const scene::PointGrid> index,
                                                               const MrcSdfOptions& options) {
  std::vector<int> links;
  std::vector<geometry::SdfGrid> grids;
  QUADHAND_RETURN_IF_ERROR(LoadLinkSdfGrids(robot, sdf_dir, &links, &grids));
  return Create(std::move(links), std::move(grids), std::move(index), options);
}

template <typename Visitor>
void MrcSdfModel::VisitNearbyPoints(int link, const Pose& X_WL, double reach, Visitor&& visit) const {
  const geometry::SdfGrid& grid = (*grids_)[slot_of_link_[link]];
  if (FarFromEveryPoint(grid, X_WL, reach)) return;
  const Vec3 box_lo = grid.info().geometry_min - Vec3::Constant(reach);
  const Vec3 box_hi = grid.info().geometry_max + Vec3::Constant(reach);
  // World-frame bounding box of the link-frame box, for the spatial index.
  const Mat3& R = X_WL.linear();
  const Vec3 center_W = X_WL * (0.5 * (box_lo + box_hi));
  const Vec3 half_W = R.cwiseAbs() * (0.5 * (box_hi - box_lo));
  const Vec3& t = X_WL.translation();
  points_->VisitBox(center_W - half_W, center_W + half_W, [&](const Vec3& x_W) {
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
