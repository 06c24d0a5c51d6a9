#include "quadhand/planner/whole_body_problem.h"

#include <atomic>
#include <cmath>

#include "quadhand/core/worker_pool.h"
#include "quadhand/planner/cost_term.h"
#include "quadhand/planner/moving_scene.h"
#include "quadhand/robot/kinematics.h"
#include "quadhand/traj/time_map.h"

namespace quadhand::planner {
namespace {

constexpr int kPositionOrder = 4;  // s = 4: minimum snap, C^6 position
constexpr int kAuxOrder = 2;       // s = 2: minimum acceleration for yaw and joints

// A whole state as the MINCO boundaries: position and its first three
// derivatives; yaw and joints, then their rates (empty joint rates: zero).
MatX PositionBoundary(const BoundaryState& s) {
  MatX m(kPositionOrder, 3);
  m << s.position.transpose(), s.velocity.transpose(), s.acceleration.transpose(), s.jerk.transpose();
  return m;
}
MatX AuxBoundary(const BoundaryState& s) {
  const int n = static_cast<int>(s.joints.size());
  MatX m = MatX::Zero(kAuxOrder, 1 + n);
  m(0, 0) = s.yaw;
  m(1, 0) = s.yaw_rate;
  m.block(0, 1, 1, n) = s.joints.transpose();
  if (s.joint_rates.size() == n) m.block(1, 1, 1, n) = s.joint_rates.transpose();
  return m;
}

bool NonNegativeFinite(double v) { return std::isfinite(v) && v >= 0.0; }
bool PositiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

// d(world rotation vector)/d(quaternion) for a unit quaternion q: a tangent
// perturbation dq rotates R(q) by dphi = 2 vec(dq * conj(q)).
Eigen::Matrix<double, 3, 4> RotationVectorPerQuaternion(const Eigen::Vector4d& q) {
  const Quat conjugate(q[0], -q[1], -q[2], -q[3]);
  Eigen::Matrix<double, 3, 4> M;
  for (int k = 0; k < 4; ++k) {
    const Quat unit(k == 0 ? 1.0 : 0.0, k == 1 ? 1.0 : 0.0, k == 2 ? 1.0 : 0.0, k == 3 ? 1.0 : 0.0);
    M.col(k) = 2.0 * (unit * conjugate).vec();
  }
  return M;
}

}  // namespace

bool WholeBodyCostOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (samples_per_piece < 1 || samples_per_piece > 1000) return fail("samples_per_piece must be in [1, 1000]");
  if (threads < 0 || threads > 256) return fail("threads must be in [0, 256] (0: all cores)");
  if (insertion_samples < 0 || insertion_samples > 1000) return fail("insertion_samples must be in [0, 1000]");
  for (double w : {time_weight, energy_weight_position, energy_weight_aux, weight_collision, weight_insertion,
                   weight_velocity, weight_acceleration, weight_yaw_rate, weight_joint_rate, weight_body_rate,
                   weight_joint_limits, weight_self_collision, insertion_position_weight, insertion_rotation_weight,
                   insertion_position_tolerance, insertion_rotation_tolerance}) {
    if (!NonNegativeFinite(w)) return fail("weights and tolerances must be finite and non-negative");
  }
  if (!PositiveFinite(collision_threshold)) return fail("collision_threshold must be positive");
  if (!NonNegativeFinite(self_collision_threshold)) return fail("self_collision_threshold must be >= 0");
  if (!std::isfinite(insertion_collision_threshold)) return fail("insertion_collision_threshold must be finite");
  if (!(limit_fraction > 0.0 && limit_fraction <= 1.0)) return fail("limit_fraction must be in (0, 1]");
  if (!NonNegativeFinite(joint_limit_margin)) return fail("joint_limit_margin must be >= 0");
  for (double mu : {collision_mu, self_collision_mu, feasibility_mu, joint_limit_mu, insertion_mu}) {
    if (!PositiveFinite(mu)) return fail("smoothing parameters (mu) must be positive");
  }
  return true;
}

