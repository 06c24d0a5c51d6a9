#include "quadhand/sim/config.h"

#include <cmath>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "quadhand/core/file_util.h"
#include "quadhand/core/yaml_text.h"

namespace quadhand::sim {
namespace {

using core::Status;

// Reads a YAML map, remembering its path for messages and rejecting unknown keys.
class Reader {
 public:
  Reader(const YAML::Node& node, std::string path, std::string source)
      : node_(node), path_(std::move(path)), source_(std::move(source)) {}

  Status CheckKeys(const std::set<std::string>& known) const {
    if (!node_.IsMap()) return Bad(path_.empty() ? "the file" : path_, "must be a map");
    for (const auto& kv : node_) {
      const std::string key = kv.first.as<std::string>();
      if (!known.count(key)) return Bad(Join(key), "unknown key");
    }
    return Status::Ok();
  }

  bool Has(const std::string& key) const { return node_[key].IsDefined() && !node_[key].IsNull(); }
  Reader Child(const std::string& key) const { return Reader(node_[key], Join(key), source_); }

  Status Get(const std::string& key, double* value) const {
    if (!Has(key)) return Status::Ok();
    try {
      *value = node_[key].as<double>();
    } catch (const YAML::Exception&) {
      return Bad(Join(key), "expected a number");
    }
    if (!std::isfinite(*value)) return Bad(Join(key), "must be finite");
    return Status::Ok();
  }
  Status Get(const std::string& key, int* value) const {
    if (!Has(key)) return Status::Ok();
    double number = 0.0;
    QUADHAND_RETURN_IF_ERROR(Get(key, &number));
    if (number != std::floor(number) || std::abs(number) > 1e6) return Bad(Join(key), "expected a whole number");
    *value = static_cast<int>(number);
    return Status::Ok();
  }
  std::string Missing(const std::string& key) const { return source_ + ": " + Join(key) + ": missing"; }
  Status Invalid(const std::string& key, const std::string& what) const { return Bad(Join(key), what); }
  Status Get(const std::string& key, bool* value) const {
    if (!Has(key)) return Status::Ok();
    try {
      *value = node_[key].as<bool>();
    } catch (const YAML::Exception&) {
      return Bad(Join(key), "expected true or false");
    }
    return Status::Ok();
  }
  Status Get(const std::string& key, std::string* value) const {
    if (!Has(key)) return Status::Ok();
    try {
      *value = node_[key].as<std::string>();
    } catch (const YAML::Exception&) {
      return Bad(Join(key), "expected a string");
    }
    return Status::Ok();
  }
  Status Get(const std::string& key, std::vector<double>* value) const {
    if (!Has(key)) return Status::Ok();
    const YAML::Node n = node_[key];
    if (!n.IsSequence()) return Bad(Join(key), "expected a list of numbers");
    value->clear();
    for (const auto& item : n) {
      try {
        value->push_back(item.as<double>());
      } catch (const YAML::Exception&) {
        return Bad(Join(key), "expected a list of numbers");
      }
      if (!std::isfinite(value->back())) return Bad(Join(key), "must be finite");
    }
    return Status::Ok();
  }
  Status Get(const std::string& key, Vec3* value) const {
    if (!Has(key)) return Status::Ok();
    std::vector<double> v;
    QUADHAND_RETURN_IF_ERROR(Get(key, &v));
    if (v.size() != 3) return Bad(Join(key), "expected 3 numbers");
    *value = Vec3(v[0], v[1], v[2]);
    return Status::Ok();
  }

