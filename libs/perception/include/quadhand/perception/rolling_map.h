// The rolling map of onboard perception (docs/perception.md, "The rolling
// map"): what a range sensor has seen, in voxels that are occupied, free or
// unknown, within a window that follows the vehicle. Each frame's rays mark
// the voxels they cross free and the voxels they end in occupied: log-odds
// occupancy with OctoMap's sensor model and clamping (so a voxel seen often
// changes its mind in a bounded number of frames), each voxel updated once
// per frame, an end voxel never also missed. The window is a dense ring of
// voxels (moving it clears only the slabs that leave); the raw points that
// ended in occupied voxels are kept (a few per voxel) for the exact checks.
// What leaves the window is forgotten: the memory is bounded by the window,
// not by the flight.
//
// A plan from this map is safe only if it treats every voxel that is not
// free as an obstacle: unknown space is never free (UnknownVoxelCentres).
#pragma once

#include <cstddef>
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
  int max_points_per_voxel = 8;  // raw points kept per occupied voxel
  bool IsValid(std::string* why) const;
};

enum class VoxelState { kUnknown, kFree, kOccupied };

class RollingMap {
 public:
  // InvalidArgument for bad options.
  static core::Result<std::unique_ptr<RollingMap>> Create(const RollingMapOptions& options);
  ~RollingMap();

  // One frame: its returns in the world frame, from the sensor at `origin`.
  // Non-finite returns are dropped and counted (dropped_points); a
  // non-finite origin is refused (InvalidArgument, nothing inserted).
  core::Status Insert(const std::vector<Vec3>& points, const Vec3& origin);
  // Centres the window on `centre` and forgets what falls outside it.
  void MoveWindow(const Vec3& centre);

  // The state of the voxel holding `p`: unknown outside the window.
  VoxelState State(const Vec3& p) const;
  // The raw points kept in the occupied voxels inside the window.
  std::vector<Vec3> OccupiedPoints() const;
  // The centres of the voxels inside [lo, hi] (and the window) that no ray
  // has seen: a plan treats each as an obstacle of the voxel's size.
  std::vector<Vec3> UnknownVoxelCentres(const Vec3& lo, const Vec3& hi) const;

  const RollingMapOptions& options() const;
  Vec3 window_centre() const;
  long frames() const;
  long dropped_points() const;
  size_t num_known_voxels() const;  // free or occupied, in the window
  size_t memory_bytes() const;      // the window's voxels and the kept points

 private:
  struct Impl;
  explicit RollingMap(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace quadhand::perception
