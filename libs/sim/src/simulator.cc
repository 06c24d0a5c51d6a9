#include "quadhand/sim/simulator.h"
#include "quadhand/traj/flatness.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace quadhand::sim {

VecX NominalJoints(const VehicleModel& model) {
  const std::vector<double>& given = model.config().controller.nominal_joints;
  if (!given.empty()) return Eigen::Map<const VecX>(given.data(), static_cast<Eigen::Index>(given.size()));
  VecX q = VecX::Zero(model.num_actuated());
  for (int k = 0; k < q.size(); ++k) {
    const double lo = model.joint_lower()[k], hi = model.joint_upper()[k];
    if (std::isfinite(lo) && std::isfinite(hi)) q[k] = 0.5 * (lo + hi);
  }
  return q;
}

namespace {

double ControllerMass(const VehicleModel& model) {
  const double m = model.config().controller.mass;
  return m > 0.0 ? m : model.TotalMass();
}

Mat3 ControllerInertia(const VehicleModel& model) {
  const Vec3& J = model.config().controller.inertia;
  if ((J.array() > 0.0).all()) return J.asDiagonal();
  return model.MassPropertiesAt(NominalJoints(model)).inertia;
}

void PutNumber(std::string* out, double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), ",%.10g", v);
  *out += buffer;
}

}  // namespace

Simulator::Simulator(VehicleModel model, uint64_t seed)
    : model_(std::move(model)),
      controller_(model_.config().controller, ControllerMass(model_), ControllerInertia(model_), model_.gravity()),
      rng_(seed),
      fault_rng_(seed ^ 0x9e3779b97f4a7c15ULL),
      gusts_(model_.config().faults.wind),
      declared_payload_(model_.payload_mass()) {
  const int n = model_.num_actuated();
  state_ = VehicleState::AtRest(model_, Vec3::Zero(), VecX::Zero(n));
  input_.thrust_command = state_.thrusts;
  input_.joint_setpoints = VecX::Zero(n);
  input_.joint_rate_setpoints = VecX::Zero(n);
}

core::Status Simulator::SetPayload(double mass, const Vec3& offset) {
  PayloadConfig payload = model_.config().payload;
  const double real_mass = mass * model_.config().faults.payload_mass_factor;
  payload.attached = real_mass > 0.0;
  payload.mass = real_mass > 0.0 ? real_mass : payload.mass;
  payload.offset = offset;
  auto model = model_.WithPayload(payload);
  if (!model.ok()) return model.status();
  // The controller learns the change of mass (the load's mass is known, as a
  // hover-thrust estimate would find it); the shift of the centre of mass is
  // left to its integrators and to PCGC, which balances the arm, not the load.
  controller_.set_mass(std::max(1e-3, controller_.mass() - declared_payload_ + mass));
  declared_payload_ = mass;
  model_ = std::move(*model);
  // Resolved once here, not at every step.
  known_load_link_ = mass > 0.0 ? model_.robot().LinkIndex(model_.config().payload.link) : -1;
  return core::Status::Ok();
}

void Simulator::Reset(const VehicleState& state, double time) {
  state_ = state;
  time_ = time;
  stalled_ = false;
  controller_.Reset();
  input_.thrust_command = state.thrusts;
  input_.joint_setpoints = state.joints;
  input_.joint_rate_setpoints = state.joint_rates;
  output_ = ControllerOutput{};
}

Vec3 Simulator::EstimatedPosition() const {
  return state_.position + model_.config().faults.estimate.PositionErrorAt(time_);
}

VehicleState Simulator::Estimate() const {
  VehicleState estimate = state_;
  estimate.position = EstimatedPosition();
  estimate.velocity += model_.config().faults.estimate.drift;
  return estimate;
}

Measurement Simulator::Measure() {
  Measurement m{EstimatedPosition(), state_.velocity + model_.config().faults.estimate.drift, state_.attitude,
                state_.body_rate};
  const NoiseConfig& noise = model_.config().noise;
  if (!noise.enabled) return m;
  std::normal_distribution<double> normal(0.0, 1.0);
  auto gaussian = [&](double sigma) -> Vec3 {
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = sigma * normal(rng_);
    return v;
  };
  m.position += gaussian(noise.position);
  m.velocity += gaussian(noise.velocity);
  m.attitude = (m.attitude * Quat(ExpSO3(gaussian(noise.attitude)))).normalized();
  m.body_rate += gaussian(noise.body_rate);
  return m;
}

