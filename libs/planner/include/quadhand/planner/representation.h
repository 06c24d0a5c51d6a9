// Geometric representations by name, in a registry like the solvers': every
// one implements env::CollisionModel and is planned with the same optimiser,
// front end and post-check, so success means the same thing for all of them.
// Built in:
//   mrc_sdf  per-link SDFs queried with the raw points (the paper's MRC-SDF)
//   esdf     OctoMap + DynamicEDT3D distance field, robot as surface points
//   sfc      safe-flight corridors along each plan's front-end path
// docs/extending.md shows how to add one.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/env/esdf_model.h"
#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/env/sfc_model.h"
#include "quadhand/scene/point_grid.h"
#include "quadhand/planner/planner.h"

namespace quadhand::planner {

struct Representation {
  std::string name;
  // The scene-wide model: optimised against (mrc_sdf, esdf), and used by the
  // terminal-state search (for sfc it is the MRC-SDF model).
  std::unique_ptr<env::CollisionModel> scene_model;
  PerPlanCollisionBuilder per_plan;  // set for sfc
  double build_ms = 0;               // SDF loading + indexing, or the ESDF build (0 for sfc: per plan)
};

// Options of each representation (the representations section of the
// configuration file, planner_config.h).
struct RepresentationOptions {
  env::MrcSdfOptions mrc_sdf;
  env::EsdfOptions esdf;
  env::SfcOptions sfc;
  // Options of representations registered from outside the library: the
  // section `representations.<name>` of the configuration file as one line
  // of (flow-style) YAML, by name. The factory registered as <name> gets its text as
  // RepresentationInputs::own_options and parses it (a bad value is its
  // InvalidArgument); the configuration only checks that <name> is registered.
  std::map<std::string, std::string> registered;

  bool IsValid(std::string* why) const;
};

// What a representation is built from: the robot, the scene's points (finite,
// non-empty; they must outlive the representation, which may keep a
// reference to them, as PlanningContext's do), the folder of the robot's
// link SDFs and the options.
struct RepresentationInputs {
  const robot::RobotModel& robot;
  const std::vector<Vec3>& points;
  const std::string& sdf_dir;
  const RepresentationOptions& options;
  // The same points indexed once per scene and shared (PlanningContext's,
  // also used by the post-check), or null: a representation whose index has
  // the same cell size uses it instead of indexing the cloud again.
  std::shared_ptr<const scene::PointGrid> index;
  // The robot's link SDFs (robot.CollisionLinks() order) already loaded from
  // sdf_dir and shared, or null: a representation that needs them loads its own.
  env::SharedSdfGrids sdf_grids;
  // options.registered's text for the representation being built; empty
  // when the configuration has no section for it (and for the built-ins).
  const std::string& own_options;
};

// Builds one representation; errors name the file or option at fault, and
// kInfeasible is kept for "this scene cannot be represented".
using RepresentationFactory = std::function<core::Result<Representation>(const RepresentationInputs& inputs)>;

// Adds a representation by name (non-empty, unique): after this,
// --representation NAME, the benchmark and the Python module can use it.
// mrc_sdf, esdf and sfc are registered before the first use of the registry.
// Thread-safe.
core::Status RegisterRepresentation(const std::string& name, RepresentationFactory factory);

// mrc_sdf, esdf or sfc: options in RepresentationOptions' own fields.
bool IsBuiltInRepresentation(const std::string& name);

// The registered names, in registration order (mrc_sdf, esdf, sfc first).
std::vector<std::string> RepresentationNames();

// InvalidArgument "unknown representation 'NAME' (known: ...)" unless `name`
// is registered.
core::Status CheckRepresentationName(const std::string& name);

// Builds the representation registered as `name` (InvalidArgument for an
// unknown name or invalid options).
core::Result<Representation> MakeRepresentation(const std::string& name, const robot::RobotModel& robot,
                                                const std::string& sdf_dir, const std::vector<Vec3>& points,
                                                const RepresentationOptions& options = {},
                                                std::shared_ptr<const scene::PointGrid> index = nullptr,
                                                env::SharedSdfGrids sdf_grids = nullptr);

}  // namespace quadhand::planner
