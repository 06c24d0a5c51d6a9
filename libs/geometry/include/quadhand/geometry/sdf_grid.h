// A signed distance field sampled on a regular grid in one link's frame, with
// trilinear interpolation and its analytic gradient. File format: docs/sdf_format.md.
#pragma once

#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::geometry {

struct SdfGridInfo {
  std::string link_name;     // the link this field belongs to
  std::string frame;         // frame the coordinates are expressed in (the link's own frame)
  std::string source;        // where the geometry came from (mesh file), informative
  double resolution = 0.0;   // node spacing, metres
  Vec3 origin = Vec3::Zero();  // position of node (0, 0, 0) in `frame`
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();  // nodes along x, y, z
  bool is_signed = true;     // false: distances are unsigned (mesh was not closed)
  Vec3 geometry_min = Vec3::Zero();  // bounding box of the geometry in `frame`
  unsigned file_version = 0;  // the format version of the file it was read from; 0: built in memory
  Vec3 geometry_max = Vec3::Zero();

  // Interpolation domain: [origin, origin + (dims - 1) * resolution].
  Vec3 GridMax() const { return origin + (dims - Eigen::Vector3i::Ones()).cast<double>() * resolution; }
  long NumNodes() const { return static_cast<long>(dims.x()) * dims.y() * dims.z(); }
};

class SdfGrid {
 public:
  // Written: version 2 (core::FastHash64 checksum). Read: 2, and 1 (the same
  // layout with a byte-wise FNV-1a checksum, ten times slower to verify).
  static constexpr unsigned kFormatVersion = 2;
  static constexpr unsigned kOldestReadableVersion = 1;

  SdfGrid() = default;
  // `values` has info.NumNodes() entries, x fastest, then y, then z.
  SdfGrid(SdfGridInfo info, std::vector<float> values);

  const SdfGridInfo& info() const { return info_; }
  const std::vector<float>& values() const { return values_; }
  float NodeValue(int i, int j, int k) const {
    return values_[static_cast<size_t>(i) + stride_y_ * j + stride_z_ * k];
  }
  // The node values and the block minima below.
  size_t MemoryBytes() const { return (values_.size() + block_min_.size()) * sizeof(float); }

  // Distance at `p` (link frame) and, if `gradient` is not null, its gradient.
  // Inside the grid: trilinear interpolation and the exact gradient of that
  // interpolant; returns true. Outside the grid: the distance from `p` to the
  // geometry's bounding box, a lower bound of the true distance (the grid
  // extends the box by the padding on every side), with its gradient; returns
  // false. Never reads out of bounds.
  bool Evaluate(const Vec3& p, double* distance, Vec3* gradient) const;

  // For callers that only need distances below `cutoff` (collision penalties
  // over many points): returns false, without interpolating, when the
  // distance at `p` is certainly >= cutoff; otherwise returns true with
  // *distance and *gradient exactly as Evaluate() gives them. The test reads
  // the smallest node value of the block of kBlockCells^3 cells around `p`,
  // a lower bound of the trilinear interpolant there (which is a convex
  // combination of its cell's nodes); the block minima are 1/64 of the node
  // values, so they stay in cache where the full grid (megabytes) does not.
  static constexpr int kBlockCells = 4;
  bool EvaluateBelow(const Vec3& p, double cutoff, double* distance, Vec3* gradient) const;

  // Binary serialisation (docs/sdf_format.md).
  std::string Serialize() const;
  // `name` is used in error messages (usually the file path).
  static core::Result<SdfGrid> Deserialize(const std::string& bytes, const std::string& name);
  static core::Result<SdfGrid> Load(const std::string& path);  // memory-mapped when it can be

 private:
  static core::Result<SdfGrid> DeserializeView(std::string_view bytes, const std::string& name);
  bool EvaluateOutside(const Vec3& p, double* distance, Vec3* gradient) const;
  void BuildBlockMinima();
  // True when the grid coordinates u = (p - origin) / resolution lie in a cell.
  bool InCell(const Vec3& u) const;

  // Trilinear value (and gradient) in the cell with lowest node (ix, iy, iz)
  // at fractions (fx, fy, fz) in [0, 1).
  void Interpolate(size_t ix, size_t iy, size_t iz, double fx, double fy, double fz, double* distance,
                   Vec3* gradient) const;

