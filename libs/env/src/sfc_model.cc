#include "quadhand/env/sfc_model.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include "quadhand/opt/penalty.h"
#include "quadhand/robot/link_meshes.h"

namespace quadhand::env {
namespace {

bool Positive(double x) { return std::isfinite(x) && x > 0.0; }

// A right-handed orthonormal frame whose first column is `x` (unit).
Mat3 FrameAlong(const Vec3& x) {
  const Vec3 helper = std::abs(x.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 y = x.cross(helper).normalized();
  Mat3 frame;
  frame << x, y, x.cross(y);
  return frame;
}

double PointSegmentDistance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double length2 = ab.squaredNorm();
  const double s = length2 > 0.0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (p - (a + s * ab)).norm();
}

}  // namespace

bool SfcOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (!Positive(local_margin)) return fail("sfc local_margin must be a positive number of metres");
  if (!Positive(surface_spacing)) return fail("sfc surface_spacing must be a positive number of metres");
  if (!Positive(cell_size)) return fail("sfc cell_size must be a positive number of metres");
  if (max_faces < 1) return fail("sfc max_faces must be at least 1");
  return true;
}

double Polytope::Margin(const Vec3& p) const {
  double margin = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < normals.size(); ++k) margin = std::min(margin, offsets[k] - normals[k].dot(p));
  return margin;
}

core::Result<Polytope> InflateSegment(const Vec3& begin, const Vec3& end, const scene::PointGrid& obstacles,
                                      const SfcOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(why);
  if (!begin.allFinite() || !end.allFinite()) return core::Status::InvalidArgument("sfc: non-finite seed segment");
  const double length = (end - begin).norm();
  if (length < 1e-9) return core::Status::InvalidArgument("sfc: degenerate seed segment (its ends coincide)");

  Polytope polytope;
  polytope.seed_begin = begin;
  polytope.seed_end = end;
  const Vec3 center = 0.5 * (begin + end);
  Mat3 frame = FrameAlong((end - begin) / length);

  // 1. Local box in the segment's frame.
  const Vec3 half(0.5 * length + options.local_margin, options.local_margin, options.local_margin);
  for (int a = 0; a < 3; ++a) {
    const Vec3 axis = frame.col(a);
    polytope.normals.push_back(axis);
    polytope.offsets.push_back(axis.dot(center) + half[a]);
    polytope.normals.push_back(-axis);
    polytope.offsets.push_back(-axis.dot(center) + half[a]);
  }
  polytope.num_box_faces = 6;
  const Vec3 half_W = frame.cwiseAbs() * half;
  std::vector<Vec3> local;  // obstacle points in the box, segment frame relative to the centre
  bool on_segment = false;
  obstacles.VisitBox(center - half_W, center + half_W, [&](const Vec3& p) {
    const Vec3 q = frame.transpose() * (p - center);
    if ((q.cwiseAbs().array() > half.array()).any()) return;
    if (std::abs(q.x()) <= 0.5 * length && std::hypot(q.y(), q.z()) < 1e-9) on_segment = true;
    local.push_back(q);
  });
  if (on_segment) return core::Status::InvalidArgument("sfc: an obstacle point lies on the seed segment");

  // 2. Ellipsoid. Semi-axes a (along the segment), b, c. For b = c the
  // ellipsoid is symmetric about x, so the shrinking of Liu et al. ends at the
  // smallest b any point needs to lie on or outside it, turned to that point.
  const double a = 0.5 * length;
  double b = a, roll = 0.0;
  for (const Vec3& q : local) {
    const double along = 1.0 - (q.x() / a) * (q.x() / a);
    if (along <= 0.0) continue;
    const double rho = std::hypot(q.y(), q.z());
    const double needed = rho / std::sqrt(along);
    if (needed < b) {
      b = needed;
      roll = std::atan2(q.z(), q.y());
    }
  }
  const Mat3 turn = Eigen::AngleAxisd(roll, Vec3::UnitX()).toRotationMatrix();
  frame = frame * turn;
  for (Vec3& q : local) q = turn.transpose() * q;
  double c = a;
  for (const Vec3& q : local) {
    const double left = 1.0 - (q.x() / a) * (q.x() / a) - (q.y() / b) * (q.y() / b);
    if (left <= 0.0) continue;
    c = std::min(c, std::abs(q.z()) / std::sqrt(left));
  }
  b = std::max(b, 1e-12);
  c = std::max(c, b);  // after the first pass no point needs c < b (and b = c is the upper bound a)
  const Vec3 axes(a, b, c);
  polytope.ellipsoid_center = center;
  polytope.ellipsoid_axes = frame * axes.asDiagonal();

  // 3. Tangent half-spaces, nearest point (in the ellipsoid's metric) first.
  const Vec3 inverse_axes2 = axes.cwiseProduct(axes).cwiseInverse();
  std::vector<double> metric(local.size());
  for (size_t i = 0; i < local.size(); ++i) metric[i] = local[i].cwiseQuotient(axes).squaredNorm();
  std::vector<int> remaining(local.size());
  std::iota(remaining.begin(), remaining.end(), 0);
  std::sort(remaining.begin(), remaining.end(), [&](int x, int y) { return metric[x] < metric[y]; });
  int faces = 0;
  while (!remaining.empty()) {
    if (faces == options.max_faces) {
      return core::Status::Infeasible("sfc: " + std::to_string(options.max_faces) +
                                      " faces leave obstacle points in the polytope (raise max_faces)");
    }
    const Vec3 q = local[remaining.front()];
    const Vec3 n = q.cwiseProduct(inverse_axes2).normalized();  // ellipsoid frame
    const double offset = n.dot(q);
    const Vec3 n_W = frame * n;
    polytope.normals.push_back(n_W);
    polytope.offsets.push_back(n_W.dot(center) + offset);
    ++faces;
    // Keep, still sorted, the points strictly inside the new face.
    size_t kept = 0;
    for (size_t i = 1; i < remaining.size(); ++i) {
      if (n.dot(local[remaining[i]]) - offset < -1e-9) remaining[kept++] = remaining[i];
    }
    remaining.resize(kept);
  }
  return polytope;
}

