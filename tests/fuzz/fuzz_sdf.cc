// Link SDF files (.qhsdf, docs/sdf_format.md).
#include <string>

#include "quadhand/geometry/sdf_grid.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  auto grid = quadhand::geometry::SdfGrid::Deserialize(bytes, "fuzz.qhsdf");
  if (grid.ok()) {
    double distance = 0.0;
    Eigen::Vector3d gradient;
    grid->Evaluate(Eigen::Vector3d(0.01, -0.02, 0.03), &distance, &gradient);  // a grid that loads can be queried
  }
  return 0;
}