// ---------------------------------------------------------------- trajectory

WholeBodyTrajectory::WholeBodyTrajectory(traj::Minco position, traj::Minco aux, traj::FlatnessOptions flatness)
    : position_(std::move(position)), aux_(std::move(aux)), flatness_(flatness) {}

WholeBodySample WholeBodyTrajectory::Sample(double t) const {
  WholeBodySample s;
  s.t = std::clamp(t, 0.0, duration());
  int piece = 0;
  double local = 0;
  position_.LocatePiece(s.t, &piece, &local);
  s.position = position_.Evaluate(piece, local, 0);
  s.velocity = position_.Evaluate(piece, local, 1);
  s.acceleration = position_.Evaluate(piece, local, 2);
  s.jerk = position_.Evaluate(piece, local, 3);
  const VecX aux = aux_.Evaluate(piece, local, 0);
  const VecX aux_rate = aux_.Evaluate(piece, local, 1);
  s.yaw = aux[0];
  s.yaw_rate = aux_rate[0];
  s.joints = aux.tail(aux.size() - 1);
  s.joint_rates = aux_rate.tail(aux_rate.size() - 1);
  const traj::FlatState flat = traj::FlatForward(s.velocity, s.acceleration, s.jerk, s.yaw, s.yaw_rate, flatness_);
  s.attitude = flat.attitude();
  s.thrust = flat.thrust;
  s.body_rate = flat.body_rate;
  return s;
}

// ------------------------------------------------------------------- problem

// What one worker needs to evaluate samples.
struct SampleScratch {
  robot::KinematicsState kinematics;
  VecX aux_value, aux_rate;
  VecX joints;  // the joint part of aux_value (ComputeKinematics takes a VecX: no temporary per sample)
  SampleGradient gradient;  // what the terms leave at one sample
};

struct WholeBodyProblem::Workspace {
  traj::Minco position, aux;
  VecX taus, durations;
  MatX position_waypoints, aux_waypoints;
  // Partial gradients w.r.t. coefficients and durations (c fixed), per curve.
  MatX grad_position_coeffs, grad_aux_coeffs;
  VecX grad_durations_position, grad_durations_aux;
  // Total gradients after the adjoint step.
  MatX total_position_waypoints, total_aux_waypoints;
  VecX total_durations_position, total_durations_aux, grad_taus;
  // The samples are evaluated piece by piece: each piece writes only its own
  // rows of the partial gradients and its own sums below, which are added
  // in piece order, so the result is the same for any number of workers.
  std::vector<SampleScratch> scratch;  // one per worker
  VecX piece_totals;                   // per piece: its samples' share of the objective
  // A moving goal: each piece's start time; per piece, the gradient w.r.t.
  // the time of its samples (every earlier duration moves them); the
  // tail's derivative w.r.t. the total duration, per curve; and the
  // adjoint's gradient w.r.t. the tail.
  VecX piece_start, piece_time_gradient;
  MatX tail_position_rate, tail_aux_rate, grad_tail_position, grad_tail_aux;
  MatX piece_term_values;              // terms x pieces (CostBreakdown)
  std::vector<double> term_values;     // each term's value (CostBreakdown)
  std::unique_ptr<core::WorkerPool> pool;
  std::atomic<int> next_piece{0};
};

WholeBodyProblem::WholeBodyProblem(const robot::RobotModel& robot, const env::CollisionModel& collision)
    : robot_(robot), collision_(collision), work_(std::make_unique<Workspace>()) {}

WholeBodyProblem::~WholeBodyProblem() = default;

