// A robot link approximated by points on its collision surface, for the
// baseline representations that measure the robot by points (ESDF, safe-flight
// corridors) instead of by a link SDF (MRC-SDF).
//
// Every triangle of the link mesh is covered by rows parallel to its longest
// edge, at most spacing * sqrt(3)/2 apart (from that edge to the opposite
// vertex), each sampled at most `spacing` apart, ends included (each vertex
// once, and the points of an edge shared by two triangles once). So every
// mesh vertex is a sample, every surface point is within `spacing` of a
// sample, and the count is close to area / (spacing^2 sqrt(3)/2) even for
// sliver triangles.
//
// The samples are grouped into clusters (cells of `cluster_size` in the link
// frame), each with a bounding sphere, so a query can skip a whole cluster
// with one test (a cluster far from every obstacle, or deep inside a polytope).
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::env {

struct LinkSurfaceSamples {
  struct Cluster {
    int begin = 0;  // samples [begin, end) of `points`
    int end = 0;
    Vec3 center = Vec3::Zero();  // link frame
    double radius = 0.0;         // every sample of the cluster is within it of `center`
  };
  std::vector<Vec3> points;  // link frame, metres, grouped by cluster
  std::vector<Cluster> clusters;
  std::vector<Vec3> vertices;  // the mesh vertices (link frame), for exact extreme-point queries
};

// Samples `mesh` (link frame) as described above. spacing > 0 and
// cluster_size > 0, metres. An empty mesh gives no samples.
LinkSurfaceSamples SampleLinkSurface(const geometry::TriangleMesh& mesh, double spacing,
                                     double cluster_size = 0.04);

// The most samples one mesh may need (about 200 MB while sampling). A robot
// link or a held object of a few square metres stays far below it at any
// allowed spacing; a mesh above it is almost always one exported in
// millimetres and read as metres.
inline constexpr double kMaxSurfaceSamples = 4e6;

// About how many samples SampleLinkSurface gives (its area over
// spacing^2 sqrt(3)/2, plus the vertices), without sampling.
double EstimatedSurfaceSampleCount(const geometry::TriangleMesh& mesh, double spacing);

// Ok when sampling `mesh` at `spacing` stays within kMaxSurfaceSamples;
// otherwise InvalidArgument naming `what`, the mesh's area and size, so
// that a wrong unit is refused in one line rather than exhausting memory.
core::Status CheckSurfaceSampleCount(const geometry::TriangleMesh& mesh, double spacing, const std::string& what);

}  // namespace quadhand::env
