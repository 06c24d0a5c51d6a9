#include "quadhand/robot/link_meshes.h"

#include <algorithm>
#include <array>
#include <optional>
#include <filesystem>
#include <map>
#include <mutex>
#include <tuple>
#include <set>
#include <utility>
#include <vector>

#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/mesh_repair.h"
#include "quadhand/geometry/repaired_mesh_cache.h"
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

// Mesh files read and repaired in this process, placed as their elements
// place them: the exact model, the self-collision pairs and the front end's
// robot size all load the same files, and a 400,000-triangle export takes
// seconds to read and repair. The key holds the file's size and
// modification time, so a file rewritten in between is read again.
using FileKey = std::tuple<std::string, std::uintmax_t, std::filesystem::file_time_type::rep, double, double>;
using PlacementKey = std::array<double, 15>;  // the origin's 3 x 4 matrix, then the scale
using PlacedKey = std::pair<FileKey, PlacementKey>;
struct PlacedElement {
  geometry::RepairedMesh repaired;  // shells in the link frame
  Pose origin = Pose::Identity();   // the element's placement, for the cache's key
  Vec3 scale = Vec3::Ones();
};
struct PlacedMemo {
  std::mutex mutex;
  std::map<PlacedKey, PlacedElement> entries;
};
PlacedMemo& Placed() {
  static PlacedMemo memo;
  return memo;
}
constexpr size_t kPlacedMemoSize = 256;  // elements; beyond it the memo starts over

// The memo's key for the file as it is now; false if it cannot be stat'ed.
bool CurrentFileKey(const std::string& path, const geometry::MeshRepairOptions& repair, FileKey* key) {
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error) return false;
  const auto modified = std::filesystem::last_write_time(path, error);
  if (error) return false;
  *key = FileKey{path, size, modified.time_since_epoch().count(), repair.tolerance, repair.metres_per_unit};
  return true;
}

PlacementKey PlacementOf(const CollisionGeometry& element) {
  PlacementKey key;
  const Eigen::Matrix<double, 3, 4> matrix = element.origin.affine();
  for (int i = 0; i < 12; ++i) key[i] = matrix(i % 3, i / 3);
  for (int i = 0; i < 3; ++i) key[12 + i] = element.mesh_scale[i];
  return key;
}

geometry::RepairedMeshCacheKey CacheKeyOf(const geometry::RepairedMeshCacheKey& file_key, const Pose& origin,
                                          const Vec3& scale) {
  geometry::RepairedMeshCacheKey key = file_key;
  key.placement = origin;
  key.scale = scale;
  return key;
}

// The element's repaired shells, scaled and placed in the link frame.
Result<geometry::RepairedMesh> ReadAndPlace(const CollisionGeometry& element, const geometry::MeshRepairOptions& repair) {
  geometry::RepairedMesh placed;
  auto shells = geometry::ReadMeshShells(element.mesh_path, repair, &placed.report);
  if (!shells.ok()) return shells.status();
  if (!placed.report.problem.empty()) return placed;
  for (const geometry::TriangleMesh& shell : *shells) {
    // Transformed() flips the winding for a mirroring scale, so outward stays outward.
    geometry::TriangleMesh moved = geometry::Transformed(shell, element.origin, element.mesh_scale);
    // The same bound as the primitives' sizes and the joints' origins: CGAL's
    // exact distances overflow (and abort) on far larger coordinates.
    for (const Vec3& vertex : moved.vertices) {
      if (!(vertex.allFinite() && vertex.cwiseAbs().maxCoeff() <= 1000.0)) {
        return Status::InvalidArgument("mesh '" + element.mesh_path +
                                       "': scaled and placed, a vertex lies more than 1000 m from the link frame");
      }
    }
    placed.shells.push_back(std::move(moved));
  }
  return placed;
}

// From the process memo, else from the repaired-mesh cache in `cache_dir`
// (when given, and holding this file's repair so placed), else read,
// repaired and placed.
Result<geometry::RepairedMesh> PlacedShells(const CollisionGeometry& element, const geometry::MeshRepairOptions& repair,
                                            const std::string& cache_dir) {
  FileKey file_key;
  const bool keyed = CurrentFileKey(element.mesh_path, repair, &file_key);
  const PlacedKey key{file_key, PlacementOf(element)};
  PlacedMemo& memo = Placed();
  if (keyed) {
    std::lock_guard<std::mutex> lock(memo.mutex);
    if (auto it = memo.entries.find(key); it != memo.entries.end()) return it->second.repaired;
  }
  std::optional<geometry::RepairedMesh> placed;
  if (!cache_dir.empty()) {
    // A miss or an unusable entry (corrupted, another revision) only costs
    // the repair below: the cache never needs to be right.
    if (auto file_hash = geometry::RepairedMeshCacheKeyOf(element.mesh_path, repair); file_hash.ok()) {
      const geometry::RepairedMeshCacheKey cache_key = CacheKeyOf(*file_hash, element.origin, element.mesh_scale);
      auto entry = geometry::ReadRepairedMeshCache(geometry::RepairedMeshCachePath(cache_dir, cache_key), cache_key);
      if (entry.ok()) placed = std::move(*entry);
    }
  }
  if (!placed) {
    auto read = ReadAndPlace(element, repair);
    if (!read.ok()) return read.status();
    placed = std::move(*read);
  }
  if (keyed) {
    std::lock_guard<std::mutex> lock(memo.mutex);
    if (memo.entries.size() >= kPlacedMemoSize) memo.entries.clear();
    memo.entries.emplace(key, PlacedElement{*placed, element.origin, element.mesh_scale});
  }
  return std::move(*placed);
}