core::Result<std::unique_ptr<WholeBodyProblem>> WholeBodyProblem::Create(
    const robot::RobotModel& robot, const env::CollisionModel& collision, const BoundaryState& start,
    const BoundaryState& goal, const Limits& limits, const InsertionGoal& insertion,
    const WholeBodyCostOptions& options, int num_pieces, const env::SelfCollisionModel* self_collision) {
  const int n = robot.num_actuated();
  if (num_pieces < 1) return core::Status::InvalidArgument("the trajectory needs at least one piece");
  for (const BoundaryState* state : {&start, &goal}) {
    if (state->joints.size() != n) {
      return core::Status::InvalidArgument("boundary state has " + std::to_string(state->joints.size()) +
                                           " joint values, the robot has " + std::to_string(n));
    }
    if (state->joint_rates.size() != 0 && state->joint_rates.size() != n) {
      return core::Status::InvalidArgument("boundary joint rates have the wrong size");
    }
  }
  if (limits.joint_rate_max.size() != n || limits.joint_lower.size() != n || limits.joint_upper.size() != n) {
    return core::Status::InvalidArgument("joint limits must have one entry per actuated joint");
  }
  if (insertion.enabled) {
    if (insertion.tool_link < 0 || insertion.tool_link >= robot.num_links()) {
      return core::Status::InvalidArgument("insertion needs a valid tool link");
    }
    if (!(insertion.direction.norm() > 0.0) || !PositiveFinite(insertion.length)) {
      return core::Status::InvalidArgument("insertion needs a non-zero direction and a positive length");
    }
  }
  std::unique_ptr<WholeBodyProblem> problem(new WholeBodyProblem(robot, collision));
  problem->self_collision_ = self_collision;
  problem->start_ = start;
  problem->goal_ = goal;
  for (BoundaryState* state : {&problem->start_, &problem->goal_}) {
    if (state->joint_rates.size() == 0) state->joint_rates = VecX::Zero(n);
  }
  problem->limits_ = limits;
  problem->insertion_ = insertion;
  problem->insertion_.direction.normalize();
  problem->num_pieces_ = num_pieces;
  problem->num_joints_ = n;
  QUADHAND_RETURN_IF_ERROR(problem->SetOptions(options));

  Workspace& w = *problem->work_;
  QUADHAND_RETURN_IF_ERROR(w.position.Reset(kPositionOrder, 3, num_pieces));
  QUADHAND_RETURN_IF_ERROR(w.aux.Reset(kAuxOrder, 1 + n, num_pieces));
  QUADHAND_RETURN_IF_ERROR(
      w.position.SetBoundary(PositionBoundary(problem->start_), PositionBoundary(problem->goal_)));
  QUADHAND_RETURN_IF_ERROR(w.aux.SetBoundary(AuxBoundary(problem->start_), AuxBoundary(problem->goal_)));
  w.position_waypoints.resize(3, num_pieces - 1);
  w.aux_waypoints.resize(1 + n, num_pieces - 1);
  w.grad_position_coeffs.resize(2 * kPositionOrder * num_pieces, 3);
  w.grad_aux_coeffs.resize(2 * kAuxOrder * num_pieces, 1 + n);
  w.grad_durations_position.resize(num_pieces);
  w.grad_durations_aux.resize(num_pieces);
  w.pool = std::make_unique<core::WorkerPool>(core::WorkerCount(options.threads, num_pieces));
  w.scratch.resize(w.pool->size());
  for (SampleScratch& scratch : w.scratch) {
    scratch.aux_value.resize(1 + n);
    scratch.aux_rate.resize(1 + n);
    scratch.joints.resize(n);
    scratch.gradient.aux_value.resize(1 + n);
    scratch.gradient.aux_rate.resize(1 + n);
    scratch.gradient.point.SetZero(n);
    scratch.gradient.scratch.SetZero(n);
  }
  w.piece_totals.resize(num_pieces);
  w.piece_start.setZero(num_pieces);
  w.piece_time_gradient.setZero(num_pieces);
  return problem;
}

core::Status WholeBodyProblem::SetMovingScene(const MovingScene* moving) {
  if (moving != nullptr && !moving->moves()) moving = nullptr;
  moving_ = moving;
  Workspace& w = *work_;
  w.tail_position_rate.setZero(kPositionOrder, 3);
  w.tail_aux_rate.setZero(kAuxOrder, 1 + num_joints_);
  return SetOptions(options_);  // the terms see the moving scene
}

