/**
 * @file cyclic_reduction.hpp
 * Block cyclic reduction of a symmetric block-tridiagonal system H x = b (n block rows of d x d,
 * H positive definite), single-source: PARDEL_HD functions of one block row of one level, which
 * the CPU runs in (OpenMP) loops over a level's rows (solve_on_host, BlockTridiagonal's
 * cyclic-reduction solve) and the device runs as one thread per row and one launch per level.
 *
 * Level 0 is the system. Each level eliminates its even rows (0, 2, 4, ...), whose diagonal
 * blocks S_j are Cholesky-factored in place, and keeps its odd rows as the next level's: row
 * m = (i - 1) / 2 of level l + 1 is level l's row i with
 *   S'_m = S_i - U_{i-1}^T S_{i-1}^-1 U_{i-1} - U_i S_{i+1}^-1 U_i^T,
 *   b'_m = b_i - U_{i-1}^T S_{i-1}^-1 b_{i-1} - U_i S_{i+1}^-1 b_{i+1},
 *   U'_m = -U_i S_{i+1}^-1 U_{i+1}   (the coupling to the next kept row),
 * U_i the coupling of row i to row i + 1 (row i + 1 couples back by U_i^T), the terms of rows
 * that do not exist left out. A level of one row is solved by its Cholesky factor; then each level
 * takes its odd rows' x from the level above and solves its even rows,
 *   x_j = S_j^-1 (b_j - U_{j-1}^T x_{j-1} - U_j x_{j+1}).
 * The pivots factored are those of the block LDL^T of H with its rows permuted (each level's even
 * rows first), so that every Cholesky factor succeeding certifies H positive definite, as block
 * LDL^T's do. The depth is the number of levels, about log2 n; each row's work depends on the
 * level below only, so any number of threads gives the same bits.
 *
 * Storage: one array of values(n, d) doubles; level l's n_l rows (n_0 = n, n_{l+1} = n_l / 2
 * down to 1) hold per row S (d x d, row-major), U (d x d), b, x (d each) and a d x d scratch
 * block for the row's elimination.
 */
#ifndef PARDEL_RUNTIME_CYCLIC_REDUCTION_HPP
#define PARDEL_RUNTIME_CYCLIC_REDUCTION_HPP

#include <math.h>

#include "pardel/kernel_abi.h"

