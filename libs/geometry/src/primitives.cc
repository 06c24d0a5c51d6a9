#include "quadhand/geometry/primitives.h"

#include <algorithm>
#include <cmath>

namespace quadhand::geometry {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Caps the polygon for absurd tolerances (zero, negative, NaN) instead of
// looping forever; a sphere is capped lower because its size grows quadratically.
constexpr int kMaxSides = 1 << 20;
constexpr int kMaxSphereSides = 1 << 12;

// Signed distance from a 2-D or 3-D "excess" vector q (per-axis distance
// beyond each slab, negative inside): the classic exact formula for an
// intersection of orthogonal slabs (box) or of a disc and a slab (cylinder).
template <typename Vector>
double DistanceFromExcess(const Vector& q) {
  const double outside = q.cwiseMax(0.0).norm();
  const double inside = std::min(q.maxCoeff(), 0.0);
  return outside + inside;
}

// Largest deviation of the triangle (a, b, c), whose vertices lie on a sphere
// of `radius` centred at the origin, from that sphere: the distance from the
// sphere to the triangle's plane bounds the distance to every point of it.
double InscribedTriangleDeviation(const Vec3& a, const Vec3& b, const Vec3& c, double radius) {
  const Vec3 normal = (b - a).cross(c - a);
  const double norm = normal.norm();
  if (norm == 0.0) return 0.0;  // a pole's degenerate sliver does not occur, but stay safe
  return radius - std::abs(normal.dot(a)) / norm;
}

// UV sphere of `radius` at the origin, `sides` vertices per latitude ring and
// `bands` bands between the poles; vertices on the sphere, triangles outward.
TriangleMesh UvSphere(double radius, int sides, int bands) {
  TriangleMesh mesh;
  mesh.vertices.emplace_back(0.0, 0.0, radius);  // north pole
  for (int band = 1; band < bands; ++band) {
    const double polar = kPi * band / bands;
    for (int side = 0; side < sides; ++side) {
      const double azimuth = 2.0 * kPi * side / sides;
      mesh.vertices.emplace_back(radius * std::sin(polar) * std::cos(azimuth),
                                 radius * std::sin(polar) * std::sin(azimuth),
                                 radius * std::cos(polar));
    }
  }
  mesh.vertices.emplace_back(0.0, 0.0, -radius);  // south pole
  const int north = 0;
  const int south = static_cast<int>(mesh.vertices.size()) - 1;
  auto ring_vertex = [sides](int ring, int side) { return 1 + ring * sides + side % sides; };
  for (int side = 0; side < sides; ++side) {
    mesh.triangles.emplace_back(north, ring_vertex(0, side), ring_vertex(0, side + 1));
    mesh.triangles.emplace_back(south, ring_vertex(bands - 2, side + 1),
                                ring_vertex(bands - 2, side));
  }
  for (int ring = 0; ring + 1 < bands - 1; ++ring) {
    for (int side = 0; side < sides; ++side) {
      const int a = ring_vertex(ring, side), b = ring_vertex(ring, side + 1);
      const int c = ring_vertex(ring + 1, side), d = ring_vertex(ring + 1, side + 1);
      mesh.triangles.emplace_back(a, c, d);
      mesh.triangles.emplace_back(a, d, b);
    }
  }
  return mesh;
}

}  // namespace

double SignedDistance(const Box& box, const Vec3& p) {
  const Vec3 local = box.pose.inverse() * p;
  return DistanceFromExcess(Vec3(local.cwiseAbs() - 0.5 * box.size));
}

double SignedDistance(const Cylinder& cylinder, const Vec3& p) {
  const Vec3 local = cylinder.pose.inverse() * p;
  const Eigen::Vector2d excess(local.head<2>().norm() - cylinder.radius,
                               std::abs(local.z()) - 0.5 * cylinder.length);
  return DistanceFromExcess(excess);
}

double SignedDistance(const Sphere& sphere, const Vec3& p) {
  return (p - sphere.center).norm() - sphere.radius;
}

int SidesForTolerance(double radius, double tolerance) {
  // A regular n-gon inscribed in the circle deviates from it by its sagitta
  // radius * (1 - cos(pi / n)), which decreases with n.
  auto within = [&](int n) { return radius * (1.0 - std::cos(kPi / n)) <= tolerance; };
  if (!(radius > 0.0) || within(3)) return 3;
  if (!(tolerance > 0.0)) return kMaxSides;
  const double estimate = std::ceil(kPi / std::acos(1.0 - tolerance / radius));
  int n = static_cast<int>(std::clamp(estimate, 3.0, static_cast<double>(kMaxSides)));
  // The estimate can be off by one from rounding; settle on the smallest n.
  while (n > 3 && within(n - 1)) --n;
  while (n < kMaxSides && !within(n)) ++n;
  return n;
}

