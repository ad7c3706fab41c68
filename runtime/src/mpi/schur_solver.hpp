/**
 * @file schur_solver.hpp
 * The distributed solve of the block-tridiagonal Newton system H x = b (block size D, Eigen::Dynamic
 * for other sizes) by a Schur-complement split. Each rank owns a contiguous run of unknown blocks;
 * the last block of every rank but the last is an interface (separator) block. A rank eliminates
 * its interior blocks (block LDL^T with Cholesky pivots) against its right-hand side and its
 * couplings to the two neighbouring separators, and contributes to the (ranks-1)-block
 * tridiagonal Schur system of the separators; the contributions are exchanged by one Allgather
 * and every rank solves that small system redundantly (identically), then recovers its interior.
 * Success certifies that H is positive definite (every pivot of the interiors and of the Schur
 * system is Cholesky-factored; H is congruent to their block diagonal). Storage is allocated by
 * resize(); solve() does not allocate for fixed D.
 */
#ifndef PARDEL_RUNTIME_MPI_SCHUR_SOLVER_HPP
#define PARDEL_RUNTIME_MPI_SCHUR_SOLVER_HPP

#include <mpi.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "../inertia.hpp"

namespace pardel::mpi::detail {

template <int D>
class SchurBlockSolver {
 public:
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;

  /**
   * Allocates for `owned` unknown blocks of size d on rank `rank` of `ranks`. With a right
   * neighbour the last owned block is this rank's separator; with a left neighbour the previous
   * rank's separator couples to block 0 through left_coupling(). Needs at least one interior block.
   */
  void resize(int owned, int d, int rank, int ranks) {
    d_ = d;
    owned_ = owned;
    rank_ = rank;
    ranks_ = ranks;
    has_left_ = rank > 0;
    has_right_ = rank + 1 < ranks;
    interior_ = owned - (has_right_ ? 1 : 0);
    const std::size_t n = static_cast<std::size_t>(owned);
    diag_.assign(n, Mat::Zero(d, d));
    off_.assign(n, Mat::Zero(d, d));
    left_ = Mat::Zero(d, d);
    const std::size_t ni = static_cast<std::size_t>(interior_ > 0 ? interior_ : 0);
    G_.assign(ni, Mat::Zero(d, d));
    llt_.assign(ni, Eigen::LLT<Mat>(d));
    XL_.assign(ni, Mat::Zero(d, d));
    XR_.assign(ni, Mat::Zero(d, d));
    xb_.assign(ni, Vec::Zero(d));
    packet_size_ = 1 + 3 * d * d + 2 * d;
    packet_.assign(static_cast<std::size_t>(packet_size_), 0.0);
    packets_.assign(static_cast<std::size_t>(packet_size_) * static_cast<std::size_t>(ranks), 0.0);
    const std::size_t m = static_cast<std::size_t>(ranks - 1);
    Sd_.assign(m, Mat::Zero(d, d));
    So_.assign(m, Mat::Zero(d, d));
    SW_.assign(m, Mat::Zero(d, d));
    Sllt_.assign(m, Eigen::LLT<Mat>(d));
    Sg_.assign(m, Vec::Zero(d));
    Sy_.assign(m, Vec::Zero(d));
    Sx_.assign(m, Vec::Zero(d));
  }

  int owned() const { return owned_; }
  int interior() const { return interior_; }
  /** Diagonal block of owned unknown i. */
  Mat& diag(int i) { return diag_[static_cast<std::size_t>(i)]; }
  const Mat& diag(int i) const { return diag_[static_cast<std::size_t>(i)]; }
  /** Coupling H(i, i+1) of owned unknown i to the next unknown (the next rank's first for the last
   *  owned block; used there only by quadratic forms). */
  Mat& off(int i) { return off_[static_cast<std::size_t>(i)]; }
  const Mat& off(int i) const { return off_[static_cast<std::size_t>(i)]; }
  /** H(L, 0): the previous rank's separator L coupled to owned unknown 0. */
  Mat& left_coupling() { return left_; }
  const Mat& left_coupling() const { return left_; }

