// A compact file of one collision mesh's repaired shells, scaled and placed
// in its link's frame by its collision element, so that a plan loads a
// robot exported from CAD without reading, repairing and checking its
// meshes again: for 400,000 triangles that is seconds per plan, against
// milliseconds for this file. quadhand-sdfgen writes one per mesh file it
// read, in the `meshes/` folder next to the link SDFs; every program that
// loads the robot with those SDFs reads them (robot/link_meshes.h).
//
// An entry is found by the hash of the mesh file's bytes, the repair options
// and the element's origin and scale, and holds only shells that bounded a
// volume, placed, when written: a changed mesh or URDF, other options or
// another repair revision (kMeshRepairRevision) simply miss, and the mesh is repaired as if there
// were no cache. The file is trusted as the SDF files are: its checksum
// finds corruption, not forgery (a forged entry can claim any solid, as a
// forged SDF can claim any distance). Format: docs/sdf_format.md.
#pragma once

#include <cstdint>
#include <string>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/geometry/mesh_repair.h"

namespace quadhand::geometry {

struct RepairedMeshCacheKey {
  uint64_t source_hash = 0;  // core::FastHash64 of the mesh file's bytes
  uint64_t source_size = 0;  // bytes
  MeshRepairOptions options;
  Pose placement = Pose::Identity();  // the collision element's origin in the link frame
  Vec3 scale = Vec3::Ones();          // the element's mesh scale, applied first
};

// The key of the mesh file at `path` (read whole and hashed: milliseconds
// for tens of megabytes), unplaced. Fails, naming the path, if it cannot be
// read.
core::Result<RepairedMeshCacheKey> RepairedMeshCacheKeyOf(const std::string& path, const MeshRepairOptions& options);

// Where the entry for `key` lives in `cache_dir`: "<16 hex digits>.qhmesh",
// a hash of the whole key.
std::string RepairedMeshCachePath(const std::string& cache_dir, const RepairedMeshCacheKey& key);

// Writes `repaired` (shells that bound a volume, report.problem empty) for
// `key` to `path` atomically, creating its folder.
core::Status WriteRepairedMeshCache(const std::string& path, const RepairedMeshCacheKey& key,
                                    const RepairedMesh& repaired);

// The entry at `path` if it holds `key`: NotFound when there is no such
// file; InvalidArgument, naming the file, when it is not an entry for this
// key (another mesh, options or revision) or is corrupted (checksum, sizes,
// a triangle indexing a missing vertex, a non-finite vertex). The shells
// read are known to CheckMesh as bounding a volume (their writer checked
// them), so the exact model built on them skips the self-intersection test.
core::Result<RepairedMesh> ReadRepairedMeshCache(const std::string& path, const RepairedMeshCacheKey& key);

}  // namespace quadhand::geometry
