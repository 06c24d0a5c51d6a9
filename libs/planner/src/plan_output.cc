#include "quadhand/planner/plan_output.h"

#include <algorithm>
#include <cmath>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

namespace quadhand::planner {

io::PlanTable SamplePlanTable(const WholeBodyTrajectory& trajectory, const robot::RobotModel& robot, double dt) {
  io::PlanTable table;
  table.columns = io::PlanColumns(robot.ActuatedJointNames());
  const double duration = trajectory.duration();
  const long steps = std::max(1L, static_cast<long>(std::ceil(duration / dt - 1e-9)));
  const int n = robot.num_actuated();
  table.values.resize(steps + 1, static_cast<Eigen::Index>(table.columns.size()));
  for (long k = 0; k <= steps; ++k) {
    const double t = k == steps ? duration : k * dt;
    const WholeBodySample s = trajectory.Sample(t);
    auto row = table.values.row(k);
    row[0] = t;
    row.segment<3>(1) = s.position.transpose();
    row.segment<3>(4) = s.velocity.transpose();
    row.segment<3>(7) = s.acceleration.transpose();
    row[10] = s.attitude.w();
    row[11] = s.attitude.x();
    row[12] = s.attitude.y();
    row[13] = s.attitude.z();
    row[14] = s.yaw;
    row[15] = s.yaw_rate;
    row.segment(16, n) = s.joints.transpose();
    row.segment(16 + n, n) = s.joint_rates.transpose();
  }
  return table;
}

void AppendMissionColumns(const std::vector<MissionStep>& mission, const std::vector<double>& step_end_times,
                          io::PlanTable* table) {
  if (mission.empty() || step_end_times.size() != mission.size()) return;
  // The gripper's state from each step on: closed from a grasp's start, open
  // from a release's start.
  std::vector<double> closed_from(mission.size(), 0.0);
  bool closed = false;
  for (size_t i = 0; i < mission.size(); ++i) {
    if (mission[i].kind == StepKind::kGrasp) closed = true;
    if (mission[i].kind == StepKind::kRelease) closed = false;
    closed_from[i] = closed ? 1.0 : 0.0;
  }
  const Eigen::Index rows = table->values.rows(), columns = table->values.cols();
  table->values.conservativeResize(rows, columns + 2);
  table->columns.push_back("step");
  table->columns.push_back("gripper");
  size_t step = 0;
  for (Eigen::Index r = 0; r < rows; ++r) {
    const double t = table->values(r, 0);
    while (step + 1 < mission.size() && t > step_end_times[step]) ++step;
    table->values(r, columns) = static_cast<double>(step);
    table->values(r, columns + 1) = closed_from[step];
  }
}

void AppendTargetColumns(const Task& task, io::PlanTable* table) {
  const ToolGoal* tool = MovingToolGoal(task);
  if (tool == nullptr) return;
  const TargetMotion& motion = tool->moving->motion;
  const Eigen::Index rows = table->values.rows(), columns = table->values.cols();
  table->values.conservativeResize(rows, columns + 7);
  for (const char* name : {"target_x", "target_y", "target_z", "target_qw", "target_qx", "target_qy", "target_qz"}) {
    table->columns.push_back(name);
  }
  const Mat3 orientation = tool->orientation.toRotationMatrix();
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Pose displacement = motion.Displacement(table->values(r, 0));
    const Vec3 position = displacement * tool->position;
    const Quat q(displacement.linear() * orientation);
    table->values.block<1, 7>(r, columns) << position.x(), position.y(), position.z(), q.w(), q.x(), q.y(), q.z();
  }
}

std::vector<double> MissionStepEndTimes(const Task& task, const PlanResult& result) {
  if (task.mission.empty() || result.steps.size() != task.mission.size()) return {};
  std::vector<double> ends;
  double last = 0.0;
  for (const StepResult& step : result.steps) {
    // A step after the one that failed was not flown: it ends where the plan does.
    last = step.planned ? step.end_s : (result.trajectory ? result.trajectory->duration() : last);
    ends.push_back(last);
  }
  return ends;
}

