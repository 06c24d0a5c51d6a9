#include "quadhand/env/esdf_model.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <dynamicEDT3D/dynamicEDTOctomap.h>
#include <octomap/OcTree.h>

#include "quadhand/opt/penalty.h"
#include "quadhand/robot/link_meshes.h"

namespace quadhand::env {
namespace {

// Bound on |grad| of the interpolated field (sqrt(3) for a 1-Lipschitz EDT),
// with room for DynamicEDT3D's small propagation errors.
constexpr double kLipschitz = 2.0;

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

bool Positive(double x) { return std::isfinite(x) && x > 0.0; }

}  // namespace

bool EsdfOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (!Positive(resolution)) return fail("esdf resolution must be a positive number of metres");
  if (!Positive(max_distance) || max_distance < 2.0 * resolution) {
    return fail("esdf max_distance must be at least two voxels");
  }
  if (!(std::isfinite(box_margin) && box_margin >= 0.0)) return fail("esdf box_margin must be >= 0 metres");
  if (!Positive(surface_spacing)) return fail("esdf surface_spacing must be a positive number of metres");
  if (max_cells <= 0) return fail("esdf max_cells must be positive");
  return true;
}

core::Result<std::unique_ptr<EsdfModel>> EsdfModel::Create(const robot::RobotModel& robot,
                                                           const std::vector<Vec3>& points,
                                                           const EsdfOptions& options) {
  std::vector<int> links = robot.CollisionLinks();
  std::vector<geometry::TriangleMesh> meshes;
  for (int link : links) {
    auto mesh = robot::LinkCollisionMesh(robot, link);
    if (!mesh.ok()) return mesh.status().WithPrefix("esdf: link '" + robot.link(link).name + "'");
    meshes.push_back(std::move(*mesh));
  }
  return Create(std::move(links), meshes, points, options);
}

core::Result<std::unique_ptr<EsdfModel>> EsdfModel::Create(std::vector<int> links,
                                                           const std::vector<geometry::TriangleMesh>& meshes,
                                                           const std::vector<Vec3>& points,
                                                           const EsdfOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(why);
  if (links.empty() || links.size() != meshes.size()) {
    return core::Status::InvalidArgument("esdf: need one mesh per collision link");
  }
  for (int link : links) {
    if (link < 0) return core::Status::InvalidArgument("esdf: negative link index");
  }
  if (points.empty()) return core::Status::InvalidArgument("esdf: the obstacle cloud is empty");
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const Vec3& p : points) {
    if (!p.allFinite()) return core::Status::InvalidArgument("esdf: obstacle points must be finite");
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }

  std::unique_ptr<EsdfModel> model(new EsdfModel());
  model->options_ = options;
  model->links_ = std::move(links);
  model->slot_of_link_ = SlotsOfLinks(model->links_);
  for (size_t i = 0; i < model->links_.size(); ++i) {
    const core::Status fits =
        CheckSurfaceSampleCount(meshes[i], options.surface_spacing, "esdf: collision link " + std::to_string(model->links_[i]));
    if (!fits.ok()) return fits;
    model->samples_.push_back(SampleLinkSurface(meshes[i], options.surface_spacing));
  }

  // The field's box; at least two voxel centres per axis so interpolation is defined.
  const double res = options.resolution;
  lo -= Vec3::Constant(options.box_margin);
  hi += Vec3::Constant(options.box_margin);
  hi = hi.cwiseMax(lo + Vec3::Constant(1.5 * res));

  auto start = std::chrono::steady_clock::now();
  octomap::OcTree tree(res);
  const octomap::point3d bbx_min(static_cast<float>(lo.x()), static_cast<float>(lo.y()), static_cast<float>(lo.z()));
  const octomap::point3d bbx_max(static_cast<float>(hi.x()), static_cast<float>(hi.y()), static_cast<float>(hi.z()));
  octomap::OcTreeKey min_key, max_key;
  if (!tree.coordToKeyChecked(bbx_min, min_key) || !tree.coordToKeyChecked(bbx_max, max_key)) {
    return core::Status::InvalidArgument("esdf: the cloud's box exceeds OctoMap's range at this resolution");
  }
  for (int a = 0; a < 3; ++a) model->dims_[a] = static_cast<int>(max_key[a]) - static_cast<int>(min_key[a]) + 1;
  const long cells = static_cast<long>(model->dims_.x()) * model->dims_.y() * model->dims_.z();
  if (cells > options.max_cells) {
    return core::Status::InvalidArgument("esdf: the field box needs " + std::to_string(cells) +
                                         " voxels, more than max_cells = " + std::to_string(options.max_cells));
  }
  octomap::KeySet occupied;
  for (const Vec3& p : points) {
    octomap::OcTreeKey key;
    if (tree.coordToKeyChecked(p.x(), p.y(), p.z(), key)) occupied.insert(key);
  }
  for (const octomap::OcTreeKey& key : occupied) tree.updateNode(key, true, /*lazy_eval=*/true);
  tree.updateInnerOccupancy();
  model->num_occupied_ = static_cast<long>(occupied.size());
  model->octomap_seconds_ = SecondsSince(start);

  start = std::chrono::steady_clock::now();
  // Unknown space (everything not hit) is free; the tree holds only hits.
  DynamicEDTOctomap edt(static_cast<float>(options.max_distance), &tree, bbx_min, bbx_max,
                        /*treatUnknownAsOccupied=*/false);
  edt.update(/*updateRealDist=*/true);
  model->edt_seconds_ = SecondsSince(start);

  start = std::chrono::steady_clock::now();
  const octomap::point3d origin = tree.keyToCoord(min_key);
  model->origin_ = Vec3(origin.x(), origin.y(), origin.z());
  model->values_.resize(cells);
  const float cap = static_cast<float>(options.max_distance);
  long n = 0;
  for (int i = 0; i < model->dims_.x(); ++i) {
    for (int j = 0; j < model->dims_.y(); ++j) {
      for (int k = 0; k < model->dims_.z(); ++k) {
        const octomap::OcTreeKey key(static_cast<octomap::key_type>(min_key[0] + i),
                                     static_cast<octomap::key_type>(min_key[1] + j),
                                     static_cast<octomap::key_type>(min_key[2] + k));
        const float d = edt.getDistance(key);
        // distanceValue_Error (-1) cannot happen inside the box; treat it as far.
        model->values_[n++] = d < 0.0f ? cap : std::min(d, cap);
      }
    }
  }
  model->grid_seconds_ = SecondsSince(start);
  return model;
}

