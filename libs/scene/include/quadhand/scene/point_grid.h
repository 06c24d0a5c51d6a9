// A uniform-grid spatial index over a static point cloud (cells stored
// contiguously, CSR style), so a collision query touches only the points in
// the cells that overlap its box instead of looping over the whole cloud.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "quadhand/core/types.h"

namespace quadhand::scene {

class PointGrid {
 public:
  // Points (finite) are copied and reordered by cell. `cell_size` in metres (> 0);
  // it is coarsened if the cloud would need more than 2^24 cells.
  PointGrid(const std::vector<Vec3>& points, double cell_size);

  int num_points() const { return static_cast<int>(points_.size()); }
  double cell_size() const { return cell_size_; }
  const Vec3& min_corner() const { return min_; }
  const Vec3& max_corner() const { return max_; }
  // All points, reordered so that each cell's points are contiguous.
  const std::vector<Vec3>& points() const { return points_; }

  // Calls visit(const Vec3& point) for every point inside the axis-aligned box
  // [lo, hi] (and possibly a few just outside it, from the same cells: callers
  // filter by their own exact test). Returns the number of points visited.
  template <typename Visitor>
  long VisitBox(const Vec3& lo, const Vec3& hi, Visitor&& visit) const;

  // Brute-force reference count of points in [lo, hi], for tests.
  long CountInBoxBruteForce(const Vec3& lo, const Vec3& hi) const;

 private:
  // Cell index range overlapping [lo, hi]; false if the box misses the cloud.
  bool CellRange(const Vec3& lo, const Vec3& hi, Eigen::Vector3i* first, Eigen::Vector3i* last) const;

  std::vector<Vec3> points_;
  std::vector<int> cell_start_;  // size num_cells + 1; points of cell c: [cell_start_[c], cell_start_[c+1])
  Vec3 min_ = Vec3::Zero();
  Vec3 max_ = Vec3::Zero();
  double cell_size_ = 1.0;
  Eigen::Vector3i dims_ = Eigen::Vector3i::Ones();
};

template <typename Visitor>
long PointGrid::VisitBox(const Vec3& lo, const Vec3& hi, Visitor&& visit) const {
  Eigen::Vector3i first, last;
  if (!CellRange(lo, hi, &first, &last)) return 0;
  long visited = 0;
  for (int k = first.z(); k <= last.z(); ++k) {
    for (int j = first.y(); j <= last.y(); ++j) {
      // Cells along x are contiguous, so one row is one span of points.
      const int row = dims_.x() * (j + dims_.y() * k);
      const int begin = cell_start_[row + first.x()];
      const int end = cell_start_[row + last.x() + 1];
      for (int i = begin; i < end; ++i) visit(points_[i]);
      visited += end - begin;
    }
  }
  return visited;
}

}  // namespace quadhand::scene
