// A plain indexed triangle mesh, the exchange type between QuadHand
// libraries (CGAL stays inside the geometry library's .cc files).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "quadhand/core/types.h"

namespace quadhand::geometry {

struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<Eigen::Vector3i> triangles;  // counter-clockwise seen from outside

  int num_triangles() const { return static_cast<int>(triangles.size()); }
};

struct AxisAlignedBox {
  Vec3 min = Vec3::Constant(1e300);
  Vec3 max = Vec3::Constant(-1e300);
  bool empty() const { return (max.array() < min.array()).any(); }
  Vec3 size() const { return max - min; }
};

AxisAlignedBox BoundingBox(const TriangleMesh& mesh);

// Signed volume by the divergence theorem: positive for a closed mesh whose
// triangles face outward.
double SignedVolume(const TriangleMesh& mesh);

// The mesh with every vertex mapped through `pose` (and scaled first).
TriangleMesh Transformed(const TriangleMesh& mesh, const Pose& pose,
                         const Vec3& scale = Vec3::Ones());

// Concatenation, without merging anything (a soup of several closed parts).
TriangleMesh Concatenated(const std::vector<TriangleMesh>& parts);

}  // namespace quadhand::geometry