  SdfGridInfo info_;
  std::vector<float> values_;
  double inverse_resolution_ = 0.0;
  size_t stride_y_ = 0;
  size_t stride_z_ = 0;
  // block_min_[bx + bstride_y_ * by + bstride_z_ * bz]: smallest node value
  // of the cells [b * kBlockCells, (b + 1) * kBlockCells) per axis (their
  // nodes, both faces included).
  std::vector<float> block_min_;
  size_t bstride_y_ = 0;
  size_t bstride_z_ = 0;
};

inline void SdfGrid::Interpolate(size_t ix, size_t iy, size_t iz, double fx, double fy, double fz, double* distance,
                                 Vec3* gradient) const {
  const float* c = values_.data() + ix + stride_y_ * iy + stride_z_ * iz;
  const double v000 = c[0], v100 = c[1];
  const double v010 = c[stride_y_], v110 = c[stride_y_ + 1];
  const double v001 = c[stride_z_], v101 = c[stride_z_ + 1];
  const double v011 = c[stride_y_ + stride_z_], v111 = c[stride_y_ + stride_z_ + 1];
  // Interpolate along x, then y, then z.
  const double v00 = v000 + fx * (v100 - v000), v10 = v010 + fx * (v110 - v010);
  const double v01 = v001 + fx * (v101 - v001), v11 = v011 + fx * (v111 - v011);
  const double v0 = v00 + fy * (v10 - v00), v1 = v01 + fy * (v11 - v01);
  *distance = v0 + fz * (v1 - v0);
  if (gradient != nullptr) {
    const double dx00 = v100 - v000, dx10 = v110 - v010, dx01 = v101 - v001, dx11 = v111 - v011;
    const double dx0 = dx00 + fy * (dx10 - dx00), dx1 = dx01 + fy * (dx11 - dx01);
    const double dy0 = v10 - v00, dy1 = v11 - v01;
    gradient->x() = (dx0 + fz * (dx1 - dx0)) * inverse_resolution_;
    gradient->y() = (dy0 + fz * (dy1 - dy0)) * inverse_resolution_;
    gradient->z() = (v1 - v0) * inverse_resolution_;
  }
}

inline bool SdfGrid::InCell(const Vec3& u) const {
  // 0 <= u < dims - 1 on every axis (the negated form also rejects NaN).
  return u.x() >= 0.0 && u.y() >= 0.0 && u.z() >= 0.0 && u.x() < info_.dims.x() - 1 && u.y() < info_.dims.y() - 1 &&
         u.z() < info_.dims.z() - 1;
}

inline bool SdfGrid::Evaluate(const Vec3& p, double* distance, Vec3* gradient) const {
  const Vec3 u = (p - info_.origin) * inverse_resolution_;
  if (!InCell(u)) return EvaluateOutside(p, distance, gradient);
  // u >= 0 here, so truncation is floor (and cheaper than std::floor).
  const size_t ix = static_cast<size_t>(u.x()), iy = static_cast<size_t>(u.y()), iz = static_cast<size_t>(u.z());
  Interpolate(ix, iy, iz, u.x() - ix, u.y() - iy, u.z() - iz, distance, gradient);
  return true;
}

inline bool SdfGrid::EvaluateBelow(const Vec3& p, double cutoff, double* distance, Vec3* gradient) const {
  const Vec3 u = (p - info_.origin) * inverse_resolution_;
  if (!InCell(u)) {
    EvaluateOutside(p, distance, gradient);  // cheap: the bounding-box distance
    return true;
  }
  const size_t ix = static_cast<size_t>(u.x()), iy = static_cast<size_t>(u.y()), iz = static_cast<size_t>(u.z());
  if (block_min_[ix / kBlockCells + bstride_y_ * (iy / kBlockCells) + bstride_z_ * (iz / kBlockCells)] >= cutoff) {
    return false;
  }
  Interpolate(ix, iy, iz, u.x() - ix, u.y() - iy, u.z() - iz, distance, gradient);
  return true;
}

}  // namespace quadhand::geometry