void Simulator::Step(const Setpoint& setpoint, double h) {
  const double full = model_.config().step;
  if (!(h > 0.0) || h > full) h = full;
  const Measurement measured = Measure();
  output_ = controller_.Update(measured, setpoint, h);
  if (known_load_link_ >= 0) {
    // The load the gripper holds is known (its mass from the task, where it
    // hangs from the grab): its weight's moment about the base, at the
    // measured attitude and the joints' encoders, is fed forward, as the
    // arm's own weight is balanced by PCGC. A configured payload is not.
    const Vec3 load_in_base =
        model_.LinkPosesInBase(state_.joints)[known_load_link_] * model_.config().payload.offset;
    const Vec3 weight_in_base =
        measured.attitude.toRotationMatrix().transpose() * Vec3(0.0, 0.0, -model_.payload_mass() * model_.gravity());
    output_.torque -= load_in_base.cross(weight_in_base);
  }
  const RotorConfig& rotors = model_.config().rotors;
  input_.thrust_command =
      MixRotors(model_.allocation(), output_.thrust, output_.torque, rotors.min_thrust, rotors.max_thrust);
  input_.joint_setpoints = setpoint.joints;
  input_.joint_rate_setpoints = setpoint.joint_rates;
  if (stalled_) {
    // A jammed joint is rigid: its motor's torque meets the jam's inside the
    // arm, and the base feels the arm as one body. Commanded to stay, the
    // servo model accelerates nothing, so no reaction reaches the base (a
    // servo still driving it would push the base with the reaction of an
    // acceleration the joint never makes).
    input_.joint_setpoints[model_.config().faults.servo.stall_joint] = stalled_position_;
    input_.joint_rate_setpoints[model_.config().faults.servo.stall_joint] = 0.0;
  }
  const WindFault& wind = model_.config().faults.wind;
  if (wind.active()) {
    const double airspeed = (wind.steady + gusts_.current() - state_.velocity).norm();
    input_.wind = wind.steady + gusts_.Step(h, airspeed, &fault_rng_);
  }
  state_ = Rk4Step(model_, state_, input_, h);
  time_ += h;
  const ServoFault& servo = model_.config().faults.servo;
  if (servo.stall_joint >= 0 && time_ >= servo.stall_time) {
    // A stalled servo holds where it stopped, whatever it is commanded.
    if (!stalled_) stalled_position_ = state_.joints[servo.stall_joint];
    stalled_ = true;
    state_.joints[servo.stall_joint] = stalled_position_;
    state_.joint_rates[servo.stall_joint] = 0.0;
  }
}

DynamicsInfo Simulator::CurrentDynamics() const {
  DynamicsInfo info;
  StateDerivative(model_, PackState(state_), input_, &info);
  return info;
}

TrackingErrorStats ComputeErrorStats(const std::vector<FlownSample>& samples) {
  TrackingErrorStats s;
  if (samples.empty()) return s;
  std::vector<double> e;
  e.reserve(samples.size());
  double sum = 0.0, sum_sq = 0.0;
  for (const FlownSample& f : samples) {
    const double v = f.position_error.norm();
    e.push_back(v);
    sum += v;
    sum_sq += v * v;
  }
  std::sort(e.begin(), e.end());
  const double n = static_cast<double>(e.size());
  auto quantile = [&](double p) {  // linear interpolation between order statistics
    const double x = p * (n - 1.0);
    const size_t i = static_cast<size_t>(std::floor(x));
    const size_t j = std::min(i + 1, e.size() - 1);
    return e[i] + (x - i) * (e[j] - e[i]);
  };
  s.mean = sum / n;
  s.rms = std::sqrt(sum_sq / n);
  s.median = quantile(0.5);
  s.p95 = quantile(0.95);
  s.max = e.back();
  return s;
}

FlownSample RecordFlown(const Simulator& simulator, const Vec3& planned_position, double planned_yaw) {
  const VehicleState& s = simulator.state();
  const DynamicsInfo info = simulator.CurrentDynamics();
  FlownSample f;
  f.flown.t = simulator.time();
  f.flown.position = s.position;
  f.flown.velocity = s.velocity;
  f.flown.acceleration = info.acceleration;
  f.flown.attitude = s.attitude;
  f.flown.yaw = traj::HopfYawOf(s.attitude);
  f.flown.yaw_rate = traj::HopfYawRateOf(s.attitude, s.body_rate);
  f.flown.joints = s.joints;
  f.flown.joint_rates = s.joint_rates;
  f.position_error = s.position - planned_position;
  f.yaw_error = std::remainder(f.flown.yaw - planned_yaw, 2.0 * M_PI);
  f.center_of_mass = simulator.model().MassPropertiesAt(s.joints).com;
  f.arm_wrench = info.arm_wrench;
  f.thrust = s.thrusts.sum();
  return f;
}