std::string PlanReportJson(const PlanResult& result, const robot::RobotModel& robot, const PlanReportInfo& info) {
  nlohmann::json report;
  report["success"] = result.success;
  report["status"] = PlanStatusName(result.status);
  report["message"] = result.message;
  report["task"] = info.task;
  report["solver"] = info.solver;
  report["representation"] = info.representation;
  report["seed"] = info.seed;
  report["solve_ms"] = result.solve_ms;
  report["front_end_ms"] = result.front_end_ms;
  report["post_check_ms"] = result.post_check_ms;
  report["representation_build_ms"] = info.representation_build_ms + result.per_plan_collision_ms;
  if (info.scene_load_ms >= 0.0) report["scene_load_ms"] = info.scene_load_ms;
  if (info.robot_load_ms >= 0.0) report["robot_load_ms"] = info.robot_load_ms;
  if (info.sdf_load_ms >= 0.0) report["sdf_load_ms"] = info.sdf_load_ms;
  if (info.front_end_build_ms >= 0.0) report["front_end_build_ms"] = info.front_end_build_ms;
  if (info.front_end_grid_bytes >= 0) report["front_end_grid_bytes"] = info.front_end_grid_bytes;
  if (info.scene_points >= 0) report["scene_points"] = info.scene_points;
  if (info.checked_points >= 0) report["checked_points"] = info.checked_points;
  report["total_ms"] = info.total_ms;
  report["iterations"] = result.iterations;
  report["cost_evaluations"] = result.evaluations;
  report["num_pieces"] = result.num_pieces;
  report["initial_guess"] = result.initial_guess;
  report["alternatives_tried"] = result.alternatives_tried;
  report["terminal_state"] = {{"position", {result.terminal.position.x(), result.terminal.position.y(),
                                            result.terminal.position.z()}},
                              {"yaw", result.terminal.yaw},
                              {"joints", std::vector<double>(result.terminal.joints.data(),
                                                             result.terminal.joints.data() + result.terminal.joints.size())},
                              {"searched", result.terminal_searched}};
  if (result.terminal_searched) {
    report["terminal_state"]["search"] = {{"tool_position_error_m", result.terminal_search.position_error},
                                          {"tool_angle_error_rad", result.terminal_search.angle_error},
                                          {"clearance_m", result.terminal_search.clearance},
                                          {"restarts", result.terminal_search.restarts_used},
                                          {"seconds", result.terminal_search.seconds}};
  }
  if (result.moving_target) {
    // Where the plan meets the target (docs/moving_targets.md): the arrival
    // the initial guess aimed at, how many searches it took, and where the
    // target and the tool are at the plan's end.
    nlohmann::json moving = {{"arrival_guess_s", result.arrival_guess_s},
                             {"arrival_rounds", result.arrival_rounds}};
    if (result.status == PlanStatus::kTargetUnreachable) {
      moving["out_of_reach_m"] = result.target_out_of_reach_m;
      moving["out_of_reach_at_s"] = result.target_out_of_reach_at_s;
    }
    const bool in_mission = result.target_met_s >= 0.0;
    const InsertionGoal& met = in_mission ? result.target_met_insertion : result.insertion;
    if (result.trajectory && met.tool_link >= 0) {
      const double end = in_mission ? result.target_met_s : result.trajectory->duration();
      const WholeBodySample last = result.trajectory->Sample(end);
      const Vec3 tool = robot::LinkPose(robot, last.BasePose(), last.joints, met.tool_link).translation();
      moving["arrival_s"] = end;
      moving["target_position"] = {met.tool_position.x(), met.tool_position.y(), met.tool_position.z()};
      moving["tool_to_target_m"] = (tool - met.tool_position).norm();
    }
    for (const CheckResult& check : result.post_check.checks) {
      if (check.kind == CheckKind::kRelativeSpeed) moving["relative_speed_mps"] = check.value;
    }
    report["moving_target"] = moving;
  }
  if (result.trajectory) {
    const VecX& durations = result.trajectory->position().durations();
    report["piece_durations_s"] = std::vector<double>(durations.data(), durations.data() + durations.size());
  }
  report["duration_s"] = result.trajectory ? result.trajectory->duration() : 0.0;
  if (result.sections > 0) report["sections"] = result.sections;
  report["min_clearance_m"] = result.post_check.min_clearance_model;
  report["min_clearance_exact_m"] = result.post_check.min_clearance_exact;
  report["min_clearance_exact_is_lower_bound"] = result.post_check.min_clearance_exact_is_bound;
  report["closest_link"] = result.post_check.closest_link >= 0 ? robot.link(result.post_check.closest_link).name : "";
  // A mission that failed at a step planned no leg for it: its legs before
  // may all be certified, the plan is not.
  report["certified"] = result.success && result.post_check.certified;
  if (info.mission != nullptr && !info.mission->empty() && result.steps.size() == info.mission->size()) {
    // Per step (contracts.md 0.3); a step after the one that failed was
    // not planned: its figures are null.
    nlohmann::json steps = nlohmann::json::array();
    for (const StepResult& s : result.steps) {
      nlohmann::json step;
      step["kind"] = StepKindName(s.kind);
      step["planned"] = s.planned;
      step["start_s"] = s.planned ? nlohmann::json(s.start_s) : nlohmann::json(nullptr);
      step["end_s"] = s.planned ? nlohmann::json(s.end_s) : nlohmann::json(nullptr);
      step["min_clearance_m"] = s.planned ? nlohmann::json(s.min_clearance) : nlohmann::json(nullptr);
      step["min_clearance_is_lower_bound"] = s.min_clearance_is_bound;
      step["held_object_min_clearance_m"] =
          s.held_object_min_clearance ? nlohmann::json(*s.held_object_min_clearance) : nlohmann::json(nullptr);
      step["held_object_min_clearance_is_lower_bound"] = s.held_object_min_clearance_is_bound;
      step["certified"] = s.certified;
      steps.push_back(step);
    }
    report["steps"] = steps;
    report["mission_phase_build_ms"] = result.mission_phase_ms;
  }
  report["certified_clearance_m"] = result.post_check.certified_clearance;
  report["certified_margin_m"] = result.post_check.certified_margin;
  report["certificate_samples"] = result.post_check.certificate_samples;
  if (info.self_collision != nullptr) {
    nlohmann::json checked = nlohmann::json::array(), excluded = nlohmann::json::array();
    for (const env::LinkPair& p : info.self_collision->pairs()) {
      checked.push_back({robot.link(p.sampled_link).name, robot.link(p.queried_link).name});
    }
    for (const env::ExcludedPair& p : info.self_collision->excluded()) {
      excluded.push_back({{"links", {robot.link(p.link_a).name, robot.link(p.link_b).name}},
                          {"why", env::PairExclusionName(p.why)}});
    }
    report["self_collision_pairs"] = checked;
    report["self_collision_excluded"] = excluded;
    report["self_safety_distance_m"] = info.self_collision->options().safety_distance;
    report["min_self_distance_m"] = result.post_check.min_self_distance;
    report["certified_self_distance_m"] = result.post_check.certified_self_distance;
  }
  nlohmann::json violations = nlohmann::json::object();
  for (const auto& [name, ratio] : result.post_check.violations) violations[name] = ratio;
  report["violations"] = violations;
  nlohmann::json checks = nlohmann::json::array();
  for (const auto& c : result.post_check.checks) {
    checks.push_back({{"name", c.name}, {"passed", c.passed}, {"value", c.value}, {"bound", c.bound},
                      {"time_s", c.time}, {"detail", c.detail}});
  }
  report["checks"] = checks;
  nlohmann::json attempts = nlohmann::json::array();
  for (const auto& a : result.attempts) {
    attempts.push_back({{"solve_ms", a.solve_ms}, {"post_check_ms", a.post_check_ms}, {"iterations", a.iterations}, {"cost_evaluations", a.evaluations},
                        {"solver_status", opt::SolveStatusName(a.solver_status)}, {"post_check_failure", a.post_check_failure}});
  }
  report["attempts"] = attempts;
  const auto& c = result.final_cost;
  report["final_cost"] = {{"total", c.total}, {"energy", c.energy}, {"time_s", c.time}};
  for (const auto& [name, value] : c.terms) report["final_cost"][name] = value;
  nlohmann::json path = nlohmann::json::array();
  for (const Vec3& p : result.path.shortcut) path.push_back({p.x(), p.y(), p.z()});
  report["front_end_path"] = path;
  if (info.front_end_inflation >= 0.0) report["front_end_inflation_m"] = info.front_end_inflation;
  if (info.config != nullptr) {
    nlohmann::json values = nlohmann::json::object();
    for (const auto& entry : PlannerConfigEntries(*info.config)) {
      const std::string& key = entry.first;  // named: the lambda below captures it
      const auto& value = entry.second;
      nlohmann::json* section = &values;  // "cost.flatness.gravity" -> values["cost"]["flatness"]["gravity"]
      size_t begin = 0;
      for (size_t dot = key.find('.'); dot != std::string::npos; begin = dot + 1, dot = key.find('.', begin)) {
        section = &(*section)[key.substr(begin, dot - begin)];
      }
      std::visit([&](const auto& v) { (*section)[key.substr(begin)] = v; }, value);
    }
    report["planner_config"] = {{"source", info.config_source}, {"values", values}};
  }
  return report.dump(2) + "\n";
}

}  // namespace quadhand::planner
