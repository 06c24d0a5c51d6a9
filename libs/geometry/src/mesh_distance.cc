// Exact point-mesh distances with a CGAL AABB tree. One of the two
// translation units that include CGAL (each takes about a minute to compile).
#include "quadhand/geometry/mesh_distance.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>

#include "quadhand/geometry/mesh_io.h"

namespace quadhand::geometry {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
// The triangle is cached in each primitive: the distance search then reads
// it next to the tree instead of walking the mesh's halfedges for it.
using Primitive = CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh, CGAL::Default, CGAL::Tag_true, CGAL::Tag_true>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
using SideOfMesh = CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel, CGAL::Default, Tree>;

Point ToPoint(const Vec3& v) { return Point(v.x(), v.y(), v.z()); }
Vec3 ToVec3(const Point& p) { return Vec3(p.x(), p.y(), p.z()); }

// Closest-point search that descends into the nearer child box first.
// CGAL's own closest_point() visits children in build order, so on a large
// mesh the first leaves it reaches are often far away and many triangles get
// projected before the search sphere shrinks. Nearest-first finds a close
// triangle at once and prunes more of the rest. The answer is the same: a box
// is skipped only when it is farther than a point already found.
class NearestFirstProjection {
 public:
  using Priority = double;  // higher is visited first: the negated squared box distance
  using Node = CGAL::AABB_node<Tree::AABB_traits>;

  NearestFirstProjection(const Point& query, const Point& hint, const Tree::AABB_traits& traits)
      : closest_(hint), best_squared_(CGAL::squared_distance(query, hint)), traits_(traits) {}

  bool go_further() const { return true; }

  // Most triangles reached are farther than the best point: their squared
  // distance alone rejects them, without constructing their closest point.
  void intersection(const Point& query, const Tree::Primitive& primitive) {
    const Kernel::Triangle_3& triangle =
        CGAL::internal::Primitive_helper<Tree::AABB_traits>::get_datum(primitive, traits_);
    // The leaves hold two or three triangles under one box: each triangle's
    // own box rejects most of them more cheaply still.
    if (SquaredBoxDistance(query, triangle.bbox()) > best_squared_) return;
    if (!(CGAL::squared_distance(query, triangle) < best_squared_)) return;
    const Point candidate = Kernel().construct_projected_point_3_object()(triangle, query);
    const double squared = CGAL::squared_distance(query, candidate);
    if (squared < best_squared_) {
      closest_ = candidate;
      best_squared_ = squared;
    }
  }

  bool do_intersect(const Point& query, const Node& node) const {
    return SquaredBoxDistance(query, node.bbox()) <= best_squared_;
  }

  std::pair<bool, Priority> do_intersect_with_priority(const Point& query, const Node& node) const {
    const double squared = SquaredBoxDistance(query, node.bbox());
    return {squared <= best_squared_, -squared};
  }

  const Point& closest_point() const { return closest_; }

 private:
  // Rounded down a little so that rounding never prunes a box that may hold
  // a point as close as the best one.
  static double SquaredBoxDistance(const Point& p, const CGAL::Bbox_3& box) {
    double squared = 0.0;
    for (int axis = 0; axis < 3; ++axis) {
      const double below = box.min(axis) - p[axis];
      const double above = p[axis] - box.max(axis);
      const double gap = std::max({below, above, 0.0});
      squared += gap * gap;
    }
    return squared * (1.0 - 1e-12);
  }

  Point closest_;
  double best_squared_;
  const Tree::AABB_traits& traits_;
};

}  // namespace

struct MeshDistanceQuery::Impl {
  SurfaceMesh mesh;
  Tree tree;  // refers to `mesh`, so an Impl never moves once built
  std::unique_ptr<SideOfMesh> side;  // only for signed queries
};

