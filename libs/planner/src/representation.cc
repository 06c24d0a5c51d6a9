#include "quadhand/planner/representation.h"

#include <algorithm>
#include <chrono>

#include "quadhand/env/esdf_model.h"
#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/env/sfc_model.h"
#include "quadhand/robot/link_meshes.h"

namespace quadhand::planner {
namespace {

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

bool RepresentationOptions::IsValid(std::string* why) const {
  std::string inner;
  const std::pair<const char*, bool> parts[] = {{"mrc_sdf", mrc_sdf.IsValid(&inner)},
                                                {"esdf", esdf.IsValid(&inner)},
                                                {"sfc", sfc.IsValid(&inner)}};
  for (const auto& [name, valid] : parts) {
    if (!valid) {
      if (why != nullptr) *why = std::string(name) + ": " + inner;
      return false;
    }
  }
  return true;
}

std::vector<std::string> RepresentationNames() { return {"mrc_sdf", "esdf", "sfc"}; }

core::Status CheckRepresentationName(const std::string& name) {
  const std::vector<std::string> known = RepresentationNames();
  if (std::find(known.begin(), known.end(), name) != known.end()) return core::Status::Ok();
  std::string list;
  for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
  return core::Status::InvalidArgument("unknown representation '" + name + "' (known: " + list + ")");
}

core::Result<Representation> MakeRepresentation(const std::string& name, const robot::RobotModel& robot,
                                                const std::string& sdf_dir, const std::vector<Vec3>& points,
                                                const RepresentationOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("representation options: " + why);
  QUADHAND_RETURN_IF_ERROR(CheckRepresentationName(name));
  Representation representation;
  representation.name = name;
  const auto start = std::chrono::steady_clock::now();
  if (name == "mrc_sdf" || name == "sfc") {
    auto model = env::MrcSdfModel::Create(robot, sdf_dir, points, options.mrc_sdf);
    if (!model.ok()) return model.status();
    representation.scene_model = std::move(*model);
    representation.build_ms = MillisecondsSince(start);
  } else if (name == "esdf") {
    auto model = env::EsdfModel::Create(robot, points, options.esdf);
    if (!model.ok()) return model.status();
    representation.build_ms = (*model)->build_seconds() * 1e3;
    representation.scene_model = std::move(*model);
  }
  if (name == "sfc") {
    // The MRC-SDF model above only serves the terminal-state search; what sfc
    // builds is its corridors, per plan (PlanResult::per_plan_collision_ms).
    representation.build_ms = 0.0;
    // Corridors depend on the path, so they are built per plan; the robot's
    // link meshes are loaded once here.
    std::vector<int> links = robot.CollisionLinks();
    std::vector<geometry::TriangleMesh> meshes;
    for (int link : links) {
      auto mesh = robot::LinkCollisionMesh(robot, link);
      if (!mesh.ok()) return mesh.status();
      meshes.push_back(std::move(*mesh));
    }
    const env::SfcOptions sfc_options = options.sfc;
    representation.per_plan = [links, meshes, points, sfc_options](const std::vector<Vec3>& path,
                                                      const std::vector<Vec3>& boundaries,
                                                      double* build_ms) -> core::Result<std::unique_ptr<env::CollisionModel>> {
      const auto corridor_start = std::chrono::steady_clock::now();
      auto model = env::SfcModel::Create(links, meshes, points, path, sfc_options);
      if (!model.ok()) return model.status();
      QUADHAND_RETURN_IF_ERROR((*model)->SetPieceAssignment(env::AssignPiecesToSegments(path, boundaries)));
      *build_ms = MillisecondsSince(corridor_start);
      return std::unique_ptr<env::CollisionModel>(std::move(*model));
    };
  }
  return representation;
}

}  // namespace quadhand::planner
