#include "quadhand/planner/planner_config.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "quadhand/core/file_util.h"
#include "quadhand/core/yaml_text.h"
#include "quadhand/geometry/mesh_repair.h"

namespace quadhand::planner {
namespace {

// The one table of keys: Visit() calls `visitor(key, field)` for every
// tunable, in file order. Reading, writing and the report all use it, so a
// new option is one line here (and one in docs/configuration.md).
template <typename Config, typename Visitor>
void Visit(Config& c, Visitor&& v) {
  auto& p = c.planner;
  v("plan.collision_margin", p.collision_margin);
  v("plan.insertion_collision_margin", p.insertion_collision_margin);
  v("plan.piece_length", p.piece_length);
  v("plan.min_pieces", p.min_pieces);
  v("plan.cruise_speed", p.cruise_speed);
  v("plan.cruise_acceleration", p.cruise_acceleration);
  v("plan.stow_joints_in_transit", p.stow_joints_in_transit);
  v("plan.stow_margin", p.stow_margin);
  v("plan.settle_yaw_in_transit", p.settle_yaw_in_transit);
  v("plan.stow_lead", p.stow_lead);
  v("plan.max_attempts", p.max_attempts);
  v("plan.alternative_guesses", p.alternative_guesses);
  v("plan.section_pieces", p.section_pieces);
  v("plan.weight_raise_factor", p.weight_raise_factor);
  v("plan.resolve_sample_factor", p.resolve_sample_factor);
  v("plan.max_samples_per_piece", p.max_samples_per_piece);
  v("plan.self_collision_margin", p.self_collision_margin);

  auto& k = p.cost;
  v("cost.samples_per_piece", k.samples_per_piece);
  v("cost.insertion_samples", k.insertion_samples);
  v("cost.threads", k.threads);
  v("cost.time_weight", k.time_weight);
  v("cost.energy_weight_position", k.energy_weight_position);
  v("cost.energy_weight_aux", k.energy_weight_aux);
  v("cost.weight_collision", k.weight_collision);
  v("cost.weight_insertion", k.weight_insertion);
  v("cost.weight_velocity", k.weight_velocity);
  v("cost.weight_acceleration", k.weight_acceleration);
  v("cost.weight_yaw_rate", k.weight_yaw_rate);
  v("cost.weight_joint_rate", k.weight_joint_rate);
  v("cost.weight_body_rate", k.weight_body_rate);
  v("cost.weight_joint_limits", k.weight_joint_limits);
  v("cost.weight_self_collision", k.weight_self_collision);
  v("cost.limit_fraction", k.limit_fraction);
  v("cost.joint_limit_margin", k.joint_limit_margin);
  v("cost.collision_mu", k.collision_mu);
  v("cost.self_collision_mu", k.self_collision_mu);
  v("cost.feasibility_mu", k.feasibility_mu);
  v("cost.joint_limit_mu", k.joint_limit_mu);
  v("cost.insertion_position_tolerance", k.insertion_position_tolerance);
  v("cost.insertion_rotation_tolerance", k.insertion_rotation_tolerance);
  v("cost.insertion_position_weight", k.insertion_position_weight);
  v("cost.insertion_rotation_weight", k.insertion_rotation_weight);
  v("cost.insertion_mu", k.insertion_mu);
  v("cost.insertion_backoff_margin", k.insertion_backoff_margin);
  v("cost.flatness.gravity", k.flatness.gravity);
  v("cost.flatness.min_thrust", k.flatness.min_thrust);
  v("cost.flatness.inverted_tolerance", k.flatness.inverted_tolerance);

  auto solver = [&v](const std::string& prefix, auto& s) {
    v(prefix + "max_iterations", s.max_iterations);
    v(prefix + "max_time_seconds", s.max_time_seconds);
    v(prefix + "relative_cost_tolerance", s.relative_cost_tolerance);
    v(prefix + "relative_cost_window", s.relative_cost_window);
    v(prefix + "gradient_tolerance", s.gradient_tolerance);
    v(prefix + "memory_size", s.memory_size);
    v(prefix + "line_search_c1", s.line_search_c1);
    v(prefix + "line_search_c2", s.line_search_c2);
    v(prefix + "line_search_max_steps", s.line_search_max_steps);
  };
  solver("solver.", p.solver);

  auto& pc = p.post_check;
  v("post_check.dt", pc.dt);
  v("post_check.clearance_dt", pc.clearance_dt);
  v("post_check.clearance_tolerance", pc.clearance_tolerance);
  v("post_check.limit_tolerance", pc.limit_tolerance);
  v("post_check.position_tolerance", pc.position_tolerance);
  v("post_check.angle_tolerance", pc.angle_tolerance);
  v("post_check.rate_tolerance", pc.rate_tolerance);
  v("post_check.insertion_tolerance", pc.insertion_tolerance);
  v("post_check.threads", pc.threads);

  auto& t = p.terminal_state;
  v("terminal_state.restarts", t.restarts);
  v("terminal_state.position_tolerance", t.position_tolerance);
  v("terminal_state.angle_tolerance", t.angle_tolerance);
  v("terminal_state.collision_margin", t.collision_margin);
  v("terminal_state.joint_limit_margin", t.joint_limit_margin);
  v("terminal_state.weight_position", t.weight_position);
  v("terminal_state.weight_rotation", t.weight_rotation);
  v("terminal_state.weight_collision", t.weight_collision);
  v("terminal_state.weight_joint_limits", t.weight_joint_limits);
  v("terminal_state.weight_turn", t.weight_turn);
  v("terminal_state.collision_mu", t.collision_mu);
  v("terminal_state.joint_limit_mu", t.joint_limit_mu);

  auto& f = c.front_end;
  v("front_end.voxel_size", f.voxel_size);
  v("front_end.inflation_radius", f.inflation_radius);
  v("front_end.inflation_height", f.inflation_height);
  v("front_end.tight_cost_factor", f.tight_cost_factor);
  v("front_end.shortcut_clearance", f.shortcut_clearance);
  v("front_end.bounds_margin", f.bounds_margin);
  v("front_end.max_escape_distance", f.max_escape_distance);
  v("front_end.heuristic_weight", f.heuristic_weight);
  v("front_end.max_expansions", f.max_expansions);
  v("front_end.max_seconds", f.max_seconds);
  v("front_end.max_voxels", f.max_voxels);
  v("front_end.size_from_robot", f.size_from_robot);
  v("front_end.shortcut_ratio", f.shortcut_ratio);

  auto& r = c.replan;
  v("replan.max_attempts", r.max_attempts);
  v("replan.min_piece_duration", r.min_piece_duration);
  v("replan.max_start_penetration", r.max_start_penetration);
  v("replan.recovery_time", r.recovery_time);
  v("replan.horizon", r.horizon);
  v("replan.horizon_attempts", r.horizon_attempts);
  v("replan.max_rejoin_stretch", r.max_rejoin_stretch);
  v("replan.max_rejoin_tries", r.max_rejoin_tries);
  solver("replan.solver.", r.solver);

  v("meshes.repair_tolerance", c.mesh_repair_tolerance);
  v("mission.payload_limit", c.payload_limit);
  v("mission.object_sdf_resolution", p.mission.object_sdf_resolution);
  v("mission.object_sdf_padding", p.mission.object_sdf_padding);
  v("mission.released_surface_spacing", p.mission.released_surface_spacing);
  v("mission.move_speed", p.mission.move_speed);
  v("mission.move_min_duration", p.mission.move_min_duration);

  // Last: representations registered from outside follow as their own sections.
  auto& m = c.representations;
  v("representations.mrc_sdf.cell_size", m.mrc_sdf.cell_size);
  v("representations.mrc_sdf.far_cell_size", m.mrc_sdf.far_cell_size);
  v("representations.mrc_sdf.far_padding", m.mrc_sdf.far_padding);
  v("representations.mrc_sdf.far_max_steps", m.mrc_sdf.far_max_steps);
  v("representations.esdf.resolution", m.esdf.resolution);
  v("representations.esdf.max_distance", m.esdf.max_distance);
  v("representations.esdf.box_margin", m.esdf.box_margin);
  v("representations.esdf.surface_spacing", m.esdf.surface_spacing);
  v("representations.esdf.max_cells", m.esdf.max_cells);
  v("representations.sfc.local_margin", m.sfc.local_margin);
  v("representations.sfc.surface_spacing", m.sfc.surface_spacing);
  v("representations.sfc.max_faces", m.sfc.max_faces);
  v("representations.sfc.cell_size", m.sfc.cell_size);
}

std::string Number(double value) {
  if (std::isinf(value)) return value > 0 ? ".inf" : "-.inf";
  // The shortest of 15 to 17 significant digits that reads back exactly.
  char buffer[40];
  for (int digits = 15; digits <= 17; ++digits) {
    std::snprintf(buffer, sizeof(buffer), "%.*g", digits, value);
    if (std::strtod(buffer, nullptr) == value) break;
  }
  return buffer;
}

// Reads each visited field from the YAML tree; the first error wins.
class Reader {
 public:
  Reader(const YAML::Node& root, std::string name) : root_(root), name_(std::move(name)) {}