core::Status WholeBodyProblem::SetOptions(const WholeBodyCostOptions& options) {
  if (std::string why; !options.IsValid(&why)) return core::Status::InvalidArgument("cost options: " + why);
  options_ = options;
  terms_.clear();
  needs_kinematics_ = false;
  const CostTermInputs inputs{robot_, collision_, limits_, insertion_, options_, self_collision_, moving_};
  for (const CostTermDescriptor& term : CostTermDescriptors()) {
    terms_.push_back(term.make(inputs, options_.*(term.weight)));
    if (terms_.back() != nullptr) needs_kinematics_ = needs_kinematics_ || terms_.back()->NeedsKinematics();
  }
  work_->term_values.assign(terms_.size(), 0.0);
  work_->piece_term_values.setZero(static_cast<Eigen::Index>(terms_.size()), num_pieces_);
  return core::Status::Ok();
}

double CostBreakdown::Term(const std::string& name) const {
  for (const auto& [term, value] : terms) {
    if (term == name) return value;
  }
  return 0.0;
}

namespace {

// The ball map of a WaypointBall (whole_body_problem.h) and its inverse.
Vec3 BallPoint(const WaypointBall& ball, const Vec3& v) {
  return ball.center + ball.radius * 2.0 / (1.0 + v.squaredNorm()) * v;
}

Vec3 BallVariable(const WaypointBall& ball, const Vec3& q) {
  Vec3 d = (q - ball.center) / ball.radius;
  const double norm = d.norm();
  if (norm > 1.0) d /= norm;  // a guess outside the ball starts on its sphere
  return d / (1.0 + std::sqrt(std::max(0.0, 1.0 - d.squaredNorm())));
}

// dq/dv^T g (the Jacobian is symmetric).
Vec3 BallGradient(const WaypointBall& ball, const Vec3& v, const Vec3& g) {
  const double s = 1.0 + v.squaredNorm();
  return ball.radius * (2.0 / s * g - 4.0 / (s * s) * v * v.dot(g));
}

}  // namespace

core::Status WholeBodyProblem::SetWaypointBalls(std::vector<WaypointBall> balls) {
  std::vector<bool> used(std::max(0, num_pieces_ - 1), false);
  for (const WaypointBall& ball : balls) {
    if (ball.waypoint < 0 || ball.waypoint >= num_pieces_ - 1) {
      return core::Status::InvalidArgument("waypoint ball: no inner waypoint " + std::to_string(ball.waypoint));
    }
    if (used[ball.waypoint]) {
      return core::Status::InvalidArgument("waypoint ball: waypoint " + std::to_string(ball.waypoint) + " twice");
    }
    used[ball.waypoint] = true;
    if (!PositiveFinite(ball.radius) || !ball.center.allFinite()) {
      return core::Status::InvalidArgument("waypoint ball: the radius must be positive and the centre finite");
    }
  }
  balls_ = std::move(balls);
  return core::Status::Ok();
}

int WholeBodyProblem::num_variables() const { return num_pieces_ + (3 + 1 + num_joints_) * (num_pieces_ - 1); }

VecX WholeBodyProblem::Pack(const MatX& position_waypoints, const MatX& aux_waypoints, const VecX& durations) const {
  VecX x(num_variables());
  VecX taus;
  if (!traj::TausFromDurations(durations, &taus).ok()) taus = VecX::Zero(num_pieces_);
  const int m = num_pieces_ - 1;
  x.head(num_pieces_) = taus;
  x.segment(num_pieces_, 3 * m) = Eigen::Map<const VecX>(position_waypoints.data(), 3 * m);
  for (const WaypointBall& ball : balls_) {
    x.segment<3>(num_pieces_ + 3 * ball.waypoint) = BallVariable(ball, position_waypoints.col(ball.waypoint));
  }
  x.tail((1 + num_joints_) * m) = Eigen::Map<const VecX>(aux_waypoints.data(), (1 + num_joints_) * m);
  return x;
}

