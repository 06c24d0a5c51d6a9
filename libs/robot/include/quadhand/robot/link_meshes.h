// The collision geometry of a link as one closed mesh in the link's frame:
// every collision element loaded (mesh files) or tessellated (URDF boxes,
// cylinders, spheres), placed by its origin and scale, and merged by boolean
// union when there are several, so consumers see one surface per link.
#pragma once

#include "quadhand/core/status.h"
#include "quadhand/geometry/triangle_mesh.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::robot {

// Tolerance used to tessellate URDF cylinders and spheres, metres.
inline constexpr double kPrimitiveTessellationTolerance = 1e-4;

// Fails if the link has no collision geometry or a mesh cannot be read.
core::Result<geometry::TriangleMesh> LinkCollisionMesh(const RobotModel& model, int link);

}  // namespace quadhand::robot
