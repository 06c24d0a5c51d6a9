#include "quadhand/robot/link_sdfs.h"

#include <algorithm>
#include <filesystem>

#include "quadhand/core/file_util.h"
#include "quadhand/geometry/mesh_io.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::robot {

core::Result<std::vector<LinkSdfJob>> LinkSdfJobsFromUrdf(const std::string& urdf_path,
                                                          const std::vector<std::string>& only_links,
                                                          double mesh_repair_tolerance) {
  auto model = RobotModel::LoadFromUrdfFile(urdf_path);
  if (!model.ok()) return model.status();
  model->set_mesh_repair_tolerance(mesh_repair_tolerance);
  for (const std::string& name : only_links) {
    const int index = model->LinkIndex(name);
    if (index < 0) return core::Status::InvalidArgument(urdf_path + ": no link named '" + name + "'");
    if (model->link(index).collisions.empty()) {
      return core::Status::InvalidArgument(urdf_path + ": link '" + name + "' has no collision geometry");
    }
  }
  std::vector<LinkSdfJob> jobs;
  for (int link : model->CollisionLinks()) {
    const std::string& name = model->link(link).name;
    if (!only_links.empty() && std::find(only_links.begin(), only_links.end(), name) == only_links.end()) {
      continue;
    }
    auto elements = LinkCollisionElements(*model, link);
    if (!elements.ok()) return elements.status().WithPrefix(urdf_path);
    jobs.push_back({name, urdf_path + "#" + name, std::move(*elements)});
  }
  if (jobs.empty()) return core::Status::InvalidArgument(urdf_path + ": no link has collision geometry");
  return jobs;
}

core::Status CheckLinkSdfJobs(const std::vector<LinkSdfJob>& jobs, const geometry::SdfGenerationOptions& options) {
  for (const LinkSdfJob& job : jobs) {
    if (auto path = LinkSdfPath(".", job.link_name); !path.ok()) return path.status().WithPrefix(job.source);
    // Every grid's size before the first is made (an absurd mesh scale in
    // the last link must not fail after minutes of work).
    if (auto dims = geometry::SdfGridDims(job.elements, options); !dims.ok()) {
      return dims.status().WithPrefix(job.source);
    }
  }
  if (options.allow_unsigned) return core::Status::Ok();
  for (const LinkSdfJob& job : jobs) {
    for (size_t e = 0; e < job.elements.size(); ++e) {
      const geometry::MeshCheck check = geometry::CheckMesh(job.elements[e]);
      if (check.bounds_volume) continue;
      const std::string which =
          job.elements.size() > 1 ? "collision element " + std::to_string(e + 1) + " of link '" : "mesh of link '";
      return core::Status::InvalidArgument(job.source + ": " + which + job.link_name + "' does not bound a volume (" +
                                           check.problem + ")");
    }
  }
  return core::Status::Ok();
}

core::Result<std::string> LinkSdfPath(const std::string& dir, const std::string& link_name) {
  bool control = false;
  for (unsigned char c : link_name) control = control || c < 0x20 || c == 0x7f;
  if (link_name.empty() || link_name == "." || link_name == ".." || link_name.find('/') != std::string::npos ||
      control) {
    return core::Status::InvalidArgument("link '" + link_name +
                                         "': its name cannot be a file name (empty, '.', '..', a '/' or a control "
                                         "character); rename the link in the URDF");
  }
  return dir + "/" + link_name + kSdfFileExtension;
}

core::Result<std::vector<WrittenLinkSdf>> WriteLinkSdfs(const std::vector<LinkSdfJob>& jobs, const std::string& out_dir,
                                                     const geometry::SdfGenerationOptions& options,
                                                     const LinkSdfProgress& progress) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("invalid option: " + why);
  std::vector<std::string> paths;
  for (const LinkSdfJob& job : jobs) {
    auto path = LinkSdfPath(out_dir, job.link_name);
    if (!path.ok()) return path.status().WithPrefix(job.source);
    paths.push_back(*path);
  }
  std::error_code error;
  // Whether the folder can be made is known at once (a bad --out fails in
  // seconds, not after the grids); but a folder made here is removed again
  // until the grids are done, so a run killed while computing (minutes, for
  // a fine grid) leaves nothing behind.
  const bool existed = std::filesystem::exists(out_dir, error);
  QUADHAND_RETURN_IF_ERROR(core::CheckFolderCanBeMade(out_dir));

  std::vector<std::string> bytes;
  std::vector<WrittenLinkSdf> written;
  for (size_t i = 0; i < jobs.size(); ++i) {
    const LinkSdfJob& job = jobs[i];
    geometry::ProgressCallback link_progress;
    if (progress) link_progress = [&](long done, long total) { progress(job.link_name, done, total); };
    auto grid = geometry::GenerateSdf(job.elements, job.link_name, job.source, options, link_progress);
    if (!grid.ok()) return grid.status();
    bytes.push_back(grid->Serialize());
    int triangles = 0;
    for (const geometry::TriangleMesh& element : job.elements) triangles += element.num_triangles();
    written.push_back({paths[i], grid->info(), grid->MemoryBytes(), triangles});
  }

  // A folder made here and left empty by a failure is removed again (after
  // the staged files, which `outputs` removes first).
  struct RemoveIfEmptyOnFailure {
    std::string dir;
    bool committed = false;
    ~RemoveIfEmptyOnFailure() {
      std::error_code ignored;
      if (!dir.empty() && !committed) std::filesystem::remove(dir, ignored);  // only an empty folder goes
    }
  } made_here{existed ? std::string() : out_dir};
  std::filesystem::create_directories(out_dir, error);
  if (!std::filesystem::is_directory(out_dir)) {
    return core::Status::IoError(out_dir + ": cannot create output directory" +
                                 (error ? ": " + error.message() : ""));
  }
  core::AtomicFileSet outputs;
  for (size_t i = 0; i < jobs.size(); ++i) QUADHAND_RETURN_IF_ERROR(outputs.Stage(paths[i], bytes[i]));
  QUADHAND_RETURN_IF_ERROR(outputs.Commit());
  made_here.committed = true;
  return written;
}

}  // namespace quadhand::robot