double EsdfModel::Distance(const Vec3& p_W, Vec3* gradient) const {
  const double res = options_.resolution;
  int i0[3];
  double t[3];
  bool inside[3];
  for (int a = 0; a < 3; ++a) {
    const double top = dims_[a] - 1;
    double u = (p_W[a] - origin_[a]) / res;
    inside[a] = u >= 0.0 && u <= top;
    u = std::clamp(u, 0.0, top);
    i0[a] = std::min(static_cast<int>(u), dims_[a] - 2);
    t[a] = u - i0[a];
  }
  const int x = i0[0], y = i0[1], z = i0[2];
  const double v000 = Value(x, y, z), v100 = Value(x + 1, y, z);
  const double v010 = Value(x, y + 1, z), v110 = Value(x + 1, y + 1, z);
  const double v001 = Value(x, y, z + 1), v101 = Value(x + 1, y, z + 1);
  const double v011 = Value(x, y + 1, z + 1), v111 = Value(x + 1, y + 1, z + 1);
  const double tx = t[0], ty = t[1], tz = t[2];
  const double c00 = v000 + tx * (v100 - v000), c10 = v010 + tx * (v110 - v010);
  const double c01 = v001 + tx * (v101 - v001), c11 = v011 + tx * (v111 - v011);
  const double c0 = c00 + ty * (c10 - c00), c1 = c01 + ty * (c11 - c01);
  if (gradient != nullptr) {
    const double dx = ((v100 - v000) * (1 - ty) + (v110 - v010) * ty) * (1 - tz) +
                      ((v101 - v001) * (1 - ty) + (v111 - v011) * ty) * tz;
    const double dy = (c10 - c00) * (1 - tz) + (c11 - c01) * tz;
    const double dz = c1 - c0;
    *gradient = Vec3(inside[0] ? dx / res : 0.0, inside[1] ? dy / res : 0.0, inside[2] ? dz / res : 0.0);
  }
  return c0 + tz * (c1 - c0);
}

double EsdfModel::LinkPenalty(int link, const Pose& X_WL, const PenaltyParameters& parameters,
                              const QueryContext& /*context*/, LinkWrench* wrench) const {
  const LinkSurfaceSamples& samples = samples_[slot_of_link_[link]];
  const Mat3& R = X_WL.linear();
  const Vec3& t = X_WL.translation();
  const double res = options_.resolution;
  double cost = 0.0;
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
  for (const LinkSurfaceSamples::Cluster& cluster : samples.clusters) {
    // Every sample of the cluster is provably beyond the threshold.
    if (Distance(R * cluster.center + t) - kLipschitz * cluster.radius - res >= parameters.threshold) continue;
    for (int s = cluster.begin; s < cluster.end; ++s) {
      const Vec3 r_W = R * samples.points[s];
      Vec3 gradient;
      const double d = Distance(r_W + t, wrench != nullptr ? &gradient : nullptr);
      if (d >= parameters.threshold) continue;
      double slope;
      cost += opt::SmoothedL1(parameters.threshold - d, parameters.mu, &slope);
      if (wrench == nullptr || slope == 0.0) continue;
      const Vec3 dcost_dx = -slope * gradient;
      force += dcost_dx;
      torque += r_W.cross(dcost_dx);
    }
  }
  if (wrench != nullptr) {
    wrench->force += force;
    wrench->torque += torque;
  }
  return cost;
}

double EsdfModel::LinkClearance(int link, const Pose& X_WL, double search_radius,
                                const QueryContext& /*context*/) const {
  const LinkSurfaceSamples& samples = samples_[slot_of_link_[link]];
  double clearance = search_radius;
  for (const LinkSurfaceSamples::Cluster& cluster : samples.clusters) {
    if (Distance(X_WL * cluster.center) - kLipschitz * cluster.radius - options_.resolution >= clearance) continue;
    for (int s = cluster.begin; s < cluster.end; ++s) clearance = std::min(clearance, Distance(X_WL * samples.points[s]));
  }
  return clearance;
}

}  // namespace quadhand::env