namespace pardel::cyclic_reduction {

/** One level's rows: S, U, T (d x d each, row-major) and b, x (d each) of row i at i d^2 and i d. */
struct Level {
  long n = 0;
  double* S = nullptr;
  double* U = nullptr;
  double* b = nullptr;
  double* x = nullptr;
  double* T = nullptr;
};

/** The number of levels for n rows (0 for none). */
PARDEL_HD inline int level_count(long n) {
  int levels = 0;
  for (long m = n; m >= 1; m /= 2) {
    ++levels;
    if (m == 1) break;
  }
  return levels;
}

/** Doubles of storage for n rows of size d, all levels. */
PARDEL_HD inline long values(long n, int d) {
  long rows = 0;
  for (long m = n; m >= 1; m /= 2) {
    rows += m;
    if (m == 1) break;
  }
  return rows * (3L * d * d + 2L * d);
}

/** Level l of the storage at `base` for n rows of size d. */
PARDEL_HD inline Level level(double* base, long n, int d, int l) {
  const long dd = static_cast<long>(d) * d;
  long m = n;
  for (int k = 0; k < l; ++k) {
    base += m * (3 * dd + 2L * d);
    m /= 2;
  }
  Level L;
  L.n = m;
  L.S = base;
  L.U = base + m * dd;
  L.T = base + 2 * m * dd;
  L.b = base + 3 * m * dd;
  L.x = L.b + m * d;
  return L;
}

/** The block size: D where it is fixed at compile time (D > 0), else d. */
template <int D>
PARDEL_HD inline int size(int d) {
  return D > 0 ? D : d;
}

/** Cholesky factor of the symmetric d x d block A in place (lower triangle, upper left as is);
 *  false where a pivot is not a positive finite number. */
template <int D>
PARDEL_HD inline bool factor_block(double* A, int d_) {
  const int d = size<D>(d_);
  for (int j = 0; j < d; ++j) {
    double s = A[j * d + j];
    for (int k = 0; k < j; ++k) s -= A[j * d + k] * A[j * d + k];
    if (!(s > 0) || !isfinite(s)) return false;
    const double l = sqrt(s);
    A[j * d + j] = l;
    for (int i = j + 1; i < d; ++i) {
      double v = A[i * d + j];
      for (int k = 0; k < j; ++k) v -= A[i * d + k] * A[j * d + k];
      A[i * d + j] = v / l;
    }
  }
  return true;
}

/** y <- (L L^T)^-1 y for the factor of factor_block, y's entries `stride` apart. */
template <int D>
PARDEL_HD inline void solve_block(const double* L, double* y, long stride, int d_) {
  const int d = size<D>(d_);
  for (int i = 0; i < d; ++i) {
    double v = y[i * stride];
    for (int k = 0; k < i; ++k) v -= L[i * d + k] * y[k * stride];
    y[i * stride] = v / L[i * d + i];
  }
  for (int i = d - 1; i >= 0; --i) {
    double v = y[i * stride];
    for (int k = i + 1; k < d; ++k) v -= L[k * d + i] * y[k * stride];
    y[i * stride] = v / L[i * d + i];
  }
}

/** S -= M^T T and b -= T^T c for d x d blocks: M = U, or with `transposed` M = U^T (the two
 *  neighbours' terms of reduce()). */
template <int D>
PARDEL_HD inline void subtract(double* S, double* b, const double* U, bool transposed, const double* T, const double* c,
                               int d_) {
  const int d = size<D>(d_);
  for (int a = 0; a < d; ++a) {
    for (int e = 0; e < d; ++e) {
      double s = 0;
      for (int k = 0; k < d; ++k) s += (transposed ? U[a * d + k] : U[k * d + a]) * T[k * d + e];
      S[a * d + e] -= s;
    }
    double s = 0;
    for (int k = 0; k < d; ++k) s += T[k * d + a] * c[k];
    b[a] -= s;
  }
}

/** Level A's even row j: its S factored in place; false where it is not positive definite. */
template <int D>
PARDEL_HD inline bool eliminate(const Level& A, long j, int d_) {
  const int d = size<D>(d_);
  return factor_block<D>(A.S + j * d * d, d);
}

/** Row m of level B (the level above A), from A's odd row i = 2m + 1 and its even neighbours,
 *  which eliminate() has factored. */
template <int D>
PARDEL_HD inline void reduce(const Level& A, const Level& B, long m, int d_) {
  const int d = size<D>(d_);
  const long dd = static_cast<long>(d) * d;
  const long i = 2 * m + 1;
  double* S = B.S + m * dd;
  double* U = B.U + m * dd;
  double* b = B.b + m * d;
  double* T = B.T + m * dd;
  const double* Si = A.S + i * dd;
  for (long k = 0; k < dd; ++k) S[k] = Si[k];
  for (int a = 0; a < d; ++a) b[a] = A.b[i * d + a];
  // Row i - 1 (always there): T = S_{i-1}^-1 U_{i-1}, S -= U_{i-1}^T T, b -= T^T b_{i-1}.
  {
    const double* L = A.S + (i - 1) * dd;
    const double* Up = A.U + (i - 1) * dd;
    for (long k = 0; k < dd; ++k) T[k] = Up[k];
    for (int c = 0; c < d; ++c) solve_block<D>(L, T + c, d, d);
    subtract<D>(S, b, Up, false, T, A.b + (i - 1) * d, d);
  }
  if (i + 1 < A.n) {
    // Row i + 1: T = S_{i+1}^-1 U_i^T, S -= U_i T, b -= T^T b_{i+1}, U' = -T^T U_{i+1}.
    const double* L = A.S + (i + 1) * dd;
    const double* Ui = A.U + i * dd;
    for (int a = 0; a < d; ++a)
      for (int c = 0; c < d; ++c) T[a * d + c] = Ui[c * d + a];
    for (int c = 0; c < d; ++c) solve_block<D>(L, T + c, d, d);
    subtract<D>(S, b, Ui, true, T, A.b + (i + 1) * d, d);
    const double* Un = A.U + (i + 1) * dd;
    for (int a = 0; a < d; ++a)
      for (int c = 0; c < d; ++c) {
        double s = 0;
        if (i + 2 < A.n)
          for (int k = 0; k < d; ++k) s += T[k * d + a] * Un[k * d + c];
        U[a * d + c] = -s;
      }
  } else {
    for (long k = 0; k < dd; ++k) U[k] = 0;
  }
}

/** Row r of level A once level B (above it) is solved: an odd row takes its x from B, an even
 *  row j solves x_j = S_j^-1 (b_j - U_{j-1}^T x_{j-1} - U_j x_{j+1}) with B's values of its
 *  neighbours (A's odd rows, which are B's). */
template <int D>
PARDEL_HD inline void substitute(const Level& A, const Level& B, long r, int d_) {
  const int d = size<D>(d_);
  const long dd = static_cast<long>(d) * d;
  double* x = A.x + r * d;
  if (r % 2 == 1) {
    for (int a = 0; a < d; ++a) x[a] = B.x[(r / 2) * d + a];
    return;
  }
  for (int a = 0; a < d; ++a) x[a] = A.b[r * d + a];
  if (r > 0) {
    const double* Up = A.U + (r - 1) * dd;
    const double* xp = B.x + ((r - 1) / 2) * d;
    for (int a = 0; a < d; ++a)
      for (int k = 0; k < d; ++k) x[a] -= Up[k * d + a] * xp[k];
  }
  if (r + 1 < A.n) {
    const double* Ur = A.U + r * dd;
    const double* xn = B.x + ((r + 1) / 2) * d;
    for (int a = 0; a < d; ++a)
      for (int k = 0; k < d; ++k) x[a] -= Ur[a * d + k] * xn[k];
  }
  solve_block<D>(A.S + r * dd, x, 1, d);
}

/** The last level (one row): factored and solved; false where its block is not positive definite. */
template <int D>
PARDEL_HD inline bool solve_top(const Level& top, int d_) {
  const int d = size<D>(d_);
  if (!factor_block<D>(top.S, d)) return false;
  for (int a = 0; a < d; ++a) top.x[a] = top.b[a];
  solve_block<D>(top.S, top.x, 1, d);
  return true;
}

/** The host path: the whole reduction and substitution over the storage at `base` (level 0's S,
 *  U and b filled; U of the last row unused), level 0's x the solution; false where a pivot is
 *  not positive definite (`failed`: its level). Rows of a level in parallel over `threads` where
 *  the level has at least `parallel_min` rows. */
template <int D>
bool solve_on_host(double* base, long n, int d, int threads, long parallel_min, int* failed = nullptr) {
  if (n <= 0) return true;
  const int levels = level_count(n);
  for (int l = 0; l + 1 < levels; ++l) {
    const Level A = level(base, n, d, l), B = level(base, n, d, l + 1);
    const bool parallel = threads > 1 && A.n >= parallel_min;
    int ok = 1;
#pragma omp parallel for if (parallel) num_threads(threads) schedule(static) reduction(&& : ok)
    for (long j = 0; j < A.n; j += 2) ok = eliminate<D>(A, j, d) && ok;
    if (!ok) {
      if (failed) *failed = l;
      return false;
    }
#pragma omp parallel for if (parallel) num_threads(threads) schedule(static)
    for (long m = 0; m < B.n; ++m) reduce<D>(A, B, m, d);
  }
  if (!solve_top<D>(level(base, n, d, levels - 1), d)) {
    if (failed) *failed = levels - 1;
    return false;
  }
  for (int l = levels - 1; l-- > 0;) {
    const Level A = level(base, n, d, l), B = level(base, n, d, l + 1);
#pragma omp parallel for if (threads > 1 && A.n >= parallel_min) num_threads(threads) schedule(static)
    for (long r = 0; r < A.n; ++r) substitute<D>(A, B, r, d);
  }
  return true;
}

}  // namespace pardel::cyclic_reduction

#endif  // PARDEL_RUNTIME_CYCLIC_REDUCTION_HPP
