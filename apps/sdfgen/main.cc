// quadhand-sdfgen: link meshes -> one signed distance field per link.
//
//   quadhand-sdfgen --urdf FILE --out DIR [--resolution M] [--padding M]
//   quadhand-sdfgen --mesh FILE --link NAME --out DIR [...]
//   quadhand-sdfgen probe FILE [x y z]
//   quadhand-sdfgen info FILE
//
// Exit codes: 0 success, 2 bad input (one line on stderr). Files are written
// only when every link succeeded (docs/sdfgen.md).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "app_options.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/core/file_util.h"
#include "quadhand/core/log.h"
#include "quadhand/env/self_collision.h"
#include "quadhand/env/surface_sample_cache.h"
#include "quadhand/geometry/mesh_io.h"
#include "quadhand/geometry/mesh_repair.h"
#include "quadhand/geometry/mesh_to_sdf.h"
#include "quadhand/geometry/sdf_grid.h"
#include "quadhand/robot/link_sdfs.h"
#include "quadhand/robot/robot_model.h"

namespace {

using quadhand::Vec3;
namespace core = quadhand::core;
namespace env = quadhand::env;
namespace geometry = quadhand::geometry;
namespace robot = quadhand::robot;

constexpr int kExitBadInput = 2;

int Fail(const std::string& message) {
  core::PrintError("quadhand-sdfgen", message);
  return kExitBadInput;
}

// Generates every job's grid, then writes all files together (or none).
int Generate(const std::vector<robot::LinkSdfJob>& jobs, const std::string& out_dir,
             const geometry::SdfGenerationOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  std::optional<core::ProgressBar> progress;
  std::string progress_link;
  auto written = robot::WriteLinkSdfs(jobs, out_dir, options, [&](const std::string& link, long done, long total) {
    if (link != progress_link) {
      if (progress) progress->Finish();
      progress.emplace("  " + link, total);
      progress_link = link;
    }
    progress->Update(done);
  });
  if (progress) progress->Finish();
  if (!written.ok()) return Fail(written.status().message());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const robot::WrittenLinkSdf& file : *written) {
    const geometry::SdfGridInfo& info = file.info;
    core::LogInfo("  %s: %d x %d x %d nodes, %.1f MB, %d triangles", info.link_name.c_str(), info.dims.x(),
                  info.dims.y(), info.dims.z(), file.memory_bytes / 1e6, file.num_triangles);
  }
  for (const robot::WrittenLinkSdf& file : *written) std::printf("%s\n", file.path.c_str());
  core::LogInfo("wrote %zu SDF file(s) in %.1f s", written->size(), seconds);
  return 0;
}

// "distance gx gy gz" for one point, in the link frame.
void PrintProbe(const geometry::SdfGrid& grid, const Vec3& p) {
  double distance = 0;
  Vec3 gradient;
  grid.Evaluate(p, &distance, &gradient);
  std::printf("%.9g %.9g %.9g %.9g\n", distance, gradient.x(), gradient.y(), gradient.z());
}