void WholeBodyProblem::Unpack(const VecX& x, MatX* position_waypoints, MatX* aux_waypoints, VecX* durations) const {
  const int m = num_pieces_ - 1;
  traj::DurationsFromTaus(x.head(num_pieces_), durations);
  *position_waypoints = Eigen::Map<const MatX>(x.data() + num_pieces_, 3, m);
  for (const WaypointBall& ball : balls_) {
    position_waypoints->col(ball.waypoint) = BallPoint(ball, x.segment<3>(num_pieces_ + 3 * ball.waypoint));
  }
  *aux_waypoints = Eigen::Map<const MatX>(x.data() + num_pieces_ + 3 * m, 1 + num_joints_, m);
}

bool WholeBodyProblem::Generate(const VecX& x) const {
  Workspace& w = *work_;
  if (!x.allFinite()) return false;
  Unpack(x, &w.position_waypoints, &w.aux_waypoints, &w.durations);
  w.taus = x.head(num_pieces_);
  if (!(w.durations.array() > 0.0).all()) return false;
  double start = 0.0;
  for (int i = 0; i < num_pieces_; ++i) {
    w.piece_start[i] = start;
    start += w.durations[i];
  }
  if (moving_ != nullptr && moving_->goal_moves) {
    // The tail follows the target to the trajectory's own end; its rate of
    // change with the total duration is its next derivative.
    const TargetMotion& motion = *moving_->motion;
    const double total = w.durations.sum();
    Vec3 d[5];
    motion.PointDerivatives(goal_.position, total, d);
    MatX position_tail(kPositionOrder, 3), aux_tail(kAuxOrder, 1 + num_joints_);
    for (int r = 0; r < kPositionOrder; ++r) {
      position_tail.row(r) = d[r].transpose();
      w.tail_position_rate.row(r) = d[r + 1].transpose();
    }
    aux_tail.setZero();
    aux_tail(0, 0) = goal_.yaw + motion.Yaw(total);
    aux_tail(1, 0) = motion.YawRate(total);
    aux_tail.block(0, 1, 1, num_joints_) = goal_.joints.transpose();
    w.tail_aux_rate.setZero();
    w.tail_aux_rate(0, 0) = motion.YawRate(total);
    if (!w.position.SetBoundary(w.position.head(), position_tail).ok() ||
        !w.aux.SetBoundary(w.aux.head(), aux_tail).ok()) {
      return false;
    }
  }
  return w.position.Generate(w.position_waypoints, w.durations).ok() &&
         w.aux.Generate(w.aux_waypoints, w.durations).ok();
}