core::Result<TrackResult> TrackPlan(Simulator* sim, const Plan& plan, const TrackOptions& options) {
  const VehicleModel& model = sim->model();
  if (plan.joint_names != model.robot().ActuatedJointNames()) {
    return core::Status::InvalidArgument("the plan's joints do not match the robot's actuated joints");
  }
  if (plan.rows.size() < 2) return core::Status::InvalidArgument("a plan needs at least 2 rows");
  if (!(options.settle >= 0.0 && options.settle <= kMaxSimulatedSeconds)) {
    return core::Status::InvalidArgument("settle time must be in [0, " + std::to_string(int(kMaxSimulatedSeconds)) +
                                         "] s");
  }
  // A plan of a few rows can still span years: the time simulated is bounded.
  const double span = plan.rows.back().t - plan.rows.front().t;
  if (!(span <= kMaxSimulatedSeconds)) {
    return core::Status::InvalidArgument("the plan spans " + std::to_string(span) + " s; at most " +
                                         std::to_string(int(kMaxSimulatedSeconds)) + " s are simulated");
  }

  const PlanRow& first = plan.rows.front();
  VehicleState initial = VehicleState::AtRest(model, first.position, first.joints);
  initial.velocity = first.velocity;
  initial.attitude = first.attitude;
  initial.joint_rates = first.joint_rates;
  const double t0 = first.t;
  TrackResult result;

  sim->Reset(initial, t0 - options.settle);
  if (options.settle > 0.0) {
    Setpoint hold = SamplePlan(plan, t0);
    hold.velocity.setZero();
    hold.acceleration.setZero();
    hold.jerk.setZero();
    hold.yaw_rate = 0.0;
    hold.joint_rates.setZero();
    while (sim->time() < t0 - 1e-12) sim->Step(hold, std::min(sim->step(), t0 - sim->time()));
  }

  result.samples.reserve(plan.rows.size());
  for (const PlanRow& row : plan.rows) {
    while (sim->time() < row.t - 1e-9) {
      sim->Step(SamplePlan(plan, sim->time()), std::min(sim->step(), row.t - sim->time()));
    }
    const VehicleState& s = sim->state();
    if (!PackState(s).allFinite()) {
      return core::Status::Infeasible("the simulation diverged before t = " + std::to_string(row.t) + " s");
    }
    FlownSample f = RecordFlown(*sim, row.position, row.yaw);
    f.flown.t = row.t;
    result.samples.push_back(std::move(f));
  }
  result.error = ComputeErrorStats(result.samples);
  result.simulated_s = options.settle + (plan.end_time() - t0);
  return result;
}

std::string FlownCsv(const std::vector<FlownSample>& samples, const std::vector<std::string>& joint_names) {
  // A mission's record says when the gripper closed (its rows' gripper).
  const bool gripper = !samples.empty() && samples.front().flown.gripper >= 0;
  std::string out = PlanCsvHeader(joint_names, gripper) +
                    ",err_x,err_y,err_z,err_pos,err_yaw,cog_x,cog_y,cog_z,arm_fx,arm_fy,arm_fz,arm_tx,arm_ty,arm_tz,"
                    "thrust\n";
  for (const FlownSample& f : samples) {
    out += PlanCsvRow(f.flown);
    for (int i = 0; i < 3; ++i) PutNumber(&out, f.position_error[i]);
    PutNumber(&out, f.position_error.norm());
    PutNumber(&out, f.yaw_error);
    for (int i = 0; i < 3; ++i) PutNumber(&out, f.center_of_mass[i]);
    for (int i = 0; i < 3; ++i) PutNumber(&out, f.arm_wrench.force[i]);
    for (int i = 0; i < 3; ++i) PutNumber(&out, f.arm_wrench.torque[i]);
    PutNumber(&out, f.thrust);
    out += '\n';
  }
  return out;
}

}  // namespace quadhand::sim
