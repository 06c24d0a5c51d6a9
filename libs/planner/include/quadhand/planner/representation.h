// Geometric representations by name, for the apps: every one implements
// env::CollisionModel and is planned with the same optimiser, front end and
// post-check, so success means the same thing for all of them.
//   mrc_sdf  per-link SDFs queried with the raw points (the paper's MRC-SDF)
//   esdf     OctoMap + DynamicEDT3D distance field, robot as surface points
//   sfc      safe-flight corridors along each plan's front-end path
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/env/collision_model.h"
#include "quadhand/env/esdf_model.h"
#include "quadhand/env/mrc_sdf_model.h"
#include "quadhand/env/sfc_model.h"
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

  bool IsValid(std::string* why) const;
};

std::vector<std::string> RepresentationNames();

// InvalidArgument "unknown representation 'NAME' (known: ...)" unless `name`
// is one of RepresentationNames().
core::Status CheckRepresentationName(const std::string& name);

// InvalidArgument naming the known names for an unknown one; the model's own
// errors (missing SDF files, ...) otherwise.
core::Result<Representation> MakeRepresentation(const std::string& name, const robot::RobotModel& robot,
                                                const std::string& sdf_dir, const std::vector<Vec3>& points,
                                                const RepresentationOptions& options = {});

}  // namespace quadhand::planner
