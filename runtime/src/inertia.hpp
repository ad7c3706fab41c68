/**
 * @file inertia.hpp
 * The inertia of the Hessian of the discrete action counted pivot by pivot of a block elimination
 * (Haynsworth: the inertia of H is the sum of the inertias of its pivots S_i), with the one rule
 * that decides when a pivot eigenvalue is zero. Every count of positive, negative and zero
 * eigenvalues (the point assessment, the certificate of `pardel check`, Newton's saddle check, the
 * Schur split over MPI ranks) goes through these functions, so that they agree.
 */
#ifndef PARDEL_RUNTIME_INERTIA_HPP
#define PARDEL_RUNTIME_INERTIA_HPP

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace pardel::detail {

/**
 * The zero rule. Zero is judged in the Jacobi-scaled H~ = J H J, J = diag(|H_aa|^-1/2) (1 where a
 * diagonal entry is zero or not finite): a congruence, so H~ has H's inertia (Sylvester's law), and
 * its rows have one size whatever the units of the coordinates. An eigenvalue v of a scaled pivot
 * J S_i J counts as zero when
 *     |v| <= kZeroPivot * max(1, ||H~||),   ||H~|| Gershgorin's bound of H~ (about 1 to 2d).
 * The reference is the whole matrix's size, not the pivot's own: the rounding error a pivot carries
 * is that of the entries it is formed from (D_i - C^T S^-1 C, all bounded by ||H~|| for a definite
 * H~), so a pivot whose eigenvalues cancel down to round-off is zero however small the pivot itself
 * is, and a one-by-one pivot, which is never small against itself, is judged as well. 10^-12 is
 * about 4500 unit roundoffs: room for the growth over the 3d terms of a row's elimination and the
 * pivot's eigendecomposition, while an eigenvalue above it is far from what rounding makes.
 */
inline constexpr double kZeroPivot = 1e-12;

/** Counts of positive, negative and zero eigenvalues. */
struct Inertia {
  long positive = 0, negative = 0, zero = 0;
  Inertia& operator+=(const Inertia& o) {
    positive += o.positive;
    negative += o.negative;
    zero += o.zero;
    return *this;
  }
};

/** The Jacobi scaling of a diagonal entry h of H: |h|^-1/2, 1 where h is zero or not finite. */
inline double jacobi_scale(double h) {
  const double a = std::fabs(h);
  return a > 0 && std::isfinite(a) ? 1 / std::sqrt(a) : 1.0;
}

/** The rule's threshold for the scaled pivot eigenvalues, given Gershgorin's bound of H~. */
inline double zero_threshold(double scaled_bound) { return kZeroPivot * std::max(1.0, scaled_bound); }

/**
 * ||(J L)^-1||_F^2 for a pivot S = L L^T (L its lower Cholesky factor): every eigenvalue of J S J
 * is at least its inverse, lambda_min(J S J) = 1 / ||(J L)^-1||_2^2 >= 1 / ||(J L)^-1||_F^2, so
 * that f tiny < 1 certainly puts them above `tiny`. Where this lower bound does not decide (it is
 * within a factor d of the value), split_pivot() does.
 */
template <class Mat>
double scaled_inverse_norm2(const Mat& L, const double* J) {
  Mat M = L.template triangularView<Eigen::Lower>();
  for (Eigen::Index a = 0; a < M.rows(); ++a) M.row(a) *= J[a];
  Mat inv = Mat::Identity(M.rows(), M.cols());
  M.template triangularView<Eigen::Lower>().solveInPlace(inv);
  return inv.squaredNorm();  // ||(J L)^-1||_F^2
}

/**
 * The inertia of one symmetric pivot S under the zero rule, from the eigendecomposition of its
 * scaled form J S J, added to `in`; `pinv` becomes S's inverse, or its pseudo-inverse
 * J V diag(1/v, 0 for the zeros) V^T J where eigenvalues count as zero (they are left out of the
 * elimination). A failed eigendecomposition counts every eigenvalue as zero.
 */
template <class Mat>
void split_pivot(const Mat& S, const double* J, double tiny, Inertia& in, Mat& pinv) {
  using Vec = Eigen::Matrix<double, Mat::RowsAtCompileTime, 1>;
  const Eigen::Index d = S.rows();
  Mat St = S;
  for (Eigen::Index a = 0; a < d; ++a)
    for (Eigen::Index b = 0; b < d; ++b) St(a, b) *= J[a] * J[b];
  Eigen::SelfAdjointEigenSolver<Mat> eig(St);
  if (eig.info() != Eigen::Success) {
    in.zero += d;
    pinv.setZero(d, d);
    return;
  }
  Vec inv = eig.eigenvalues();
  for (Eigen::Index a = 0; a < d; ++a) {
    const double v = inv(a);
    if (!std::isfinite(v) || std::fabs(v) <= tiny) {
      ++in.zero;
      inv(a) = 0;
    } else {
      if (v > 0) ++in.positive; else ++in.negative;
      inv(a) = 1 / v;
    }
  }
  Mat V = eig.eigenvectors();
  for (Eigen::Index a = 0; a < d; ++a) V.row(a) *= J[a];
  pinv.noalias() = V * inv.asDiagonal() * V.transpose();
}

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_INERTIA_HPP