  const core::Status& status() const { return status_; }
  const std::set<std::string>& keys() const { return keys_; }

  template <typename T>
  void operator()(const std::string& key, T& field) {
    keys_.insert(key);
    if (!status_.ok()) return;
    const YAML::Node node = Find(key);
    if (!node) return;
    Read(key, node, field);
  }

 private:
  // The node at a dotted key, or an invalid node. Const all the way: a
  // non-const yaml-cpp lookup would insert the missing keys it asks for.
  YAML::Node Find(const std::string& key) const {
    std::vector<std::string> parts;
    std::stringstream in(key);
    for (std::string part; std::getline(in, part, '.');) parts.push_back(part);
    return Descend(root_, parts, 0);
  }
  static YAML::Node Descend(const YAML::Node& node, const std::vector<std::string>& parts, size_t i) {
    if (i == parts.size()) return node;
    if (!node.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
    const YAML::Node child = node[parts[i]];
    if (!child) return YAML::Node(YAML::NodeType::Undefined);
    return Descend(child, parts, i + 1);
  }

  void Error(const std::string& key, const std::string& problem) {
    status_ = core::Status::InvalidArgument(name_ + ": " + key + ": " + problem);
  }

  bool Scalar(const std::string& key, const YAML::Node& node, double* out) {
    if (!node.IsScalar()) {
      Error(key, "expected a number");
      return false;
    }
    try {
      *out = node.as<double>();
    } catch (const YAML::Exception&) {
      Error(key, "expected a number, got '" + node.Scalar() + "'");
      return false;
    }
    // Infinity means "no limit" for time limits only.
    const bool may_be_infinite = key.size() >= 16 && key.compare(key.size() - 16, 16, "max_time_seconds") == 0;
    if (std::isnan(*out) || (std::isinf(*out) && !(may_be_infinite && *out > 0))) {
      Error(key, "must be a finite number");
      return false;
    }
    return true;
  }

  void Read(const std::string& key, const YAML::Node& node, double& field) {
    double value = 0;
    if (Scalar(key, node, &value)) field = value;
  }

  void Read(const std::string& key, const YAML::Node& node, bool& field) {
    if (!node.IsScalar()) return Error(key, "expected true or false");
    try {
      field = node.as<bool>();
    } catch (const YAML::Exception&) {
      Error(key, "expected true or false, got '" + node.Scalar() + "'");
    }
  }

  template <typename Integer>
  void ReadInteger(const std::string& key, const YAML::Node& node, Integer& field) {
    double value = 0;
    if (!Scalar(key, node, &value)) return;
    if (value != std::floor(value) || value < static_cast<double>(std::numeric_limits<Integer>::min()) ||
        value > static_cast<double>(std::numeric_limits<Integer>::max())) {
      return Error(key, "expected a whole number in range, got '" + node.Scalar() + "'");
    }
    field = static_cast<Integer>(value);
  }
  void Read(const std::string& key, const YAML::Node& node, int& field) { ReadInteger(key, node, field); }
  void Read(const std::string& key, const YAML::Node& node, long& field) { ReadInteger(key, node, field); }

  void Read(const std::string& key, const YAML::Node& node, Vec3& field) {
    if (!node.IsSequence() || node.size() != 3) return Error(key, "expected a list of 3 numbers");
    Vec3 value;
    for (int i = 0; i < 3; ++i) {
      if (!Scalar(key + "[" + std::to_string(i) + "]", node[i], &value[i])) return;
    }
    field = value;
  }

  YAML::Node root_;
  std::string name_;
  core::Status status_;
  std::set<std::string> keys_;
};

// Every key of the tree as a dotted path to a leaf (a scalar or a list).
void LeafKeys(const YAML::Node& node, const std::string& prefix, std::vector<std::string>* out) {
  if (!node.IsMap()) {
    out->push_back(prefix);
    return;
  }
  for (const auto& entry : node) {
    LeafKeys(entry.second, prefix.empty() ? entry.first.Scalar() : prefix + "." + entry.first.Scalar(), out);
  }
}

// The sections representations.<name> of representations registered from
// outside the library, kept as YAML text for their factories.
core::Status ReadRegisteredRepresentationOptions(const YAML::Node& root, const std::string& name,
                                                 RepresentationOptions* options) {
  const YAML::Node& const_root = root;  // const lookups insert nothing
  const YAML::Node sections = const_root["representations"];
  if (!sections || !sections.IsMap()) return core::Status::Ok();
  for (const auto& entry : sections) {
    const std::string representation = entry.first.Scalar();
    if (IsBuiltInRepresentation(representation)) continue;  // the key table reads those
    if (core::Status known = CheckRepresentationName(representation); !known.ok()) {
      return core::Status::InvalidArgument(name + ": representations." + representation + ": " + known.message());
    }
    YAML::Node section = YAML::Clone(entry.second);
    section.SetStyle(YAML::EmitterStyle::Flow);  // one line, so that it nests anywhere
    YAML::Emitter text;
    text << section;
    options->registered[representation] = text.c_str();
  }
  return core::Status::Ok();
}

bool IsRegisteredOptionsKey(const RepresentationOptions& options, const std::string& key) {
  for (const auto& [representation, text] : options.registered) {
    const std::string prefix = "representations." + representation;
    if (key == prefix || key.rfind(prefix + ".", 0) == 0) return true;
  }
  return false;
}

}  // namespace

bool PlannerConfig::IsValid(std::string* why) const {
  std::string inner;
  auto fail = [&](const char* part) {
    if (why != nullptr) *why = std::string(part) + ": " + inner;
    return false;
  };
  if (!planner.IsValid(&inner)) return fail("plan");
  if (!planner.terminal_state.IsValid(&inner)) return fail("terminal_state");
  if (!front_end.IsValid(&inner)) return fail("front_end");
  if (!replan.IsValid(&inner)) return fail("replan");
  if (!representations.IsValid(&inner)) return fail("representations");
  geometry::MeshRepairOptions repair;
  repair.tolerance = mesh_repair_tolerance;
  if (!repair.IsValid(&inner)) return fail("meshes");
  if (!(std::isfinite(payload_limit) && payload_limit >= 0.0 && payload_limit <= 100.0)) {
    inner = "payload_limit must be in [0, 100] kg";
    return fail("mission");
  }
  return true;
}

PlannerConfig DefaultPlannerConfig() { return PlannerConfig{}; }

PlannerOptions RunPlannerOptions(const PlannerConfig& config, double dt, unsigned seed, bool verbose) {
  PlannerOptions options = config.planner;
  options.post_check.dt = std::min(options.post_check.dt, dt);
  options.solver.verbosity = verbose ? 1 : 0;
  options.terminal_state.seed = seed;
  return options;
}

void SetWorkerThreads(int threads, PlannerConfig* config) {
  config->planner.cost.threads = threads;
  config->planner.post_check.threads = threads;
}

PlanningContextOptions ContextOptions(const PlannerConfig& config, std::vector<std::string> representations) {
  PlanningContextOptions options;
  options.representations = std::move(representations);
  options.front_end = config.front_end;
  options.representation_options = config.representations;
  options.mesh_repair_tolerance = config.mesh_repair_tolerance;
  options.payload_limit = config.payload_limit;
  return options;
}

core::Result<PlannerConfig> LoadPlannerConfig(const std::string& path) {
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return text.status();
  return ParsePlannerConfig(*text, path);
}

core::Result<PlannerConfig> LoadPlannerConfigOrDefaults(const std::string& path) {
  if (path.empty()) return DefaultPlannerConfig();
  return LoadPlannerConfig(path);
}

core::Result<PlannerConfig> ParsePlannerConfig(const std::string& text, const std::string& name) {
  // A file with nothing in it is more likely a failed copy or a wrong path
  // than a wish for the defaults (leaving --planner-config out gives those);
  // one whose keys are all commented out says what it means.
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
    return core::Status::InvalidArgument(name + ": the planner configuration is empty (leave the option out for the "
                                                "defaults, or write the keys to change)");
  }
  QUADHAND_RETURN_IF_ERROR(core::CheckYamlText(text, name));
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return core::Status::InvalidArgument(name + ": not valid YAML: line " + std::to_string(e.mark.line + 1) + ": " +
                                         e.msg);
  }
  if (root.IsNull()) return DefaultPlannerConfig();  // only comments: all defaults
  if (!root.IsMap()) return core::Status::InvalidArgument(name + ": expected a YAML mapping of configuration keys");
  PlannerConfig config = DefaultPlannerConfig();
  try {
    Reader reader(root, name);
    Visit(config, reader);
    QUADHAND_RETURN_IF_ERROR(reader.status());
    QUADHAND_RETURN_IF_ERROR(ReadRegisteredRepresentationOptions(root, name, &config.representations));
    std::vector<std::string> present;
    LeafKeys(root, "", &present);
    for (const std::string& key : present) {
      if (reader.keys().count(key) != 0 || IsRegisteredOptionsKey(config.representations, key)) continue;
      const auto after = reader.keys().lower_bound(key + ".");
      const bool is_section = after != reader.keys().end() && after->rfind(key + ".", 0) == 0;
      return core::Status::InvalidArgument(name + ": " + key +
                                           (is_section ? ": expected a mapping of keys"
                                                       : ": unknown key (docs/configuration.md lists every key)"));
    }
  } catch (const YAML::Exception& e) {
    return core::Status::InvalidArgument(name + ": malformed configuration: " + e.msg);
  }
  if (std::string why; !config.IsValid(&why)) return core::Status::InvalidArgument(name + ": " + why);
  return config;
}

