// The planner's front end: an initial path of the base centre from start to
// goal through a point-cloud scene, and an initial MINCO guess from it.
//
//   FrontEndMap  - built once per scene: a voxel grid holding, at every voxel
//                  centre, the exact distance to the nearest cloud point
//                  (clamped), so many queries share it. Stored in blocks:
//                  only the blocks near a point hold values (memory grows
//                  with the scene's surface, not with its box).
//   FindPath     - (weighted) A* over free voxels (26-connected, octile
//                  heuristic, integer costs, deterministic ties), then a
//                  greedy line-of-sight shortcut checked exactly against the
//                  cloud points.
//   InitialGuessFromPath - waypoints along the path (every corner kept) and
//                  durations from a trapezoidal speed profile.
//
// World frame, metres, seconds. The path is for the base centre only: the
// clearance is a point-to-point distance, not the robot's surface.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/scene/point_grid.h"

namespace quadhand::planner {

struct FrontEndOptions {
  // Edge of a voxel, m. 0.05 leaves at least three voxel centres across each
  // free band of the benchmark windows with the default radius.
  double voxel_size = 0.05;
  // Clearance the base centre keeps from every obstacle point, m (used when
  // size_from_robot is off, or the robot has no collision geometry). The raw
  // path keeps it exactly along every segment (not only at voxel centres):
  // a voxel is free when its centre is at least
  //   sqrt(inflation_radius^2 + 3 voxel_size^2 / 4)
  // from every point, which bounds the dip between two adjacent centres.
  // Default 0.15: the benchmark windows are 0.45 m high (0.48 m between the
  // sampled edge points), so the free band left for voxel centres is
  // 0.48 - 2 * 0.156 = 0.17 m high (0.29 m wide): three or four centres at
  // voxel_size 0.05. Radii up to about 0.21 keep at least one centre free at
  // any grid alignment; from about 0.22 the windows close (and, with the
  // default margin, the path goes over the walls instead). 0.15 is also
  // about the base's half size (the rotor guards reach 0.18 m in x-y, the
  // plate is 0.05 m high), so the optimiser starts from a path that keeps
  // the body mostly clear.
  double inflation_radius = 0.15;
  // The same clearance along z, m: the search treats the base as an
  // ellipsoid of these half-axes (the voxel allowance added to each as to
  // the radius), so a flat vehicle passes a gap lower than its width. 0:
  // inflation_radius (a sphere). With size_from_robot, the robot's own
  // half height with the arm stowed (QuadHand: 0.065 m, so that the
  // paper's 0.6 x 0.35 m gap is open to it).
  double inflation_height = 0.0;
  // A voxel the ellipsoid leaves free but the sphere of inflation_radius
  // would block is tight: the search crosses it at this many times the
  // distance (>= 1), so it passes a gap only the flat robot fits when
  // there is no roomier way within about that factor of the length (the
  // sphere keeps the path off window edges, which the whole-body solve
  // then need not push it from).
  double tight_cost_factor = 5.0;
  // Clearance every shortcut segment keeps from every point, m (checked
  // exactly, see FrontEndMap::SegmentIsClear); at most inflation_radius, so
  // the raw path is always a valid fallback.
  double shortcut_clearance = 0.15;
  // How far beyond the bounding box of the cloud (and of the start and goal,
  // or whatever FrontEndMap::Build is told to contain) the search may go, m,
  // per axis (>= 0). The grid box is fixed when the map is built.
  Vec3 bounds_margin = Vec3::Constant(0.5);
  // A start or goal whose voxel is blocked (closer than the inflation radius)
  // is joined to the nearest free voxel centre within this distance, m (>= 0;
  // 0 makes such a start or goal an error).
  double max_escape_distance = 0.5;
  // A* weight on the heuristic, in [1, 10]: 1 gives a shortest grid path;
  // w > 1 a grid path at most w times longer than the shortest, for far fewer
  // expansions. Default 1.5: on the benchmark scene about 450 expansions
  // instead of 9k-34k (from about 10-30 ms to under 1 ms per query), and after
  // the shortcut the path is at most about 1 % longer than with w = 1.
  double heuristic_weight = 1.5;
  // Search budget per query: A* node expansions (> 0) and wall time, s (> 0).
  long max_expansions = 5'000'000;
  double max_seconds = 2.0;
  // Largest grid box, in voxels (< 2^31: the search numbers them). The
  // memory is not per voxel of the box: 5 bytes per voxel of the blocks of
  // 8^3 voxels near a point, 4 bytes per block of the box, and 12 bytes per
  // voxel of the blocks a query's search touches (per querying thread).
  long max_voxels = 1'500'000'000;
  // Read by PlanningContext, not by the map: with size_from_robot the
  // inflation radius is the robot's half-width (robot::StowedHalfWidth) and
  // the shortcut clearance shortcut_ratio times it, instead of the two
  // absolute values above (kept for a robot without collision geometry).
  // On the benchmark (QuadHand's half-width is 0.18 m, its rotor guards)
  // 100/100 plans succeed either way; the derived values also fit robots of
  // other sizes.
  bool size_from_robot = true;
  double shortcut_ratio = 0.85;  // in [0, 1]

