// Obstacle point clouds: PCD files (ascii, binary, binary_compressed;
// organised or not) and PLY files read with PCL, PCD written with PCL. PCL
// stays inside point_cloud.cc.
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

// Loads the x, y, z fields of a PCD file as doubles, whatever numeric type
// they are stored in (float32, float64, 8- to 32-bit integers), ignoring
// other fields (rgb, intensity, normals) and dropping non-finite points (an
// organised cloud's NaNs). Errors (naming the file): not a regular file,
// unreadable, not a PCD, no x/y/z fields, a coordinate field with COUNT > 1,
// less data than the header says, and no finite point left.
// A cloud without a finite point is an error for a scene; a sensor's frame
// may be empty (it saw nothing in range), which kAllow reads as no points.
enum class EmptyCloud { kRefuse, kAllow };
core::Result<PointCloud> LoadPcd(const std::string& path, EmptyCloud empty = EmptyCloud::kRefuse);

// The same for a PLY file (vertex x, y, z properties of any numeric type).
core::Result<PointCloud> LoadPly(const std::string& path, EmptyCloud empty = EmptyCloud::kRefuse);

// LoadPcd or LoadPly by the file's extension (.pcd, .ply, any case); other
// extensions are errors.
core::Result<PointCloud> LoadPointCloud(const std::string& path, EmptyCloud empty = EmptyCloud::kRefuse);

enum class PcdEncoding { kAscii, kBinary, kBinaryCompressed };

// Writes x, y, z (float32, as PCD stores them) atomically.
core::Status WritePcd(const std::string& path, const std::vector<Vec3>& points,
                      PcdEncoding encoding = PcdEncoding::kBinary);

}  // namespace quadhand::scene
