// MINCO: minimum-control piecewise polynomials (Wang et al., "Geometrically
// constrained trajectory optimization for multicopters", T-RO 2022).
//
// An order-s MINCO trajectory with N pieces and m columns (dimensions) is the
// unique minimiser of sum_i integral_0^{T_i} ||p^(s)(t)||^2 dt subject to a
// head state (value and derivatives 1..s-1 at t = 0), a tail state, and N-1
// intermediate waypoints. Each piece i is a polynomial of degree 2s-1 in its
// local time t in [0, T_i]:  p_i(t) = sum_k c_{i,k} t^k.  The solution is
// C^{2s-2} at the waypoints. Its coefficients solve a 2sN x 2sN banded linear
// system M(T) c = b(q, head, tail), factorised in O(N). Accuracy depends on the
// ratios of adjacent durations, not on their scale: for s = 4, ratios up to
// ~100 keep constraints to ~1e-8 relative; ratios of 1e4 lose most digits.
//
// Gradients: for any cost K(c, T) whose partial gradients dK/dc (2sN x m) and
// dK/dT (N) are known, PropagateGradient() returns the total gradients with
// respect to the waypoints, the durations (including dc/dT) and, optionally,
// the head and tail states, using one transposed banded solve (adjoint method).
//
// Several Minco objects (e.g. position with s = 4, m = 3 and yaw + joints with
// s = 2, m = 4) may share one duration vector: their duration gradients add.
//
// Units are whatever the caller uses (metres/radians and seconds in QuadHand).
// Not thread-safe for concurrent mutation; const methods may run concurrently.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "quadhand/core/status.h"
#include "quadhand/traj/banded_system.h"

namespace quadhand::traj {

class Minco {
 public:
  static constexpr int kMinOrder = 1;
  static constexpr int kMaxOrder = 4;

  Minco() = default;

  // Sets the order s (kMinOrder..kMaxOrder), the number of columns m >= 1 and
  // the number of pieces N >= 1, and allocates every buffer. Calling it again
  // with the same sizes does nothing (allocates nothing, keeps the head and
  // tail); otherwise head and tail are reset to zero and valid() is false.
  core::Status Reset(int order, int dims, int num_pieces);

  // Head and tail states: s x m each, row k is the k-th derivative
  // (row 0 = value). Non-finite entries are rejected.
  core::Status SetBoundary(const Eigen::Ref<const Eigen::MatrixXd>& head,
                           const Eigen::Ref<const Eigen::MatrixXd>& tail);

  // Computes the coefficients for waypoints (m x (N-1), column i is the
  // junction between pieces i and i+1; may have zero columns when N = 1) and
  // durations (N, each finite and > 0). Allocation-free. Fails with
  // kInvalidArgument on bad sizes or values and kInternal if the
  // factorisation breaks down (durations spanning an extreme range); on
  // failure the previous trajectory is no longer valid (valid() is false).
  core::Status Generate(const Eigen::Ref<const Eigen::MatrixXd>& waypoints,
                        const Eigen::Ref<const Eigen::VectorXd>& durations);

  // The pieces of `first` followed by the pieces of `second` from piece
  // `second_from` on: one piecewise polynomial (head of `first`, tail of
  // `second`) that is no longer the minimiser of any waypoints - it is as
  // smooth at the seam as the caller made the two agree there. Evaluation,
  // LocatePiece and Energy work on it; Generate() replaces it by a MINCO
  // again, and PropagateGradient() needs a Generate() first. InvalidArgument
  // when the orders or columns differ, a part is not valid, or second_from is
  // not a piece of `second`.
  static core::Result<Minco> Joined(const Minco& first, const Minco& second, int second_from);
  // The first `pieces` pieces of `whole` (1 .. its count): its head, and
  // as tail the state where they end. Like Joined's, no longer a MINCO.
  static core::Result<Minco> Prefix(const Minco& whole, int pieces);

