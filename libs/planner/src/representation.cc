#include "quadhand/planner/representation.h"

#include <algorithm>
#include <chrono>
#include <mutex>

#include "quadhand/env/esdf_model.h"
#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/env/sfc_model.h"
#include "quadhand/robot/link_meshes.h"

namespace quadhand::planner {
namespace {

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

core::Result<Representation> MakeMrcSdf(const RepresentationInputs& in) {
  Representation representation;
  const auto start = std::chrono::steady_clock::now();
  const bool share = in.index != nullptr && in.index->cell_size() == in.options.mrc_sdf.cell_size;
  core::Result<std::unique_ptr<env::MrcSdfModel>> model = core::Status::Internal("unset");
  if (in.sdf_grids != nullptr) {
    auto index = share ? in.index : std::make_shared<const scene::PointGrid>(in.points, in.options.mrc_sdf.cell_size);
    model = env::MrcSdfModel::Create(in.robot.CollisionLinks(), in.sdf_grids, std::move(index), in.options.mrc_sdf);
  } else {
    model = share ? env::MrcSdfModel::Create(in.robot, in.sdf_dir, in.index, in.options.mrc_sdf)
                  : env::MrcSdfModel::Create(in.robot, in.sdf_dir, in.points, in.options.mrc_sdf);
  }
  if (!model.ok()) return model.status();
  representation.scene_model = std::move(*model);
  representation.build_ms = MillisecondsSince(start);
  return representation;
}

core::Result<Representation> MakeEsdf(const RepresentationInputs& in) {
  Representation representation;
  auto model = env::EsdfModel::Create(in.robot, in.points, in.options.esdf);
  if (!model.ok()) return model.status();
  representation.build_ms = (*model)->build_seconds() * 1e3;
  representation.scene_model = std::move(*model);
  return representation;
}

// Corridors depend on the path, so they are built per plan; the MRC-SDF
// model only serves the terminal-state search, and what sfc builds is its
// corridors (PlanResult::per_plan_collision_ms), so build_ms stays 0.
core::Result<Representation> MakeSfc(const RepresentationInputs& in) {
  auto representation = MakeMrcSdf(in);
  if (!representation.ok()) return representation.status();
  representation->build_ms = 0.0;
  // The robot's link meshes are loaded once here, not per plan.
  std::vector<int> links = in.robot.CollisionLinks();
  std::vector<geometry::TriangleMesh> meshes;
  for (int link : links) {
    auto mesh = robot::LinkCollisionMesh(in.robot, link);
    if (!mesh.ok()) return mesh.status();
    meshes.push_back(std::move(*mesh));
  }
  const env::SfcOptions sfc_options = in.options.sfc;
  // The cloud is referenced, not copied: it outlives the representation (RepresentationInputs).
  representation->per_plan = [links, meshes, points = &in.points, sfc_options](
                                 const std::vector<Vec3>& path, const std::vector<Vec3>& boundaries,
                                 double* build_ms) -> core::Result<std::unique_ptr<env::CollisionModel>> {
    const auto corridor_start = std::chrono::steady_clock::now();
    auto model = env::SfcModel::Create(links, meshes, *points, path, sfc_options);
    if (!model.ok()) return model.status();
    QUADHAND_RETURN_IF_ERROR((*model)->SetPieceAssignment(env::AssignPiecesToSegments(path, boundaries)));
    *build_ms = MillisecondsSince(corridor_start);
    return std::unique_ptr<env::CollisionModel>(std::move(*model));
  };
  return representation;
}

struct Registry {
  std::mutex mutex;
  std::vector<std::pair<std::string, RepresentationFactory>> entries;  // in registration order

  Registry() {
    entries.emplace_back("mrc_sdf", MakeMrcSdf);
    entries.emplace_back("esdf", MakeEsdf);
    entries.emplace_back("sfc", MakeSfc);
  }
  const RepresentationFactory* Find(const std::string& name) const {
    for (const auto& [registered, factory] : entries) {
      if (registered == name) return &factory;
    }
    return nullptr;
  }
};

Registry& TheRegistry() {
  static Registry registry;
  return registry;
}

core::Status UnknownRepresentation(const std::string& name, const std::vector<std::string>& known) {
  std::string list;
  for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
  return core::Status::InvalidArgument("unknown representation '" + name + "' (known: " + list + ")");
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
  for (const auto& [name, text] : registered) {
    if (IsBuiltInRepresentation(name)) {
      if (why != nullptr) *why = name + ": a built-in representation's options are fields, not text";
      return false;
    }
  }
  return true;
}

bool IsBuiltInRepresentation(const std::string& name) {
  return name == "mrc_sdf" || name == "esdf" || name == "sfc";
}

core::Status RegisterRepresentation(const std::string& name, RepresentationFactory factory) {
  if (name.empty() || !factory) return core::Status::InvalidArgument("a representation needs a name and a factory");
  Registry& registry = TheRegistry();
  std::lock_guard<std::mutex> lock(registry.mutex);
  if (registry.Find(name) != nullptr) {
    return core::Status::InvalidArgument("representation '" + name + "' is already registered");
  }
  registry.entries.emplace_back(name, std::move(factory));
  return core::Status::Ok();
}

std::vector<std::string> RepresentationNames() {
  Registry& registry = TheRegistry();
  std::lock_guard<std::mutex> lock(registry.mutex);
  std::vector<std::string> names;
  for (const auto& entry : registry.entries) names.push_back(entry.first);
  return names;
}

core::Status CheckRepresentationName(const std::string& name) {
  const std::vector<std::string> known = RepresentationNames();
  if (std::find(known.begin(), known.end(), name) != known.end()) return core::Status::Ok();
  return UnknownRepresentation(name, known);
}

core::Result<Representation> MakeRepresentation(const std::string& name, const robot::RobotModel& robot,
                                                const std::string& sdf_dir, const std::vector<Vec3>& points,
                                                const RepresentationOptions& options,
                                                std::shared_ptr<const scene::PointGrid> index,
                                                env::SharedSdfGrids sdf_grids) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("representation options: " + why);
  RepresentationFactory factory;
  {
    Registry& registry = TheRegistry();
    std::lock_guard<std::mutex> lock(registry.mutex);
    if (const RepresentationFactory* found = registry.Find(name)) factory = *found;
  }
  if (!factory) return UnknownRepresentation(name, RepresentationNames());
  const auto own = options.registered.find(name);
  const std::string no_options;
  auto representation =
      factory(RepresentationInputs{robot, points, sdf_dir, options, std::move(index), std::move(sdf_grids),
                                   own != options.registered.end() ? own->second : no_options});
  if (!representation.ok()) return representation.status();
  representation->name = name;
  return representation;
}

}  // namespace quadhand::planner