  // False (with a reason in `why`, which may be null) for a non-positive or
  // non-finite size, a negative margin, shortcut_clearance >
  // inflation_radius, and so on.
  bool IsValid(std::string* why) const;
};

struct FrontEndPath {
  // start, the A* voxel centres (after an escape voxel when the start or goal
  // voxel is blocked), goal. Consecutive points are distinct.
  std::vector<Vec3> raw;
  // A subsequence of `raw` from start to goal: corners only.
  std::vector<Vec3> shortcut;
  long expansions = 0;            // A* nodes expanded
  double search_seconds = 0.0;    // A* wall time
  double shortcut_seconds = 0.0;  // shortcut wall time
  double seconds = 0.0;           // whole query wall time
  bool start_escaped = false;     // the start voxel was blocked (see max_escape_distance)
  bool goal_escaped = false;      // the goal voxel was blocked
};

// Occupancy of one point cloud for front-end queries. Immutable after Build;
// FindPath may be called from several threads at once (its search scratch is
// per thread).
class FrontEndMap {
 public:
  // The grid covers the bounding box of `obstacle_points` and of
  // `also_contain` (e.g. start and goal, or the corners of a start region),
  // grown by options.bounds_margin. InvalidArgument for invalid options, an
  // empty cloud, a non-finite point, or a grid larger than options.max_voxels.
  static core::Result<FrontEndMap> Build(const std::vector<Vec3>& obstacle_points,
                                         const FrontEndOptions& options,
                                         const std::vector<Vec3>& also_contain = {});

  // A path from start to goal (see FrontEndPath). InvalidArgument for a
  // non-finite start or goal, or one outside the grid box, or one whose voxel
  // is blocked with no free voxel within max_escape_distance; Infeasible when
  // no free path exists in the grid box or the search budget runs out (the
  // message says which).
  core::Result<FrontEndPath> FindPath(const Vec3& start, const Vec3& goal) const;

  // True when the segment [a, b] keeps at least options.shortcut_clearance
  // from every cloud point (exact: certified by the distance grid where it is
  // far from the cloud, by point-to-segment distances near it). False for a
  // segment leaving the grid box.
  bool SegmentIsClear(const Vec3& a, const Vec3& b) const;

  // True when `p` lies in the grid box and its voxel is free for the search.
  bool IsFree(const Vec3& p) const;

  const FrontEndOptions& options() const { return options_; }
  const Vec3& min_corner() const { return lo_; }  // of the grid box
  const Vec3& max_corner() const { return hi_; }
  Eigen::Vector3i dims() const { return dims_; }  // voxels per axis
  long num_blocked() const { return num_blocked_; }  // voxels the search may not enter
  double search_radius() const { return search_radius_; }  // free-voxel threshold, m (horizontal)
  double search_height() const { return search_height_; }  // the same along z
  double build_seconds() const { return build_seconds_; }
  // Bytes the grid holds: its blocks near points and the table of blocks.
  size_t grid_bytes() const {
    return distance_.size() * sizeof(float) + blocked_.size() + block_slot_.size() * sizeof(int);
  }

 private:
  FrontEndMap(const std::vector<Vec3>& points, double cell_size) : points_(points, cell_size) {}

