#include "quadhand/scene/point_grid.h"

#include <algorithm>
#include <cmath>

namespace quadhand::scene {

PointGrid::PointGrid(const std::vector<Vec3>& points, double cell_size) : cell_size_(cell_size) {
  if (points.empty()) {
    cell_start_.assign(2, 0);
    return;
  }
  min_ = points.front();
  max_ = points.front();
  for (const Vec3& p : points) {
    min_ = min_.cwiseMin(p);
    max_ = max_.cwiseMax(p);
  }
  // A few far outliers must not make the cell array explode: coarsen instead.
  constexpr double kMaxCells = 1 << 24;
  auto cells_along = [&](int axis) { return std::floor((max_[axis] - min_[axis]) / cell_size_) + 1; };
  while (cells_along(0) * cells_along(1) * cells_along(2) > kMaxCells) cell_size_ *= 2;
  for (int axis = 0; axis < 3; ++axis) dims_[axis] = static_cast<int>(cells_along(axis));
  const long num_cells = static_cast<long>(dims_.x()) * dims_.y() * dims_.z();
  std::vector<int> cell_of(points.size());
  cell_start_.assign(num_cells + 1, 0);
  for (size_t n = 0; n < points.size(); ++n) {
    const Eigen::Vector3i c =
        ((points[n] - min_) / cell_size_).array().floor().cast<int>().min(dims_.array() - 1).matrix();
    cell_of[n] = c.x() + dims_.x() * (c.y() + dims_.y() * c.z());
    ++cell_start_[cell_of[n] + 1];
  }
  for (long c = 0; c < num_cells; ++c) cell_start_[c + 1] += cell_start_[c];
  std::vector<int> next(cell_start_.begin(), cell_start_.end() - 1);
  points_.resize(points.size());
  for (size_t n = 0; n < points.size(); ++n) points_[next[cell_of[n]]++] = points[n];
}

bool PointGrid::CellRange(const Vec3& lo, const Vec3& hi, Eigen::Vector3i* first,
                          Eigen::Vector3i* last) const {
  if (points_.empty() || !(lo.allFinite() && hi.allFinite())) return false;
  if ((hi.array() < min_.array()).any() || (lo.array() > max_.array()).any()) return false;
  for (int axis = 0; axis < 3; ++axis) {
    // Clamp in floating point before converting, so huge boxes cannot overflow int.
    const double top = dims_[axis] - 1;
    (*first)[axis] = static_cast<int>(std::clamp(std::floor((lo[axis] - min_[axis]) / cell_size_), 0.0, top));
    (*last)[axis] = static_cast<int>(std::clamp(std::floor((hi[axis] - min_[axis]) / cell_size_), 0.0, top));
  }
  return true;
}

long PointGrid::CountInBoxBruteForce(const Vec3& lo, const Vec3& hi) const {
  long count = 0;
  for (const Vec3& p : points_) count += (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
  return count;
}

}  // namespace quadhand::scene
