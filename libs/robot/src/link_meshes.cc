#include "quadhand/robot/link_meshes.h"

#include <algorithm>
#include <utility>
#include <vector>

#include "quadhand/geometry/mesh_io.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/geometry/primitives.h"

namespace quadhand::robot {
namespace {

using core::Result;
using core::Status;

// One collision element as a closed mesh in the link frame.
Result<geometry::TriangleMesh> ElementMesh(const CollisionGeometry& element) {
  switch (element.type) {
    case GeometryType::kMesh: {
      Result<geometry::TriangleMesh> mesh = geometry::ReadMesh(element.mesh_path);
      if (!mesh.ok()) return mesh.status();
      // Transformed() flips the winding for a mirroring scale, so outward stays outward.
      geometry::TriangleMesh placed = geometry::Transformed(*mesh, element.origin, element.mesh_scale);
      // The same bound as the primitives' sizes and the joints' origins: CGAL's
      // exact distances overflow (and abort) on far larger coordinates.
      for (const Vec3& vertex : placed.vertices) {
        if (!(vertex.allFinite() && vertex.cwiseAbs().maxCoeff() <= 1000.0)) {
          return Status::InvalidArgument("mesh '" + element.mesh_path +
                                         "': scaled and placed, a vertex lies more than 1000 m from the link frame");
        }
      }
      return placed;
    }
    case GeometryType::kBox:
      return geometry::TessellateBox(geometry::Box{element.origin, element.box_size});
    case GeometryType::kCylinder:
      return geometry::TessellateCylinder(
          geometry::Cylinder{element.origin, element.radius, element.length},
          kPrimitiveTessellationTolerance);
    case GeometryType::kSphere:
      return geometry::TessellateSphere(
          geometry::Sphere{element.origin.translation(), element.radius},
          kPrimitiveTessellationTolerance);
  }
  return Status::Internal("unknown collision geometry type");
}

}  // namespace

Result<std::vector<geometry::TriangleMesh>> LinkCollisionElements(const RobotModel& model, int link) {
  if (link < 0 || link >= model.num_links()) {
    return Status::InvalidArgument("link index " + std::to_string(link) + " out of range");
  }
  const Link& data = model.link(link);
  const std::string where = "link '" + data.name + "'";
  if (data.collisions.empty()) return Status::InvalidArgument(where + ": no collision geometry");
  std::vector<geometry::TriangleMesh> parts;
  parts.reserve(data.collisions.size());
  for (const CollisionGeometry& element : data.collisions) {
    Result<geometry::TriangleMesh> part = ElementMesh(element);
    if (!part.ok()) return part.status().WithPrefix(where);
    parts.push_back(std::move(part).value());
  }
  return parts;
}

Result<geometry::TriangleMesh> LinkCollisionMesh(const RobotModel& model, int link) {
  Result<std::vector<geometry::TriangleMesh>> parts = LinkCollisionElements(model, link);
  if (!parts.ok()) return parts.status();
  // A single element is returned as read: the union would only re-mesh it.
  if (parts->size() == 1) return std::move(parts->front());
  Result<geometry::TriangleMesh> merged = geometry::UnionOfClosedMeshes(*parts);
  if (merged.ok()) return merged;
  geometry::TriangleMesh soup;
  for (const geometry::TriangleMesh& part : *parts) {
    const int offset = static_cast<int>(soup.vertices.size());
    soup.vertices.insert(soup.vertices.end(), part.vertices.begin(), part.vertices.end());
    for (const auto& triangle : part.triangles) {
      soup.triangles.push_back(triangle + Eigen::Vector3i::Constant(offset));
    }
  }
  return soup;
}

core::Result<double> StowedHalfWidth(const RobotModel& model) {
  VecX q(model.num_actuated());
  for (int i = 0; i < model.num_actuated(); ++i) {
    const Joint& joint = model.joint(model.actuated_joints()[i]);
    q[i] = std::clamp(0.0, joint.lower, joint.upper);
  }
  KinematicsState state;
  ComputeKinematics(model, Pose::Identity(), q, &state);
  Vec3 reach = Vec3::Zero();
  bool any = false;
  for (int link : model.CollisionLinks()) {
    auto elements = LinkCollisionElements(model, link);
    if (!elements.ok()) return elements.status();
    for (const geometry::TriangleMesh& mesh : *elements) {
      for (const Vec3& v : mesh.vertices) {
        reach = reach.cwiseMax((state.link_poses[link] * v).cwiseAbs());
        any = true;
      }
    }
  }
  return any ? std::min(reach.x(), reach.y()) : 0.0;
}

}  // namespace quadhand::robot