std::string PlannerConfigYaml(const PlannerConfig& config) {
  // Nested mappings in visiting order: a line per key, indented by depth.
  std::ostringstream out;
  std::vector<std::string> open;  // the sections of the previous key
  Visit(config, [&](const std::string& key, const auto& field) {
    std::vector<std::string> parts;
    std::stringstream in(key);
    for (std::string part; std::getline(in, part, '.');) parts.push_back(part);
    size_t common = 0;
    while (common < open.size() && common + 1 < parts.size() && open[common] == parts[common]) ++common;
    for (size_t i = common; i + 1 < parts.size(); ++i) {
      out << std::string(2 * i, ' ') << parts[i] << ":\n";
    }
    open.assign(parts.begin(), parts.end() - 1);
    out << std::string(2 * (parts.size() - 1), ' ') << parts.back() << ": ";
    using T = std::decay_t<decltype(field)>;
    if constexpr (std::is_same_v<T, bool>) {
      out << (field ? "true" : "false");
    } else if constexpr (std::is_same_v<T, Vec3>) {
      out << "[" << Number(field.x()) << ", " << Number(field.y()) << ", " << Number(field.z()) << "]";
    } else if constexpr (std::is_integral_v<T>) {
      out << field;
    } else {
      out << Number(field);
    }
    out << "\n";
  });
  // Registered representations' sections, as given, under "representations:"
  // (the last section of the key table).
  for (const auto& [representation, text] : config.representations.registered) {
    out << "  " << representation << ": " << text << "\n";
  }
  return out.str();
}

std::vector<std::pair<std::string, ConfigValue>> PlannerConfigEntries(const PlannerConfig& config) {
  std::vector<std::pair<std::string, ConfigValue>> entries;
  Visit(config, [&](const std::string& key, const auto& field) {
    using T = std::decay_t<decltype(field)>;
    if constexpr (std::is_same_v<T, bool>) {
      entries.emplace_back(key, ConfigValue(field));
    } else if constexpr (std::is_same_v<T, Vec3>) {
      entries.emplace_back(key, ConfigValue(std::vector<double>{field.x(), field.y(), field.z()}));
    } else if constexpr (std::is_integral_v<T>) {
      entries.emplace_back(key, ConfigValue(static_cast<long long>(field)));
    } else {
      entries.emplace_back(key, ConfigValue(static_cast<double>(field)));
    }
  });
  for (const auto& [representation, text] : config.representations.registered) {
    entries.emplace_back("representations." + representation, ConfigValue(text));
  }
  return entries;
}

}  // namespace quadhand::planner
