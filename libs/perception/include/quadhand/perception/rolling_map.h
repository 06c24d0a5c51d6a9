// The rolling map of onboard perception (docs/perception.md, "The rolling
// map"): what a range sensor has seen, in voxels that are occupied, free or
// unknown, within a window that follows the vehicle. Each frame's rays mark
// the voxels they cross free and the voxels they end in occupied: log-odds
// occupancy with OctoMap's sensor model and clamping, each voxel updated
// once per frame, an end voxel never also missed. By default a voxel a
// return ended in stays occupied (RollingMapOptions::returns_stay_occupied);
// under OctoMap's model alone a voxel seen often changes its mind in a
// bounded number of frames. The window is a dense ring of voxels (moving it
// clears only the slabs that leave); the raw points that ended in occupied
// voxels are kept (a few per voxel) for the exact checks.
// What leaves the window is forgotten: the memory is bounded by the window,
// not by the flight.
//
// A plan from this map is safe only if it treats every voxel that is not
// free as an obstacle: unknown space is never free (UnknownVoxelCentres).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::perception {

struct RollingMapOptions {
  double resolution = 0.1;  // voxel edge, m
  // The window: an axis-aligned box of these half-extents about its centre
  // (MoveWindow; at the origin until then), m. What lies outside it is
  // forgotten. At most 2^28 voxels (a byte each, and a byte of scratch).
  Vec3 window_half_extent = Vec3(15.0, 15.0, 5.0);
  // A return farther than this from its sensor marks the voxels along its
  // first max_range metres free, and nothing occupied (m).
  double max_range = 6.0;
  // The sensor model (OctoMap's defaults): the probability that a voxel is
  // occupied after a hit, and after a miss; occupied above the threshold.
  double probability_hit = 0.7, probability_miss = 0.4, occupied_threshold = 0.5;
  // A voxel a return has ended in is occupied from then on (until the
  // window forgets it): a hit makes it occupied at once, and rays crossing
  // it do not free it. Without this, rays that pass a surface's edge
  // through the edge's voxel free it after a few frames (or keep a voxel
  // seen free before free after its first hits), and the edge is inside
  // "free" space, which no certificate covers: a flight through a 0.35 m
  // gap on a 0.05 m map came 1.5 cm into the wall that way. Off:
  // OctoMap's model alone, where the log-odds decide both ways.
  bool returns_stay_occupied = true;
  int max_points_per_voxel = 8;  // raw points kept per occupied voxel
  // Threads that walk a frame's rays (the caller's among them). Each voxel
  // is still updated once per frame (but see stop_ray_after_crossed).
  // More than one pays off on a computer with cores to spare (the paper's
  // onboard computer has 8); on a loaded one the threads compete.
  int ray_threads = 1;
  // Opt-in (8 is a good value; 0 walks every ray whole): a ray is walked
  // back from its end toward the sensor, and stops after this many voxels
  // in a row that earlier rays of the same frame crossed (the idea of
  // voxblox's limit on consecutive ray collisions). Near the
  // sensor every ray crosses the same few voxels; walking each to the end
  // cost most of a frame. A voxel the stop skips that no other ray of the
  // frame crosses gets no miss, so the map frees less, never more: every voxel it holds free is
  // free in the map of whole rays, and its occupied and unknown voxels are
  // a superset. Which voxels are skipped depends on the rays' order, so
  // with more than one ray thread the map may differ from run to run
  // (each one a subset of the whole rays' free space). 0 walks every ray
  // whole: the map is then the same for any thread count. Not the default:
  // the flights take other ways through the space it leaves unknown, and
  // one of the ten seeded gap-crossing grasps that arrive with whole rays
  // does not (docs/perception.md).
  int stop_ray_after_crossed = 0;
  bool IsValid(std::string* why) const;
};

enum class VoxelState { kUnknown, kFree, kOccupied };

// A set of voxels of a box (RollingMap::ConnectedFree).
struct FreeRegion {
  Eigen::Vector3i first = Eigen::Vector3i::Zero(), size = Eigen::Vector3i::Zero();  // the box, in voxels
  double resolution = 0.1;
  std::vector<std::uint8_t> in;  // per voxel of the box, x then y then z
  bool Contains(const Vec3& p) const;
};

// Half the diagonal of a voxel of edge `resolution`: the radius of the ball
// about its centre that holds the whole voxel.
inline double VoxelBallRadius(double resolution) { return 0.5 * 1.7320508075688772 * resolution; }

