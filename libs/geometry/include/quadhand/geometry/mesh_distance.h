// Exact distance queries against a triangle mesh (CGAL AABB tree), with a
// robust inside test for closed meshes. Used to build SDFs and to post-check
// plans against the true link geometry rather than its sampled SDF.
#pragma once

#include <memory>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::geometry {

class MeshDistanceQuery {
 public:
  // `is_signed`: the mesh must bound a volume (CheckMesh().bounds_volume);
  // otherwise distances are unsigned and Create fails only on an empty mesh.
  static core::Result<std::unique_ptr<MeshDistanceQuery>> Create(const TriangleMesh& mesh,
                                                                 bool is_signed);
  ~MeshDistanceQuery();

  // Distance to the surface, negative inside when signed. Thread-safe. A
  // point with an infinite or NaN coordinate has no distance: NaN (and
  // IsInside() is false).
  double SignedDistance(const Vec3& p) const;
  // Unsigned distance and the closest surface point. Thread-safe.
  double UnsignedDistance(const Vec3& p, Vec3* closest = nullptr) const;
  // Same, with a hint (a nearby closest point) that speeds up coherent queries.
  double UnsignedDistanceWithHint(const Vec3& p, const Vec3& hint, Vec3* closest) const;
  bool IsInside(const Vec3& p) const;  // false for unsigned queries
  bool is_signed() const { return is_signed_; }

 private:
  struct Impl;
  explicit MeshDistanceQuery(std::unique_ptr<Impl> impl, bool is_signed);
  std::unique_ptr<Impl> impl_;
  bool is_signed_;
};

}  // namespace quadhand::geometry
