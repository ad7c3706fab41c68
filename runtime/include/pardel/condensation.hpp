/**
 * @file condensation.hpp
 * Static condensation of a Galerkin interval, included by the kernels pardel-gen generates for
 * discretizations with interior values (galerkin_gauss(s=S), galerkin_lobatto(s=S) with S above
 * the model's order; docs/discretizations.md).
 *
 * Such an interval's action S(q0, z, q1) depends on interior values z besides the two nodes; its
 * discrete Lagrangian is L_d(q0, q1) = S(q0, z*, q1) with z* the stationary point, dS/dz = 0.
 * Each kernel finds z* by Newton's method from the generated starting values and returns
 *   D_a L_d  = dS/da (z*)                                    (a in q0, q1: the envelope theorem)
 *   D_ab L_d = d2S/dadb - d2S/dadz (d2S/dz2)^-1 d2S/dzdb     (the Schur complement)
 * so that the solvers see node blocks only. Sizes are compile-time constants: every array lives
 * on the stack, nothing is allocated. When the interior Newton iteration does not converge (or
 * d2S/dz2 is singular), every output is NaN, which the solvers report as a failure of the model
 * at that point.
 */
#ifndef PARDEL_CONDENSATION_HPP
#define PARDEL_CONDENSATION_HPP

#include <cmath>
#include <limits>

namespace pardel_condensation {

/** z's starting values. */
using start_fn = void (*)(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                          double* z);
/** dS/dz (M) and d2S/dz2 (M x M, row-major) at z. */
using interior_fn = void (*)(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                             const double* z, double* g, double* H);
/** S and its gradient over x = [q0, z, q1] (E = 2 D + M entries). */
using ext_grad_fn = void (*)(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                             const double* z, double* S, double* g);
/** S, its gradient and its Hessian (E x E, row-major) over x = [q0, z, q1]. */
using ext_full_fn = void (*)(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                             const double* z, double* S, double* g, double* H);

/** The functions of one discretization. */
struct Interval {
  start_fn start;
  interior_fn interior;
  ext_grad_fn ext_grad;
  ext_full_fn ext_full;
};

/** LU factorization with partial pivoting of the n x n row-major A in place; false when a pivot
 *  is zero or not finite. */
inline bool lu_factor(int n, double* A, int* piv) {
  for (int k = 0; k < n; ++k) {
    int best = k;
    for (int i = k + 1; i < n; ++i)
      if (std::fabs(A[i * n + k]) > std::fabs(A[best * n + k])) best = i;
    piv[k] = best;
    if (!(std::fabs(A[best * n + k]) > 0) || !std::isfinite(A[best * n + k])) return false;
    if (best != k)
      for (int j = 0; j < n; ++j) {
        const double t = A[k * n + j];
        A[k * n + j] = A[best * n + j];
        A[best * n + j] = t;
      }
    const double inv = 1.0 / A[k * n + k];
    for (int i = k + 1; i < n; ++i) {
      const double f = A[i * n + k] *= inv;
      if (f != 0)
        for (int j = k + 1; j < n; ++j) A[i * n + j] -= f * A[k * n + j];
    }
  }
  return true;
}

/** Solves A x = b with lu_factor's result; b (n entries, stride `stride`) is overwritten by x. */
inline void lu_solve(int n, const double* A, const int* piv, double* b, int stride = 1) {
  // The row exchanges first (lu_factor exchanged whole rows, multipliers included), then L and U.
  for (int k = 0; k < n; ++k) {
    if (piv[k] != k) {
      const double t = b[k * stride];
      b[k * stride] = b[piv[k] * stride];
      b[piv[k] * stride] = t;
    }
  }
  for (int k = 0; k < n; ++k)
    for (int i = k + 1; i < n; ++i) b[i * stride] -= A[i * n + k] * b[k * stride];
  for (int k = n - 1; k >= 0; --k) {
    double s = b[k * stride];
    for (int j = k + 1; j < n; ++j) s -= A[k * n + j] * b[j * stride];
    b[k * stride] = s / A[k * n + k];
  }
}

/**
 * Newton's method on dS/dz = 0 from the starting values. Converged when a step changes every
 * entry of z by at most 8 eps times the size of its coordinate (|z_i| and the node values of the
 * same coordinate); when the step that quadratic convergence predicts next is that small (the
 * largest relative step r_k at most 1e-6 and below the one before, and r_k^3 / r_(k-1)^2 at most
 * 8 eps: Newton's steps shrink like r_(k+1) = K r_k^2 with K = r_k / r_(k-1)^2), which saves the
 * evaluation that would only confirm it; or when the steps stop decreasing below 1e-8 of that
 * size (round-off).
 * @tparam D the dimension of a node point, N the number of coordinates, M = interior values
 */
template <int D, int N, int M>
bool solve_interior(const Interval& f, double h, double t0, double t1, const double* q0, const double* q1,
                    const double* p, double* z) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  constexpr int kMaxIterations = 40;
  double g[M], H[M * M];
  int piv[M];
  f.start(h, t0, t1, q0, q1, p, z);
  double previous = std::numeric_limits<double>::infinity();
  for (int it = 0; it < kMaxIterations; ++it) {
    f.interior(h, t0, t1, q0, q1, p, z, g, H);
    if (!lu_factor(M, H, piv)) return false;
    lu_solve(M, H, piv, g);
    double ratio = 0;  // the largest step relative to its coordinate's size
    bool small = true;
    for (int i = 0; i < M; ++i) {
      const int c = i % N;
      z[i] -= g[i];
      const double size = std::fabs(z[i]) + std::fabs(q0[c]) + std::fabs(q1[c]);
      const double step = std::fabs(g[i]);
      if (!std::isfinite(z[i])) return false;
      if (step > 8 * eps * size) small = false;
      ratio = size > 0 ? std::fmax(ratio, step / size) : (step > 0 ? std::numeric_limits<double>::infinity() : ratio);
    }
    if (small) return true;
    if (std::isfinite(previous) && ratio < previous && ratio <= 1e-6 &&
        ratio * ratio * ratio <= 8 * eps * previous * previous)
      return true;
    if (ratio >= previous && ratio <= 1e-8) return true;
    previous = ratio;
  }
  return false;
}