int Probe(const std::string& path, const std::vector<double>& point) {
  if (!point.empty() && point.size() != 3) return Fail("probe takes exactly three coordinates: x y z");
  for (double c : point) {
    if (!std::isfinite(c)) return Fail("probe coordinates must be finite numbers");
  }
  auto grid = geometry::SdfGrid::Load(path);
  if (!grid.ok()) return Fail(grid.status().message());
  if (!point.empty()) {
    PrintProbe(*grid, Vec3(point[0], point[1], point[2]));
    return 0;
  }
  std::string line;
  long line_number = 0;
  while (std::getline(std::cin, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream in(line);
    Vec3 p;
    std::string extra;
    if (!(in >> p.x() >> p.y() >> p.z()) || (in >> extra) || !p.allFinite()) {
      return Fail("standard input line " + std::to_string(line_number) +
                  ": expected three finite numbers 'x y z'");
    }
    PrintProbe(*grid, p);
  }
  return 0;
}

int Info(const std::string& path) {
  auto grid = geometry::SdfGrid::Load(path);
  if (!grid.ok()) return Fail(grid.status().message());
  const geometry::SdfGridInfo& info = grid->info();
  const Vec3 grid_max = info.GridMax();
  std::printf("file: %s\n", path.c_str());
  std::printf("format_version: %u\n", info.file_version);
  std::printf("link: %s\n", info.link_name.c_str());
  std::printf("frame: %s\n", info.frame.c_str());
  std::printf("source: %s\n", info.source.c_str());
  std::printf("signed: %s\n", info.is_signed ? "yes" : "no");
  std::printf("resolution: %.9g\n", info.resolution);
  std::printf("origin: %.9g %.9g %.9g\n", info.origin.x(), info.origin.y(), info.origin.z());
  std::printf("grid_max: %.9g %.9g %.9g\n", grid_max.x(), grid_max.y(), grid_max.z());
  std::printf("dimensions: %d %d %d\n", info.dims.x(), info.dims.y(), info.dims.z());
  std::printf("geometry_min: %.9g %.9g %.9g\n", info.geometry_min.x(), info.geometry_min.y(),
              info.geometry_min.z());
  std::printf("geometry_max: %.9g %.9g %.9g\n", info.geometry_max.x(), info.geometry_max.y(),
              info.geometry_max.z());
  std::printf("memory_bytes: %zu\n", grid->MemoryBytes());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "quadhand-sdfgen: signed distance fields of robot links, one file per collision link.\n"
      "Generate from a URDF (--urdf) or from one mesh (--mesh, --link); inspect a file with\n"
      "'probe' and 'info'. Distances in metres, in the link's own frame, negative inside.\n"
      "File format: docs/sdf_format.md. Exit codes: 0 ok, 2 bad input."};
  app.set_help_all_flag("--help-all", "Show help for all subcommands");

  std::string urdf_path, mesh_path, link_name, out_dir;
  std::vector<std::string> only_links;
  geometry::SdfGenerationOptions options;
  bool allow_unsigned = false, quiet = false;
  app.add_option("--urdf", urdf_path, "URDF file: one SDF per link with collision geometry");
  app.add_option("--mesh", mesh_path, "One mesh file (STL, OBJ, PLY, OFF, Collada DAE), already in the link frame");
  app.add_option("--link", link_name, "With --mesh: the link name (output file <link>.qhsdf)");
  app.add_option("--links", only_links, "With --urdf: only these links (comma separated)")->delimiter(',');
  app.add_option("--out", out_dir, "Output directory (created if missing)");
  app.add_option("--resolution", options.resolution, "Grid spacing in metres")
      ->capture_default_str();
  app.add_option("--padding", options.padding, "Margin around each mesh's bounding box in metres")
      ->capture_default_str();
  app.add_option("--threads", options.num_threads, "Worker threads (0: all cores)")->capture_default_str();
  geometry::MeshRepairOptions repair;
  app.add_option("--repair-tolerance", repair.tolerance,
                 "Mesh repair: vertices closer than this (m) are merged, closing cracks narrower than it; "
                 "in (0, resolution] and at most 0.001 (docs/sdfgen.md); give quadhand-plan the same")
      ->capture_default_str();
  app.add_flag("--unsigned", allow_unsigned,
               "Accept meshes that are not closed or self-intersect; distances are then unsigned");
  std::vector<std::string> package_path;
  quadhand::apps::AddPackagePathOption(&app, &package_path);
  app.add_flag("-q,--quiet", quiet, "No progress output");

  std::string probe_file, info_file;
  std::vector<double> probe_point;
  CLI::App* probe = app.add_subcommand(
      "probe", "Print 'distance gx gy gz' at x y z (link frame); without coordinates, answer one\n"
               "line per 'x y z' line of standard input. Outside the grid: the distance to the\n"
               "geometry's bounding box, a lower bound (docs/sdf_format.md).");
  probe->add_option("file", probe_file, "SDF file")->required();
  probe->add_option("point", probe_point, "x y z")->expected(0, 3);
  CLI::App* info = app.add_subcommand("info", "Print the header of an SDF file");
  info->add_option("file", info_file, "SDF file")->required();
  app.require_subcommand(0, 1);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return Fail(e.what());
  }

  if (*probe) return Probe(probe_file, probe_point);
  if (*info) return Info(info_file);
  robot::PrependRosPackagePath(package_path);

  if (quiet) core::SetLogLevel(core::LogLevel::kQuiet);
  options.allow_unsigned = allow_unsigned;
  if (urdf_path.empty() == mesh_path.empty()) return Fail("give exactly one of --urdf or --mesh (see --help)");
  if (out_dir.empty()) return Fail("--out DIR is required");
  // Whether --out can be made, before any work or output (the folder
  // itself is made only once the grids are computed: WriteLinkSdfs).
  if (core::Status s = core::CheckFolderCanBeMade(out_dir); !s.ok()) return Fail("--out " + s.message());

  if (!mesh_path.empty() && link_name.empty()) return Fail("--mesh needs --link NAME");
  if (!urdf_path.empty() && !link_name.empty()) return Fail("--link goes with --mesh; use --links with --urdf");
  if (!mesh_path.empty() && !only_links.empty()) return Fail("--links goes with --urdf");
  if (std::string why; !options.IsValid(&why)) return Fail("invalid option: " + why);
  if (core::Status s = geometry::CheckRepairTolerance(repair.tolerance, options.resolution); !s.ok()) {
    return Fail("invalid option: --repair-tolerance: " + s.message());
  }

  std::vector<robot::LinkSdfJob> jobs;
  std::string mesh_repairs;  // --mesh: what its repair changed, printed once it is accepted
  if (!urdf_path.empty()) {
    auto from_urdf = robot::LinkSdfJobsFromUrdf(urdf_path, only_links, repair.tolerance);
    if (!from_urdf.ok()) return Fail(from_urdf.status().message());
    jobs = std::move(*from_urdf);
  } else {
    geometry::MeshRepairReport repairs;
    auto shells = geometry::ReadMeshShells(mesh_path, repair, &repairs);
    if (!shells.ok()) return Fail(shells.status().message());
    if (!repairs.problem.empty() && !allow_unsigned) {
      return Fail(mesh_path + " (link '" + link_name + "'): does not bound a volume, even repaired: " + repairs.problem);
    }
    for (const std::string& line : repairs.Lines()) mesh_repairs += (mesh_repairs.empty() ? "" : "; ") + line;
    jobs.push_back({link_name, mesh_path, std::move(*shells)});
  }
  // Check every mesh before generating anything, so a bad last link fails in
  // seconds rather than after the others were computed.
  if (core::Status s = robot::CheckLinkSdfJobs(jobs, options); !s.ok()) return Fail(s.message());
  if (!mesh_repairs.empty()) core::LogInfo("quadhand-sdfgen: mesh '%s' repaired: %s", mesh_path.c_str(), mesh_repairs.c_str());
  for (const std::string& line : robot::TakeMeshRepairReports()) core::LogInfo("quadhand-sdfgen: %s", line.c_str());
  core::LogInfo("quadhand-sdfgen: %zu link(s), resolution %.4g m, padding %.4g m", jobs.size(),
                options.resolution, options.padding);
  const int generated = Generate(jobs, out_dir, options);
  if (generated != 0 || urdf_path.empty()) return generated;
  // The repairs, for plans with these SDFs to load the meshes without
  // repairing them again; only a speed-up, so a failure is a warning.
  const std::string cache_dir = robot::MeshCacheDirOf(out_dir);
  auto cached = robot::SaveMeshRepairCache(cache_dir);
  if (!cached.ok()) {
    std::fprintf(stderr, "quadhand-sdfgen: warning: the mesh repairs were not cached (plans will repair the meshes again): %s\n",
                     cached.status().message().c_str());
  } else if (*cached > 0) {
    core::LogInfo("cached %d mesh repair(s) in %s", *cached, cache_dir.c_str());
  }
  // And each element's surface samples at the self-collision model's
  // default spacings, which a plan would otherwise compute again.
  const env::SelfCollisionOptions defaults;
  int sampled = 0;
  for (const robot::LinkSdfJob& job : jobs) {
    for (const geometry::TriangleMesh& element : job.elements) {
      for (double spacing : {defaults.sample_spacing, defaults.penalty_spacing}) {
        if (core::Status s = env::WriteLinkSurfaceSamples(element, spacing, cache_dir); !s.ok()) {
          std::fprintf(stderr, "quadhand-sdfgen: warning: surface samples not cached: %s\n", s.message().c_str());
          return 0;
        }
        ++sampled;
      }
    }
  }
  core::LogInfo("cached %d element surface sampling(s) in %s", sampled, cache_dir.c_str());
  return 0;
}
