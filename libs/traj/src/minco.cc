#include "quadhand/traj/minco.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

namespace quadhand::traj {

namespace {

constexpr int kMaxCoeffs = 2 * Minco::kMaxOrder;

// Row layout of the system (one column of unknowns per coefficient, piece by piece):
//   rows 0 .. s-1                      head: p_0^(k)(0) = head_k                 (diagonal c_{0,k})
//   for each junction i (pieces i, i+1):
//     rows 2si + d, d = s .. 2s-2      p_i^(d)(T_i) - p_{i+1}^(d)(0) = 0         (diagonal c_{i,d})
//     row  2si + 2s - 1                p_i(T_i) = q_i                            (diagonal c_{i,2s-1})
//     rows 2s(i+1) + d, d = 0 .. s-1   p_i^(d)(T_i) - p_{i+1}^(d)(0) = 0         (diagonal c_{i+1,d})
//   rows 2s(N-1) + s + k, k = 0..s-1   tail: p_{N-1}^(k)(T) = tail_k             (diagonal c_{N-1,s+k})
// The diagonal entries are factorials or T^(2s-1), so LU runs without pivoting.
// (Unpivoted LU commutes with diagonal scaling, so rescaling the rows or columns
// to normalised time would not change its rounding.) Accuracy is limited by the
// ratios of adjacent durations, not their scale: see ManyPiecesStayAccurate.
int ContinuityRow(int s, int junction, int d) {
  return d < s ? 2 * s * (junction + 1) + d : 2 * s * junction + d;
}

bool AllFinite(const Eigen::Ref<const Eigen::MatrixXd>& x) { return x.allFinite(); }

}  // namespace

core::Status Minco::Reset(int order, int dims, int num_pieces) {
  if (order < kMinOrder || order > kMaxOrder) {
    return core::Status::InvalidArgument("MINCO order must be in [" + std::to_string(kMinOrder) +
                                         ", " + std::to_string(kMaxOrder) + "], got " +
                                         std::to_string(order));
  }
  if (dims < 1) return core::Status::InvalidArgument("MINCO needs at least one column");
  if (num_pieces < 1) return core::Status::InvalidArgument("MINCO needs at least one piece");
  if (order == s_ && dims == m_ && num_pieces == n_) return core::Status::Ok();

  s_ = order;
  m_ = dims;
  n_ = num_pieces;
  valid_ = false;
  const int rows = 2 * s_ * n_;
  head_.setZero(s_, m_);
  tail_.setZero(s_, m_);
  durations_.setOnes(n_);
  coeffs_.setZero(rows, m_);
  adjoint_.setZero(rows, m_);
  system_.Reset(rows, 2 * s_, 2 * s_);

  const int nc = 2 * s_;
  fall_.assign(static_cast<std::size_t>(nc * nc), 0.0);
  for (int d = 0; d < nc; ++d) {
    for (int k = d; k < nc; ++k) {
      double f = 1.0;
      for (int j = k - d + 1; j <= k; ++j) f *= j;
      fall_[static_cast<std::size_t>(d * nc + k)] = f;
    }
  }
  return core::Status::Ok();
}

core::Status Minco::SetBoundary(const Eigen::Ref<const Eigen::MatrixXd>& head,
                                const Eigen::Ref<const Eigen::MatrixXd>& tail) {
  if (s_ == 0) return core::Status::InvalidArgument("MINCO: call Reset() first");
  if (head.rows() != s_ || head.cols() != m_ || tail.rows() != s_ || tail.cols() != m_) {
    return core::Status::InvalidArgument("MINCO: head and tail must be " + std::to_string(s_) +
                                         " x " + std::to_string(m_));
  }
  if (!AllFinite(head) || !AllFinite(tail)) {
    return core::Status::InvalidArgument("MINCO: head or tail state is not finite");
  }
  head_ = head;
  tail_ = tail;
  valid_ = false;
  return core::Status::Ok();
}

void Minco::BuildSystem() {
  const int s = s_;
  const int nc = 2 * s;
  BandedSystem& a = system_;
  a.SetZero();
  double pw[kMaxCoeffs];

  for (int k = 0; k < s; ++k) a(k, k) = fall_[static_cast<std::size_t>(k * nc + k)];

  for (int i = 0; i < n_; ++i) {
    pw[0] = 1.0;
    for (int k = 1; k < nc; ++k) pw[k] = pw[k - 1] * durations_[i];
    const int col0 = nc * i;
    if (i + 1 < n_) {
      // Continuity of derivatives 0 .. 2s-2 with piece i+1.
      for (int d = 0; d <= nc - 2; ++d) {
        const int row = ContinuityRow(s, i, d);
        for (int k = d; k < nc; ++k) {
          a(row, col0 + k) = fall_[static_cast<std::size_t>(d * nc + k)] * pw[k - d];
        }
        a(row, col0 + nc + d) = -fall_[static_cast<std::size_t>(d * nc + d)];
      }
      const int row = WaypointRow(i);
      for (int k = 0; k < nc; ++k) a(row, col0 + k) = pw[k];
    } else {
      for (int d = 0; d < s; ++d) {
        const int row = col0 + s + d;
        for (int k = d; k < nc; ++k) {
          a(row, col0 + k) = fall_[static_cast<std::size_t>(d * nc + k)] * pw[k - d];
        }
      }
    }
  }
}

core::Status Minco::Generate(const Eigen::Ref<const Eigen::MatrixXd>& waypoints,
                             const Eigen::Ref<const Eigen::VectorXd>& durations) {
  valid_ = false;
  if (s_ == 0) return core::Status::InvalidArgument("MINCO: call Reset() first");
  if (waypoints.rows() != m_ || waypoints.cols() != n_ - 1) {
    return core::Status::InvalidArgument("MINCO: waypoints must be " + std::to_string(m_) + " x " +
                                         std::to_string(n_ - 1));
  }
  if (durations.size() != n_) {
    return core::Status::InvalidArgument("MINCO: expected " + std::to_string(n_) + " durations");
  }
  for (int i = 0; i < n_; ++i) {
    if (!(durations[i] > 0.0) || !std::isfinite(durations[i])) {
      return core::Status::InvalidArgument("MINCO: durations must be finite and positive");
    }
  }
  if (!AllFinite(waypoints)) return core::Status::InvalidArgument("MINCO: waypoints not finite");

  durations_ = durations;
  BuildSystem();
  if (!system_.Factorize()) {
    return core::Status::Internal("MINCO: banded factorisation broke down");
  }

  coeffs_.setZero();
  coeffs_.topRows(s_) = head_;
  for (int i = 0; i + 1 < n_; ++i) coeffs_.row(WaypointRow(i)) = waypoints.col(i).transpose();
  coeffs_.bottomRows(s_) = tail_;
  system_.Solve(coeffs_);
  if (!coeffs_.allFinite()) return core::Status::Internal("MINCO: solution is not finite");
  valid_ = true;
  return core::Status::Ok();
}

core::Result<Minco> Minco::Joined(const Minco& first, const Minco& second, int second_from) {
  if (!first.valid_ || !second.valid_) return core::Status::InvalidArgument("joining an invalid MINCO trajectory");
  if (first.s_ != second.s_ || first.m_ != second.m_) {
    return core::Status::InvalidArgument("joining MINCO trajectories of different orders or columns");
  }
  if (second_from < 0 || second_from >= second.n_) {
    return core::Status::InvalidArgument("joining from piece " + std::to_string(second_from) + " of " +
                                         std::to_string(second.n_));
  }
  const int kept = second.n_ - second_from;
  const int nc = 2 * first.s_;
  Minco joined;
  QUADHAND_RETURN_IF_ERROR(joined.Reset(first.s_, first.m_, first.n_ + kept));
  joined.head_ = first.head_;
  joined.tail_ = second.tail_;
  joined.durations_ << first.durations_, second.durations_.tail(kept);
  joined.coeffs_ << first.coeffs_, second.coeffs_.bottomRows(nc * kept);
  joined.valid_ = true;
  return joined;
}

core::Result<Minco> Minco::Prefix(const Minco& whole, int pieces) {
  if (!whole.valid_) return core::Status::InvalidArgument("a prefix of an invalid MINCO trajectory");
  if (pieces < 1 || pieces > whole.n_) {
    return core::Status::InvalidArgument("a prefix of " + std::to_string(pieces) + " of " + std::to_string(whole.n_) +
                                         " pieces");
  }
  const int nc = 2 * whole.s_;
  Minco prefix;
  QUADHAND_RETURN_IF_ERROR(prefix.Reset(whole.s_, whole.m_, pieces));
  prefix.head_ = whole.head_;
  for (int k = 0; k < whole.s_; ++k) {
    prefix.tail_.row(k) = whole.Evaluate(pieces - 1, whole.durations_[pieces - 1], k).transpose();
  }
  prefix.durations_ = whole.durations_.head(pieces);
  prefix.coeffs_ = whole.coeffs_.topRows(nc * pieces);
  prefix.valid_ = true;
  return prefix;
}

void Minco::Evaluate(int piece, double t, int deriv, Eigen::Ref<Eigen::VectorXd> out) const {
  assert(piece >= 0 && piece < n_ && deriv >= 0 && out.size() == m_);
  const int nc = 2 * s_;
  if (deriv >= nc) {
    out.setZero();
    return;
  }
  const int row0 = nc * piece;
  const double* fd = &fall_[static_cast<std::size_t>(deriv * nc)];
  for (int j = 0; j < m_; ++j) {
    const double* c = coeffs_.col(j).data() + row0;
    double acc = fd[nc - 1] * c[nc - 1];
    for (int k = nc - 2; k >= deriv; --k) acc = acc * t + fd[k] * c[k];
    out[j] = acc;
  }
}

Eigen::VectorXd Minco::Evaluate(int piece, double t, int deriv) const {
  Eigen::VectorXd out(m_);
  Evaluate(piece, t, deriv, out);
  return out;
}

void Minco::LocatePiece(double global_t, int* piece, double* local_t) const {
  int i = 0;
  double t = std::max(global_t, 0.0);
  while (i + 1 < n_ && t > durations_[i]) {
    t -= durations_[i];
    ++i;
  }
  if (i + 1 == n_) t = std::min(t, durations_[i]);
  *piece = i;
  *local_t = t;
}

double Minco::Energy() const {
  const int s = s_;
  const int nc = 2 * s;
  const double* alpha = &fall_[static_cast<std::size_t>(s * nc)];
  double pw[2 * kMaxCoeffs];
  double energy = 0.0;
  for (int i = 0; i < n_; ++i) {
    pw[0] = 1.0;
    for (int k = 1; k < nc; ++k) pw[k] = pw[k - 1] * durations_[i];
    const int row0 = nc * i;
    for (int k = s; k < nc; ++k) {
      for (int l = s; l < nc; ++l) {
        const int e = k + l - nc + 1;
        const double w = alpha[k] * alpha[l] * pw[e] / e;
        energy += w * coeffs_.row(row0 + k).dot(coeffs_.row(row0 + l));
      }
    }
  }
  return energy;
}

void Minco::AddEnergyGradient(Eigen::Ref<Eigen::MatrixXd> grad_coeffs,
                              Eigen::Ref<Eigen::VectorXd> grad_durations) const {
  assert(grad_coeffs.rows() == coeffs_.rows() && grad_coeffs.cols() == m_);
  assert(grad_durations.size() == n_);
  const int s = s_;
  const int nc = 2 * s;
  const double* alpha = &fall_[static_cast<std::size_t>(s * nc)];
  double pw[2 * kMaxCoeffs];
  for (int i = 0; i < n_; ++i) {
    pw[0] = 1.0;
    for (int k = 1; k < nc; ++k) pw[k] = pw[k - 1] * durations_[i];
    const int row0 = nc * i;
    double d_t = 0.0;
    for (int k = s; k < nc; ++k) {
      for (int l = s; l < nc; ++l) {
        const int e = k + l - nc + 1;
        const double aa = alpha[k] * alpha[l];
        const double w = aa * pw[e] / e;
        for (int j = 0; j < m_; ++j) grad_coeffs(row0 + k, j) += 2.0 * w * coeffs_(row0 + l, j);
        d_t += aa * pw[e - 1] * coeffs_.row(row0 + k).dot(coeffs_.row(row0 + l));
      }
    }
    grad_durations[i] += d_t;
  }
}

void Minco::AddSampleGradient(int piece, double t, int deriv,
                              const Eigen::Ref<const Eigen::VectorXd>& grad_value, double dt_dT,
                              Eigen::Ref<Eigen::MatrixXd> grad_coeffs,
                              Eigen::Ref<Eigen::VectorXd> grad_durations) const {
  assert(piece >= 0 && piece < n_ && deriv >= 0 && grad_value.size() == m_);
  const int nc = 2 * s_;
  if (deriv >= nc) return;
  const int row0 = nc * piece;
  const double* fd = &fall_[static_cast<std::size_t>(deriv * nc)];
  double tp = 1.0;
  for (int k = deriv; k < nc; ++k) {
    const double w = fd[k] * tp;
    for (int j = 0; j < m_; ++j) grad_coeffs(row0 + k, j) += w * grad_value[j];
    tp *= t;
  }
  if (dt_dT != 0.0 && deriv + 1 < nc) {
    const double* fd1 = &fall_[static_cast<std::size_t>((deriv + 1) * nc)];
    double dot = 0.0;
    for (int j = 0; j < m_; ++j) {
      const double* c = coeffs_.col(j).data() + row0;
      double acc = fd1[nc - 1] * c[nc - 1];
      for (int k = nc - 2; k > deriv; --k) acc = acc * t + fd1[k] * c[k];
      dot += acc * grad_value[j];
    }
    grad_durations[piece] += dt_dT * dot;
  }
}

core::Status Minco::PropagateGradient(const Eigen::Ref<const Eigen::MatrixXd>& grad_coeffs,
                                      const Eigen::Ref<const Eigen::VectorXd>& partial_grad_durations,
                                      Eigen::MatrixXd* grad_waypoints,
                                      Eigen::VectorXd* grad_durations,
                                      Eigen::MatrixXd* grad_head, Eigen::MatrixXd* grad_tail) {
  if (!valid_) return core::Status::InvalidArgument("MINCO: no valid trajectory to differentiate");
  if (grad_coeffs.rows() != coeffs_.rows() || grad_coeffs.cols() != m_ ||
      partial_grad_durations.size() != n_) {
    return core::Status::InvalidArgument("MINCO: gradient sizes do not match the trajectory");
  }
  if (grad_waypoints == nullptr || grad_durations == nullptr) {
    return core::Status::InvalidArgument("MINCO: waypoint and duration gradients are required");
  }
  const int s = s_;
  const int nc = 2 * s;

  // Adjoint: M^T lambda = dK/dc. Then dK/db = lambda and
  // dK/dT_i = partial - sum_rows lambda_r . (dM_r/dT_i c).
  adjoint_ = grad_coeffs;
  system_.SolveTransposed(adjoint_);

  grad_waypoints->resize(m_, n_ - 1);
  for (int i = 0; i + 1 < n_; ++i) grad_waypoints->col(i) = adjoint_.row(WaypointRow(i)).transpose();
  if (grad_head != nullptr) *grad_head = adjoint_.topRows(s);
  if (grad_tail != nullptr) *grad_tail = adjoint_.bottomRows(s);

  grad_durations->resize(n_);
  double deriv[kMaxCoeffs + 1];  // p_i^(d)(T_i), d = 0 .. 2s, for one column
  for (int i = 0; i < n_; ++i) {
    const double t = durations_[i];
    const int row0 = nc * i;
    double g = partial_grad_durations[i];
    for (int j = 0; j < m_; ++j) {
      const double* c = coeffs_.col(j).data() + row0;
      for (int d = 1; d < nc; ++d) {
        const double* fd = &fall_[static_cast<std::size_t>(d * nc)];
        double acc = fd[nc - 1] * c[nc - 1];
        for (int k = nc - 2; k >= d; --k) acc = acc * t + fd[k] * c[k];
        deriv[d] = acc;
      }
      deriv[nc] = 0.0;
      if (i + 1 < n_) {
        // Rows containing p_i^(d)(T_i): continuity d = 0 .. 2s-2 and the waypoint row.
        for (int d = 0; d <= nc - 2; ++d) g -= adjoint_(ContinuityRow(s, i, d), j) * deriv[d + 1];
        g -= adjoint_(WaypointRow(i), j) * deriv[1];
      } else {
        for (int d = 0; d < s; ++d) g -= adjoint_(row0 + s + d, j) * deriv[d + 1];
      }
    }
    (*grad_durations)[i] = g;
  }
  return core::Status::Ok();
}

}  // namespace quadhand::traj
