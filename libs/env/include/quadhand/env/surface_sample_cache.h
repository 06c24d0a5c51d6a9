// Surface samples of a collision element (link_surface_samples.h) kept on
// disk next to the repaired-mesh cache (geometry/repaired_mesh_cache.h):
// quadhand-sdfgen writes them at the self-collision model's default
// spacings, and a plan with those SDFs reads them instead of sampling a CAD
// export's hundreds of thousands of triangles again (tens of milliseconds
// per plan). An entry is found by a hash of the element's exact vertices
// and triangles, the spacing, the cluster size and the sampling revision:
// another mesh or spacing misses, and the samples are computed. Entries are
// trusted as the SDF files are: the checksum finds corruption (a corrupted
// entry is ignored), not forgery. Format: docs/sdfgen.md.
#pragma once

#include <string>

#include "quadhand/core/status.h"
#include "quadhand/env/link_surface_samples.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::env {

// Increment with any change of SampleLinkSurface's samples or their order:
// entries of another revision are then ignored.
inline constexpr uint32_t kSurfaceSamplingRevision = 1;

// SampleLinkSurface(mesh, spacing, cluster_size), read from `cache_dir`
// when it holds them (an empty `cache_dir`: never).
LinkSurfaceSamples CachedLinkSurfaceSamples(const geometry::TriangleMesh& mesh, double spacing,
                                            const std::string& cache_dir, double cluster_size = 0.04);

// Samples `mesh` and writes the samples into `cache_dir` (created if
// missing), atomically. Fails naming the file.
core::Status WriteLinkSurfaceSamples(const geometry::TriangleMesh& mesh, double spacing, const std::string& cache_dir,
                                     double cluster_size = 0.04);

}  // namespace quadhand::env
