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
 *
 * The same steps run in extended precision (pd_quad, pardel/extended_kernels.hpp) for the
 * grad_extended and full_extended kernels of iterative refinement: the interior values found in
 * double are refined by Newton's method in pd_quad with the extended interval kernels, and the
 * outputs are written as double-double pairs.
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

/** The extended-precision interval kernels (no starting values: the double solve gives them). */
template <class S>
struct ExtendedInterval {
  void (*interior)(S h, S t0, S t1, const S* q0, const S* q1, const S* p, const S* z, S* g, S* H);
  void (*ext_grad)(S h, S t0, S t1, const S* q0, const S* q1, const S* p, const S* z, S* Sz, S* g);
  void (*ext_full)(S h, S t0, S t1, const S* q0, const S* q1, const S* p, const S* z, S* Sz, S* g, S* H);
};

// The arithmetic the steps below need, for double (the std:: functions) and for an extended type.
inline double magnitude(double x) { return std::fabs(x); }
template <class S>
S magnitude(S x) {
  return x < 0 ? -x : x;
}
inline bool finite(double x) { return std::isfinite(x); }
template <class S>
bool finite(S x) {
  return x - x == x - x;  // NaN for an infinity or a NaN
}
inline double larger(double a, double b) { return std::fmax(a, b); }
template <class S>
S larger(S a, S b) {
  return a < b ? b : a;
}
template <class S>
S epsilon_of() {
  static const S eps = [] {
    S e = 1;
    while (S(1) + e / 2 != S(1)) e /= 2;
    return e;
  }();
  return eps;
}
template <>
inline double epsilon_of<double>() {
  return std::numeric_limits<double>::epsilon();
}

/** LU factorization with partial pivoting of the n x n row-major A in place; false when a pivot
 *  is zero or not finite. */
template <class S>
bool lu_factor(int n, S* A, int* piv) {
  for (int k = 0; k < n; ++k) {
    int best = k;
    for (int i = k + 1; i < n; ++i)
      if (magnitude(A[i * n + k]) > magnitude(A[best * n + k])) best = i;
    piv[k] = best;
    if (!(magnitude(A[best * n + k]) > 0) || !finite(A[best * n + k])) return false;
    if (best != k)
      for (int j = 0; j < n; ++j) {
        const S t = A[k * n + j];
        A[k * n + j] = A[best * n + j];
        A[best * n + j] = t;
      }
    const S inv = S(1) / A[k * n + k];
    for (int i = k + 1; i < n; ++i) {
      const S f = A[i * n + k] *= inv;
      if (f != 0)
        for (int j = k + 1; j < n; ++j) A[i * n + j] -= f * A[k * n + j];
    }
  }
  return true;
}

/** Solves A x = b with lu_factor's result; b (n entries, stride `stride`) is overwritten by x. */
template <class S>
void lu_solve(int n, const S* A, const int* piv, S* b, int stride = 1) {
  // The row exchanges first (lu_factor exchanged whole rows, multipliers included), then L and U.
  for (int k = 0; k < n; ++k) {
    if (piv[k] != k) {
      const S t = b[k * stride];
      b[k * stride] = b[piv[k] * stride];
      b[piv[k] * stride] = t;
    }
  }
  for (int k = 0; k < n; ++k)
    for (int i = k + 1; i < n; ++i) b[i * stride] -= A[i * n + k] * b[k * stride];
  for (int k = n - 1; k >= 0; --k) {
    S s = b[k * stride];
    for (int j = k + 1; j < n; ++j) s -= A[k * n + j] * b[j * stride];
    b[k * stride] = s / A[k * n + k];
  }
}

/**
 * Newton's method on dS/dz = 0 from the values in z, with interior(z, g, H) giving dS/dz and
 * d2S/dz2. Converged when a step changes every entry of z by at most 8 eps times the size of its
 * coordinate on the interval (its nodes' jets scaled to the interval, sum_k h^k (|x0^(k)| +
 * |x1^(k)|), and the magnitudes of all its interior coefficients: a coefficient, or a node's
 * value, may be zero, where its own size would leave only round-off to compare the step with), or
 * when the steps stop decreasing below 1e-8 of that size (round-off). eps is T's. No
 * stop on the step that quadratic convergence predicts next: D1 and D2 are first order in the
 * error of z, and a prediction made from a step before the quadratic regime left them 2.5e-11 off
 * (relative) on an interval of a torus geodesic (tests/python/test_condensation_accuracy.py).
 * @tparam D the dimension of a node point, N the number of coordinates, M = interior values
 */