void WholeBodyProblem::AccumulatePiece(int piece, bool with_gradient, SampleScratch* scratch) const {
  Workspace& w = *work_;
  const WholeBodyCostOptions& o = options_;
  const int n = num_joints_;
  SampleGradient& g = scratch->gradient;
  SampleState s;
  s.aux_value = &scratch->aux_value;
  s.aux_rate = &scratch->aux_rate;
  double& total = w.piece_totals[piece];
  total = 0.0;
  w.piece_time_gradient[piece] = 0.0;
  for (size_t i = 0; i < terms_.size(); ++i) w.piece_term_values(i, piece) = 0.0;
  {
    const double duration = w.durations[piece];
    s.piece = piece;
    // An approach that has begun is the whole trajectory.
    s.insertion_piece = insertion_.enabled && (piece == num_pieces_ - 1 || insertion_.begun);
    const int K = s.insertion_piece && o.insertion_samples > 0 ? o.insertion_samples : o.samples_per_piece;
    s.K = K;
    for (int k = 0; k <= K; ++k) {
      const double fraction = static_cast<double>(k) / K;
      const double t = fraction * duration;
      const double end_weight = (k == 0 || k == K) ? 0.5 : 1.0;
      const double weight = end_weight * duration / K;  // trapezoidal quadrature
      s.k = k;
      s.t = t;
      s.time = w.piece_start[piece] + t;
      s.weight = weight;
      w.position.Evaluate(piece, t, 0, s.position);
      w.position.Evaluate(piece, t, 1, s.velocity);
      w.position.Evaluate(piece, t, 2, s.acceleration);
      w.position.Evaluate(piece, t, 3, s.jerk);
      w.aux.Evaluate(piece, t, 0, scratch->aux_value);
      w.aux.Evaluate(piece, t, 1, scratch->aux_rate);
      s.yaw = scratch->aux_value[0];
      s.yaw_rate = scratch->aux_rate[0];
      const traj::FlatState flat =
          traj::FlatForward(s.velocity, s.acceleration, s.jerk, s.yaw, s.yaw_rate, o.flatness);
      s.flat = &flat;
      if (needs_kinematics_) {
        scratch->joints = scratch->aux_value.tail(n);
        robot::ComputeKinematics(robot_, MakePose(s.position, flat.rotation()), scratch->joints, &scratch->kinematics);
        s.kinematics = &scratch->kinematics;
      }

      // Every term adds its value and its gradient w.r.t. this sample's state.
      if (with_gradient) {
        g.position.setZero();
        g.velocity.setZero();
        g.acceleration.setZero();
        g.rotation.setZero();
        g.aux_value.setZero();
        g.aux_rate.setZero();
        g.flat = traj::FlatStateGrad{};
        g.point.SetZero(n);
        g.point_active = false;
        g.time = 0.0;
        g.point_time = 0.0;
      }
      double sample = 0.0;  // lambda-weighted integrand at this sample
      for (size_t i = 0; i < terms_.size(); ++i) {
        SampleSums sums{w.piece_term_values(i, piece), sample, total};
        if (terms_[i] != nullptr) terms_[i]->AddSample(s, &sums, with_gradient ? &g : nullptr);
      }
      total += weight * sample;
      if (!with_gradient) continue;
      // Every penalty here is zero with a zero slope below its threshold, so
      // a sample that costs nothing has no gradient either: most samples of
      // a feasible trajectory. Skipping them leaves the sums unchanged.
      if (sample == 0.0 && !g.point_active) continue;

      // Backward: the quadrature step moves with the duration...
      w.grad_durations_position[piece] += sample * end_weight / K;
      // ...a moving target's clock moves with every duration up to the
      // sample (all earlier pieces are added in Accumulate)...
      const double time_gradient = weight * g.time + g.point_time;
      w.grad_durations_position[piece] += fraction * time_gradient;
      w.piece_time_gradient[piece] += time_gradient;
      // ...and so does the sample time (dt/dT = fraction), through AddSampleGradient.
      traj::FlatStateGrad flat_grad = g.flat;
      flat_grad.quat = RotationVectorPerQuaternion(flat.quat).transpose() * (weight * g.rotation + g.point.rotation);
      flat_grad.body_rate_xy_sq *= weight;
      const traj::FlatInputGrad through_flatness =
          traj::FlatBackward(s.velocity, s.acceleration, s.jerk, s.yaw, s.yaw_rate, flat, flat_grad, o.flatness);
      w.position.AddSampleGradient(piece, t, 0, weight * g.position + g.point.position, fraction,
                                   w.grad_position_coeffs, w.grad_durations_position);
      w.position.AddSampleGradient(piece, t, 1, weight * g.velocity + through_flatness.vel, fraction,
                                   w.grad_position_coeffs, w.grad_durations_position);
      w.position.AddSampleGradient(piece, t, 2, weight * g.acceleration + through_flatness.acc, fraction,
                                   w.grad_position_coeffs, w.grad_durations_position);
      w.position.AddSampleGradient(piece, t, 3, through_flatness.jerk, fraction, w.grad_position_coeffs,
                                   w.grad_durations_position);
      g.aux_value *= weight;
      g.aux_value.tail(n) += g.point.joints;
      g.aux_value[0] += through_flatness.yaw;
      g.aux_rate *= weight;
      g.aux_rate[0] += through_flatness.yaw_rate;
      w.aux.AddSampleGradient(piece, t, 0, g.aux_value, fraction, w.grad_aux_coeffs, w.grad_durations_aux);
      w.aux.AddSampleGradient(piece, t, 1, g.aux_rate, fraction, w.grad_aux_coeffs, w.grad_durations_aux);
    }
  }
}

