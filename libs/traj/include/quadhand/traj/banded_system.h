// A square banded matrix with an in-place LU factorisation (no pivoting) and
// solves with A and with A^T. Used by MINCO, whose constraint matrices are
// banded and whose natural diagonal ordering needs no pivoting.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace quadhand::traj {

class BandedSystem {
 public:
  BandedSystem() = default;

  // Sizes the matrix to n x n with `lower` sub-diagonals and `upper`
  // super-diagonals and zeroes it. Allocates only when the storage grows.
  void Reset(int n, int lower, int upper);

  // Zeroes every stored entry (keeps the sizes).
  void SetZero();

  int size() const { return n_; }
  int lower() const { return lower_; }
  int upper() const { return upper_; }

  // Whether (i, j) lies inside the band.
  bool InBand(int i, int j) const { return j - i <= upper_ && i - j <= lower_; }

  // Entry (i, j); must lie inside the band (checked only by assertions).
  double& operator()(int i, int j) { return data_[Index(i, j)]; }
  double operator()(int i, int j) const { return data_[Index(i, j)]; }

  // Replaces the matrix by its LU factors (L unit lower, U upper) without
  // pivoting. Returns false, leaving the factors incomplete, if a pivot is
  // zero or not finite.
  bool Factorize();

  // Solve A X = B or A^T X = B in place for every column of `b` (n rows).
  // Only valid after a successful Factorize().
  void Solve(Eigen::Ref<Eigen::MatrixXd> b) const;
  void SolveTransposed(Eigen::Ref<Eigen::MatrixXd> b) const;

 private:
  int Index(int i, int j) const { return i * width_ + (j - i + lower_); }
  template <int C>
  void SolveChunk(double* b, Eigen::Index ld) const;
  template <int C>
  void SolveTransposedChunk(double* b, Eigen::Index ld) const;

  int n_ = 0;
  int lower_ = 0;
  int upper_ = 0;
  int width_ = 1;
  std::vector<double> data_;  // row-major band: row i holds columns i-lower .. i+upper
};

}  // namespace quadhand::traj