  /**
   * Solves H x = b; b and x hold the owned unknowns in node layout (d values each). Collective over
   * `comm`; returns the same verdict on every rank: false if some pivot is not positive definite.
   */
  bool solve(const double* b, double* x, MPI_Comm comm) {
    const int d = d_;
    using VecMap = Eigen::Map<const Vec>;
    bool ok = interior_ >= 1 && factor_interior();
    if (ok) {
      // Interior solves: T xb = b_I, T XL = E_L (C_L^T at block 0), T XR = E_R (off(last) at the last block).
      for (int i = 0; i < interior_; ++i) {
        const std::size_t ii = static_cast<std::size_t>(i);
        xb_[ii] = VecMap(b + ii * d, d);
        if (i > 0) xb_[ii].noalias() -= G_[ii - 1].transpose() * xb_[ii - 1];
        if (has_left_) {
          if (i == 0) {
            XL_[0] = left_.transpose();
          } else {
            XL_[ii].noalias() = -G_[ii - 1].transpose() * XL_[ii - 1];
          }
        }
      }
      if (has_right_) {
        for (int i = 0; i + 1 < interior_; ++i) XR_[static_cast<std::size_t>(i)].setZero();
        XR_[static_cast<std::size_t>(interior_ - 1)] = off_[static_cast<std::size_t>(interior_ - 1)];
      }
      for (int i = interior_ - 1; i >= 0; --i) {
        const std::size_t ii = static_cast<std::size_t>(i);
        xb_[ii] = llt_[ii].solve(xb_[ii]);
        if (i + 1 < interior_) xb_[ii].noalias() -= G_[ii] * xb_[ii + 1];
        if (has_left_) {
          XL_[ii] = llt_[ii].solve(XL_[ii]);
          if (i + 1 < interior_) XL_[ii].noalias() -= G_[ii] * XL_[ii + 1];
        }
        if (has_right_) {
          XR_[ii] = llt_[ii].solve(XR_[ii]);
          if (i + 1 < interior_) XR_[ii].noalias() -= G_[ii] * XR_[ii + 1];
        }
      }
    }
    // This rank's contributions to the Schur system of the separators.
    double* p = packet_.data();
    p[0] = ok ? 1.0 : 0.0;
    Eigen::Map<Mat> SRR(p + 1, d, d), SLL(p + 1 + d * d, d, d), SLR(p + 1 + 2 * d * d, d, d);
    Eigen::Map<Vec> gR(p + 1 + 3 * d * d, d), gL(p + 1 + 3 * d * d + d, d);
    SRR.setZero();
    SLL.setZero();
    SLR.setZero();
    gR.setZero();
    gL.setZero();
    if (ok) {
      const std::size_t last = static_cast<std::size_t>(interior_ - 1);
      if (has_right_) {
        const std::size_t r = static_cast<std::size_t>(interior_);
        const Mat& Rc = off_[last];
        SRR = diag_[r];
        SRR.noalias() -= Rc.transpose() * XR_[last];
        gR = VecMap(b + r * d, d);
        gR.noalias() -= Rc.transpose() * xb_[last];
      }
      if (has_left_) {
        SLL.noalias() = -left_ * XL_[0];
        gL.noalias() = -left_ * xb_[0];
        if (has_right_) SLR.noalias() = -left_ * XR_[0];
      }
    }
    MPI_Allgather(packet_.data(), packet_size_, MPI_DOUBLE, packets_.data(), packet_size_, MPI_DOUBLE, comm);
    for (int r = 0; r < ranks_; ++r)
      if (packets_[static_cast<std::size_t>(r) * packet_size_] != 1.0) ok = false;
    if (!ok) return false;
    // The Schur system over separators j = 0..ranks-2 (separator j is rank j's last owned block).
    const int m = ranks_ - 1;
    for (int j = 0; j < m; ++j) {
      const double* pj = packets_.data() + static_cast<std::size_t>(j) * packet_size_;
      const double* pn = pj + packet_size_;  // rank j + 1
      const std::size_t jj = static_cast<std::size_t>(j);
      Sd_[jj] = Eigen::Map<const Mat>(pj + 1, d, d);
      Sd_[jj] += Eigen::Map<const Mat>(pn + 1 + d * d, d, d);
      Sg_[jj] = Eigen::Map<const Vec>(pj + 1 + 3 * d * d, d);
      Sg_[jj] += Eigen::Map<const Vec>(pn + 1 + 3 * d * d + d, d);
      if (j + 1 < m)
        So_[jj] = Eigen::Map<const Mat>(pn + 1 + 2 * d * d, d, d);
      else
        So_[jj].setZero();
    }
    for (int j = 0; j < m; ++j) {
      const std::size_t jj = static_cast<std::size_t>(j);
      SW_[jj] = Sd_[jj];
      if (j > 0) SW_[jj].noalias() -= So_[jj - 1].transpose() * SW_[jj - 1];
      Sllt_[jj].compute(SW_[jj]);
      if (Sllt_[jj].info() != Eigen::Success || !finite_positive_diag(Sllt_[jj])) return false;
      SW_[jj] = Sllt_[jj].solve(So_[jj]);
      Sy_[jj] = Sg_[jj];
      if (j > 0) Sy_[jj].noalias() -= SW_[jj - 1].transpose() * Sy_[jj - 1];
    }
    for (int j = m - 1; j >= 0; --j) {
      const std::size_t jj = static_cast<std::size_t>(j);
      Sx_[jj] = Sllt_[jj].solve(Sy_[jj]);
      if (j + 1 < m) Sx_[jj].noalias() -= SW_[jj] * Sx_[jj + 1];
    }
    // Interior from the separators.
    for (int i = 0; i < interior_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      Eigen::Map<Vec> xi(x + ii * d, d);
      xi = xb_[ii];
      if (has_left_) xi.noalias() -= XL_[ii] * Sx_[static_cast<std::size_t>(rank_ - 1)];
      if (has_right_) xi.noalias() -= XR_[ii] * Sx_[static_cast<std::size_t>(rank_)];
    }
    if (has_right_) Eigen::Map<Vec>(x + static_cast<std::size_t>(interior_) * d, d) = Sx_[static_cast<std::size_t>(rank_)];
    return true;
  }

