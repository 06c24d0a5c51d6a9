// Inside the geometry library only: CheckMesh's memo (mesh_io.cc).
#pragma once

#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::geometry {

// Records that `mesh` bounds a volume with outward faces, so CheckMesh
// answers from its memo without the self-intersection test. Only for
// meshes read back from the repaired-mesh cache, whose writer checked them
// (repaired_mesh_cache.h).
void RememberMeshBoundsVolume(const TriangleMesh& mesh);

}  // namespace quadhand::geometry