 private:
  std::string Join(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  Status Bad(const std::string& key, const std::string& what) const {
    return Status::InvalidArgument(source_ + ": " + key + ": " + what);
  }

  YAML::Node node_;
  std::string path_;
  std::string source_;
};

// A time the fault starts, and how long it lasts where it lasts.
Status ParseWindow(const Reader& p, bool with_duration, double* time, double* duration) {
  QUADHAND_RETURN_IF_ERROR(with_duration ? p.CheckKeys({"time", "duration"}) : p.CheckKeys({"time", "offset"}));
  if (!p.Has("time")) return Status::InvalidArgument(p.Missing("time"));
  QUADHAND_RETURN_IF_ERROR(p.Get("time", time));
  if (with_duration) {
    if (!p.Has("duration")) return Status::InvalidArgument(p.Missing("duration"));
    QUADHAND_RETURN_IF_ERROR(p.Get("duration", duration));
  }
  return Status::Ok();
}

Status ParseFaults(const Reader& f, FaultConfig* faults) {
  QUADHAND_RETURN_IF_ERROR(f.CheckKeys({"wind", "motor", "servo", "payload_mass_factor", "estimate"}));
  if (f.Has("wind")) {
    const Reader p = f.Child("wind");
    WindFault& w = faults->wind;
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys({"steady", "gust_intensity", "altitude", "min_airspeed", "base_drag_area",
                                          "arm_drag_coefficient", "air_density"}));
    QUADHAND_RETURN_IF_ERROR(p.Get("steady", &w.steady));
    QUADHAND_RETURN_IF_ERROR(p.Get("gust_intensity", &w.gust_intensity));
    QUADHAND_RETURN_IF_ERROR(p.Get("altitude", &w.altitude));
    QUADHAND_RETURN_IF_ERROR(p.Get("min_airspeed", &w.min_airspeed));
    QUADHAND_RETURN_IF_ERROR(p.Get("base_drag_area", &w.base_drag_area));
    QUADHAND_RETURN_IF_ERROR(p.Get("arm_drag_coefficient", &w.arm_drag_coefficient));
    QUADHAND_RETURN_IF_ERROR(p.Get("air_density", &w.air_density));
  }
  if (f.Has("motor")) {
    const Reader p = f.Child("motor");
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys({"rotor", "thrust_factor"}));
    if (!p.Has("rotor")) return Status::InvalidArgument(p.Missing("rotor"));
    QUADHAND_RETURN_IF_ERROR(p.Get("rotor", &faults->motor.rotor));
    QUADHAND_RETURN_IF_ERROR(p.Get("thrust_factor", &faults->motor.thrust_factor));
  }
  if (f.Has("servo")) {
    const Reader p = f.Child("servo");
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys({"extra_lag", "stall_joint", "stall_time"}));
    QUADHAND_RETURN_IF_ERROR(p.Get("extra_lag", &faults->servo.extra_lag));
    QUADHAND_RETURN_IF_ERROR(p.Get("stall_joint", &faults->servo.stall_joint));
    QUADHAND_RETURN_IF_ERROR(p.Get("stall_time", &faults->servo.stall_time));
  }
  QUADHAND_RETURN_IF_ERROR(f.Get("payload_mass_factor", &faults->payload_mass_factor));
  if (f.Has("estimate")) {
    const Reader p = f.Child("estimate");
    EstimateFault& e = faults->estimate;
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys({"jump", "drift", "freeze", "nan"}));
    if (p.Has("jump")) {
      const Reader j = p.Child("jump");
      QUADHAND_RETURN_IF_ERROR(ParseWindow(j, false, &e.jump_time, nullptr));
      if (!j.Has("offset")) return Status::InvalidArgument(j.Missing("offset"));
      QUADHAND_RETURN_IF_ERROR(j.Get("offset", &e.jump));
    }
    QUADHAND_RETURN_IF_ERROR(p.Get("drift", &e.drift));
    if (p.Has("freeze")) QUADHAND_RETURN_IF_ERROR(ParseWindow(p.Child("freeze"), true, &e.freeze_time, &e.freeze_duration));
    if (p.Has("nan")) QUADHAND_RETURN_IF_ERROR(ParseWindow(p.Child("nan"), true, &e.nan_time, &e.nan_duration));
  }
  return Status::Ok();
}