template <class T, int D, int N, int M, class Interior>
bool newton_interior(Interior&& interior, T h, const T* q0, const T* q1, T* z) {
  const T eps = epsilon_of<T>();
  constexpr int kMaxIterations = 40;
  T g[M], H[M * M];
  int piv[M];
  const T infinity = T(std::numeric_limits<double>::infinity());
  T previous = infinity;
  for (int it = 0; it < kMaxIterations; ++it) {
    interior(z, g, H);
    if (!lu_factor(M, H, piv)) return false;
    lu_solve(M, H, piv, g);
    T size[N];  // each coordinate's size: its nodes' jets on the interval and its interior coefficients
    for (int c = 0; c < N; ++c) {
      T scale = 1;  // h^k
      size[c] = 0;
      for (int k = c; k < D; k += N, scale *= magnitude(h)) size[c] += scale * (magnitude(q0[k]) + magnitude(q1[k]));
    }
    for (int i = 0; i < M; ++i) {
      z[i] -= g[i];
      if (!finite(z[i])) return false;
      size[i % N] += magnitude(z[i]);
    }
    T ratio = 0;  // the largest step relative to its coordinate's size
    bool small = true;
    for (int i = 0; i < M; ++i) {
      const T step = magnitude(g[i]), scale = size[i % N];
      if (step > 8 * eps * scale) small = false;
      ratio = scale > 0 ? larger(ratio, step / scale) : (step > 0 ? infinity : ratio);
    }
    if (small) return true;
    if (ratio >= previous && ratio <= T(1e-8)) return true;
    previous = ratio;
  }
  return false;
}

/** The interior values of the double interval kernels: z's starting values, then newton_interior. */
template <int D, int N, int M>
bool solve_interior(const Interval& f, double h, double t0, double t1, const double* q0, const double* q1,
                    const double* p, double* z) {
  f.start(h, t0, t1, q0, q1, p, z);
  return newton_interior<double, D, N, M>(
      [&](const double* x, double* g, double* H) { f.interior(h, t0, t1, q0, q1, p, x, g, H); }, h, q0, q1, z);
}

/** d2S/dz2 (M x M, row-major) at the interior values z* that the condensed kernels find
 *  (pardel_interior_hessian_kernel); every entry NaN where they cannot be found. */
template <int D, int N, int M>
void interior_hessian(const Interval& f, double h, double t0, double t1, const double* q0, const double* q1,
                      const double* p, double* H) {
  double z[M], g[M];
  if (!solve_interior<D, N, M>(f, h, t0, t1, q0, q1, p, z)) {
    for (int i = 0; i < M * M; ++i) H[i] = std::numeric_limits<double>::quiet_NaN();
    return;
  }
  f.interior(h, t0, t1, q0, q1, p, z, g, H);
}

/** g(h, t0, t1, q0, q1, p, z) at the interval's interior values z* (dS/dz = 0, as the condensed
 *  kernels find them): an integral over the interval's polynomial, such as the clock's
 *  (pardel_discretization::travel); NaN where they cannot be found. */
