#include "quadhand/geometry/triangle_mesh.h"

#include <utility>
#include <Eigen/LU>

namespace quadhand::geometry {

AxisAlignedBox BoundingBox(const TriangleMesh& mesh) {
  AxisAlignedBox box;
  for (const Vec3& v : mesh.vertices) {
    box.min = box.min.cwiseMin(v);
    box.max = box.max.cwiseMax(v);
  }
  return box;
}

double SignedVolume(const TriangleMesh& mesh) {
  // Sum of the signed volumes of the tetrahedra (origin, a, b, c). Summed in
  // a frame centred on the first vertex so that meshes far from the origin do
  // not lose digits to cancellation.
  if (mesh.vertices.empty()) return 0.0;
  const Vec3 reference = mesh.vertices.front();
  double six_volume = 0.0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]] - reference;
    const Vec3 b = mesh.vertices[t[1]] - reference;
    const Vec3 c = mesh.vertices[t[2]] - reference;
    six_volume += a.dot(b.cross(c));
  }
  return six_volume / 6.0;
}

TriangleMesh Transformed(const TriangleMesh& mesh, const Pose& pose, const Vec3& scale) {
  TriangleMesh out;
  out.triangles = mesh.triangles;
  out.vertices.reserve(mesh.vertices.size());
  for (const Vec3& v : mesh.vertices) out.vertices.push_back(pose * v.cwiseProduct(scale));
  // A mirroring map (negative scale product, or a pose with a reflection)
  // would turn outward triangles inward: flip the winding to compensate.
  if (scale.x() * scale.y() * scale.z() * pose.linear().determinant() < 0.0) {
    for (Eigen::Vector3i& t : out.triangles) std::swap(t[1], t[2]);
  }
  return out;
}

TriangleMesh Concatenated(const std::vector<TriangleMesh>& parts) {
  TriangleMesh out;
  for (const TriangleMesh& part : parts) {
    const int offset = static_cast<int>(out.vertices.size());
    out.vertices.insert(out.vertices.end(), part.vertices.begin(), part.vertices.end());
    for (const Eigen::Vector3i& t : part.triangles) {
      out.triangles.push_back(t + Eigen::Vector3i::Constant(offset));
    }
  }
  return out;
}

}  // namespace quadhand::geometry