Status ParseInto(const YAML::Node& root, const std::string& base_dir, const std::string& source, SimConfig* c) {
  const Reader r(root, "", source);
  QUADHAND_RETURN_IF_ERROR(r.CheckKeys({"robot", "step", "gravity", "pcgc", "payload", "rotors", "linear_drag",
                                        "servo", "controller", "noise", "faults", "failsafe", "sensor"}));
  std::string robot;
  QUADHAND_RETURN_IF_ERROR(r.Get("robot", &robot));
  if (!robot.empty()) c->robot_path = core::ResolvePath(base_dir, robot);
  QUADHAND_RETURN_IF_ERROR(r.Get("step", &c->step));
  QUADHAND_RETURN_IF_ERROR(r.Get("gravity", &c->gravity));
  QUADHAND_RETURN_IF_ERROR(r.Get("linear_drag", &c->linear_drag));
  if (r.Has("pcgc")) {
    const Reader p = r.Child("pcgc");
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys({"enabled", "joint"}));
    QUADHAND_RETURN_IF_ERROR(p.Get("enabled", &c->pcgc));
    QUADHAND_RETURN_IF_ERROR(p.Get("joint", &c->pcgc_joint));
    c->pcgc_joint_given = p.Has("joint");
  }
  if (r.Has("payload")) {
    const Reader p = r.Child("payload");
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys({"attached", "mass", "offset", "link"}));
    QUADHAND_RETURN_IF_ERROR(p.Get("link", &c->payload.link));
    QUADHAND_RETURN_IF_ERROR(p.Get("attached", &c->payload.attached));
    QUADHAND_RETURN_IF_ERROR(p.Get("mass", &c->payload.mass));
    QUADHAND_RETURN_IF_ERROR(p.Get("offset", &c->payload.offset));
  }
  if (r.Has("rotors")) {
    const Reader p = r.Child("rotors");
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys(
        {"wheelbase", "height", "min_thrust", "max_thrust", "time_constant", "torque_coefficient"}));
    QUADHAND_RETURN_IF_ERROR(p.Get("wheelbase", &c->rotors.wheelbase));
    QUADHAND_RETURN_IF_ERROR(p.Get("height", &c->rotors.height));
    QUADHAND_RETURN_IF_ERROR(p.Get("min_thrust", &c->rotors.min_thrust));
    QUADHAND_RETURN_IF_ERROR(p.Get("max_thrust", &c->rotors.max_thrust));
    QUADHAND_RETURN_IF_ERROR(p.Get("time_constant", &c->rotors.time_constant));
    QUADHAND_RETURN_IF_ERROR(p.Get("torque_coefficient", &c->rotors.torque_coefficient));
  }
  if (r.Has("servo")) {
    const Reader p = r.Child("servo");
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys({"position_gain", "time_constant", "max_rate", "max_acceleration"}));
    QUADHAND_RETURN_IF_ERROR(p.Get("position_gain", &c->servo.position_gain));
    QUADHAND_RETURN_IF_ERROR(p.Get("time_constant", &c->servo.time_constant));
    QUADHAND_RETURN_IF_ERROR(p.Get("max_rate", &c->servo.max_rate));
    QUADHAND_RETURN_IF_ERROR(p.Get("max_acceleration", &c->servo.max_acceleration));
  }
  if (r.Has("controller")) {
    const Reader p = r.Child("controller");
    ControllerConfig& k = c->controller;
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys({"mass", "inertia", "nominal_joints", "position_gain", "velocity_gain",
                                          "position_integral_gain", "position_integral_limit", "attitude_gain",
                                          "rate_gain", "attitude_integral_gain", "attitude_integral_limit"}));
    QUADHAND_RETURN_IF_ERROR(p.Get("mass", &k.mass));
    QUADHAND_RETURN_IF_ERROR(p.Get("inertia", &k.inertia));
    QUADHAND_RETURN_IF_ERROR(p.Get("nominal_joints", &k.nominal_joints));
    QUADHAND_RETURN_IF_ERROR(p.Get("position_gain", &k.position_gain));
    QUADHAND_RETURN_IF_ERROR(p.Get("velocity_gain", &k.velocity_gain));
    QUADHAND_RETURN_IF_ERROR(p.Get("position_integral_gain", &k.position_integral_gain));
    QUADHAND_RETURN_IF_ERROR(p.Get("position_integral_limit", &k.position_integral_limit));
    QUADHAND_RETURN_IF_ERROR(p.Get("attitude_gain", &k.attitude_gain));
    QUADHAND_RETURN_IF_ERROR(p.Get("rate_gain", &k.rate_gain));
    QUADHAND_RETURN_IF_ERROR(p.Get("attitude_integral_gain", &k.attitude_integral_gain));
    QUADHAND_RETURN_IF_ERROR(p.Get("attitude_integral_limit", &k.attitude_integral_limit));
  }
  if (r.Has("noise")) {
    const Reader p = r.Child("noise");
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys({"enabled", "position", "velocity", "attitude", "body_rate"}));
    QUADHAND_RETURN_IF_ERROR(p.Get("enabled", &c->noise.enabled));
    QUADHAND_RETURN_IF_ERROR(p.Get("position", &c->noise.position));
    QUADHAND_RETURN_IF_ERROR(p.Get("velocity", &c->noise.velocity));
    QUADHAND_RETURN_IF_ERROR(p.Get("attitude", &c->noise.attitude));
    QUADHAND_RETURN_IF_ERROR(p.Get("body_rate", &c->noise.body_rate));
  }
  if (r.Has("sensor")) {
    const Reader p = r.Child("sensor");
    SensorConfig& sensor = c->sensor;
    QUADHAND_RETURN_IF_ERROR(
        p.CheckKeys({"link", "mount", "splat_radius", "splat_spacing_factor", "depth", "lidar"}));
    QUADHAND_RETURN_IF_ERROR(p.Get("link", &sensor.link));
    QUADHAND_RETURN_IF_ERROR(p.Get("splat_radius", &sensor.splat_radius));
    QUADHAND_RETURN_IF_ERROR(p.Get("splat_spacing_factor", &sensor.splat_spacing_factor));
    if (p.Has("mount")) {
      const Reader m = p.Child("mount");
      QUADHAND_RETURN_IF_ERROR(m.CheckKeys({"position", "orientation"}));
      Vec3 position = Vec3::Zero();
      std::vector<double> q = {1.0, 0.0, 0.0, 0.0};
      QUADHAND_RETURN_IF_ERROR(m.Get("position", &position));
      QUADHAND_RETURN_IF_ERROR(m.Get("orientation", &q));
      const auto unit = [](const std::vector<double>& v) {
        return v.size() == 4 && std::abs(Quat(v[0], v[1], v[2], v[3]).norm() - 1.0) <= 1e-3;
      };
      if (!unit(q)) return m.Invalid("orientation", "expected a unit quaternion [w, x, y, z]");
      const Quat rotation(q[0], q[1], q[2], q[3]);
      sensor.mount = MakePose(position, rotation.normalized().toRotationMatrix());
      sensor.mount_given = true;
    }
    if (p.Has("depth")) {
      const Reader d = p.Child("depth");
      DepthCameraOptions& o = sensor.depth;
      QUADHAND_RETURN_IF_ERROR(d.CheckKeys({"width", "height", "horizontal_fov_deg", "vertical_fov_deg", "min_range",
                                            "max_range", "rate", "noise_at_1m"}));
      QUADHAND_RETURN_IF_ERROR(d.Get("width", &o.width));
      QUADHAND_RETURN_IF_ERROR(d.Get("height", &o.height));
      QUADHAND_RETURN_IF_ERROR(d.Get("horizontal_fov_deg", &o.horizontal_fov_deg));
      QUADHAND_RETURN_IF_ERROR(d.Get("vertical_fov_deg", &o.vertical_fov_deg));
      QUADHAND_RETURN_IF_ERROR(d.Get("min_range", &o.min_range));
      QUADHAND_RETURN_IF_ERROR(d.Get("max_range", &o.max_range));
      QUADHAND_RETURN_IF_ERROR(d.Get("rate", &o.rate));
      QUADHAND_RETURN_IF_ERROR(d.Get("noise_at_1m", &o.noise_at_1m));
    }
    if (p.Has("lidar")) {
      const Reader l = p.Child("lidar");
      LidarOptions& o = sensor.lidar;
      QUADHAND_RETURN_IF_ERROR(l.CheckKeys({"channels", "vertical_fov_deg", "horizontal_resolution_deg", "min_range",
                                            "max_range", "rate", "noise"}));
      QUADHAND_RETURN_IF_ERROR(l.Get("channels", &o.channels));
      QUADHAND_RETURN_IF_ERROR(l.Get("vertical_fov_deg", &o.vertical_fov_deg));
      QUADHAND_RETURN_IF_ERROR(l.Get("horizontal_resolution_deg", &o.horizontal_resolution_deg));
      QUADHAND_RETURN_IF_ERROR(l.Get("min_range", &o.min_range));
      QUADHAND_RETURN_IF_ERROR(l.Get("max_range", &o.max_range));
      QUADHAND_RETURN_IF_ERROR(l.Get("rate", &o.rate));
      QUADHAND_RETURN_IF_ERROR(l.Get("noise", &o.noise));
    }
  }
  if (r.Has("faults")) QUADHAND_RETURN_IF_ERROR(ParseFaults(r.Child("faults"), &c->faults));
  if (r.Has("failsafe")) {
    const Reader p = r.Child("failsafe");
    QUADHAND_RETURN_IF_ERROR(p.CheckKeys({"action", "delay", "land_speed", "land_height"}));
    std::string action = c->failsafe.action == FailsafeConfig::Action::kLand ? "land" : "hold";
    QUADHAND_RETURN_IF_ERROR(p.Get("action", &action));
    if (action != "hold" && action != "land") return p.Invalid("action", "must be hold or land, not '" + action + "'");
    c->failsafe.action = action == "land" ? FailsafeConfig::Action::kLand : FailsafeConfig::Action::kHold;
    QUADHAND_RETURN_IF_ERROR(p.Get("delay", &c->failsafe.delay));
    QUADHAND_RETURN_IF_ERROR(p.Get("land_speed", &c->failsafe.land_speed));
    QUADHAND_RETURN_IF_ERROR(p.Get("land_height", &c->failsafe.land_height));
  }
  return Status::Ok();
}

