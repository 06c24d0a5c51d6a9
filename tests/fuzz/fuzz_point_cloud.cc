// Point-cloud files (PCD in every encoding, PLY): the first byte picks the
// format, the rest is the file. Every input must give a cloud or an error.
#include "fuzz_support.h"
#include "quadhand/scene/point_cloud.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string path = quadhand::fuzz::WriteInput(data + 1, size - 1, data[0] % 2 == 0 ? "scan.pcd" : "scan.ply");
  auto cloud = quadhand::scene::LoadPointCloud(path);
  if (cloud.ok()) {
    for (const auto& p : cloud->points) {
      if (!p.allFinite()) __builtin_trap();  // a cloud that loads holds finite points only
    }
  }
  return 0;
}