  using Inertia = pardel::detail::Inertia;

  /**
   * The inertia of H as assembled, by Haynsworth's theorem over the split: the inertias of the
   * interiors' pivots (block elimination) plus that of the separators' Schur complement. Each pivot
   * is split by split_pivot() of inertia.hpp, under the zero rule there (the one-process
   * elimination's): zero is judged in the Jacobi-scaled H~ = J H J against Gershgorin's bound of
   * H~ over all ranks, and eigenvalues that count as zero are left out of the elimination (a
   * pseudo-inverse). Collective over `comm`; the same counts on every rank. Overwrites the
   * factorization of solve() (which refactors on every call).
   */
  Inertia inertia(MPI_Comm comm) {
    const int d = d_;
    const std::size_t dz = static_cast<std::size_t>(d);
    // J per owned unknown, and the neighbours' J at the two ends of this rank (every rank's first
    // and last block, gathered), for the Gershgorin bound of H~ over the rows this rank owns.
    std::vector<double> J(static_cast<std::size_t>(owned_) * dz, 1.0);
    for (int i = 0; i < owned_; ++i)
      for (int a = 0; a < d; ++a)
        J[static_cast<std::size_t>(i) * dz + static_cast<std::size_t>(a)] = pardel::detail::jacobi_scale(diag_[static_cast<std::size_t>(i)](a, a));
    std::vector<double> ends(2 * dz, 1.0), all_ends(2 * dz * static_cast<std::size_t>(ranks_), 1.0);
    if (owned_ > 0) {
      std::copy(J.begin(), J.begin() + d, ends.begin());
      std::copy(J.end() - d, J.end(), ends.begin() + d);
    }
    MPI_Allgather(ends.data(), 2 * d, MPI_DOUBLE, all_ends.data(), 2 * d, MPI_DOUBLE, comm);
    const double* J_left = has_left_ ? all_ends.data() + static_cast<std::size_t>(rank_ - 1) * 2 * dz + dz : nullptr;
    const double* J_right = has_right_ ? all_ends.data() + static_cast<std::size_t>(rank_ + 1) * 2 * dz : nullptr;
    double bound = 0;
    for (int i = 0; i < owned_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      const double* Ji = J.data() + ii * dz;
      const double* Jn = i + 1 < owned_ ? Ji + dz : J_right;
      const double* Jp = i > 0 ? Ji - dz : J_left;
      const Mat* previous = i > 0 ? &off_[ii - 1] : has_left_ ? &left_ : nullptr;
      for (int a = 0; a < d; ++a) {
        double row = 0;
        for (int c = 0; c < d; ++c) {
          row += std::fabs(diag_[ii](a, c)) * Ji[a] * Ji[c];
          if (Jn) row += std::fabs(off_[ii](a, c)) * Ji[a] * Jn[c];
          if (previous) row += std::fabs((*previous)(c, a)) * Ji[a] * Jp[c];
        }
        bound = std::max(bound, row);
      }
    }
    MPI_Allreduce(MPI_IN_PLACE, &bound, 1, MPI_DOUBLE, MPI_MAX, comm);
    const double tol = pardel::detail::zero_threshold(bound);
    Inertia local;
    auto pivot = [&](const Mat& S, const double* Js, Mat& p, Inertia& in) {
      pardel::detail::split_pivot(S, Js, tol, in, p);
    };
    // Interior: pivots P_i, G_i = P_i C_i, and the eliminations XL = T^+ E_L, XR = T^+ E_R.
    std::vector<Mat> P(static_cast<std::size_t>(std::max(interior_, 0)), Mat::Zero(d, d));
    for (int i = 0; i < interior_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      Mat S = diag_[ii];
      if (i > 0) S.noalias() -= off_[ii - 1].transpose() * G_[ii - 1];
      pivot(S, J.data() + ii * dz, P[ii], local);
      if (i + 1 < interior_) G_[ii] = P[ii] * off_[ii]; else G_[ii].setZero();
      if (has_left_) {
        if (i == 0) XL_[0] = left_.transpose(); else XL_[ii].noalias() = -G_[ii - 1].transpose() * XL_[ii - 1];
      }
      if (has_right_) {
        if (i + 1 < interior_) XR_[ii].setZero(); else XR_[ii] = off_[ii];
      }
    }
    for (int i = interior_ - 1; i >= 0; --i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      if (has_left_) {
        XL_[ii] = P[ii] * XL_[ii];
        if (i + 1 < interior_) XL_[ii].noalias() -= G_[ii] * XL_[ii + 1];
      }
      if (has_right_) {
        XR_[ii] = P[ii] * XR_[ii];
        if (i + 1 < interior_) XR_[ii].noalias() -= G_[ii] * XR_[ii + 1];
      }
    }
    // This rank's counts and Schur contributions, gathered by every rank.
    const int size = 3 + 3 * d * d;
    std::vector<double> mine(static_cast<std::size_t>(size), 0.0), all(static_cast<std::size_t>(size) * ranks_, 0.0);
    mine[0] = static_cast<double>(local.positive);
    mine[1] = static_cast<double>(local.negative);
    mine[2] = static_cast<double>(local.zero);
    Eigen::Map<Mat> SRR(mine.data() + 3, d, d), SLL(mine.data() + 3 + d * d, d, d), SLR(mine.data() + 3 + 2 * d * d, d, d);
    if (interior_ > 0) {
      const std::size_t last = static_cast<std::size_t>(interior_ - 1);
      if (has_right_) SRR = diag_[static_cast<std::size_t>(interior_)] - off_[last].transpose() * XR_[last];
      if (has_left_) {
        SLL.noalias() = -left_ * XL_[0];
        if (has_right_) SLR.noalias() = -left_ * XR_[0];
      }
    }
    MPI_Allgather(mine.data(), size, MPI_DOUBLE, all.data(), size, MPI_DOUBLE, comm);
    Inertia total;
    for (int r = 0; r < ranks_; ++r) {
      const double* pr = all.data() + static_cast<std::size_t>(r) * size;
      total.positive += static_cast<long>(pr[0]);
      total.negative += static_cast<long>(pr[1]);
      total.zero += static_cast<long>(pr[2]);
    }
    // The separators' Schur complement, eliminated with pseudo-inverse pivots.
    Mat W = Mat::Zero(d, d), Pj = Mat::Zero(d, d), So = Mat::Zero(d, d);
    for (int j = 0; j + 1 < ranks_; ++j) {
      const double* pj = all.data() + static_cast<std::size_t>(j) * size;
      const double* pn = pj + size;  // rank j + 1
      Mat S = Eigen::Map<const Mat>(pj + 3, d, d);
      S += Eigen::Map<const Mat>(pn + 3 + d * d, d, d);
      if (j > 0) S.noalias() -= So.transpose() * W;
      pivot(S, all_ends.data() + static_cast<std::size_t>(j) * 2 * dz + dz, Pj, total);  // rank j's last block
      So = j + 2 < ranks_ ? Mat(Eigen::Map<const Mat>(pn + 3 + 2 * d * d, d, d)) : Mat(Mat::Zero(d, d));
      W = Pj * So;
    }
    return total;
  }