  // Padded index (one blocked voxel of border on every side) of voxel (i, j, k).
  long Index(int i, int j, int k) const {
    return (static_cast<long>(i + 1) * (dims_.y() + 2) + (j + 1)) * (dims_.z() + 2) + (k + 1);
  }
  // The grid's storage, by padded coordinates (i + 1, j + 1, k + 1): blocks
  // of kBlockEdge^3 voxels, only those near a point held (a slot); every
  // other voxel is far (the distance cap) and free; the border is blocked.
  static constexpr int kBlockShift = 3, kBlockEdge = 1 << kBlockShift, kBlockVoxels = kBlockEdge * kBlockEdge * kBlockEdge;
  long BlockOf(int pi, int pj, int pk) const {
    return (static_cast<long>(pi >> kBlockShift) * block_dims_.y() + (pj >> kBlockShift)) * block_dims_.z() +
           (pk >> kBlockShift);
  }
  static int InBlock(int pi, int pj, int pk) {
    const int m = kBlockEdge - 1;
    return (((pi & m) << kBlockShift) | (pj & m)) << kBlockShift | (pk & m);
  }
  bool OnBorder(int pi, int pj, int pk) const {
    return pi <= 0 || pj <= 0 || pk <= 0 || pi > dims_.x() || pj > dims_.y() || pk > dims_.z();
  }
  // The search state of voxel `in_block` of `block` (not on the border).
  unsigned char StateIn(long block, int in_block) const {
    const int slot = block_slot_[block];
    return slot < 0 ? kFree : blocked_[static_cast<long>(slot) * kBlockVoxels + in_block];
  }
  unsigned char BlockedAt(int pi, int pj, int pk) const {
    return OnBorder(pi, pj, pk) ? kBlocked : StateIn(BlockOf(pi, pj, pk), InBlock(pi, pj, pk));
  }
  float DistanceAt(int pi, int pj, int pk) const {
    const int slot = block_slot_[BlockOf(pi, pj, pk)];
    return slot < 0 ? far_distance_ : distance_[static_cast<long>(slot) * kBlockVoxels + InBlock(pi, pj, pk)];
  }
  // Build: the slot of the block holding (pi, pj, pk), made when missing
  // (distances `far`, every voxel free).
  int SlotFor(int pi, int pj, int pk, float far);
  // Voxel containing p, clamped to the grid; false if p is outside the box.
  bool VoxelOf(const Vec3& p, Eigen::Vector3i* ijk) const;
  Vec3 Centre(const Eigen::Vector3i& ijk) const {
    return lo_ + (ijk.cast<double>().array() + 0.5).matrix() * options_.voxel_size;
  }
  // Lower bound on the distance from p to the cloud (-inf outside the box);
  // `*upper` gets an upper bound (+inf where the grid value was clamped).
  double DistanceLowerBound(const Vec3& p, double* upper) const;
  bool SubSegmentIsClear(const Vec3& a, const Vec3& b) const;

  FrontEndOptions options_;
  scene::PointGrid points_;
  Vec3 lo_ = Vec3::Zero(), hi_ = Vec3::Zero();
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  Eigen::Vector3i block_dims_ = Eigen::Vector3i::Zero();  // blocks per axis over the padded grid
  std::vector<int> block_slot_;  // per block: its slot in the two arrays below, or -1 (far)
  // kBlockVoxels per slot: the distance from each centre to the cloud,
  // clamped; kBlocked: not usable by the search; kTight: usable at
  // tight_cost_factor times the cost (FrontEndOptions).
  std::vector<float> distance_;
  static constexpr unsigned char kFree = 0, kBlocked = 1, kTight = 2;
  std::vector<unsigned char> blocked_;
  float far_distance_ = 0.0f;  // of a voxel in no slot
  double search_radius_ = 0.0;
  double search_height_ = 0.0;
  double distance_cap_ = 0.0;
  long num_blocked_ = 0;
  double build_seconds_ = 0.0;
};

// Builds a map for the box of the cloud, start and goal, and runs one query.
core::Result<FrontEndPath> FindBasePath(const std::vector<Vec3>& obstacle_points, const Vec3& start,
                                        const Vec3& goal, const FrontEndOptions& options);

// Sum of segment lengths, m.
double PathLength(const std::vector<Vec3>& path);

// Number of MINCO pieces for a path: one per `piece_length` of arc length
// (rounded up), at least `min_pieces`, and at least one per segment (every
// corner is a waypoint). Duplicate consecutive points are not segments.
int PieceCountForPath(const std::vector<Vec3>& path, double piece_length = 0.5, int min_pieces = 3);

// Initial guess for a MINCO trajectory along `path` (start first, goal last):
// `*waypoints` (3 x (num_pieces - 1)) are the inner piece boundaries and
// `*durations` (num_pieces) the piece times. Every corner of the path is a
// waypoint, so a window passage is never cut; the remaining pieces split the
// segments evenly, extra pieces going to the segments with the longest pieces.
// Times follow a trapezoidal speed profile over the whole arc length (rest to
// cruise_speed at `acceleration`, back to rest); every duration is > 0.
// InvalidArgument for fewer than two points, a non-finite point, non-positive
// speed or acceleration, num_pieces smaller than the number of segments, or
// null outputs. A path of zero length gets all waypoints at its point and
// 0.1 s pieces.
core::Status InitialGuessFromPath(const std::vector<Vec3>& path, int num_pieces, double cruise_speed,
                                  double acceleration, MatX* waypoints, VecX* durations);

}  // namespace quadhand::planner
