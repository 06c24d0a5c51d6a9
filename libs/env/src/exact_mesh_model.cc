#include "quadhand/env/exact_mesh_model.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "quadhand/geometry/mesh_io.h"
#include "quadhand/opt/penalty.h"
#include "quadhand/robot/link_meshes.h"

namespace quadhand::env {

ExactMeshModel::ExactMeshModel(std::vector<int> links, std::vector<LinkGeometry> geometry,
                               std::shared_ptr<const scene::PointGrid> points)
    : links_(std::move(links)), slot_of_link_(SlotsOfLinks(links_)), geometry_(std::move(geometry)),
      points_(std::move(points)) {}

ExactMeshModel::~ExactMeshModel() = default;

ExactMeshModel::Element::Element(geometry::TriangleMesh mesh, const Vec3& mesh_min, const Vec3& mesh_max)
    : box_min(mesh_min), box_max(mesh_max), mesh_(std::move(mesh)) {}

const geometry::MeshDistanceQuery& ExactMeshModel::Element::Query() const {
  std::call_once(built_, [this] {
    auto query = geometry::MeshDistanceQuery::Create(mesh_, /*is_signed=*/true);
    if (!query.ok()) {
      // Create checked every condition of MeshDistanceQuery::Create.
      std::fprintf(stderr, "quadhand: internal error: exact model: %s\n", query.status().message().c_str());
      std::abort();
    }
    query_ = std::move(*query);
    mesh_ = geometry::TriangleMesh{};
  });
  return *query_;
}

core::Result<std::unique_ptr<ExactMeshModel>> ExactMeshModel::Create(const robot::RobotModel& robot,
                                                                    const std::vector<Vec3>& points) {
  return Create(robot, std::make_shared<const scene::PointGrid>(points, kIndexCellSize));
}

core::Result<std::unique_ptr<ExactMeshModel>> ExactMeshModel::Create(const robot::RobotModel& robot,
                                                                    std::shared_ptr<const scene::PointGrid> index) {
  return Create(robot, std::move(index), robot.CollisionLinks());
}

core::Result<std::unique_ptr<ExactMeshModel>> ExactMeshModel::Create(const robot::RobotModel& robot,
                                                                    std::shared_ptr<const scene::PointGrid> index,
                                                                    const std::vector<int>& links) {
  if (index == nullptr) return core::Status::InvalidArgument("exact mesh model: no indexed cloud");
  for (int link : links) {
    if (link < 0 || link >= robot.num_links() || robot.link(link).collisions.empty()) {
      return core::Status::InvalidArgument("exact mesh model: link " + std::to_string(link) +
                                           " is not a collision link of the robot");
    }
  }
  std::vector<LinkGeometry> geometry;
  for (int link : links) {
    auto meshes = robot::LinkCollisionElements(robot, link);
    if (!meshes.ok()) return meshes.status();
    LinkGeometry g;
    for (geometry::TriangleMesh& mesh : *meshes) {
      // Everything the query's construction could refuse is checked now,
      // so that building it on first use cannot fail (the bounds-volume
      // check comes from CheckMesh's memo: the repair ran it, or the
      // repaired-mesh cache's writer did).
      const std::string where = "link '" + robot.link(link).name + "'";
      if (mesh.triangles.empty()) return core::Status::InvalidArgument(where + ": a collision element without triangles");
      const int num_vertices = static_cast<int>(mesh.vertices.size());
      for (const Eigen::Vector3i& t : mesh.triangles) {
        if ((t.array() < 0).any() || (t.array() >= num_vertices).any()) {
          return core::Status::InvalidArgument(where + ": a triangle indexes a missing vertex");
        }
      }
      if (const geometry::MeshCheck check = geometry::CheckMesh(mesh); !check.bounds_volume) {
        return core::Status::InvalidArgument(where + ": signed distance needs a mesh that bounds a volume: " +
                                             check.problem);
      }
      const geometry::AxisAlignedBox box = geometry::BoundingBox(mesh);
      g.box_min = g.elements.empty() ? box.min : g.box_min.cwiseMin(box.min);
      g.box_max = g.elements.empty() ? box.max : g.box_max.cwiseMax(box.max);
      g.elements.push_back(std::make_unique<Element>(std::move(mesh), box.min, box.max));
    }
    geometry.push_back(std::move(g));
  }
  return std::unique_ptr<ExactMeshModel>(new ExactMeshModel(std::move(links), std::move(geometry), std::move(index)));
}

template <typename Visitor>
void ExactMeshModel::VisitBoxNeighbours(const LinkGeometry& g, const Pose& X_WL, double reach, Visitor&& visit) const {
  const Vec3 lo = g.box_min - Vec3::Constant(reach), hi = g.box_max + Vec3::Constant(reach);
  const Vec3 center = X_WL * (0.5 * (lo + hi));
  const Vec3 half = X_WL.linear().cwiseAbs() * (0.5 * (hi - lo));
  points_->VisitBox(center - half, center + half, [&](const Vec3& x) {
    const Vec3 local = X_WL.linear().transpose() * (x - X_WL.translation());
    if ((local.array() < lo.array()).any() || (local.array() > hi.array()).any()) return;
    // An element's box distance is a lower bound of its signed distance
    // outside the box; inside it, a point may be inside the element (no
    // bound). The union's distance is the smallest over the elements.
    double bound = std::numeric_limits<double>::infinity();
    for (const auto& element : g.elements) {
      const Element& e = *element;
      const double outside = (e.box_min - local).cwiseMax(local - e.box_max).cwiseMax(0.0).norm();
      bound = std::min(bound, outside > 0.0 ? outside : -std::numeric_limits<double>::infinity());
    }
    visit(x, local, bound);
  });
}

double ExactMeshModel::UnionDistance(const LinkGeometry& g, const Vec3& local, Hints* hints, Vec3* gradient) {
  double best = std::numeric_limits<double>::infinity();
  if (gradient != nullptr) gradient->setZero();
  for (size_t i = 0; i < g.elements.size(); ++i) {
    const Element& e = *g.elements[i];
    // Outside an element's box a point is outside the element and at least
    // the box distance away: no query when that cannot beat the minimum.
    const double outside = (e.box_min - local).cwiseMax(local - e.box_max).cwiseMax(0.0).norm();
    if (outside > 0.0 && outside >= best) continue;
    Vec3 closest;
    const geometry::MeshDistanceQuery& query = e.Query();
    double d = hints != nullptr && hints->have[i] ? query.UnsignedDistanceWithHint(local, hints->closest[i], &closest)
                                                 : query.UnsignedDistance(local, &closest);
    if (hints != nullptr) {
      hints->closest[i] = closest;
      hints->have[i] = true;
    }
    const bool inside = outside == 0.0 && d > 0.0 && query.IsInside(local);
    if (inside) d = -d;
    if (d >= best) continue;
    best = d;
    if (gradient != nullptr) {
      // Away from the closest surface point outside, towards it inside.
      const double gap = (local - closest).norm();
      *gradient = gap > 0.0 ? Vec3((inside ? -1.0 : 1.0) / gap * (local - closest)) : Vec3::Zero();
    }
  }
  return best;
}

double ExactMeshModel::LinkClearance(int link, const Pose& X_WL, double search_radius,
                                     const QueryContext& /*context*/) const {
  const LinkGeometry& g = geometry_[slot_of_link_[link]];
  double clearance = search_radius;
  // Candidate points: (lower bound of their distance, position in the link frame).
  thread_local std::vector<std::pair<double, Vec3>> candidates, queried;
  candidates.clear();
  VisitBoxNeighbours(g, X_WL, search_radius, [&](const Vec3&, const Vec3& local, double bound) {
    if (bound < clearance) candidates.emplace_back(bound, local);
  });
  // Nearest bounds first: the minimum drops fast and prunes the rest, and
  // each query starts from the previous closest point (coherent queries).
  std::sort(candidates.begin(), candidates.end(),
            [](const std::pair<double, Vec3>& a, const std::pair<double, Vec3>& b) { return a.first < b.first; });
  thread_local Hints hints;
  hints.closest.assign(g.elements.size(), Vec3::Zero());
  hints.have.assign(g.elements.size(), false);
  queried.clear();
  int last_pruner = -1;
  for (const auto& candidate : candidates) {
    // Named, not a structured binding: the lambda below captures it (C++17
    // lambdas cannot capture structured bindings; clang refuses them).
    const double bound = candidate.first;
    const Vec3& local = candidate.second;
    if (bound >= clearance) break;
    // The signed distance is 1-Lipschitz (so is a minimum of such): d(q) >=
    // d(p) - |q - p| for every point p queried already, which prunes the
    // dense cloud's neighbours. The point that pruned last is tried first (a
    // far one prunes whole clusters), points no farther than the minimum
    // cannot prune, and the test is squared (no root per pair).
    auto prunes = [&](const std::pair<double, Vec3>& p) {
      const double room = p.first - clearance;
      return room > 0.0 && (local - p.second).squaredNorm() <= room * room;
    };
    if (last_pruner >= 0 && prunes(queried[last_pruner])) continue;
    bool pruned = false;
    for (int i = static_cast<int>(queried.size()) - 1; i >= 0; --i) {
      if (prunes(queried[i])) {
        last_pruner = i;
        pruned = true;
        break;
      }
    }
    if (pruned) continue;
    const double d = UnionDistance(g, local, &hints, nullptr);
    queried.emplace_back(d, local);
    clearance = std::min(clearance, d);
  }
  return clearance;
}

double ExactMeshModel::LinkSignedDistance(int link, const Vec3& x_L, Vec3* gradient) const {
  return UnionDistance(geometry_[slot_of_link_[link]], x_L, nullptr, gradient);
}

void ExactMeshModel::BuildAllQueries() const {
  for (const LinkGeometry& g : geometry_) {
    for (const auto& element : g.elements) element->Query();
  }
}

void ExactMeshModel::LinkBox(int link, Vec3* box_min, Vec3* box_max) const {
  const LinkGeometry& g = geometry_[slot_of_link_[link]];
  *box_min = g.box_min;
  *box_max = g.box_max;
}

double ExactMeshModel::LinkPenalty(int link, const Pose& X_WL, const PenaltyParameters& parameters,
                                   const QueryContext& /*context*/, LinkWrench* wrench) const {
  const LinkGeometry& g = geometry_[slot_of_link_[link]];
  const Mat3& R = X_WL.linear();
  const Vec3& t = X_WL.translation();
  double cost = 0.0;
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
  VisitBoxNeighbours(g, X_WL, parameters.threshold, [&](const Vec3& x_W, const Vec3& local, double bound) {
    if (bound >= parameters.threshold) return;
    Vec3 gradient_L;
    const double d = UnionDistance(g, local, nullptr, &gradient_L);
    double slope = 0.0;
    cost += opt::SmoothedL1(parameters.threshold - d, parameters.mu, &slope);
    if (wrench == nullptr || slope == 0.0) return;
    // As for MRC-SDF: d distance / d(link translation) = -g_W, / d(link
    // rotation) = g_W x (x - t), d cost / d distance = -slope.
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

}  // namespace quadhand::env