core::Result<std::unique_ptr<SfcModel>> SfcModel::Create(const robot::RobotModel& robot,
                                                          const std::vector<Vec3>& points,
                                                          const std::vector<Vec3>& path, const SfcOptions& options) {
  std::vector<int> links = robot.CollisionLinks();
  std::vector<geometry::TriangleMesh> meshes;
  for (int link : links) {
    auto mesh = robot::LinkCollisionMesh(robot, link);
    if (!mesh.ok()) return mesh.status().WithPrefix("sfc: link '" + robot.link(link).name + "'");
    meshes.push_back(std::move(*mesh));
  }
  return Create(std::move(links), meshes, points, path, options);
}

core::Result<std::unique_ptr<SfcModel>> SfcModel::Create(std::vector<int> links,
                                                          const std::vector<geometry::TriangleMesh>& meshes,
                                                          const std::vector<Vec3>& points,
                                                          const std::vector<Vec3>& path, const SfcOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument(why);
  if (links.empty() || links.size() != meshes.size()) {
    return core::Status::InvalidArgument("sfc: need one mesh per collision link");
  }
  for (int link : links) {
    if (link < 0) return core::Status::InvalidArgument("sfc: negative link index");
  }
  if (points.empty()) return core::Status::InvalidArgument("sfc: the obstacle cloud is empty");
  for (const Vec3& p : points) {
    if (!p.allFinite()) return core::Status::InvalidArgument("sfc: obstacle points must be finite");
  }
  if (path.size() < 2) return core::Status::InvalidArgument("sfc: the path needs at least two points");

  std::unique_ptr<SfcModel> model(new SfcModel());
  model->options_ = options;
  model->links_ = std::move(links);
  model->slot_of_link_ = SlotsOfLinks(model->links_);
  for (size_t i = 0; i < model->links_.size(); ++i) {
    const core::Status fits =
        CheckSurfaceSampleCount(meshes[i], options.surface_spacing, "sfc: collision link " + std::to_string(model->links_[i]));
    if (!fits.ok()) return fits;
    model->samples_.push_back(SampleLinkSurface(meshes[i], options.surface_spacing));
  }

  const auto start = std::chrono::steady_clock::now();
  const scene::PointGrid grid(points, options.cell_size);
  for (size_t s = 0; s + 1 < path.size(); ++s) {
    auto polytope = InflateSegment(path[s], path[s + 1], grid, options);
    if (!polytope.ok()) return polytope.status().WithPrefix("path segment " + std::to_string(s));
    model->polytopes_.push_back(std::move(*polytope));
  }
  model->corridor_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return model;
}

