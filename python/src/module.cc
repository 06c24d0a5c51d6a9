// quadhand._core: the C++ side of the Python module (docs/python.md). The
// Python package (python/quadhand/__init__.py) checks and converts arguments
// and documents the API; this file wraps the libraries with the same calls
// the programs make, so a plan from Python equals quadhand-plan's.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "quadhand/core/log.h"
#include "quadhand/opt/solver_registry.h"
#include "quadhand/planner/plan_output.h"
#include "quadhand/robot/link_meshes.h"
#include "quadhand/planner/planner.h"
#include "quadhand/planner/planner_config.h"
#include "quadhand/planner/mission_plan.h"
#include "quadhand/planner/planning_context.h"
#include "quadhand/planner/post_check.h"
#include "quadhand/planner/representation.h"
#include "quadhand/planner/task.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/robot/link_sdfs.h"
#include "quadhand/robot/robot_model.h"
#include "quadhand/scene/point_cloud.h"
#include "quadhand/solvers/builtin_solvers.h"

namespace py = pybind11;

namespace quadhand::python {
namespace {

using Clock = std::chrono::steady_clock;

// Every bad input becomes quadhand.Error (a ValueError) with the libraries'
// one-line message, the same text the programs print after "error: ".
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

[[noreturn]] void Raise(const core::Status& status, const std::string& prefix = "") {
  throw InputError(prefix.empty() ? status.message() : prefix + ": " + status.message());
}

template <typename T>
T Take(core::Result<T> result, const std::string& prefix = "") {
  if (!result.ok()) Raise(result.status(), prefix);
  return std::move(*result);
}

void EnsureSolversRegistered() {
  static const core::Status status = solvers::RegisterBuiltinSolvers();
  if (!status.ok()) Raise(status);
}

// A robot: its URDF model and where its link SDFs are.
struct Robot {
  robot::RobotModel model;
  std::string urdf_path;
  std::string sdf_dir;
};

// A scene cloud, owned here and shared (not copied) by every plan made with it.
struct Scene {
  std::shared_ptr<const std::vector<Vec3>> points;
  long dropped_non_finite = 0;
  std::string source;  // a PCD path, or "<array>"
};

Robot LoadRobot(const std::string& urdf_path, const std::string& sdf_dir) {
  return Robot{Take(robot::RobotModel::LoadFromUrdfFile(urdf_path)), urdf_path, sdf_dir};
}

// Copies an N x 3 float array (checked by the Python layer) into a scene.
Scene SceneFromArray(const py::array_t<double, py::array::c_style | py::array::forcecast>& array) {
  if (array.ndim() != 2 || array.shape(1) != 3 || array.shape(0) == 0) {
    throw InputError("points: expected a non-empty N x 3 array");
  }
  const auto n = static_cast<size_t>(array.shape(0));
  auto points = std::make_shared<std::vector<Vec3>>(n);
  const double* data = array.data();
  for (size_t i = 0; i < n; ++i) {
    (*points)[i] = Vec3(data[3 * i], data[3 * i + 1], data[3 * i + 2]);
    if (!(*points)[i].allFinite()) {
      throw InputError("points: row " + std::to_string(i) + " is not finite (NaN or infinite coordinates)");
    }
  }
  return Scene{std::move(points), 0, "<array>"};
}

Scene SceneFromPcd(const std::string& path) {
  scene::PointCloud cloud = Take(scene::LoadPointCloud(path));
  return Scene{std::make_shared<const std::vector<Vec3>>(std::move(cloud.points)), cloud.dropped_non_finite, path};
}

// A read-only N x 3 view of the scene's points, kept alive by `owner`.
py::array PointsView(const Scene& scene, py::handle owner) {
  static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");
  const std::vector<Vec3>& points = *scene.points;
  py::array_t<double> view({static_cast<py::ssize_t>(points.size()), py::ssize_t{3}},
                           {static_cast<py::ssize_t>(sizeof(Vec3)), static_cast<py::ssize_t>(sizeof(double))},
                           points.empty() ? nullptr : points.front().data(), owner);
  view.attr("setflags")(py::arg("write") = false);
  return std::move(view);
}

// What plan() returns; the Python layer turns the texts into a dict and the
// table into named columns.
struct PlanOutput {
  bool success = false;
  std::string status;
  std::string message;
  std::string report_json;
  std::vector<std::string> columns;
  std::optional<Eigen::MatrixXd> table;  // absent when no plan is returned
  std::string csv;                       // the plan file's text, when a table is returned
  std::vector<std::string> cautions;     // planner::TaskCautions
};

struct PlanArguments {
  std::string task_text;
  std::string task_name;  // a path, or "task" for a dict
  std::string base_dir;
  const Robot* robot = nullptr;
  const Scene* scene = nullptr;
  std::string solver;
  std::string representation;
  double dt = 0.01;
  unsigned seed = 0;
  bool verbose = false;
  bool keep_failed_plan = false;
  std::string config_text;  // YAML or JSON; empty: the defaults
  std::string config_name;  // a path, or "config" for a dict
};

PlanOutput RunPlan(const PlanArguments& args) {
  const auto start_time = Clock::now();
  if (!(std::isfinite(args.dt) && args.dt > 0.0 && args.dt <= 1.0)) throw InputError("dt: must be in (0, 1] seconds");
  EnsureSolversRegistered();
  auto solver = Take(opt::CreateSolver(args.solver), "solver");
  if (!solver->available()) throw InputError("solver: '" + args.solver + "' was built without its library");

  planner::TaskSources sources;
  sources.robot_given = args.robot != nullptr;
  sources.scene_given = args.scene != nullptr;
  planner::Task task = Take(planner::ParseTaskText(args.task_text, args.task_name, args.base_dir, sources));
  robot::RobotModel model;
  if (args.robot) {
    if (args.robot->sdf_dir.empty()) throw InputError("robot: no sdf_dir was given (quadhand.Robot(urdf, sdf_dir))");
    model = args.robot->model;
    task.robot_path = args.robot->urdf_path;
    task.sdf_dir = args.robot->sdf_dir;
  } else {
    model = Take(robot::RobotModel::LoadFromUrdfFile(task.robot_path));
  }
  std::shared_ptr<const std::vector<Vec3>> points, checked_points;
  long dropped = 0;
  double scene_load_ms = -1.0;  // not recorded for a cloud handed over in memory
  if (args.scene) {
    points = args.scene->points;
    dropped = args.scene->dropped_non_finite;
    task.scene_path = args.scene->source;
  } else {
    scene::LoadedScans scans = Take(scene::LoadScans(task.scans));
    points = std::make_shared<const std::vector<Vec3>>(std::move(scans.points));
    if (!scans.unfiltered_points.empty()) {
      checked_points = std::make_shared<const std::vector<Vec3>>(std::move(scans.unfiltered_points));
    }
    dropped = scans.dropped_non_finite;
    scene_load_ms = scans.load_seconds * 1e3;
  }

  planner::PlannerConfig config = planner::DefaultPlannerConfig();
  if (!args.config_text.empty()) config = Take(planner::ParsePlannerConfig(args.config_text, args.config_name));

  core::SetLogLevel(args.verbose ? core::LogLevel::kVerbose : core::LogLevel::kQuiet);
  auto context = Take(planner::PlanningContext::Create(std::move(task), std::move(model), std::move(points), dropped,
                                                       planner::ContextOptions(config, {args.representation}),
                                                       std::move(checked_points)));
  const double representation_ms = context->representations().front().build_ms;

  const planner::PlannerOptions options = planner::RunPlannerOptions(config, args.dt, args.seed, args.verbose);
  planner::PlanResult result = Take(planner::PlanTask(*context, 0, options, *solver));

  PlanOutput output;
  // The meshes' repairs (each file once per process) come first: they are
  // what the plan's geometry is, the task's cautions what it may not mean.
  output.cautions = robot::TakeMeshRepairReports();
  for (std::string& caution : planner::TaskCautions(context->task())) output.cautions.push_back(std::move(caution));
  output.success = result.success;
  output.status = planner::PlanStatusName(result.status);
  output.message = result.message;
  const double total_ms = std::chrono::duration<double, std::milli>(Clock::now() - start_time).count();
  planner::PlanReportInfo info{args.task_name, args.solver,        args.representation,
                               args.seed,      representation_ms, total_ms,
                               &config,        args.config_text.empty() ? "defaults" : args.config_name};
  info.self_collision = &context->self_collision();
  info.front_end_inflation = context->front_end_inflation();
  info.scene_load_ms = scene_load_ms;
  info.robot_load_ms = context->robot_load_seconds() * 1e3;
  info.sdf_load_ms = context->sdf_load_seconds() * 1e3;
  info.front_end_build_ms = context->front_end().build_seconds() * 1e3;
  info.front_end_grid_bytes = static_cast<long>(context->front_end().grid_bytes());
  info.scene_points = static_cast<long>(context->points().size());
  info.checked_points = static_cast<long>(context->checked_points().size());
  info.mission = &context->task().mission;
  info.step_end_times = planner::MissionStepEndTimes(context->task(), result);
  output.report_json = planner::PlanReportJson(result, context->robot(), info);
  if (result.trajectory && (result.success || args.keep_failed_plan)) {
    io::PlanTable table = planner::SamplePlanTable(*result.trajectory, context->robot(), args.dt);
    planner::AppendMissionColumns(context->task().mission, info.step_end_times, &table);
    planner::AppendTargetColumns(context->task(), &table);
    output.csv = io::PlanTableCsv(table);
    output.columns = std::move(table.columns);
    output.table = std::move(table.values);
  }
  return output;
}

// Exact distances between the robot's link meshes and a scene, as the
// post-check measures them.
class Clearance {
 public:
  Clearance(const Robot& robot, const Scene& scene)
      : model_(robot.model), points_(scene.points), exact_(Take(env::ExactMeshModel::Create(model_, *points_))) {}

