#include "quadhand/scene/frame_folder.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <sstream>

#include "quadhand/core/file_util.h"
#include "quadhand/core/text.h"
#include "quadhand/scene/point_cloud.h"

namespace quadhand::scene {
namespace {

bool Number(const std::string& text, double* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  errno = 0;
  *value = std::strtod(text.c_str(), &end);
  return errno == 0 && end == text.c_str() + text.size() && std::isfinite(*value);
}

}  // namespace

core::Result<FrameIndex> ReadFrameIndex(const std::string& dir) {
  const std::string path = dir + "/frames.csv";
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return core::Status::InvalidArgument(path + ": " + text.status().message());
  std::istringstream in(*text);
  std::string line;
  std::vector<std::string> header;
  while (header.empty() && std::getline(in, line)) {
    if (!core::Trimmed(line).empty()) header = core::TrimmedFields(core::Trimmed(line));
  }
  std::map<std::string, size_t> column;
  for (size_t c = 0; c < header.size(); ++c) column[header[c]] = c;
  for (const char* name : {"index", "t", "file", "x", "y", "z", "qw", "qx", "qy", "qz"}) {
    if (column.count(name) == 0) {
      return core::Status::InvalidArgument(path + ": the header has no column '" + name +
                                           "' (expected index,t,file,x,y,z,qw,qx,qy,qz)");
    }
  }
  FrameIndex index;
  double last_t = -std::numeric_limits<double>::infinity();
  while (std::getline(in, line)) {
    if (core::Trimmed(line).empty()) continue;
    const std::vector<std::string> cells = core::TrimmedFields(core::Trimmed(line));
    if (cells.size() != header.size()) {
      ++index.malformed;
      continue;
    }
    double numbers[9];
    const char* names[9] = {"index", "t", "x", "y", "z", "qw", "qx", "qy", "qz"};
    bool ok = !cells[column["file"]].empty();
    for (int k = 0; k < 9 && ok; ++k) ok = Number(cells[column[names[k]]], &numbers[k]);
    if (!ok) {
      ++index.malformed;
      continue;
    }
    const Quat q(numbers[5], numbers[6], numbers[7], numbers[8]);
    if (std::abs(q.norm() - 1.0) > kFramePoseQuaternionTolerance) {
      ++index.bad_pose;
      continue;
    }
    if (!(numbers[1] > last_t)) {
      ++index.out_of_order;
      continue;
    }
    last_t = numbers[1];
    FrameRecord record;
    record.index = static_cast<long>(numbers[0]);
    record.t = numbers[1];
    const std::string& file = cells[column["file"]];
    record.path = !file.empty() && file.front() == '/' ? file : dir + "/" + file;
    record.sensor_to_world = MakePose(Vec3(numbers[2], numbers[3], numbers[4]), q.normalized().toRotationMatrix());
    index.frames.push_back(std::move(record));
  }
  return index;
}

core::Status ForEachFrameCloud(const FrameIndex& index,
                               const std::function<core::Status(const FrameRecord&, std::vector<Vec3>&)>& visit,
                               FrameCloudCounts* counts) {
  for (const FrameRecord& frame : index.frames) {
    auto cloud = LoadPointCloud(frame.path, EmptyCloud::kAllow);
    if (!cloud.ok()) {
      ++counts->unreadable;
      continue;
    }
    counts->non_finite_points += cloud->dropped_non_finite;
    if (cloud->points.empty()) {
      ++counts->empty;
      continue;
    }
    ++counts->used;
    for (Vec3& p : cloud->points) p = frame.sensor_to_world * p;
    QUADHAND_RETURN_IF_ERROR(visit(frame, cloud->points));
  }
  return core::Status::Ok();
}

}  // namespace quadhand::scene
