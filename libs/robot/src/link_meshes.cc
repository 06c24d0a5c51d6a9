#include "quadhand/robot/link_meshes.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <mutex>
#include <tuple>
#include <set>
#include <utility>
#include <vector>

#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/mesh_repair.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/geometry/primitives.h"

namespace quadhand::robot {
namespace {

using core::Result;
using core::Status;

// A primitive collision element as a closed mesh in the link frame.
Result<geometry::TriangleMesh> ElementMesh(const CollisionGeometry& element) {
  switch (element.type) {
    case GeometryType::kMesh:
      return Status::Internal("ElementMesh: a mesh file is read by ElementMeshes");
    case GeometryType::kBox:
      return geometry::TessellateBox(geometry::Box{element.origin, element.box_size});
    case GeometryType::kCylinder:
      return geometry::TessellateCylinder(
          geometry::Cylinder{element.origin, element.radius, element.length},
          kPrimitiveTessellationTolerance);
    case GeometryType::kSphere:
      return geometry::TessellateSphere(
          geometry::Sphere{element.origin.translation(), element.radius},
          kPrimitiveTessellationTolerance);
  }
  return Status::Internal("unknown collision geometry type");
}

// Each mesh file's repairs are kept once per process, for the program to
// print when it is done loading (TakeMeshRepairReports): the SDFs, the exact
// model, the self-collision pairs and the drawing all load the same files,
// and one line per file is what a user needs.
struct RepairLog {
  std::mutex mutex;
  std::set<std::string> files;
  std::vector<std::string> untaken;
};
RepairLog& Repairs() {
  static RepairLog log;
  return log;
}

void ReportRepairs(const std::string& where, const std::string& path, const geometry::MeshRepairReport& report) {
  const std::vector<std::string> lines = report.Lines();
  if (lines.empty()) return;
  RepairLog& log = Repairs();
  std::lock_guard<std::mutex> lock(log.mutex);
  if (!log.files.insert(path).second) return;
  std::string text;
  for (const std::string& line : lines) text += (text.empty() ? "" : "; ") + line;
  log.untaken.push_back("mesh '" + path + "' (" + where + ") repaired: " + text);
}

// Mesh files read and repaired in this process: the exact model, the
// self-collision pairs and the front end's robot size all load the same
// files, and a 400,000-triangle export takes seconds to read and repair.
// The key holds the file's size and modification time, so a file rewritten
// in between is read again.
struct ReadShells {
  std::vector<geometry::TriangleMesh> shells;
  geometry::MeshRepairReport report;
};
using ReadKey = std::tuple<std::string, std::uintmax_t, std::filesystem::file_time_type::rep, double, double>;
struct ReadMemo {
  std::mutex mutex;
  std::map<ReadKey, ReadShells> entries;
};
ReadMemo& Reads() {
  static ReadMemo memo;
  return memo;
}
constexpr size_t kReadMemoSize = 256;  // mesh files; beyond it the memo starts over

Result<ReadShells> ReadRepairedShells(const std::string& path, const geometry::MeshRepairOptions& repair) {
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  const auto modified = error ? std::filesystem::file_time_type{} : std::filesystem::last_write_time(path, error);
  const bool keyed = !error;
  const ReadKey key{path, size, modified.time_since_epoch().count(), repair.tolerance, repair.metres_per_unit};
  ReadMemo& memo = Reads();
  if (keyed) {
    std::lock_guard<std::mutex> lock(memo.mutex);
    if (auto it = memo.entries.find(key); it != memo.entries.end()) return it->second;
  }
  ReadShells read;
  auto shells = geometry::ReadMeshShells(path, repair, &read.report);
  if (!shells.ok()) return shells.status();
  read.shells = std::move(*shells);
  if (keyed) {
    std::lock_guard<std::mutex> lock(memo.mutex);
    if (memo.entries.size() >= kReadMemoSize) memo.entries.clear();
    memo.entries.emplace(key, read);
  }
  return read;
}

// One collision element as closed meshes in the link frame: a mesh file
// gives one per shell (mesh_repair.h), their union being the element.
Result<std::vector<geometry::TriangleMesh>> ElementMeshes(const CollisionGeometry& element, const std::string& where,
                                                          double repair_tolerance) {
  switch (element.type) {
    case GeometryType::kMesh: {
      geometry::MeshRepairOptions repair;
      repair.tolerance = repair_tolerance;
      repair.metres_per_unit = element.mesh_scale.cwiseAbs().maxCoeff();
      auto read = ReadRepairedShells(element.mesh_path, repair);
      if (!read.ok()) return read.status();
      const geometry::MeshRepairReport& report = read->report;
      const std::vector<geometry::TriangleMesh>* shells = &read->shells;
      if (!report.problem.empty()) {
        return Status::InvalidArgument("mesh '" + element.mesh_path + "' does not bound a volume, even repaired: " +
                                       report.problem);
      }
      ReportRepairs(where, element.mesh_path, report);
      std::vector<geometry::TriangleMesh> placed_shells;
      for (const geometry::TriangleMesh& shell : *shells) {
        // Transformed() flips the winding for a mirroring scale, so outward stays outward.
        geometry::TriangleMesh placed = geometry::Transformed(shell, element.origin, element.mesh_scale);
        // The same bound as the primitives' sizes and the joints' origins: CGAL's
        // exact distances overflow (and abort) on far larger coordinates.
        for (const Vec3& vertex : placed.vertices) {
          if (!(vertex.allFinite() && vertex.cwiseAbs().maxCoeff() <= 1000.0)) {
            return Status::InvalidArgument("mesh '" + element.mesh_path +
                                           "': scaled and placed, a vertex lies more than 1000 m from the link frame");
          }
        }
        placed_shells.push_back(std::move(placed));
      }
      return placed_shells;
    }
    default: {
      Result<geometry::TriangleMesh> primitive = ElementMesh(element);
      if (!primitive.ok()) return primitive.status();
      return std::vector<geometry::TriangleMesh>{std::move(*primitive)};
    }
  }
}

}  // namespace

Result<std::vector<geometry::TriangleMesh>> LinkCollisionElements(const RobotModel& model, int link) {
  if (link < 0 || link >= model.num_links()) {
    return Status::InvalidArgument("link index " + std::to_string(link) + " out of range");
  }
  const Link& data = model.link(link);
  const std::string where = "link '" + data.name + "'";
  if (data.collisions.empty()) return Status::InvalidArgument(where + ": no collision geometry");
  std::vector<geometry::TriangleMesh> parts;
  parts.reserve(data.collisions.size());
  for (const CollisionGeometry& element : data.collisions) {
    auto element_parts = ElementMeshes(element, where, model.mesh_repair_tolerance());
    if (!element_parts.ok()) return element_parts.status().WithPrefix(where);
    for (geometry::TriangleMesh& part : *element_parts) parts.push_back(std::move(part));
  }
  return parts;
}

std::vector<std::string> TakeMeshRepairReports() {
  RepairLog& log = Repairs();
  std::lock_guard<std::mutex> lock(log.mutex);
  return std::exchange(log.untaken, {});
}

Result<geometry::TriangleMesh> LinkCollisionMesh(const RobotModel& model, int link) {
  Result<std::vector<geometry::TriangleMesh>> parts = LinkCollisionElements(model, link);
  if (!parts.ok()) return parts.status();
  // A single element is returned as read: the union would only re-mesh it.
  if (parts->size() == 1) return std::move(parts->front());
  Result<geometry::TriangleMesh> merged = geometry::UnionOfClosedMeshes(*parts);
  if (merged.ok()) return merged;
  geometry::TriangleMesh soup;
  for (const geometry::TriangleMesh& part : *parts) {
    const int offset = static_cast<int>(soup.vertices.size());
    soup.vertices.insert(soup.vertices.end(), part.vertices.begin(), part.vertices.end());
    for (const auto& triangle : part.triangles) {
      soup.triangles.push_back(triangle + Eigen::Vector3i::Constant(offset));
    }
  }
  return soup;
}

core::Result<double> StowedHalfWidth(const RobotModel& model) {
  VecX q(model.num_actuated());
  for (int i = 0; i < model.num_actuated(); ++i) {
    const Joint& joint = model.joint(model.actuated_joints()[i]);
    q[i] = std::clamp(0.0, joint.lower, joint.upper);
  }
  KinematicsState state;
  ComputeKinematics(model, Pose::Identity(), q, &state);
  Vec3 reach = Vec3::Zero();
  bool any = false;
  for (int link : model.CollisionLinks()) {
    auto elements = LinkCollisionElements(model, link);
    if (!elements.ok()) return elements.status();
    for (const geometry::TriangleMesh& mesh : *elements) {
      for (const Vec3& v : mesh.vertices) {
        reach = reach.cwiseMax((state.link_poses[link] * v).cwiseAbs());
        any = true;
      }
    }
  }
  return any ? std::min(reach.x(), reach.y()) : 0.0;
}

}  // namespace quadhand::robot