  // (distance, closest link name); the distance is `reach` when nothing is closer.
  std::pair<double, std::string> Query(const Vec3& position, const Quat& attitude, const VecX& joints,
                                       double reach) const {
    if (joints.size() != model_.num_actuated()) {
      throw InputError("joints: expected " + std::to_string(model_.num_actuated()) + " values (" +
                       Join(model_.ActuatedJointNames()) + "), got " + std::to_string(joints.size()));
    }
    robot::KinematicsState kinematics;
    robot::ComputeKinematics(model_, MakePose(position, attitude.normalized().toRotationMatrix()), joints,
                             &kinematics);
    int link = -1;
    const double distance = env::WholeBodyClearance(kinematics, *exact_, reach, {}, &link);
    return {distance, link >= 0 ? model_.link(link).name : std::string()};
  }

 private:
  static std::string Join(const std::vector<std::string>& names) {
    std::string out;
    for (const auto& name : names) out += (out.empty() ? "" : ", ") + name;
    return out;
  }

  robot::RobotModel model_;
  std::shared_ptr<const std::vector<Vec3>> points_;
  std::unique_ptr<env::ExactMeshModel> exact_;
};

std::vector<std::string> GenerateSdfs(const std::string& urdf_path, const std::string& out_dir, double resolution,
                                      double padding, int threads, const std::vector<std::string>& links,
                                      bool allow_unsigned) {
  geometry::SdfGenerationOptions options;
  options.resolution = resolution;
  options.padding = padding;
  options.num_threads = threads;
  options.allow_unsigned = allow_unsigned;
  if (std::string why; !options.IsValid(&why)) throw InputError("invalid option: " + why);
  auto jobs = Take(robot::LinkSdfJobsFromUrdf(urdf_path, links));
  if (core::Status s = robot::CheckLinkSdfJobs(jobs, options); !s.ok()) Raise(s);
  auto written = Take(robot::WriteLinkSdfs(jobs, out_dir, options));
  std::vector<std::string> paths;
  for (const auto& file : written) paths.push_back(file.path);
  return paths;
}

}  // namespace
}  // namespace quadhand::python

