// Mesh -> signed distance grid, with exact point-triangle distances (CGAL
// AABB tree) and a robust inside test, multithreaded over grid slices.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/geometry/sdf_grid.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::geometry {

struct SdfGenerationOptions {
  double resolution = 0.002;  // node spacing, metres (docs/sdf_accuracy.md for the choice)
  double padding = 0.08;      // margin around the mesh's bounding box, metres
  int num_threads = 0;        // 0: all hardware threads
  bool allow_unsigned = false;  // accept meshes that do not bound a volume; distances unsigned

  bool IsValid(std::string* why) const;
};

// Nodes along x, y and z of the grid GenerateSdf() makes for `meshes` (their
// union's bounding box plus the padding), without making it: InvalidArgument
// when there is no geometry or the grid would have more than 2e8 nodes, so a
// caller can refuse every link's size before it starts on the first.
core::Result<Eigen::Vector3i> SdfGridDims(const std::vector<TriangleMesh>& meshes, const SdfGenerationOptions& options);

// (nodes done, nodes total); called from the generating threads, serialised.
using ProgressCallback = std::function<void(long done, long total)>;

// `mesh` is in the link frame. Fails (InvalidArgument) on an empty mesh, and on
// a mesh that does not bound a volume unless options.allow_unsigned.
core::Result<SdfGrid> GenerateSdf(const TriangleMesh& mesh, const std::string& link_name,
                                  const std::string& source, const SdfGenerationOptions& options,
                                  const ProgressCallback& progress = {});

// The SDF of the union of several closed meshes (a link's collision
// elements, overlapping freely): at every node the smallest of their signed
// distances, which is the exact distance to the union outside it and a
// negative value inside (a bound on the depth, never positive). No mesh
// boolean is needed, so touching, coincident or degenerate overlaps are
// fine. The grid spans the union's bounding box; any element that does not
// bound a volume fails it, or (options.allow_unsigned) makes it unsigned.
core::Result<SdfGrid> GenerateSdf(const std::vector<TriangleMesh>& meshes, const std::string& link_name,
                                  const std::string& source, const SdfGenerationOptions& options,
                                  const ProgressCallback& progress = {});

}  // namespace quadhand::geometry
