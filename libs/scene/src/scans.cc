#include "quadhand/scene/scans.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include <pcl/filters/crop_box.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "quadhand/core/text.h"
#include "quadhand/scene/frame_folder.h"
#include "quadhand/scene/point_cloud.h"

namespace quadhand::scene {
namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr ToPcl(const std::vector<Vec3>& points) {
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(points.size());
  for (const Vec3& p : points) {
    cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  }
  return cloud;
}

// Indices of the points inside the box (pcl::CropBox); the points
// themselves stay in double precision.
std::vector<Vec3> Crop(const std::vector<Vec3>& points, const CropBox& box) {
  pcl::CropBox<pcl::PointXYZ> filter;
  filter.setInputCloud(ToPcl(points));
  filter.setMin(Eigen::Vector4f(box.min.x(), box.min.y(), box.min.z(), 1.0f));
  filter.setMax(Eigen::Vector4f(box.max.x(), box.max.y(), box.max.z(), 1.0f));
  pcl::Indices inside;
  filter.filter(inside);
  std::vector<Vec3> kept;
  kept.reserve(inside.size());
  for (const auto index : inside) kept.push_back(points[static_cast<size_t>(index)]);
  return kept;
}

// Crop, counting what it took away.
void CropCounting(const CropBox& box, std::vector<Vec3>* points, long* cropped_away) {
  const size_t before = points->size();
  *points = Crop(*points, box);
  *cropped_away += static_cast<long>(before - points->size());
}

core::Result<std::vector<Vec3>> Voxelise(const std::vector<Vec3>& points, double leaf, const std::string& path) {
  Vec3 lo = points.front(), hi = points.front();
  for (const Vec3& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // PCL indexes voxels with 32-bit integers and, beyond that, returns the
  // cloud unfiltered with a console warning: refuse instead.
  const Vec3 cells = ((hi - lo) / leaf).array().floor() + 1.0;
  if (cells.x() * cells.y() * cells.z() > static_cast<double>(std::numeric_limits<std::int32_t>::max())) {
    char leaf_text[32];
    std::snprintf(leaf_text, sizeof(leaf_text), "%g", leaf);
    return core::Status::InvalidArgument(path + ": voxel: leaf " + leaf_text +
                                         " m is too small for the scan's extent (PCL's voxel indices would overflow)");
  }
  pcl::VoxelGrid<pcl::PointXYZ> filter;
  filter.setInputCloud(ToPcl(points));
  const float size = static_cast<float>(leaf);
  filter.setLeafSize(size, size, size);
  pcl::PointCloud<pcl::PointXYZ> reduced;
  filter.filter(reduced);
  std::vector<Vec3> out;
  out.reserve(reduced.size());
  for (const auto& p : reduced) out.emplace_back(p.x, p.y, p.z);
  return out;
}

// A bag's clouds in the world, each cropped as it is read (a long bag need
// not be held whole before the crop).
core::Result<std::vector<Vec3>> LoadBag(const BagCloudSource& bag, const std::optional<CropBox>& crop,
                                        bool skip_unusable, LoadedScans* scans) {
  std::vector<Vec3> points;
  BagCloudCounts counts;
  const core::Status read = ForEachBagCloud(
      bag,
      [&](BagCloud& cloud) {
        for (Vec3& p : cloud.points) p = cloud.sensor_to_world * p;
        if (crop) CropCounting(*crop, &cloud.points, &scans->cropped_away);
        points.insert(points.end(), cloud.points.begin(), cloud.points.end());
        return core::Status::Ok();
      },
      &counts);
  if (!read.ok()) return read;
  if (counts.used == 0) {
    return core::Status::InvalidArgument(core::Format(
        "%s: no cloud on %s could be used (%ld messages: %ld malformed, %ld without a pose at their stamp)",
        bag.path.c_str(), bag.cloud_topic.c_str(), counts.messages, counts.malformed, counts.no_pose));
  }
  // A scene is planned as the truth: a cloud left out is what it saw left
  // out, and a plan through there would be certified against a scene with
  // a hole. So leaving one out is the user's decision, not the reader's.
  if (counts.used < counts.messages && !skip_unusable) {
    return core::Status::InvalidArgument(core::Format(
        "%s: %ld of the %ld clouds on %s could not be used (%ld malformed, %ld without a pose at their stamp): the "
        "scene would miss what they saw (skip_unusable: true plans without them)",
        bag.path.c_str(), counts.messages - counts.used, counts.messages, bag.cloud_topic.c_str(), counts.malformed,
        counts.no_pose));
  }
  scans->bag_clouds += counts;
  scans->dropped_non_finite += counts.non_finite_points;
  return points;
}

// A frames folder's clouds in the world, each cropped as it is read.
core::Result<std::vector<Vec3>> LoadFrameFolder(const std::string& dir, const std::optional<CropBox>& crop,
                                                bool skip_unusable, LoadedScans* scans) {
  auto index = ReadFrameIndex(dir);
  if (!index.ok()) return index.status();
  std::vector<Vec3> points;
  FrameCloudCounts read;
  QUADHAND_RETURN_IF_ERROR(ForEachFrameCloud(
      *index,
      [&](const FrameRecord&, std::vector<Vec3>& cloud) {
        if (crop) CropCounting(*crop, &cloud, &scans->cropped_away);
        points.insert(points.end(), cloud.begin(), cloud.end());
        return core::Status::Ok();
      },
      &read));
  FrameFolderCounts counts;
  counts.dropped_rows = index->dropped();
  counts.rows = static_cast<long>(index->frames.size()) + counts.dropped_rows;
  counts.used = read.used;
  counts.unreadable_clouds = read.unreadable;
  counts.empty_clouds = read.empty;
  const long unusable = counts.dropped_rows + counts.unreadable_clouds;
  if (counts.used == 0) {
    return core::Status::InvalidArgument(core::Format(
        "%s: no frame with a return could be used (%ld rows in frames.csv: %ld dropped, %ld clouds unreadable, %ld "
        "empty)",
        dir.c_str(), counts.rows, counts.dropped_rows, counts.unreadable_clouds, counts.empty_clouds));
  }
  // As for a bag: a frame left out is what it saw left out.
  if (unusable > 0 && !skip_unusable) {
    return core::Status::InvalidArgument(core::Format(
        "%s: %ld of the %ld frames could not be used (%ld rows of frames.csv malformed, with a bad pose or out of "
        "order; %ld clouds unreadable): the scene would miss what they saw (skip_unusable: true plans without them)",
        dir.c_str(), unusable, counts.rows, counts.dropped_rows, counts.unreadable_clouds));
  }
  scans->frame_clouds += counts;
  scans->dropped_non_finite += read.non_finite_points;
  return points;
}

}  // namespace

FrameFolderCounts& FrameFolderCounts::operator+=(const FrameFolderCounts& other) {
  rows += other.rows;
  used += other.used;
  dropped_rows += other.dropped_rows;
  unreadable_clouds += other.unreadable_clouds;
  empty_clouds += other.empty_clouds;
  return *this;
}

core::Result<LoadedScans> LoadScans(const std::vector<ScanSource>& sources) {
  const auto start = std::chrono::steady_clock::now();
  if (sources.empty()) return core::Status::InvalidArgument("the scene lists no scan");
  LoadedScans scans;
  bool any_voxel = false;
  for (const ScanSource& source : sources) any_voxel = any_voxel || source.voxel > 0.0;
  for (const ScanSource& source : sources) {
    if (!IsRigidMotion(source.sensor_to_world)) {
      return core::Status::InvalidArgument(source.path + ": pose: not a rigid motion (a unit quaternion and a finite position)");
    }
    if (source.crop && !(source.crop->min.array() < source.crop->max.array()).all()) {
      return core::Status::InvalidArgument(source.path + ": crop: min must be below max on every axis");
    }
    if (!(source.voxel >= 0.0 && std::isfinite(source.voxel))) {
      return core::Status::InvalidArgument(source.path + ": voxel: the leaf size must be a positive number of metres");
    }
    std::vector<Vec3> points;
    if (source.bag) {
      auto bag = LoadBag(*source.bag, source.crop, source.skip_unusable_clouds, &scans);
      if (!bag.ok()) return bag.status();
      points = std::move(*bag);
      if (points.empty()) continue;
    } else if (source.frame_folder) {
      auto folder = LoadFrameFolder(source.path, source.crop, source.skip_unusable_clouds, &scans);
      if (!folder.ok()) return folder.status();
      points = std::move(*folder);
      if (points.empty()) continue;
    } else {
      auto cloud = LoadPointCloud(source.path);
      if (!cloud.ok()) return cloud.status();
      scans.dropped_non_finite += cloud->dropped_non_finite;
      points = std::move(cloud->points);
      if (!source.sensor_to_world.isApprox(Pose::Identity(), 0.0)) {
        for (Vec3& p : points) p = source.sensor_to_world * p;
      }
      if (source.crop) {
        CropCounting(*source.crop, &points, &scans.cropped_away);
        if (points.empty()) continue;
      }
    }
    std::vector<Vec3> planned = points;
    if (source.voxel > 0.0) {
      auto reduced = Voxelise(points, source.voxel, source.path);
      if (!reduced.ok()) return reduced.status();
      planned = std::move(*reduced);
    }
    if (any_voxel) scans.unfiltered_points.insert(scans.unfiltered_points.end(), points.begin(), points.end());
    scans.points.insert(scans.points.end(), planned.begin(), planned.end());
  }
  if (scans.points.empty()) {
    return core::Status::InvalidArgument(sources.front().path + ": no scene point is left inside the crop box" +
                                         std::string(sources.size() > 1 ? "es" : ""));
  }
  scans.load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return scans;
}

}  // namespace quadhand::scene
