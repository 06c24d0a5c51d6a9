// A self-contained, offline 3-D page of a plan: the obstacle point cloud, the
// base path, the robot's link meshes at a time chosen with a slider (plus
// faint copies at a few sampled times), the tool path and the insertion line.
// three.js (pinned in libs/viz/web/package.json) is embedded in the library at
// build time and inlined into every page, so viewing it fetches nothing.
// What the page shows and how to use it: docs/html_view.md.
#pragma once

#include <string>
#include <vector>

#include "quadhand/core/status.h"
#include "quadhand/core/types.h"
#include "quadhand/geometry/triangle_mesh.h"

namespace quadhand::viz {

// Everything is in the world frame (ENU, z up), metres and seconds.
struct HtmlViewData {
  std::string title;              // page title and heading; may be empty
  std::vector<Vec3> points;       // obstacle cloud; non-finite points are skipped

  struct Link {
    std::string name;
    geometry::TriangleMesh mesh_in_link_frame;  // may be empty (link not drawn)
  };
  std::vector<Link> links;

  // Sample times, non-decreasing, and for each the world pose X_WL of every
  // link in `links` order: link_poses[i][j] is link j at times[i]. Between
  // samples the page interpolates (position linearly, rotation by slerp).
  // Both may be empty (no robot drawn).
  std::vector<double> times;
  std::vector<std::vector<Pose>> link_poses;

  std::vector<Vec3> base_path;    // polyline of the base origin; may be empty
  std::vector<Vec3> tool_path;    // polyline of the tool frame; may be empty

  bool has_insertion = false;     // draws insertion_start -> insertion_end
  Vec3 insertion_start = Vec3::Zero();
  Vec3 insertion_end = Vec3::Zero();

  // Points that move rigidly (a moving target's, docs/moving_targets.md):
  // where they are at t = 0, and their displacement at each of `times` (one
  // per time when there are points). Drawn in a colour of their own and
  // moved with the slider. May be empty.
  std::vector<Vec3> moving_points;
  std::vector<Pose> moving_displacements;

  std::string summary;            // free text shown in a corner (several lines allowed)
};

struct HtmlViewOptions {
  // Clouds with more finite points than this are subsampled (a fixed-seed
  // uniform random subset, so the same input gives the same page).
  int max_points = 200000;
  // Faint robot copies at this many evenly spaced sample times (0: none).
  int num_ghosts = 6;
  // Path polylines longer than this are thinned (every k-th point, ends kept).
  int max_path_points = 4000;

  bool IsValid(std::string* why) const;
};

// The page as one HTML string. InvalidArgument when the data is inconsistent
// (link_poses not times x links, times decreasing or not finite, a triangle
// index out of range, a non-finite pose or path point) or the options are.
core::Result<std::string> RenderHtmlView(const HtmlViewData& data,
                                         const HtmlViewOptions& options = {});

// RenderHtmlView written to `path` atomically (temporary name, then rename);
// on failure nothing is left at `path`. Errors name the file.
core::Status WriteHtmlView(const std::string& path, const HtmlViewData& data,
                           const HtmlViewOptions& options = {});

// The embedded three.js release, e.g. "0.170.0".
const char* EmbeddedThreeVersion();

}  // namespace quadhand::viz