bool Fail(std::string* why, const std::string& message) {
  if (why) *why = message;
  return false;
}

}  // namespace

// Every number has a range (docs/sim.md): far outside any multirotor and
// servo, a value is a typo or a unit error, and the simulation would only
// diverge or, worse, fly something meaningless.
bool SimConfig::IsValid(std::string* why) const {
  if (!(step > 0.0 && step <= 0.002)) return Fail(why, "step must be in (0, 0.002] s (RK4 at >= 500 Hz)");
  auto in = [](double v, double low, double high) { return v >= low && v <= high; };
  auto all_in = [&](const Vec3& v, double low, double high) {
    return in(v.x(), low, high) && in(v.y(), low, high) && in(v.z(), low, high);
  };
  // RK4 on a first-order lag is unstable once the step exceeds about 2.8
  // time constants: a lag faster than half a step is refused (0: none).
  auto lag_ok = [&](double tc) { return tc == 0.0 || in(tc, step / 2.0, 10.0); };
  if (!in(gravity, 0.0, 100.0)) return Fail(why, "gravity must be in [0, 100] m/s^2");
  if (!all_in(linear_drag, 0.0, 1000.0)) return Fail(why, "linear_drag must be in [0, 1000] N/(m/s)");
  if (!(rotors.wheelbase > 0.0 && rotors.wheelbase <= 10.0)) return Fail(why, "rotors.wheelbase must be in (0, 10] m");
  if (!in(rotors.height, -1.0, 1.0)) return Fail(why, "rotors.height must be in [-1, 1] m");
  if (!(rotors.min_thrust >= 0.0 && rotors.max_thrust > rotors.min_thrust && rotors.max_thrust <= 10000.0)) {
    return Fail(why, "rotors: need 0 <= min_thrust < max_thrust <= 10000 N");
  }
  if (!lag_ok(rotors.time_constant)) {
    return Fail(why, "rotors.time_constant must be 0 or in [step / 2, 10] s");
  }
  if (!(rotors.torque_coefficient > 0.0 && rotors.torque_coefficient <= 1.0)) {
    return Fail(why, "rotors.torque_coefficient must be in (0, 1] m");
  }
  if (!in(servo.position_gain, 0.0, 10000.0)) return Fail(why, "servo.position_gain must be in [0, 10000] 1/s");
  if (!(servo.time_constant > 0.0 && lag_ok(servo.time_constant))) {
    return Fail(why, "servo.time_constant must be in [step / 2, 10] s");
  }
  for (double v : servo.max_rate) {
    if (!(v > 0.0 && v <= 1000.0)) return Fail(why, "servo.max_rate entries must be in (0, 1000] rad/s");
  }
  for (double v : servo.max_acceleration) {
    if (!(v > 0.0 && v <= 1e6)) return Fail(why, "servo.max_acceleration entries must be in (0, 1e6] rad/s^2");
  }
  // 100 kg is far beyond what an aerial manipulator carries: a larger value
  // is a typo or a unit error (grams), not a payload.
  if (!in(payload.mass, 0.0, 100.0)) return Fail(why, "payload.mass must be in [0, 100] kg");
  if (!all_in(payload.offset, -10.0, 10.0)) return Fail(why, "payload.offset entries must be in [-10, 10] m");
  const ControllerConfig& k = controller;
  if (!in(k.mass, 0.0, 1000.0) || !all_in(k.inertia, 0.0, 1000.0)) {
    return Fail(why, "controller mass and inertia must be in [0, 1000] (kg, kg m^2)");
  }
  for (const Vec3* gain : {&k.position_gain, &k.velocity_gain, &k.position_integral_gain, &k.attitude_gain,
                           &k.rate_gain, &k.attitude_integral_gain}) {
    if (!all_in(*gain, 0.0, 1e6)) return Fail(why, "controller gains must be in [0, 1e6]");
  }
  if (!in(k.position_integral_limit, 0.0, 1000.0) || !in(k.attitude_integral_limit, 0.0, 1000.0)) {
    return Fail(why, "controller integral limits must be in [0, 1000]");
  }
  if (!in(noise.position, 0.0, 1.0) || !in(noise.velocity, 0.0, 10.0) || !in(noise.attitude, 0.0, 1.0) ||
      !in(noise.body_rate, 0.0, 10.0)) {
    return Fail(why, "noise standard deviations must be in [0, 1] m, [0, 10] m/s, [0, 1] rad and [0, 10] rad/s");
  }
  if (!in(failsafe.delay, 0.0, 3600.0)) return Fail(why, "failsafe.delay must be in [0, 3600] s");
  if (!(failsafe.land_speed > 0.0 && failsafe.land_speed <= 5.0)) {
    return Fail(why, "failsafe.land_speed must be in (0, 5] m/s");
  }
  if (!in(failsafe.land_height, -1000.0, 1000.0)) return Fail(why, "failsafe.land_height must be in [-1000, 1000] m");
  // The joint count is the robot's: VehicleModel::Create checks the stalled
  // joint against it.
  {
    // Both sensors' options are checked: --sensor picks one of them.
    SensorConfig depth = sensor, lidar = sensor;
    depth.kind = SensorKind::kDepth;
    lidar.kind = SensorKind::kLidar;
    std::string sensor_why;
    if (!depth.IsValid(&sensor_why) || !lidar.IsValid(&sensor_why)) return Fail(why, "sensor." + sensor_why);
  }
  return faults.IsValid(1 << 20, why);
}

core::Result<SimConfig> ParseSimConfig(const std::string& yaml, const std::string& base_dir,
                                       const std::string& source) {
  SimConfig config;
  QUADHAND_RETURN_IF_ERROR(core::CheckYamlText(yaml, source));
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    return Status::InvalidArgument(source + ": malformed YAML: " + e.msg);
  }
  if (root.IsNull()) return Status::InvalidArgument(source + ": empty configuration");
  try {
    QUADHAND_RETURN_IF_ERROR(ParseInto(root, base_dir, source, &config));
  } catch (const YAML::Exception& e) {
    return Status::InvalidArgument(source + ": " + e.msg);
  }
  std::string why;
  if (!config.IsValid(&why)) return Status::InvalidArgument(source + ": " + why);
  return config;
}

core::Result<SimConfig> LoadSimConfig(const std::string& path) {
  auto text = core::ReadFileToString(path);
  if (!text.ok()) return text.status();
  return ParseSimConfig(*text, core::DirectoryOf(path), path);
}

}  // namespace quadhand::sim
