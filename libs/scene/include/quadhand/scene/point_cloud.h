// Obstacle point clouds: PCD files (ascii, binary, binary_compressed) read and
// written with PCL. PCL stays inside point_cloud.cc.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"

namespace quadhand::scene {

struct PointCloud {
  std::vector<Vec3> points;  // world frame, metres
  long dropped_non_finite = 0;  // points with NaN/inf coordinates skipped while loading
};

// Loads the x, y, z fields of a PCD file, dropping non-finite points.
// Errors (naming the file): unreadable, not a PCD, no x/y/z fields, and no
// finite point left.
core::Result<PointCloud> LoadPcd(const std::string& path);

enum class PcdEncoding { kAscii, kBinary, kBinaryCompressed };

// Writes x, y, z (float32, as PCD stores them) atomically.
core::Status WritePcd(const std::string& path, const std::vector<Vec3>& points,
                      PcdEncoding encoding = PcdEncoding::kBinary);

}  // namespace quadhand::scene