/** Every output NaN: the interval could not be condensed. */
inline void fail_outputs(int D, double* Ld, double* D1, double* D2, double* D11, double* D12, double* D22) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  if (Ld) *Ld = nan;
  for (int i = 0; i < D; ++i) D1[i] = D2[i] = nan;
  for (int i = 0; D11 && i < D * D; ++i) {
    D11[i] = D22[i] = nan;
    if (D12) D12[i] = nan;
  }
}

/**
 * Ld, D1, D2 and, when D11 is not null, D11, D12 (unless null: the sweep kernel) and D22 of the
 * condensed interval. Ld and the gradient are the envelope values S(z*) and dS/da(z*) at the
 * converged interior values, the same in every kernel.
 */
template <int D, int N, int M>
void condensed(const Interval& f, double h, double t0, double t1, const double* q0, const double* q1,
               const double* p, double* Ld, double* D1, double* D2, double* D11, double* D12, double* D22) {
  constexpr int E = 2 * D + M;
  double z[M];
  if (!solve_interior<D, N, M>(f, h, t0, t1, q0, q1, p, z)) return fail_outputs(D, Ld, D1, D2, D11, D12, D22);
  double S, g[E];
  auto node = [](int a) { return a < D ? a : D + M + (a - D); };  // index in x = [q0, z, q1]
  if (D11 == nullptr) {
    f.ext_grad(h, t0, t1, q0, q1, p, z, &S, g);
  } else {
    double Hx[E * E], Hzz[M * M], X[M * 2 * D];
    int piv[M];
    f.ext_full(h, t0, t1, q0, q1, p, z, &S, g, Hx);
    for (int i = 0; i < M; ++i)
      for (int j = 0; j < M; ++j) Hzz[i * M + j] = Hx[(D + i) * E + D + j];
    if (!lu_factor(M, Hzz, piv)) return fail_outputs(D, Ld, D1, D2, D11, D12, D22);
    // X = (d2S/dz2)^-1 d2S/dzdb for the 2 D node variables b, then the Schur complement.
    for (int i = 0; i < M; ++i)
      for (int b = 0; b < 2 * D; ++b) X[i * 2 * D + b] = Hx[(D + i) * E + node(b)];
    for (int b = 0; b < 2 * D; ++b) lu_solve(M, Hzz, piv, X + b, 2 * D);
    // D11 and D22 from their upper triangles, mirrored: exactly symmetric like every other kernel's.
    for (int a = 0; a < 2 * D; ++a) {
      for (int b = a; b < 2 * D; ++b) {
        if (a < D && b >= D && D12 == nullptr) continue;
        double s = Hx[node(a) * E + node(b)];
        for (int i = 0; i < M; ++i) s -= Hx[node(a) * E + D + i] * X[i * 2 * D + b];
        if (a < D && b < D) D11[a * D + b] = D11[b * D + a] = s;
        else if (a < D) D12[a * D + (b - D)] = s;
        else D22[(a - D) * D + (b - D)] = D22[(b - D) * D + (a - D)] = s;
      }
    }
    // D12's lower-left part (a >= D, b < D) is D12 transposed, not an output; the loop above
    // covers D12 whole because b runs over all of q1 for every a in q0.
  }
  if (Ld) *Ld = S;
  for (int a = 0; a < D; ++a) {
    D1[a] = g[a];
    D2[a] = g[D + M + a];
  }
}

}  // namespace pardel_condensation

#endif  // PARDEL_CONDENSATION_HPP
