#include "quadhand/scene/point_cloud.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>

#include <pcl/PCLPointCloud2.h>
#include <pcl/console/print.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace quadhand::scene {
namespace {

// PCL prints its own diagnostics to the console; ours come back as Status.
void SilencePcl() { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }

bool HasField(const pcl::PCLPointCloud2& cloud, const std::string& name) {
  for (const auto& field : cloud.fields) {
    if (field.name == name) return true;
  }
  return false;
}

}  // namespace

core::Result<PointCloud> LoadPcd(const std::string& path) {
  SilencePcl();
  if (!std::ifstream(path).good()) return core::Status::NotFound(path + ": cannot open point cloud file");
  pcl::PCLPointCloud2 blob;
  pcl::PCDReader reader;
  // PCL 1.13 accepts a header-less file in readHeader and then crashes in
  // read(), so the header is validated here before any data is read.
  {
    Eigen::Vector4f origin;
    Eigen::Quaternionf orientation;
    int version = 0, data_type = 0;
    unsigned int data_offset = 0;
    if (reader.readHeader(path, blob, origin, orientation, version, data_type, data_offset) < 0) {
      return core::Status::InvalidArgument(path + ": not a readable PCD file (bad header)");
    }
    if (!HasField(blob, "x") || !HasField(blob, "y") || !HasField(blob, "z")) {
      return core::Status::InvalidArgument(path + ": not a PCD point cloud with x, y, z fields");
    }
    if (static_cast<long>(blob.width) * blob.height == 0) {
      return core::Status::InvalidArgument(path + ": point cloud has no finite points (it is empty)");
    }
  }
  int result = -1;
  try {
    result = reader.read(path, blob);
  } catch (const std::exception& e) {  // PCL throws on some malformed data
    return core::Status::InvalidArgument(path + ": not a readable PCD file: " + e.what());
  }
  if (result < 0) return core::Status::InvalidArgument(path + ": not a readable PCD file (bad header or data)");
  pcl::PointCloud<pcl::PointXYZ> cloud;
  pcl::fromPCLPointCloud2(blob, cloud);
  PointCloud out;
  out.points.reserve(cloud.size());
  for (const auto& p : cloud) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) {
      out.points.emplace_back(p.x, p.y, p.z);
    } else {
      ++out.dropped_non_finite;
    }
  }
  if (out.points.empty()) {
    return core::Status::InvalidArgument(path + ": point cloud has no finite points (" +
                                         std::to_string(out.dropped_non_finite) + " non-finite)");
  }
  return out;
}

core::Status WritePcd(const std::string& path, const std::vector<Vec3>& points, PcdEncoding encoding) {
  SilencePcl();
  pcl::PointCloud<pcl::PointXYZ> cloud;
  cloud.reserve(points.size());
  for (const Vec3& p : points) {
    cloud.push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  }
  const std::string temporary = path + ".tmp-" + std::to_string(static_cast<long>(getpid()));
  pcl::PCDWriter writer;
  int result = -1;
  try {
    switch (encoding) {
      case PcdEncoding::kAscii: result = writer.writeASCII(temporary, cloud, 9); break;
      case PcdEncoding::kBinary: result = writer.writeBinary(temporary, cloud); break;
      case PcdEncoding::kBinaryCompressed: result = writer.writeBinaryCompressed(temporary, cloud); break;
    }
  } catch (const std::exception& e) {
    result = -1;
  }
  if (result < 0 || std::rename(temporary.c_str(), path.c_str()) != 0) {
    std::remove(temporary.c_str());
    return core::Status::IoError(path + ": cannot write point cloud");
  }
  return core::Status::Ok();
}

}  // namespace quadhand::scene
