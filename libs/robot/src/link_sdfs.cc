#include "quadhand/robot/link_sdfs.h"

#include <algorithm>
#include <filesystem>

#include "quadhand/core/file_util.h"
#include "quadhand/geometry/mesh_io.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/robot/robot_model.h"

namespace quadhand::robot {

core::Result<std::vector<LinkSdfJob>> LinkSdfJobsFromUrdf(const std::string& urdf_path,
                                                          const std::vector<std::string>& only_links) {
  auto model = RobotModel::LoadFromUrdfFile(urdf_path);
  if (!model.ok()) return model.status();
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
  if (options.allow_unsigned) return core::Status::Ok();
  for (const LinkSdfJob& job : jobs) {
    for (size_t e = 0; e < job.elements.size(); ++e) {
      const geometry::MeshCheck check = geometry::CheckMesh(job.elements[e]);
      if (check.bounds_volume) continue;
      const std::string which =
          job.elements.size() > 1 ? "collision element " + std::to_string(e + 1) + " of link '" : "mesh of link '";
      return core::Status::InvalidArgument(job.source + ": " + which + job.link_name + "' does not bound a volume (" +
                                           check.problem + "); pass --unsigned to accept it with unsigned distances");
    }
  }
  return core::Status::Ok();
}

core::Result<std::vector<WrittenLinkSdf>> WriteLinkSdfs(const std::vector<LinkSdfJob>& jobs, const std::string& out_dir,
                                                     const geometry::SdfGenerationOptions& options,
                                                     const LinkSdfProgress& progress) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("invalid option: " + why);
  std::error_code error;
  std::filesystem::create_directories(out_dir, error);
  if (!std::filesystem::is_directory(out_dir)) {
    return core::Status::IoError(out_dir + ": cannot create output directory" +
                                 (error ? ": " + error.message() : ""));
  }
  core::AtomicFileSet outputs;
  std::vector<WrittenLinkSdf> written;
  for (const LinkSdfJob& job : jobs) {
    geometry::ProgressCallback link_progress;
    if (progress) link_progress = [&](long done, long total) { progress(job.link_name, done, total); };
    auto grid = geometry::GenerateSdf(job.elements, job.link_name, job.source, options, link_progress);
    if (!grid.ok()) return grid.status();
    const std::string path = out_dir + "/" + job.link_name + kSdfFileExtension;
    QUADHAND_RETURN_IF_ERROR(outputs.Stage(path, grid->Serialize()));
    int triangles = 0;
    for (const geometry::TriangleMesh& element : job.elements) triangles += element.num_triangles();
    written.push_back({path, grid->info(), grid->MemoryBytes(), triangles});
  }
  QUADHAND_RETURN_IF_ERROR(outputs.Commit());
  return written;
}

}  // namespace quadhand::robot
