// Mesh files (STL ascii/binary, OBJ, PLY, OFF), validity checks and boolean
// union, implemented with CGAL's Polygon Mesh Processing.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::geometry {

struct MeshRepairOptions;
struct MeshRepairReport;

// Largest mesh file read (every format is read whole by its reader).
inline constexpr unsigned long long kMaxMeshBytes = 256ull << 20;

// Reads a mesh and repairs it (mesh_repair.h) into the closed shells it
// means, reporting the repairs in *report (may be null). A mesh that does
// not bound a volume even so is returned as read, one "shell" (open
// surfaces are allowed for unsigned distances; CheckMesh tells). Fails with
// a message naming the file if unreadable or empty.
core::Result<std::vector<TriangleMesh>> ReadMeshShells(const std::string& path, const MeshRepairOptions& options,
                                                       MeshRepairReport* report);

// ReadMeshShells with the default repair, its shells as one mesh.
core::Result<TriangleMesh> ReadMesh(const std::string& path);

// Writes by extension (.stl is written binary, .off/.obj/.ply ascii).
core::Status WriteMesh(const std::string& path, const TriangleMesh& mesh);

struct MeshCheck {
  bool closed = false;              // every edge has exactly two incident faces
  bool self_intersecting = false;
  bool bounds_volume = false;       // closed, no self-intersection, consistently oriented
  bool outward = false;             // normals point out (positive signed volume)
  // A one-line summary of what is wrong, empty if nothing.
  std::string problem;
};

// Thread-safe. A large mesh is checked once per process: the answer is
// remembered for the recent meshes, matched bit for bit.
MeshCheck CheckMesh(const TriangleMesh& mesh);

// Boolean union of closed meshes (overlapping or touching), one closed surface
// without self-intersections. Exact constructions, so coplanar faces are fine.
// Vertices and triangles come in a canonical (sorted) order, so the same input
// always gives the same output.
core::Result<TriangleMesh> UnionOfClosedMeshes(const std::vector<TriangleMesh>& parts);

}  // namespace quadhand::geometry