TriangleMesh TessellateBox(const Box& box) {
  TriangleMesh mesh;
  // Vertex index = ix + 2 iy + 4 iz, with i = 0 at the minus side.
  for (int index = 0; index < 8; ++index) {
    const Vec3 sign((index & 1) ? 0.5 : -0.5, (index & 2) ? 0.5 : -0.5, (index & 4) ? 0.5 : -0.5);
    mesh.vertices.push_back(box.pose * sign.cwiseProduct(box.size));
  }
  // Two triangles per face, counter-clockwise seen from outside.
  mesh.triangles = {{0, 4, 6}, {0, 6, 2},   // -x
                    {1, 3, 7}, {1, 7, 5},   // +x
                    {0, 1, 5}, {0, 5, 4},   // -y
                    {2, 6, 7}, {2, 7, 3},   // +y
                    {0, 2, 3}, {0, 3, 1},   // -z
                    {4, 5, 7}, {4, 7, 6}};  // +z
  if (box.pose.linear().determinant() < 0.0) {
    for (Eigen::Vector3i& t : mesh.triangles) std::swap(t[1], t[2]);
  }
  return mesh;
}

TriangleMesh TessellateCylinder(const Cylinder& cylinder, double tolerance) {
  // The side faces are planar rectangles whose deviation from the cylinder is
  // exactly the sagitta of the polygon; the caps are exact. Rounding the side
  // count up to a multiple of 4 (a smaller sagitta still) keeps the mesh
  // symmetric under the cylinder's own mirror planes, so symmetric parts stay
  // symmetric (e.g. zero products of inertia, centred bounding boxes).
  const int sides = std::min((SidesForTolerance(cylinder.radius, tolerance) + 3) / 4 * 4,
                             kMaxSides);
  const double half_length = 0.5 * cylinder.length;
  TriangleMesh mesh;
  for (int ring = 0; ring < 2; ++ring) {
    const double z = ring == 0 ? -half_length : half_length;
    for (int side = 0; side < sides; ++side) {
      const double azimuth = 2.0 * kPi * side / sides;
      mesh.vertices.emplace_back(cylinder.radius * std::cos(azimuth),
                                 cylinder.radius * std::sin(azimuth), z);
    }
  }
  const int bottom_centre = static_cast<int>(mesh.vertices.size());
  mesh.vertices.emplace_back(0.0, 0.0, -half_length);
  const int top_centre = bottom_centre + 1;
  mesh.vertices.emplace_back(0.0, 0.0, half_length);
  for (int side = 0; side < sides; ++side) {
    const int next = (side + 1) % sides;
    const int b0 = side, b1 = next, t0 = sides + side, t1 = sides + next;
    mesh.triangles.emplace_back(bottom_centre, b1, b0);
    mesh.triangles.emplace_back(top_centre, t0, t1);
    mesh.triangles.emplace_back(b0, b1, t1);
    mesh.triangles.emplace_back(b0, t1, t0);
  }
  return Transformed(mesh, cylinder.pose);
}

TriangleMesh TessellateSphere(const Sphere& sphere, double tolerance) {
  // The triangles of a UV sphere deviate more than the edge sagitta (a
  // quad's diagonal is longer than its edges), so the deviation is measured
  // on the mesh itself and the resolution raised until it is within tolerance.
  int sides = std::clamp(SidesForTolerance(sphere.radius, tolerance), 4, kMaxSphereSides);
  for (;;) {
    const int bands = std::max((sides + 1) / 2, 2);
    TriangleMesh mesh = UvSphere(sphere.radius, sides, bands);
    double deviation = 0.0;
    for (const Eigen::Vector3i& t : mesh.triangles) {
      deviation = std::max(deviation, InscribedTriangleDeviation(
                                          mesh.vertices[t[0]], mesh.vertices[t[1]],
                                          mesh.vertices[t[2]], sphere.radius));
    }
    if (deviation <= tolerance || sides >= kMaxSphereSides) {
      for (Vec3& v : mesh.vertices) v += sphere.center;
      return mesh;
    }
    sides = std::min(sides + std::max(1, sides / 8), kMaxSphereSides);
  }
}

}  // namespace quadhand::geometry