core::Result<std::unique_ptr<MeshDistanceQuery>> MeshDistanceQuery::Create(
    const TriangleMesh& mesh, bool is_signed) {
  if (mesh.triangles.empty()) {
    return core::Status::InvalidArgument("distance query on an empty mesh");
  }
  if (is_signed) {
    // Side_of_triangle_mesh is silently wrong on a mesh that does not bound a volume.
    const MeshCheck check = CheckMesh(mesh);
    if (!check.bounds_volume) {
      return core::Status::InvalidArgument(
          "signed distance needs a mesh that bounds a volume: " + check.problem);
    }
  }
  const int num_vertices = static_cast<int>(mesh.vertices.size());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    if ((t.array() < 0).any() || (t.array() >= num_vertices).any()) {
      return core::Status::InvalidArgument("distance query: a triangle indexes a missing vertex");
    }
  }

  auto impl = std::make_unique<Impl>();
  std::vector<std::array<std::size_t, 3>> soup;
  std::vector<Point> points;
  soup.reserve(mesh.triangles.size());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    soup.push_back({static_cast<std::size_t>(t[0]), static_cast<std::size_t>(t[1]),
                    static_cast<std::size_t>(t[2])});
  }
  if (PMP::is_polygon_soup_a_polygon_mesh(soup)) {
    points.reserve(mesh.vertices.size());
    for (const Vec3& v : mesh.vertices) points.push_back(ToPoint(v));
  } else {
    // Unsigned distances only need the triangles, not their connectivity:
    // give every triangle its own vertices so that any soup fits a surface mesh.
    points.reserve(3 * mesh.triangles.size());
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      for (int corner = 0; corner < 3; ++corner) {
        points.push_back(ToPoint(mesh.vertices[mesh.triangles[t][corner]]));
        soup[t][corner] = 3 * t + corner;
      }
    }
  }
  try {
    PMP::polygon_soup_to_polygon_mesh(points, soup, impl->mesh);
    impl->tree.insert(faces(impl->mesh).first, faces(impl->mesh).second, impl->mesh);
    // Build the tree and its distance-acceleration structure now: both are
    // otherwise built lazily by the first query, which concurrent queries would race on.
    impl->tree.build();
    impl->tree.accelerate_distance_queries();
    if (is_signed) {
      // Given the prebuilt tree, the inside test builds nothing lazily either.
      impl->side = std::make_unique<SideOfMesh>(impl->tree);
    }
  } catch (const std::exception& e) {
    return core::Status::Internal(std::string("distance query: CGAL failed: ") + e.what());
  }
  return std::unique_ptr<MeshDistanceQuery>(new MeshDistanceQuery(std::move(impl), is_signed));
}

MeshDistanceQuery::MeshDistanceQuery(std::unique_ptr<Impl> impl, bool is_signed)
    : impl_(std::move(impl)), is_signed_(is_signed) {}

MeshDistanceQuery::~MeshDistanceQuery() = default;

// CGAL's exact predicates convert coordinates to GMP rationals, which abort
// the process (SIGFPE) on an infinite or NaN one: such a point has no
// distance.
double MeshDistanceQuery::UnsignedDistance(const Vec3& p, Vec3* closest) const {
  if (!p.allFinite()) {
    if (closest != nullptr) closest->setConstant(std::numeric_limits<double>::quiet_NaN());
    return std::numeric_limits<double>::quiet_NaN();
  }
  const Point query = ToPoint(p);
  // The tree's own search for a start point: the nearest of its sample points.
  return UnsignedDistanceWithHint(p, ToVec3(impl_->tree.best_hint(query).first), closest);
}

double MeshDistanceQuery::UnsignedDistanceWithHint(const Vec3& p, const Vec3& hint,
                                                   Vec3* closest) const {
  if (!p.allFinite() || !hint.allFinite()) return UnsignedDistance(p, closest);
  const Point query = ToPoint(p);
  NearestFirstProjection search(query, ToPoint(hint), impl_->tree.traits());
  impl_->tree.traversal_with_priority(query, search);
  const Point& nearest = search.closest_point();
  if (closest != nullptr) *closest = ToVec3(nearest);
  return std::sqrt(CGAL::squared_distance(query, nearest));
}

bool MeshDistanceQuery::IsInside(const Vec3& p) const {
  if (!is_signed_ || !p.allFinite()) return false;
  return (*impl_->side)(ToPoint(p)) == CGAL::ON_BOUNDED_SIDE;
}

double MeshDistanceQuery::SignedDistance(const Vec3& p) const {
  const double distance = UnsignedDistance(p);
  return distance > 0.0 && IsInside(p) ? -distance : distance;
}

}  // namespace quadhand::geometry