class RollingMap {
 public:
  // InvalidArgument for bad options.
  static core::Result<std::unique_ptr<RollingMap>> Create(const RollingMapOptions& options);
  ~RollingMap();

  // One frame: its returns in the world frame, from the sensor at `origin`.
  // Non-finite returns are dropped and counted (dropped_points); a
  // non-finite origin is refused (InvalidArgument, nothing inserted).
  // `misses` (world frame) are the far ends of the sensor's rays that
  // returned nothing within its range: the voxels up to each end (at most
  // max_range) are missed, and none is hit. Non-finite ones are dropped
  // and counted too.
  core::Status Insert(const std::vector<Vec3>& points, const Vec3& origin, const std::vector<Vec3>& misses = {});
  // Centres the window on `centre` and forgets what falls outside it.
  void MoveWindow(const Vec3& centre);
  // A prior map (docs/perception.md, "A prior map"): points of obstacles
  // known before the flight, such as a task's scene. Each voxel holding one
  // that the sensor has not seen is occupied, with those points kept, now
  // and whenever the window brings it in again. The prior only ever adds
  // obstacles: no space is free because of it, so a plan still goes only
  // where the sensor saw free space. What the sensor sees wins: a return in
  // such a voxel makes it the sensor's, and a ray through it frees it as it
  // would free unknown space (returns_stay_occupied keeps only the sensor's
  // own returns). Non-finite points are dropped and counted
  // (dropped_points). Once per map (InvalidArgument the second time); the
  // points are kept for the window's later moves (memory_bytes).
  core::Status SetPrior(const std::vector<Vec3>& points);
  size_t prior_points() const;  // the prior's finite points
  // Marks the voxels (inside the window) whose centres lie within `radius`
  // of `centre` free, as often-missed voxels: space the caller knows to be
  // empty, such as where the vehicle stands at take-off (its own body is
  // there, and no sensor sees it). Nothing for a non-finite centre or a
  // radius that is not positive.
  void MarkFree(const Vec3& centre, double radius);

  // The state of the voxel holding `p`: unknown outside the window.
  VoxelState State(const Vec3& p) const;
  // The raw points kept in the occupied voxels inside the window.
  std::vector<Vec3> OccupiedPoints() const;
  // The centres of the occupied voxels inside the window (each once).
  std::vector<Vec3> OccupiedVoxelCentres() const;
  // The centres of the voxels inside [lo, hi] (and the window) that no ray
  // has seen: a plan treats each as an obstacle of the voxel's size.
  std::vector<Vec3> UnknownVoxelCentres(const Vec3& lo, const Vec3& hi) const;

  // What a plan must keep away from, as voxel centres: every voxel that is
  // not free (occupied, unknown, or outside the window) and shares a face
  // with a free voxel of the box [lo, hi]; a voxel outside the box counts as
  // not free. Why this is enough (docs/perception.md, "Planning from the
  // map"): a body that starts inside the free voxels of the box and moves
  // continuously can reach the rest of space only through such a voxel, and
  // every point of a voxel lies within BoundaryBallRadius() of its centre.
  // So a clearance of d + BoundaryBallRadius() to these centres certifies a
  // clearance of d to everything not seen free.
  std::vector<Vec3> ObstacleBoundary(const Vec3& lo, const Vec3& hi) const;
  // The free voxels of the box [lo, hi] joined to `from`'s voxel by a chain
  // of free voxels of the box sharing faces: where a body at `from` can go
  // through seen free space (empty when from's voxel is not free).
  FreeRegion ConnectedFree(const Vec3& lo, const Vec3& hi, const Vec3& from) const;
  // VoxelBallRadius of this map's voxels.
  double BoundaryBallRadius() const;
  // The centres of the voxels the last Insert turned from free to occupied:
  // a new obstacle in space that was seen free, which a plan certified
  // against the map before may cross (an unknown voxel turned occupied was
  // an obstacle to the plans already).
  const std::vector<Vec3>& NewlyBlocked() const;

  const RollingMapOptions& options() const;
  Vec3 window_centre() const;
  long frames() const;
  long dropped_points() const;
  size_t num_known_voxels() const;  // free or occupied, in the window
  size_t memory_bytes() const;      // the window's voxels, the kept points and the prior

 private:
  struct Impl;
  explicit RollingMap(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace quadhand::perception
