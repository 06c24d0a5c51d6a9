// Meshes read with Assimp (Collada .dae, common in ROS packages): the only
// translation unit that includes Assimp. Private to the geometry library;
// ReadMesh (mesh_io.h) calls it and repairs the soup as for other formats.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::geometry {

// Every triangle of every mesh in the file, in the file's own axes scaled to
// metres by its unit (Collada <unit meter=...>), with the node transforms
// applied: the ROS convention (RViz, MoveIt), which ignores Collada's
// <up_axis> instead of turning the model to Assimp's y-up. Points and lines
// are dropped. Errors name the file.
struct TriangleSoup {
  std::vector<Vec3> vertices;
  std::vector<std::array<std::size_t, 3>> triangles;
};
core::Result<TriangleSoup> ReadAssimpSoup(const std::string& path);

}  // namespace quadhand::geometry