// One collision element as closed meshes in the link frame: a mesh file
// gives one per shell (mesh_repair.h), their union being the element.
Result<std::vector<geometry::TriangleMesh>> ElementMeshes(const CollisionGeometry& element, const std::string& where,
                                                          double repair_tolerance, const std::string& cache_dir) {
  switch (element.type) {
    case GeometryType::kMesh: {
      geometry::MeshRepairOptions repair;
      repair.tolerance = repair_tolerance;
      repair.metres_per_unit = element.mesh_scale.cwiseAbs().maxCoeff();
      auto placed = PlacedShells(element, repair, cache_dir);
      if (!placed.ok()) return placed.status();
      if (!placed->report.problem.empty()) {
        return Status::InvalidArgument("mesh '" + element.mesh_path + "' does not bound a volume, even repaired: " +
                                       placed->report.problem);
      }
      ReportRepairs(where, element.mesh_path, placed->report);
      return std::move(placed->shells);
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
    auto element_parts = ElementMeshes(element, where, model.mesh_repair_tolerance(), model.mesh_cache_dir());
    if (!element_parts.ok()) return element_parts.status().WithPrefix(where);
    for (geometry::TriangleMesh& part : *element_parts) parts.push_back(std::move(part));
  }
  return parts;
}

std::string MeshCacheDirOf(const std::string& sdf_dir) {
  return (std::filesystem::path(sdf_dir) / "meshes").string();
}

core::Result<int> SaveMeshRepairCache(const std::string& cache_dir) {
  std::vector<std::pair<FileKey, PlacedElement>> entries;
  {
    PlacedMemo& memo = Placed();
    std::lock_guard<std::mutex> lock(memo.mutex);
    for (const auto& [key, element] : memo.entries) {
      if (element.repaired.report.problem.empty() && !element.repaired.shells.empty()) {
        entries.emplace_back(key.first, element);
      }
    }
  }
  int written = 0;
  for (const auto& [file_key, element] : entries) {
    const geometry::RepairedMesh& placed = element.repaired;
    geometry::MeshRepairOptions repair;
    repair.tolerance = std::get<3>(file_key);
    repair.metres_per_unit = std::get<4>(file_key);
    const std::string& path = std::get<0>(file_key);
    // A file changed since it was repaired is not this repair's source.
    if (FileKey now; !CurrentFileKey(path, repair, &now) || now != file_key) continue;
    // Placing can, in principle, round two faces into each other: only
    // shells that still bound a volume in the link frame are vouched for
    // (quadhand-sdfgen checked them already; CheckMesh remembers).
    bool bounds_volume = true;
    for (const geometry::TriangleMesh& shell : placed.shells) bounds_volume &= geometry::CheckMesh(shell).bounds_volume;
    if (!bounds_volume) continue;
    auto file_hash = geometry::RepairedMeshCacheKeyOf(path, repair);
    if (!file_hash.ok()) continue;
    const geometry::RepairedMeshCacheKey cache_key = CacheKeyOf(*file_hash, element.origin, element.scale);
    const core::Status saved =
        geometry::WriteRepairedMeshCache(geometry::RepairedMeshCachePath(cache_dir, cache_key), cache_key, placed);
    if (!saved.ok()) return saved;
    ++written;
  }
  return written;
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

core::Result<std::vector<std::vector<Vec3>>> LinkCollisionVertices(const RobotModel& model) {
  std::vector<std::vector<Vec3>> vertices(static_cast<size_t>(model.num_links()));
  for (int link : model.CollisionLinks()) {
    auto elements = LinkCollisionElements(model, link);
    if (!elements.ok()) return elements.status();
    std::vector<Vec3>& own = vertices[static_cast<size_t>(link)];
    for (const geometry::TriangleMesh& mesh : *elements) own.insert(own.end(), mesh.vertices.begin(), mesh.vertices.end());
  }
  return vertices;
}

core::Result<Vec3> StowedHalfExtents(const RobotModel& model) {
  VecX q(model.num_actuated());
  for (int i = 0; i < model.num_actuated(); ++i) {
    const Joint& joint = model.joint(model.actuated_joints()[i]);
    q[i] = std::clamp(0.0, joint.lower, joint.upper);
  }
  KinematicsState state;
  ComputeKinematics(model, Pose::Identity(), q, &state);
  auto vertices = LinkCollisionVertices(model);
  if (!vertices.ok()) return vertices.status();
  Vec3 reach = Vec3::Zero();
  for (size_t link = 0; link < vertices->size(); ++link) {
    for (const Vec3& v : (*vertices)[link]) reach = reach.cwiseMax((state.link_poses[link] * v).cwiseAbs());
  }
  return reach;
}

core::Result<double> StowedHalfWidth(const RobotModel& model) {
  auto extents = StowedHalfExtents(model);
  if (!extents.ok()) return extents.status();
  return std::min(extents->x(), extents->y());
}

}  // namespace quadhand::robot