double WholeBodyProblem::Accumulate(CostBreakdown* breakdown, bool with_gradient) const {
  Workspace& w = *work_;
  const WholeBodyCostOptions& o = options_;
  if (with_gradient) {
    w.grad_position_coeffs.setZero();
    w.grad_aux_coeffs.setZero();
    w.grad_durations_position.setZero();
    w.grad_durations_aux.setZero();
    w.position.AddEnergyGradient(w.grad_position_coeffs, w.grad_durations_position);
    w.grad_position_coeffs *= o.energy_weight_position;
    w.grad_durations_position *= o.energy_weight_position;
    w.aux.AddEnergyGradient(w.grad_aux_coeffs, w.grad_durations_aux);
    w.grad_aux_coeffs *= o.energy_weight_aux;
    w.grad_durations_aux *= o.energy_weight_aux;
    w.grad_durations_position.array() += o.time_weight;
  }
  const double energy = o.energy_weight_position * w.position.Energy() + o.energy_weight_aux * w.aux.Energy();
  const double time = w.durations.sum();
  w.next_piece.store(0, std::memory_order_relaxed);
  w.pool->Run([&](int worker) {
    for (int piece = w.next_piece.fetch_add(1); piece < num_pieces_; piece = w.next_piece.fetch_add(1)) {
      AccumulatePiece(piece, with_gradient, &w.scratch[worker]);
    }
  });
  double total = energy + o.time_weight * time;
  for (int piece = 0; piece < num_pieces_; ++piece) total += w.piece_totals[piece];
  if (with_gradient && moving_ != nullptr) {
    double later = 0.0;  // the time gradients of the samples after each piece
    for (int piece = num_pieces_ - 1; piece >= 0; --piece) {
      w.grad_durations_position[piece] += later;
      later += w.piece_time_gradient[piece];
    }
  }
  for (size_t i = 0; i < terms_.size(); ++i) {
    w.term_values[i] = 0.0;
    for (int piece = 0; piece < num_pieces_; ++piece) w.term_values[i] += w.piece_term_values(i, piece);
  }
  if (breakdown != nullptr) {
    breakdown->energy = energy;
    breakdown->time = time;
    breakdown->total = total;
    breakdown->terms.clear();
    const std::vector<CostTermDescriptor>& descriptors = CostTermDescriptors();
    for (size_t i = 0; i < terms_.size(); ++i) breakdown->terms.emplace_back(descriptors[i].name, w.term_values[i]);
  }
  return total;
}

bool WholeBodyProblem::DoEvaluate(const VecX& x, double* cost, VecX* grad) const {
  if (!Generate(x)) return false;
  Workspace& w = *work_;
  *cost = Accumulate(nullptr, grad != nullptr);
  if (grad == nullptr) return std::isfinite(*cost);
  const bool moving = moving_ != nullptr && moving_->goal_moves;
  if (!w.position.PropagateGradient(w.grad_position_coeffs, w.grad_durations_position, &w.total_position_waypoints,
                                    &w.total_durations_position, nullptr,
                                    moving ? &w.grad_tail_position : nullptr).ok() ||
      !w.aux.PropagateGradient(w.grad_aux_coeffs, w.grad_durations_aux, &w.total_aux_waypoints,
                               &w.total_durations_aux, nullptr, moving ? &w.grad_tail_aux : nullptr).ok()) {
    return false;
  }
  if (moving) {
    // The tail moves with the total duration, so with every duration alike.
    const double through_tail = w.grad_tail_position.cwiseProduct(w.tail_position_rate).sum() +
                                w.grad_tail_aux.cwiseProduct(w.tail_aux_rate).sum();
    w.total_durations_position.array() += through_tail;
  }
  traj::DurationGradientToTau(w.taus, w.total_durations_position + w.total_durations_aux, &w.grad_taus);
  const int m = num_pieces_ - 1;
  grad->head(num_pieces_) = w.grad_taus;
  grad->segment(num_pieces_, 3 * m) = Eigen::Map<const VecX>(w.total_position_waypoints.data(), 3 * m);
  for (const WaypointBall& ball : balls_) {
    const int at = num_pieces_ + 3 * ball.waypoint;
    grad->segment<3>(at) = BallGradient(ball, x.segment<3>(at), w.total_position_waypoints.col(ball.waypoint));
  }
  grad->tail((1 + num_joints_) * m) = Eigen::Map<const VecX>(w.total_aux_waypoints.data(), (1 + num_joints_) * m);
  return grad->allFinite() && std::isfinite(*cost);
}

