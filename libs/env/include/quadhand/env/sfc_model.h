// Safe-flight-corridor baseline (paper Sec. "Simulation and Benchmark
// Comparisons"): a chain of convex polytopes, one per segment of the
// front-end base path, each free of every scene point (the target object
// included, as in the paper), and the robot's link surface samples
// (link_surface_samples.h) kept inside the polytope of the current trajectory
// piece.
//
// Polytope of a segment [p, q] (Liu et al., "Planning Dynamically Feasible
// Trajectories for Quadrotors Using Safe Flight Corridors in 3-D Complex
// Environments", RA-L 2017, regional inflation by an ellipsoid):
//   1. Local box: the segment's frame (x along q - p), half extents
//      |q - p| / 2 + local_margin along x and local_margin across; only the
//      points in it are obstacles, and its six faces bound the polytope.
//   2. Ellipsoid: start from the sphere on the segment (centre (p + q)/2,
//      all semi-axes |q - p|/2, so p and q lie on it); while obstacle points
//      lie inside, take the one nearest in the ellipsoid's metric, turn the
//      frame about x so it lies in the x-y plane, and shrink the y and z
//      semi-axes so it lies on the boundary; then do the same for the z
//      semi-axis alone. The segment stays inside, no point is left inside.
//   3. Half-spaces: repeatedly take the remaining point nearest in the
//      ellipsoid's metric, add the plane tangent to the ellipsoid scaled
//      through it (normal C^-2 (x - centre), normalised) and drop every point
//      on or beyond it, until no point is left.
// The polytope contains the seed segment and no obstacle point lies in its
// interior (each is on or beyond at least one face).
//
// Penalty of a link in polytope {x : a_k . x <= b_k} (unit a_k):
//   sum over samples x, over faces k, of SmoothedL1(a_k . x - b_k + threshold, mu)
// i.e. the signed violation of each face plus the safety distance, so a
// sample is free of cost when it is at least `threshold` inside every face.
// The wrench is the sum of dcost/dx = slope a_k (force) and of
// (x - p_WL) x dcost/dx (torque about the link origin).
//
// Pieces and polytopes: QueryContext::piece selects the polytope through the
// assignment set by SetPieceAssignment (polytope_of_piece[piece]); without an
// assignment, piece i uses polytope i. A piece outside the assignment (or
// -1, e.g. a post-check without piece) is measured against every polytope:
// the penalty is the smallest of them, the clearance the largest.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/env/link_surface_samples.h"
#include "quadhand/geometry/triangle_mesh.h"
#include "quadhand/scene/point_grid.h"

namespace quadhand::env {

struct SfcOptions {
  double local_margin = 1.0;      // local box around each segment (see above), m (> 0)
  double surface_spacing = 0.01;  // robot surface sampling, m (link_surface_samples.h)
  int max_faces = 256;            // obstacle faces per polytope at most (box faces not counted)
  double cell_size = 0.1;         // spatial index of the cloud, m

  // False (with a reason in `why`, which may be null) for non-positive or
  // non-finite sizes or max_faces < 1.
  bool IsValid(std::string* why) const;
};

// {x : normals[k] . x <= offsets[k]} with unit normals, world frame.
struct Polytope {
  std::vector<Vec3> normals;
  std::vector<double> offsets;
  Vec3 seed_begin = Vec3::Zero();  // the seed segment
  Vec3 seed_end = Vec3::Zero();
  Vec3 ellipsoid_center = Vec3::Zero();
  Mat3 ellipsoid_axes = Mat3::Identity();  // columns: the semi-axes (direction times length)
  int num_box_faces = 6;                   // the first faces are the local box's