PYBIND11_MODULE(_core, m) {
  using namespace quadhand;
  using namespace quadhand::python;
  m.doc() = "QuadHand's C++ core; use the quadhand package, not this module.";
  py::register_exception<InputError>(m, "Error", PyExc_ValueError);

  py::class_<Robot>(m, "Robot")
      .def(py::init([](const std::string& urdf, const std::string& sdf_dir) { return LoadRobot(urdf, sdf_dir); }),
           py::arg("urdf"), py::arg("sdf_dir") = "")
      .def_property_readonly("name", [](const Robot& r) { return r.model.name(); })
      .def_property_readonly("urdf", [](const Robot& r) { return r.urdf_path; })
      .def_property_readonly("sdf_dir", [](const Robot& r) { return r.sdf_dir; })
      .def_property_readonly("joint_names", [](const Robot& r) { return r.model.ActuatedJointNames(); })
      .def_property_readonly("joint_lower_limits", [](const Robot& r) { return r.model.LowerLimits(); })
      .def_property_readonly("joint_upper_limits", [](const Robot& r) { return r.model.UpperLimits(); })
      .def_property_readonly("link_names",
                             [](const Robot& r) {
                               std::vector<std::string> names;
                               for (int i = 0; i < r.model.num_links(); ++i) names.push_back(r.model.link(i).name);
                               return names;
                             })
      .def_property_readonly("collision_link_names", [](const Robot& r) {
        std::vector<std::string> names;
        for (int link : r.model.CollisionLinks()) names.push_back(r.model.link(link).name);
        return names;
      });

  py::class_<Scene>(m, "Scene")
      .def_static("_from_array", &SceneFromArray, py::arg("points"))
      .def_static("_from_pcd", &SceneFromPcd, py::arg("path"))
      .def_property_readonly("points", [](py::object self) { return PointsView(self.cast<const Scene&>(), self); })
      .def_property_readonly("dropped_non_finite", [](const Scene& s) { return s.dropped_non_finite; })
      .def_property_readonly("source", [](const Scene& s) { return s.source; })
      .def("__len__", [](const Scene& s) { return s.points->size(); });

  py::class_<PlanOutput>(m, "_PlanOutput")
      .def_readonly("success", &PlanOutput::success)
      .def_readonly("status", &PlanOutput::status)
      .def_readonly("message", &PlanOutput::message)
      .def_readonly("report_json", &PlanOutput::report_json)
      .def_readonly("columns", &PlanOutput::columns)
      .def_readonly("table", &PlanOutput::table)
      .def_readonly("csv", &PlanOutput::csv)
      .def_readonly("cautions", &PlanOutput::cautions);

  m.def(
      "_plan",
      [](const std::string& task_text, const std::string& task_name, const std::string& base_dir, const Robot* robot,
         const Scene* scene, const std::string& solver, const std::string& representation, double dt, unsigned seed,
         bool verbose, bool keep_failed_plan, const std::string& config_text, const std::string& config_name) {
        PlanArguments args{task_text, task_name, base_dir,         robot,       scene,      solver, representation,
                           dt,        seed,      verbose,          keep_failed_plan, config_text, config_name};
        py::gil_scoped_release release;
        return RunPlan(args);
      },
      py::arg("task_text"), py::arg("task_name"), py::arg("base_dir"), py::arg("robot").none(true),
      py::arg("scene").none(true), py::arg("solver"), py::arg("representation"), py::arg("dt"), py::arg("seed"),
      py::arg("verbose"), py::arg("keep_failed_plan"), py::arg("config_text"), py::arg("config_name"));

  py::class_<Clearance>(m, "_Clearance")
      .def(py::init<const Robot&, const Scene&>(), py::arg("robot"), py::arg("scene"),
           py::call_guard<py::gil_scoped_release>())
      .def(
          "query",
          [](const Clearance& c, const Vec3& position, const Eigen::Vector4d& wxyz, const VecX& joints, double reach) {
            return c.Query(position, Quat(wxyz[0], wxyz[1], wxyz[2], wxyz[3]), joints, reach);
          },
          py::arg("position"), py::arg("attitude_wxyz"), py::arg("joints"), py::arg("reach"));

  m.def("_generate_sdfs", &GenerateSdfs, py::arg("urdf"), py::arg("out_dir"), py::arg("resolution"),
        py::arg("padding"), py::arg("threads"), py::arg("links"), py::arg("allow_unsigned"),
        py::call_guard<py::gil_scoped_release>());
  m.def("solver_names", [] {
    EnsureSolversRegistered();
    return opt::SolverNames();
  });
  m.def("representation_names", &planner::RepresentationNames);
}