 private:
  bool factor_interior() {
    for (int i = 0; i < interior_; ++i) {
      const std::size_t ii = static_cast<std::size_t>(i);
      Mat& W = G_[ii];
      W = diag_[ii];
      if (i > 0) W.noalias() -= off_[ii - 1].transpose() * G_[ii - 1];
      llt_[ii].compute(W);
      if (llt_[ii].info() != Eigen::Success || !finite_positive_diag(llt_[ii])) return false;
      if (i + 1 < interior_)
        G_[ii] = llt_[ii].solve(off_[ii]);  // S_i^{-1} C_i
      else
        G_[ii].setZero();
    }
    return true;
  }

  static bool finite_positive_diag(const Eigen::LLT<Mat>& llt) {
    const auto& L = llt.matrixLLT();
    for (int a = 0; a < L.rows(); ++a)
      if (!(L(a, a) > 0) || !std::isfinite(L(a, a))) return false;
    return true;
  }

  int d_ = 0, owned_ = 0, interior_ = 0, rank_ = 0, ranks_ = 1, packet_size_ = 0;
  bool has_left_ = false, has_right_ = false;
  std::vector<Mat> diag_, off_, G_, XL_, XR_;
  Mat left_;
  std::vector<Eigen::LLT<Mat>> llt_;
  std::vector<Vec> xb_;
  std::vector<double> packet_, packets_;
  std::vector<Mat> Sd_, So_, SW_;
  std::vector<Eigen::LLT<Mat>> Sllt_;
  std::vector<Vec> Sg_, Sy_, Sx_;
};

}  // namespace pardel::mpi::detail

#endif  // PARDEL_RUNTIME_MPI_SCHUR_SOLVER_HPP