  int num_faces() const { return static_cast<int>(normals.size()); }
  // min_k (offsets[k] - normals[k] . p): the distance to the boundary from
  // inside (> 0), minus the largest violation outside (< 0).
  double Margin(const Vec3& p) const;
};

// The polytope of segment [begin, end] among `obstacles` (see the header
// comment). InvalidArgument for a degenerate (shorter than 1e-9 m) or
// non-finite segment, or an obstacle point on the segment (closer than 1e-9 m);
// Infeasible when max_faces faces do not clear the local box.
core::Result<Polytope> InflateSegment(const Vec3& begin, const Vec3& end, const scene::PointGrid& obstacles,
                                      const SfcOptions& options);

class SfcModel final : public CollisionModel {
 public:
  // One polytope per segment of `path` (the front-end base path, e.g.
  // FrontEndPath::shortcut: start first, goal last, at least two distinct
  // consecutive points), from `points` (all of the scene), and the surface
  // samples of every collision link of `robot`. Errors: bad options, an empty
  // or non-finite cloud, a path with fewer than two points, and those of
  // InflateSegment and robot::LinkCollisionMesh.
  static core::Result<std::unique_ptr<SfcModel>> Create(const robot::RobotModel& robot,
                                                        const std::vector<Vec3>& points,
                                                        const std::vector<Vec3>& path,
                                                        const SfcOptions& options = {});
  // Same with the link meshes given: meshes[i] (link frame) belongs to robot link links[i].
  static core::Result<std::unique_ptr<SfcModel>> Create(std::vector<int> links,
                                                        const std::vector<geometry::TriangleMesh>& meshes,
                                                        const std::vector<Vec3>& points,
                                                        const std::vector<Vec3>& path,
                                                        const SfcOptions& options = {});

  std::string name() const override { return "sfc"; }
  DistanceQuality distance_quality() const override { return DistanceQuality::kLowerBound; }
  const std::vector<int>& links() const override { return links_; }

  // Maps trajectory piece i to polytope polytope_of_piece[i] (each in
  // [0, num_polytopes())). Not thread-safe: set it before planning.
  core::Status SetPieceAssignment(std::vector<int> polytope_of_piece);
  const std::vector<int>& piece_assignment() const { return polytope_of_piece_; }
  // The polytope index `context` selects, or -1 for "every polytope".
  int PolytopeOf(const QueryContext& context) const;

  // See the header comment.
  double LinkPenalty(int link, const Pose& X_WL, const PenaltyParameters& parameters,
                     const QueryContext& context, LinkWrench* wrench) const override;
  // The link's smallest Polytope::Margin, over its mesh vertices (exact for the
  // polytope, as the margin is linear on each triangle), capped at
  // search_radius. Obstacles lie outside the polytope, so where it is
  // positive it is a lower bound of the link's obstacle distance.
  double LinkClearance(int link, const Pose& X_WL, double search_radius,
                       const QueryContext& context) const override;

  int num_polytopes() const { return static_cast<int>(polytopes_.size()); }
  const std::vector<Polytope>& polytopes() const { return polytopes_; }
  const LinkSurfaceSamples& samples_of_link(int link) const { return samples_[slot_of_link_[link]]; }
  // Wall time of generating every polytope (point index included), s.
  double corridor_seconds() const { return corridor_seconds_; }

 private:
  SfcModel() = default;
  double PolytopePenalty(const Polytope& polytope, const LinkSurfaceSamples& samples, const Pose& X_WL,
                         const PenaltyParameters& parameters, LinkWrench* wrench) const;

  SfcOptions options_;
  std::vector<int> links_;
  std::vector<int> slot_of_link_;
  std::vector<LinkSurfaceSamples> samples_;
  std::vector<Polytope> polytopes_;
  std::vector<int> polytope_of_piece_;
  double corridor_seconds_ = 0.0;
};

// A piece-to-polytope assignment for a trajectory whose piece boundaries are
// `boundaries` (start, inner waypoints, end: num_pieces + 1 points) along the
// path the corridor was built from: each piece gets the segment nearest to its
// midpoint (the lower index on ties). With InitialGuessFromPath's waypoints
// (every corner a waypoint) that is the segment the piece lies on.
std::vector<int> AssignPiecesToSegments(const std::vector<Vec3>& path, const std::vector<Vec3>& boundaries);

}  // namespace quadhand::env
