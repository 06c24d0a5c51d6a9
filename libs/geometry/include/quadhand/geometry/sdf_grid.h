// A signed distance field sampled on a regular grid in one link's frame, with
// trilinear interpolation and its analytic gradient. File format: docs/sdf_format.md.
#pragma once

#include <cmath>
#include <string>
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
  Vec3 geometry_max = Vec3::Zero();

  // Interpolation domain: [origin, origin + (dims - 1) * resolution].
  Vec3 GridMax() const { return origin + (dims - Eigen::Vector3i::Ones()).cast<double>() * resolution; }
  long NumNodes() const { return static_cast<long>(dims.x()) * dims.y() * dims.z(); }
};

class SdfGrid {
 public:
  static constexpr unsigned kFormatVersion = 1;

  SdfGrid() = default;
  // `values` has info.NumNodes() entries, x fastest, then y, then z.
  SdfGrid(SdfGridInfo info, std::vector<float> values);

  const SdfGridInfo& info() const { return info_; }
  const std::vector<float>& values() const { return values_; }
  float NodeValue(int i, int j, int k) const {
    return values_[static_cast<size_t>(i) + stride_y_ * j + stride_z_ * k];
  }
  size_t MemoryBytes() const { return values_.size() * sizeof(float); }

  // Distance at `p` (link frame) and, if `gradient` is not null, its gradient.
  // Inside the grid: trilinear interpolation and the exact gradient of that
  // interpolant; returns true. Outside the grid: the distance from `p` to the
  // geometry's bounding box, a lower bound of the true distance (the grid
  // extends the box by the padding on every side), with its gradient; returns
  // false. Never reads out of bounds.
  bool Evaluate(const Vec3& p, double* distance, Vec3* gradient) const;

  // Binary serialisation (docs/sdf_format.md).
  std::string Serialize() const;
  // `name` is used in error messages (usually the file path).
  static core::Result<SdfGrid> Deserialize(const std::string& bytes, const std::string& name);
  static core::Result<SdfGrid> Load(const std::string& path);

 private:
  bool EvaluateOutside(const Vec3& p, double* distance, Vec3* gradient) const;

  SdfGridInfo info_;
  std::vector<float> values_;
  double inverse_resolution_ = 0.0;
  size_t stride_y_ = 0;
  size_t stride_z_ = 0;
};

inline bool SdfGrid::Evaluate(const Vec3& p, double* distance, Vec3* gradient) const {
  const Vec3 u = (p - info_.origin) * inverse_resolution_;
  // Cell index, valid when 0 <= u < dims - 1 (the negated test also rejects NaN).
  const double ux = std::floor(u.x()), uy = std::floor(u.y()), uz = std::floor(u.z());
  if (!(ux >= 0.0 && uy >= 0.0 && uz >= 0.0 && ux < info_.dims.x() - 1 &&
        uy < info_.dims.y() - 1 && uz < info_.dims.z() - 1)) {
    return EvaluateOutside(p, distance, gradient);
  }
  const double fx = u.x() - ux, fy = u.y() - uy, fz = u.z() - uz;
  const float* c = values_.data() + static_cast<size_t>(ux) + stride_y_ * static_cast<size_t>(uy) +
                   stride_z_ * static_cast<size_t>(uz);
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
  return true;
}

}  // namespace quadhand::geometry
