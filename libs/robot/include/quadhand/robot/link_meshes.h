// The collision geometry of a link in the link's frame: every collision
// element loaded (mesh files) or tessellated (URDF boxes, cylinders,
// spheres), placed by its origin and scale. Distances (SDFs, the exact
// model) are taken from the elements, the minimum of their signed distances:
// exact outside their union, with no mesh boolean, so elements may overlap,
// touch or share faces freely. One surface per link is for drawing and
// surface sampling.
#pragma once

#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/geometry/triangle_mesh.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::robot {

// Tolerance used to tessellate URDF cylinders and spheres, metres.
inline constexpr double kPrimitiveTessellationTolerance = 1e-4;

// Every collision element of the link, each a closed mesh: primitives
// tessellated, and each mesh file repaired (geometry/mesh_repair.h: the
// defects CAD exporters write) into its closed shells, one element each
// (their union is the file's solid). Fails, naming the file and the
// defect, if the link has no collision geometry or a mesh cannot be read or
// does not bound a volume even repaired.
core::Result<std::vector<geometry::TriangleMesh>> LinkCollisionElements(const RobotModel& model, int link);

// The folder of a robot's cached mesh repairs next to its link SDFs:
// "<sdf_dir>/meshes".
std::string MeshCacheDirOf(const std::string& sdf_dir);

// Writes the repair of every mesh file read in this process (by
// LinkCollisionElements, LinkSdfJobsFromUrdf) whose shells bound a volume
// and whose file is unchanged since, into `cache_dir`
// (geometry/repaired_mesh_cache.h). quadhand-sdfgen calls it once the SDFs
// are written, so that later plans with them skip the repairs. The number
// of entries written; fails, naming the file, if one cannot be written.
core::Result<int> SaveMeshRepairCache(const std::string& cache_dir);

// One line for each mesh file that needed repairs ("mesh 'arm.stl' (link
// 'link2') repaired: removed 1 pair of reversed duplicate faces ..."), for
// every file loaded in this process since the last call; each file once.
// Programs print them when loading succeeded: nothing is repaired silently.
std::vector<std::string> TakeMeshRepairReports();

// One surface for the link: the single element as read, else the boolean
// union of the elements, or, where that union cannot be computed (elements
// sharing faces, degenerate overlaps), all elements as one mesh with their
// inner surfaces kept (fine for drawing and for surface samples, which then
// include points inside the union; not a closed surface). Fails as
// LinkCollisionElements does.
core::Result<geometry::TriangleMesh> LinkCollisionMesh(const RobotModel& model, int link);

// The vertices of every collision element of each link, in the link's
// frame, indexed by link (empty for a link without collision geometry):
// what bounds the robot's extent in a configuration. Fails as
// LinkCollisionElements does.
core::Result<std::vector<std::vector<Vec3>>> LinkCollisionVertices(const RobotModel& model);
// The largest |x|, |y| and |z| of the collision elements' vertices in the
// root link's frame with every joint at its value nearest zero within its
// limits (the arm stowed); zero for a robot without collision geometry.
// Fails as LinkCollisionElements does.
core::Result<Vec3> StowedHalfExtents(const RobotModel& model);

// Half the robot's narrower horizontal extent with every joint at its value
// nearest zero within its limits (the arm stowed): the largest |x| and the
// largest |y| of the collision elements' vertices in the root link's frame,
// the smaller of the two. 0 for a robot without collision geometry; fails as
// LinkCollisionElements does.
core::Result<double> StowedHalfWidth(const RobotModel& model);

}  // namespace quadhand::robot
