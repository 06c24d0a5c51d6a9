#include "quadhand/traj/banded_system.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <type_traits>

namespace quadhand::traj {

namespace {

// Calls f(std::integral_constant<int, C>, first column, leading dimension) on
// consecutive groups of C = 4, 3, 2 or 1 columns of b.
template <typename F>
void ForEachChunk(Eigen::Ref<Eigen::MatrixXd>& b, F&& f) {
  const Eigen::Index ld = b.outerStride();
  Eigen::Index c = 0;
  for (; c + 4 <= b.cols(); c += 4) f(std::integral_constant<int, 4>(), b.data() + c * ld, ld);
  switch (b.cols() - c) {
    case 3: f(std::integral_constant<int, 3>(), b.data() + c * ld, ld); break;
    case 2: f(std::integral_constant<int, 2>(), b.data() + c * ld, ld); break;
    case 1: f(std::integral_constant<int, 1>(), b.data() + c * ld, ld); break;
    default: break;
  }
}

}  // namespace

void BandedSystem::Reset(int n, int lower, int upper) {
  assert(n >= 0 && lower >= 0 && upper >= 0);
  n_ = n;
  lower_ = lower;
  upper_ = upper;
  width_ = lower + upper + 1;
  const std::size_t needed = static_cast<std::size_t>(n) * static_cast<std::size_t>(width_);
  if (data_.size() < needed) data_.resize(needed);
  SetZero();
}

void BandedSystem::SetZero() {
  std::fill(data_.begin(), data_.begin() + static_cast<std::ptrdiff_t>(n_) * width_, 0.0);
}

bool BandedSystem::Factorize() {
  for (int k = 0; k < n_; ++k) {
    const double pivot = (*this)(k, k);
    if (pivot == 0.0 || !std::isfinite(pivot)) return false;
    const int row_end = std::min(k + lower_, n_ - 1);
    const int col_end = std::min(k + upper_, n_ - 1);
    const double* row_k = &data_[Index(k, k)];
    for (int i = k + 1; i <= row_end; ++i) {
      double& l_ik = (*this)(i, k);
      if (l_ik == 0.0) continue;
      l_ik /= pivot;
      const double factor = l_ik;
      double* row_i = &data_[Index(i, k)];
      for (int j = 1; j <= col_end - k; ++j) row_i[j] -= factor * row_k[j];
    }
  }
  return true;
}

// The solves work on up to four right-hand sides at once: every loop is an
// independent update (axpy form), and the columns give instruction-level
// parallelism instead of a chain of dependent multiply-adds.
template <int C>
void BandedSystem::SolveChunk(double* b, Eigen::Index ld) const {
  double xk[C];
  // L y = b (unit lower), column k of L.
  for (int k = 0; k < n_; ++k) {
    for (int c = 0; c < C; ++c) xk[c] = b[k + c * ld];
    const int row_end = std::min(k + lower_, n_ - 1);
    for (int i = k + 1; i <= row_end; ++i) {
      const double l = data_[Index(i, k)];
      if (l == 0.0) continue;
      for (int c = 0; c < C; ++c) b[i + c * ld] -= l * xk[c];
    }
  }
  // U x = y, column k of U.
  for (int k = n_ - 1; k >= 0; --k) {
    const double inv = 1.0 / data_[Index(k, k)];
    for (int c = 0; c < C; ++c) xk[c] = b[k + c * ld] *= inv;
    for (int i = std::max(0, k - upper_); i < k; ++i) {
      const double u = data_[Index(i, k)];
      if (u == 0.0) continue;
      for (int c = 0; c < C; ++c) b[i + c * ld] -= u * xk[c];
    }
  }
}

template <int C>
void BandedSystem::SolveTransposedChunk(double* b, Eigen::Index ld) const {
  double xk[C];
  // U^T y = b, row k of U.
  for (int k = 0; k < n_; ++k) {
    const double* row_k = &data_[Index(k, k)];
    const double inv = 1.0 / row_k[0];
    for (int c = 0; c < C; ++c) xk[c] = b[k + c * ld] *= inv;
    const int len = std::min(k + upper_, n_ - 1) - k;
    for (int j = 1; j <= len; ++j) {
      const double u = row_k[j];
      if (u == 0.0) continue;
      for (int c = 0; c < C; ++c) b[k + j + c * ld] -= u * xk[c];
    }
  }
  // L^T x = y (unit upper), row i of L.
  for (int i = n_ - 1; i > 0; --i) {
    for (int c = 0; c < C; ++c) xk[c] = b[i + c * ld];
    for (int k = std::max(0, i - lower_); k < i; ++k) {
      const double l = data_[Index(i, k)];
      if (l == 0.0) continue;
      for (int c = 0; c < C; ++c) b[k + c * ld] -= l * xk[c];
    }
  }
}

void BandedSystem::Solve(Eigen::Ref<Eigen::MatrixXd> b) const {
  assert(b.rows() == n_);
  ForEachChunk(b, [this](auto width, double* p, Eigen::Index ld) {
    SolveChunk<decltype(width)::value>(p, ld);
  });
}

void BandedSystem::SolveTransposed(Eigen::Ref<Eigen::MatrixXd> b) const {
  assert(b.rows() == n_);
  ForEachChunk(b, [this](auto width, double* p, Eigen::Index ld) {
    SolveTransposedChunk<decltype(width)::value>(p, ld);
  });
}

}  // namespace quadhand::traj