  int order() const { return s_; }
  int dims() const { return m_; }
  int num_pieces() const { return n_; }
  // Coefficients per piece, 2s (degree 2s-1 polynomial).
  int coeffs_per_piece() const { return 2 * s_; }
  // Whether the last Generate() succeeded (coefficients are usable).
  bool valid() const { return valid_; }

  const Eigen::MatrixXd& head() const { return head_; }
  const Eigen::MatrixXd& tail() const { return tail_; }
  const Eigen::VectorXd& durations() const { return durations_; }
  double total_duration() const { return durations_.sum(); }

  // 2sN x m; row 2s*i + k holds the coefficient of t^k of piece i.
  const Eigen::MatrixXd& coefficients() const { return coeffs_; }

  // The `deriv`-th derivative (0 .. 2s-1; higher orders are zero) of piece
  // `piece` in [0, N) at local time t (seconds from the piece start; values
  // outside [0, T_i] extrapolate the polynomial). `out` must have m entries.
  // Preconditions (here and in the Add* methods) are checked by assertions only.
  void Evaluate(int piece, double t, int deriv, Eigen::Ref<Eigen::VectorXd> out) const;
  Eigen::VectorXd Evaluate(int piece, double t, int deriv) const;  // allocating convenience

  // Maps a global time (seconds from the start) to a piece and local time;
  // times outside [0, total] are clamped into the first/last piece.
  void LocatePiece(double global_t, int* piece, double* local_t) const;

  // Energy J = sum_i integral_0^{T_i} ||p_i^(s)(t)||^2 dt.
  double Energy() const;

  // Adds dJ/dc (2sN x m) and the partial dJ/dT (N, c held fixed) of the
  // energy to the given arrays. Allocation-free.
  void AddEnergyGradient(Eigen::Ref<Eigen::MatrixXd> grad_coeffs,
                         Eigen::Ref<Eigen::VectorXd> grad_durations) const;

  // Adds the partial gradients of a cost term that depends on the `deriv`-th
  // derivative evaluated at local time t of piece `piece`, given
  // grad_value = dK/d(p^(deriv)) (m entries). dt_dT is dt/dT_piece: use
  // t / T_piece when samples sit at a fixed fraction of the piece, 0 when t
  // does not move with the duration. Allocation-free.
  void AddSampleGradient(int piece, double t, int deriv,
                         const Eigen::Ref<const Eigen::VectorXd>& grad_value, double dt_dT,
                         Eigen::Ref<Eigen::MatrixXd> grad_coeffs,
                         Eigen::Ref<Eigen::VectorXd> grad_durations) const;

  // Adjoint step. Given grad_coeffs = dK/dc (2sN x m) and partial_grad_durations
  // = dK/dT with c held fixed (N), writes the total gradients of K with respect
  // to the waypoints (m x (N-1)) and durations (N). grad_head / grad_tail
  // (s x m) are optional (may be null). Outputs are resized; when they already
  // have the right size nothing is allocated. Needs a valid trajectory.
  core::Status PropagateGradient(const Eigen::Ref<const Eigen::MatrixXd>& grad_coeffs,
                                 const Eigen::Ref<const Eigen::VectorXd>& partial_grad_durations,
                                 Eigen::MatrixXd* grad_waypoints,
                                 Eigen::VectorXd* grad_durations,
                                 Eigen::MatrixXd* grad_head = nullptr,
                                 Eigen::MatrixXd* grad_tail = nullptr);

 private:
  // Row of the linear system holding the waypoint constraint of junction i.
  int WaypointRow(int junction) const { return 2 * s_ * junction + 2 * s_ - 1; }
  void BuildSystem();

  int s_ = 0;
  int m_ = 0;
  int n_ = 0;
  bool valid_ = false;
  Eigen::MatrixXd head_;
  Eigen::MatrixXd tail_;
  Eigen::VectorXd durations_;
  Eigen::MatrixXd coeffs_;
  Eigen::MatrixXd adjoint_;  // workspace for PropagateGradient
  BandedSystem system_;
  // Falling factorials k!/(k-d)! for k, d in [0, 2s); row-major [d][k].
  std::vector<double> fall_;
};

}  // namespace quadhand::traj
