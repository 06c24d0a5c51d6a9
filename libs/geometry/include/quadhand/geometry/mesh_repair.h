// Mesh intake for meshes exported from CAD: a triangle soup in, the closed
// shells it means out, every repair counted. CAD exporters routinely write
// duplicate and reversed-duplicate faces, zero-area faces, vertices that
// should coincide but differ in the last digits, inconsistently oriented
// faces and several shells in one file. What can be repaired without
// changing the solid is repaired; what cannot is refused with the defect,
// how many and where. A mesh is never made to look closed when it is not:
// a hole wider than the tolerance stays a hole and is refused.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::geometry {

// The revision of RepairMesh and ReadMeshShells' repairs. Increment it with
// any change that can give other shells or other counts for the same file
// and options: cached repairs of another revision (repaired_mesh_cache.h)
// are then ignored, not trusted.
inline constexpr uint32_t kMeshRepairRevision = 1;

struct MeshRepairOptions {
  // Vertices closer than this (m) are one vertex: cracks and slivers
  // narrower than it close. Far under any SDF resolution (the SDF's own
  // error is half a voxel) and under the finest features of real meshes
  // (the reference robot's base has distinct vertices 8 um apart), over the
  // rounding of single-precision coordinates (0.1 um at 1 m).
  double tolerance = 1e-6;
  // Metres per unit of the mesh's coordinates (a URDF's mesh scale: 0.001
  // for a mesh in millimetres), so that the tolerance is in metres whatever
  // the file's units.
  double metres_per_unit = 1.0;
  bool IsValid(std::string* why) const;  // tolerance finite, > 0 and <= 1 mm; metres_per_unit finite, > 0
};

// A repair tolerance a user gave, for a robot whose SDFs have spacing
// `resolution` (m): finite, positive, at most 1 mm and at most the
// resolution (merging vertices farther apart than the grid's spacing would
// close openings the grid itself resolves). The message names the values.
core::Status CheckRepairTolerance(double tolerance, double resolution);

struct MeshRepairReport {
  long merged_vertices = 0;          // vertices merged into another within the tolerance
  long degenerate_faces = 0;         // faces with two corners at one vertex (after merging), removed
  long duplicate_faces = 0;          // extra copies of a face, removed
  long reversed_duplicate_pairs = 0; // a face and its reversed copy (a zero-volume fin), both removed
  long reversed_duplicate_faces = 0; // reversed extra copies of a face of the surface, removed (one copy kept)
  long flipped_faces = 0;            // faces turned to agree with their neighbours
  long outward_shells = 0;           // shells turned inside out to face outward
  long shells = 0;                   // closed shells in the result
  // ReadMeshShells, for polygon files and soups RepairMesh refused as read:
  // what CGAL's general polygon-soup repair (run first there) changed.
  long soup_points_merged = 0;
  long soup_faces_removed = 0;
  // ReadMeshShells: why the mesh, returned as read, does not bound a volume
  // (RepairMesh's diagnosis); empty when it does.
  std::string problem;
  // One line per repair made, with its count ("removed 1 pair of reversed
  // duplicate faces (a zero-volume fin)"); empty when nothing was changed.
  std::vector<std::string> Lines() const;
};

struct RepairedMesh {
  std::vector<TriangleMesh> shells;  // each closed, consistently oriented, facing outward
  MeshRepairReport report;
};

// Repairs `mesh` (any soup: triangles may index any vertex). InvalidArgument
// with the true defect when the result does not bound a volume: holes (how
// many, each with its border's edge count, centre and size), an edge of
// more than two faces (where), a shell that cannot be oriented, a
// self-intersecting shell (which, and where), no face left.
core::Result<RepairedMesh> RepairMesh(const TriangleMesh& mesh, const MeshRepairOptions& options = {});

}  // namespace quadhand::geometry
