// One signed distance field per collision link of a robot, written to a
// folder as <link>.qhsdf (docs/sdf_format.md): what quadhand-sdfgen and the
// Python module's generate_sdfs() do.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/geometry/mesh_to_sdf.h"
#include "quadhand/geometry/sdf_grid.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::robot {

inline constexpr const char* kSdfFileExtension = ".qhsdf";

// `<dir>/<link_name>.qhsdf`, or InvalidArgument when the link's name cannot
// be a file name in that folder (empty, ".", "..", a '/', a control
// character): a URDF's link named "../../x" must not write or read outside
// the SDF folder.
core::Result<std::string> LinkSdfPath(const std::string& dir, const std::string& link_name);

// One grid to make: the link's name (and output file), where its geometry
// came from (for messages and the file header), and its collision elements
// in its frame (the grid is their union: geometry::GenerateSdf).
struct LinkSdfJob {
  std::string link_name;
  std::string source;
  std::vector<geometry::TriangleMesh> elements;
};

// A job for every link of the URDF with collision geometry, or only for
// `only_links` (each must exist and have collision geometry); meshes are
// repaired with `mesh_repair_tolerance` (RobotModel::mesh_repair_tolerance).
core::Result<std::vector<LinkSdfJob>> LinkSdfJobsFromUrdf(const std::string& urdf_path,
                                                          const std::vector<std::string>& only_links,
                                                          double mesh_repair_tolerance = 1e-6);

// Fails, naming the link, its source and the element, if a link's name
// cannot be a file name (LinkSdfPath), or if an element does not bound a
// volume (open, self-intersecting, NaN vertices) and
// options.allow_unsigned is off. Cheap: run it before generating anything.
core::Status CheckLinkSdfJobs(const std::vector<LinkSdfJob>& jobs, const geometry::SdfGenerationOptions& options);

// Progress of one link's grid (nodes done of total); a null function is fine.
using LinkSdfProgress = std::function<void(const std::string& link_name, long done, long total)>;

// One file written, and what is in it.
struct WrittenLinkSdf {
  std::string path;
  geometry::SdfGridInfo info;
  size_t memory_bytes = 0;
  int num_triangles = 0;  // of the elements it was made from
};

// Generates every job's grid and writes all files into `out_dir` (created if
// missing) together, or none of them. Whether `out_dir` can be made is
// checked first; a folder made here exists only once every grid is
// computed (they are held in memory until then), so a run killed while
// computing leaves nothing behind.
core::Result<std::vector<WrittenLinkSdf>> WriteLinkSdfs(const std::vector<LinkSdfJob>& jobs, const std::string& out_dir,
                                                     const geometry::SdfGenerationOptions& options,
                                                     const LinkSdfProgress& progress = {});

}  // namespace quadhand::robot