core::Status SfcModel::SetPieceAssignment(std::vector<int> polytope_of_piece) {
  for (int index : polytope_of_piece) {
    if (index < 0 || index >= num_polytopes()) {
      return core::Status::InvalidArgument("sfc: piece assigned to polytope " + std::to_string(index) + " of " +
                                           std::to_string(num_polytopes()));
    }
  }
  polytope_of_piece_ = std::move(polytope_of_piece);
  return core::Status::Ok();
}

int SfcModel::PolytopeOf(const QueryContext& context) const {
  if (context.piece < 0) return -1;
  if (!polytope_of_piece_.empty()) {
    return context.piece < static_cast<int>(polytope_of_piece_.size()) ? polytope_of_piece_[context.piece] : -1;
  }
  return context.piece < num_polytopes() ? context.piece : -1;
}

double SfcModel::PolytopePenalty(const Polytope& polytope, const LinkSurfaceSamples& samples, const Pose& X_WL,
                                 const PenaltyParameters& parameters, LinkWrench* wrench) const {
  const Mat3& R = X_WL.linear();
  const Vec3& t = X_WL.translation();
  const double margin = parameters.threshold;
  double cost = 0.0;
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
  std::vector<int> active;
  for (const LinkSurfaceSamples::Cluster& cluster : samples.clusters) {
    // Faces that some sample of the cluster may come within `margin` of.
    const Vec3 center_W = R * cluster.center + t;
    active.clear();
    for (int k = 0; k < polytope.num_faces(); ++k) {
      if (polytope.normals[k].dot(center_W) - polytope.offsets[k] + cluster.radius + margin > 0.0) active.push_back(k);
    }
    if (active.empty()) continue;
    for (int s = cluster.begin; s < cluster.end; ++s) {
      const Vec3 r_W = R * samples.points[s];
      const Vec3 x_W = r_W + t;
      Vec3 dcost_dx = Vec3::Zero();
      for (int k : active) {
        const double h = polytope.normals[k].dot(x_W) - polytope.offsets[k] + margin;
        if (h <= 0.0) continue;
        double slope;
        cost += opt::SmoothedL1(h, parameters.mu, &slope);
        dcost_dx += slope * polytope.normals[k];
      }
      if (wrench == nullptr) continue;
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

double SfcModel::LinkPenalty(int link, const Pose& X_WL, const PenaltyParameters& parameters,
                             const QueryContext& context, LinkWrench* wrench) const {
  const LinkSurfaceSamples& samples = samples_[slot_of_link_[link]];
  int index = PolytopeOf(context);
  if (index < 0) {
    // Every polytope: the one the link fits best.
    double best = std::numeric_limits<double>::infinity();
    for (int i = 0; i < num_polytopes(); ++i) {
      const double cost = PolytopePenalty(polytopes_[i], samples, X_WL, parameters, nullptr);
      if (cost < best) {
        best = cost;
        index = i;
      }
    }
    if (wrench == nullptr || best == 0.0) return best;
  }
  return PolytopePenalty(polytopes_[index], samples, X_WL, parameters, wrench);
}

double SfcModel::LinkClearance(int link, const Pose& X_WL, double search_radius,
                               const QueryContext& context) const {
  const LinkSurfaceSamples& samples = samples_[slot_of_link_[link]];
  auto clearance_in = [&](const Polytope& polytope) {
    double clearance = search_radius;
    for (const Vec3& v : samples.vertices) clearance = std::min(clearance, polytope.Margin(X_WL * v));
    return clearance;
  };
  const int index = PolytopeOf(context);
  if (index >= 0) return clearance_in(polytopes_[index]);
  double best = -std::numeric_limits<double>::infinity();
  for (const Polytope& polytope : polytopes_) best = std::max(best, clearance_in(polytope));
  return best;
}

std::vector<int> AssignPiecesToSegments(const std::vector<Vec3>& path, const std::vector<Vec3>& boundaries) {
  std::vector<int> assignment;
  if (path.size() < 2) return assignment;
  for (size_t i = 0; i + 1 < boundaries.size(); ++i) {
    const Vec3 mid = 0.5 * (boundaries[i] + boundaries[i + 1]);
    int best = 0;
    double best_distance = std::numeric_limits<double>::infinity();
    for (size_t s = 0; s + 1 < path.size(); ++s) {
      const double d = PointSegmentDistance(mid, path[s], path[s + 1]);
      if (d < best_distance) {
        best_distance = d;
        best = static_cast<int>(s);
      }
    }
    assignment.push_back(best);
  }
  return assignment;
}

}  // namespace quadhand::env
