// The exact collision model: signed distances from the raw obstacle points
// to the robot's link meshes (CGAL AABB trees), with no grid, no sampling and
// no interpolation. It is the reference the post-check judges every plan by
// (whatever representation planned it), and a CollisionModel like the others,
// so it can also be optimised against or compared with them; it is slower
// than MRC-SDF by about one exact mesh query per nearby point. A link with
// several collision elements is their union: the smallest of their signed
// distances (robot/link_meshes.h).
#pragma once

#include <memory>
#include <mutex>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/geometry/mesh_distance.h"
#include "quadhand/scene/point_grid.h"

namespace quadhand::env {

class ExactMeshModel final : public CollisionModel {
 public:
  // The cell of the index Create(robot, points) builds, metres.
  static constexpr double kIndexCellSize = 0.05;

  // The collision elements of every collision link of `robot`
  // (robot/link_meshes.h), each a closed mesh; the points (finite, world
  // frame) are indexed here.
  static core::Result<std::unique_ptr<ExactMeshModel>> Create(const robot::RobotModel& robot,
                                                              const std::vector<Vec3>& points);
  // The same with the cloud already indexed, and shared (with MRC-SDF, say).
  static core::Result<std::unique_ptr<ExactMeshModel>> Create(const robot::RobotModel& robot,
                                                              std::shared_ptr<const scene::PointGrid> index);
  // The same for `links` only (each a collision link of `robot`): e.g. the
  // robot without the object it holds, or the object alone, which a
  // mission's checks judge by different rules (planner/mission.h).
  static core::Result<std::unique_ptr<ExactMeshModel>> Create(const robot::RobotModel& robot,
                                                              std::shared_ptr<const scene::PointGrid> index,
                                                              const std::vector<int>& links);
  ~ExactMeshModel() override;

  std::string name() const override { return "exact"; }
  DistanceQuality distance_quality() const override { return DistanceQuality::kExact; }
  const std::vector<int>& links() const override { return links_; }

  // Sum over points within `threshold` of the link of SmoothedL1(threshold -
  // d, mu); the wrench from each point's closest-point direction on the
  // nearest element (zero for a point exactly on the surface, where the
  // distance has no gradient).
  double LinkPenalty(int link, const Pose& X_WL, const PenaltyParameters& parameters,
                     const QueryContext& context, LinkWrench* wrench) const override;
  // Exact signed distance of the closest point within `search_radius`;
  // points that cannot beat the minimum found so far (their bounding-box
  // distance, and the 1-Lipschitz bound from points already queried) get no
  // mesh query, so a smaller radius is faster. Thread-safe.
  double LinkClearance(int link, const Pose& X_WL, double search_radius,
                       const QueryContext& context) const override;

  // Signed distance of `x_L` (in the frame of `link`, a robot link index
  // from links()) to the link's collision elements (negative inside), and
  // its unit gradient in the link frame when `gradient` is not null (zero on
  // the surface). Thread-safe.
  double LinkSignedDistance(int link, const Vec3& x_L, Vec3* gradient = nullptr) const;
  // The link-frame bounding box of the link's elements.
  void LinkBox(int link, Vec3* box_min, Vec3* box_max) const;

  // Builds every element's distance query now instead of on its first
  // query: for a program whose later queries must not wait (the online
  // mode's replans in flight). Thread-safe.
  void BuildAllQueries() const;

 private:
  // An element's distance query (an AABB tree over its triangles: a tenth
  // of a second per 100,000) is built on its first query, not at Create:
  // most elements of a large robot are never near enough to a point to be
  // queried, and a plan should not wait for trees it does not use.
  class Element {
   public:
    Element(geometry::TriangleMesh mesh, const Vec3& box_min, const Vec3& box_max);
    const geometry::MeshDistanceQuery& Query() const;  // thread-safe
    Vec3 box_min, box_max;  // link-frame bounding box of the element

   private:
    mutable geometry::TriangleMesh mesh_;  // released once the query is built
    mutable std::once_flag built_;
    mutable std::unique_ptr<geometry::MeshDistanceQuery> query_;
  };
  struct LinkGeometry {
    std::vector<std::unique_ptr<Element>> elements;
    Vec3 box_min, box_max;  // of all elements
  };
  // Signed distance of x_L to the union of the link's elements, and the
  // unit gradient (zero on the surface); `hints` carry each element's
  // previous closest point (coherent queries).
  struct Hints {
    std::vector<Vec3> closest;
    std::vector<bool> have;
  };
  static double UnionDistance(const LinkGeometry& g, const Vec3& local, Hints* hints, Vec3* gradient);
  ExactMeshModel(std::vector<int> links, std::vector<LinkGeometry> geometry,
                 std::shared_ptr<const scene::PointGrid> points);
  // Calls visit(x_W, x_L, box_bound) for the points within `reach` of the
  // link's bounding box at X_WL, x_L in the link frame; box_bound is a lower
  // bound of the point's signed distance (-inf inside an element's box).
  template <typename Visitor>
  void VisitBoxNeighbours(const LinkGeometry& g, const Pose& X_WL, double reach, Visitor&& visit) const;

  std::vector<int> links_;
  std::vector<int> slot_of_link_;
  std::vector<LinkGeometry> geometry_;
  std::shared_ptr<const scene::PointGrid> points_;
};

}  // namespace quadhand::env