core::Result<CostBreakdown> WholeBodyProblem::Breakdown(const VecX& x) const {
  if (x.size() != num_variables() || !Generate(x)) return core::Status::InvalidArgument("cannot evaluate x");
  CostBreakdown breakdown;
  Accumulate(&breakdown, false);
  return breakdown;
}

core::Result<WholeBodyTrajectory> WholeBodyProblem::Trajectory(const VecX& x) const {
  if (x.size() != num_variables() || !Generate(x)) return core::Status::InvalidArgument("cannot evaluate x");
  return WholeBodyTrajectory(work_->position, work_->aux, options_.flatness);
}

core::Result<WholeBodyTrajectory> TrajectoryThrough(const BoundaryState& start, const BoundaryState& end,
                                                    const MatX& position_waypoints, const MatX& aux_waypoints,
                                                    const VecX& durations, const traj::FlatnessOptions& flatness) {
  const int pieces = static_cast<int>(durations.size());
  const int n = static_cast<int>(start.joints.size());
  if (pieces < 1 || end.joints.size() != n || position_waypoints.rows() != 3 ||
      position_waypoints.cols() != pieces - 1 || aux_waypoints.rows() != 1 + n || aux_waypoints.cols() != pieces - 1) {
    return core::Status::InvalidArgument("TrajectoryThrough: sizes do not match");
  }
  traj::Minco position, aux;
  QUADHAND_RETURN_IF_ERROR(position.Reset(kPositionOrder, 3, pieces));
  QUADHAND_RETURN_IF_ERROR(aux.Reset(kAuxOrder, 1 + n, pieces));
  QUADHAND_RETURN_IF_ERROR(position.SetBoundary(PositionBoundary(start), PositionBoundary(end)));
  QUADHAND_RETURN_IF_ERROR(aux.SetBoundary(AuxBoundary(start), AuxBoundary(end)));
  QUADHAND_RETURN_IF_ERROR(position.Generate(position_waypoints, durations));
  QUADHAND_RETURN_IF_ERROR(aux.Generate(aux_waypoints, durations));
  return WholeBodyTrajectory(std::move(position), std::move(aux), flatness);
}

core::Result<WholeBodyTrajectory> JoinedTrajectory(const WholeBodyTrajectory& first, const WholeBodyTrajectory& second) {
  auto position = traj::Minco::Joined(first.position(), second.position(), 0);
  if (!position.ok()) return position.status();
  auto aux = traj::Minco::Joined(first.aux(), second.aux(), 0);
  if (!aux.ok()) return aux.status();
  return WholeBodyTrajectory(std::move(*position), std::move(*aux), first.flatness());
}

core::Result<WholeBodyTrajectory> TrajectoryPrefix(const WholeBodyTrajectory& whole, int pieces) {
  auto position = traj::Minco::Prefix(whole.position(), pieces);
  if (!position.ok()) return position.status();
  auto aux = traj::Minco::Prefix(whole.aux(), pieces);
  if (!aux.ok()) return aux.status();
  return WholeBodyTrajectory(std::move(*position), std::move(*aux), whole.flatness());
}

}  // namespace quadhand::planner