template <int D, int N, int M, class G>
double interior_integral(const Interval& f, G&& g, double h, double t0, double t1, const double* q0, const double* q1,
                         const double* p) {
  double z[M];
  if (!solve_interior<D, N, M>(f, h, t0, t1, q0, q1, p, z)) return std::numeric_limits<double>::quiet_NaN();
  return g(h, t0, t1, q0, q1, p, z);
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
 * interval condensed at the interior values z, with ext_grad(z, S, g) and ext_full(z, S, g, H) its
 * action's derivatives over x = [q0, z, q1]; false (nothing written) where d2S/dz2 is singular.
 * Ld and the gradient are the envelope values S(z*) and dS/da(z*).
 */
template <class T, int D, int N, int M, class Grad, class Full>
bool condense_at(Grad&& ext_grad, Full&& ext_full, const T* z, T* Ld, T* D1, T* D2, T* D11, T* D12, T* D22) {
  constexpr int E = 2 * D + M;
  T action, g[E];
  auto node = [](int a) { return a < D ? a : D + M + (a - D); };  // index in x = [q0, z, q1]
  if (D11 == nullptr) {
    ext_grad(z, &action, g);
  } else {
    T Hx[E * E], Hzz[M * M], X[M * 2 * D];
    int piv[M];
    ext_full(z, &action, g, Hx);
    for (int i = 0; i < M; ++i)
      for (int j = 0; j < M; ++j) Hzz[i * M + j] = Hx[(D + i) * E + D + j];
    if (!lu_factor(M, Hzz, piv)) return false;
    // X = (d2S/dz2)^-1 d2S/dzdb for the 2 D node variables b, then the Schur complement.
    for (int i = 0; i < M; ++i)
      for (int b = 0; b < 2 * D; ++b) X[i * 2 * D + b] = Hx[(D + i) * E + node(b)];
    for (int b = 0; b < 2 * D; ++b) lu_solve(M, Hzz, piv, X + b, 2 * D);
    // D11 and D22 from their upper triangles, mirrored: exactly symmetric like every other kernel's.
    for (int a = 0; a < 2 * D; ++a) {
      for (int b = a; b < 2 * D; ++b) {
        if (a < D && b >= D && D12 == nullptr) continue;
        T s = Hx[node(a) * E + node(b)];
        for (int i = 0; i < M; ++i) s -= Hx[node(a) * E + D + i] * X[i * 2 * D + b];
        if (a < D && b < D) D11[a * D + b] = D11[b * D + a] = s;
        else if (a < D) D12[a * D + (b - D)] = s;
        else D22[(a - D) * D + (b - D)] = D22[(b - D) * D + (a - D)] = s;
      }
    }
    // D12's lower-left part (a >= D, b < D) is D12 transposed, not an output; the loop above
    // covers D12 whole because b runs over all of q1 for every a in q0.
  }
  if (Ld) *Ld = action;
  for (int a = 0; a < D; ++a) {
    D1[a] = g[a];
    D2[a] = g[D + M + a];
  }
  return true;
}

/** Ld, D1, D2 and, when D11 is not null, D11, D12 (unless null: the sweep kernel) and D22 of the
 *  condensed interval; every output NaN where it cannot be condensed. */
template <int D, int N, int M>
void condensed(const Interval& f, double h, double t0, double t1, const double* q0, const double* q1,
               const double* p, double* Ld, double* D1, double* D2, double* D11, double* D12, double* D22) {
  double z[M];
  if (!solve_interior<D, N, M>(f, h, t0, t1, q0, q1, p, z) ||
      !condense_at<double, D, N, M>(
          [&](const double* x, double* a, double* g) { f.ext_grad(h, t0, t1, q0, q1, p, x, a, g); },
          [&](const double* x, double* a, double* g, double* H) { f.ext_full(h, t0, t1, q0, q1, p, x, a, g, H); },
          z, Ld, D1, D2, D11, D12, D22))
    fail_outputs(D, Ld, D1, D2, D11, D12, D22);
}

/** n values of T as double-double pairs out[2i] + out[2i+1]. */
template <class T>
void split_pairs(const T* v, double* out, int n) {
  for (int i = 0; i < n; ++i) {
    out[2 * i] = static_cast<double>(v[i]);
    out[2 * i + 1] = static_cast<double>(v[i] - static_cast<T>(out[2 * i]));
  }
}

/**
 * The condensed interval in extended precision T (the kernels grad_extended and, with D11 not
 * null, full_extended of pardel/kernel_abi.h): the interior values found in double, refined by
 * newton_interior in T with the extended kernels `x`, and the outputs of condense_at in T written
 * as double-double pairs (Ld 2, D1 and D2 2 D, D11, D12 and D22 2 D^2 values each); every value NaN
 * where the interval cannot be condensed. P: the model's params.
 */
template <class T, int D, int N, int M, int P>
void condensed_extended(const Interval& f, const ExtendedInterval<T>& x, double h, double t0, double t1,
                        const double* q0, const double* q1, const double* p, double* Ld, double* D1, double* D2,
                        double* D11, double* D12, double* D22) {
  double z[M];
  T zq[M], a[D], b[D], pq[P + 1], Lq, D1q[D], D2q[D], D11q[D * D], D12q[D * D], D22q[D * D];
  const T hq = h, t0q = t0, t1q = t1;
  for (int i = 0; i < D; ++i) {
    a[i] = q0[i];
    b[i] = q1[i];
  }
  for (int i = 0; i < P; ++i) pq[i] = p[i];
  bool done = solve_interior<D, N, M>(f, h, t0, t1, q0, q1, p, z);
  if (done) {
    for (int i = 0; i < M; ++i) zq[i] = z[i];
    done = newton_interior<T, D, N, M>(
        [&](const T* w, T* g, T* H) { x.interior(hq, t0q, t1q, a, b, pq, w, g, H); }, hq, a, b, zq);
  }
  const bool full = D11 != nullptr;
  done = done && condense_at<T, D, N, M>(
                     [&](const T* w, T* s, T* g) { x.ext_grad(hq, t0q, t1q, a, b, pq, w, s, g); },
                     [&](const T* w, T* s, T* g, T* H) { x.ext_full(hq, t0q, t1q, a, b, pq, w, s, g, H); }, zq, &Lq,
                     D1q, D2q, full ? D11q : nullptr, full ? D12q : nullptr, full ? D22q : nullptr);
  if (!done) {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    for (int i = 0; i < 2; ++i) Ld[i] = nan;
    for (int i = 0; i < 2 * D; ++i) D1[i] = D2[i] = nan;
    for (int i = 0; full && i < 2 * D * D; ++i) D11[i] = D12[i] = D22[i] = nan;
    return;
  }
  split_pairs(&Lq, Ld, 1);
  split_pairs(D1q, D1, D);
  split_pairs(D2q, D2, D);
  if (full) {
    split_pairs(D11q, D11, D * D);
    split_pairs(D12q, D12, D * D);
    split_pairs(D22q, D22, D * D);
  }
}

}  // namespace pardel_condensation

#endif  // PARDEL_CONDENSATION_HPP
