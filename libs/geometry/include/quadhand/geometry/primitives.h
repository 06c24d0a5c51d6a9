// Exact primitives (box, cylinder, sphere): closed-form signed distances,
// used as ground truth by tests and accuracy benchmarks, and tessellations
// within a stated tolerance of the true surface.
#pragma once

#include "quadhand/core/types.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::geometry {

// Box with full edge lengths `size`, centred at the origin of `pose`.
struct Box {
  Pose pose = Pose::Identity();
  Vec3 size = Vec3::Ones();
};

// Cylinder along the z axis of `pose`, centred at its origin.
struct Cylinder {
  Pose pose = Pose::Identity();
  double radius = 1.0;
  double length = 1.0;
};

struct Sphere {
  Vec3 center = Vec3::Zero();
  double radius = 1.0;
};

// Exact signed distance (negative inside).
double SignedDistance(const Box& box, const Vec3& p);
double SignedDistance(const Cylinder& cylinder, const Vec3& p);
double SignedDistance(const Sphere& sphere, const Vec3& p);

// Closed, outward-oriented meshes. Curved surfaces deviate from the true
// primitive by at most `tolerance` (vertices on the surface, chords inside).
TriangleMesh TessellateBox(const Box& box);
TriangleMesh TessellateCylinder(const Cylinder& cylinder, double tolerance);
TriangleMesh TessellateSphere(const Sphere& sphere, double tolerance);

// Number of polygon sides so that chords of a circle of `radius` stay within `tolerance`.
int SidesForTolerance(double radius, double tolerance);

}  // namespace quadhand::geometry
