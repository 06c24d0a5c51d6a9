// Robot mesh files (STL ascii/binary, OBJ, PLY, OFF, Collada): the first
// byte picks the extension, the rest is the file.
#include "fuzz_support.h"
#include "quadhand/geometry/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const char* const kNames[] = {"mesh.stl", "mesh.obj", "mesh.ply", "mesh.off", "mesh.dae"};
  const std::string path = quadhand::fuzz::WriteInput(data + 1, size - 1, kNames[data[0] % 5]);
  auto mesh = quadhand::geometry::ReadMesh(path);
  (void)mesh;
  return 0;
}
