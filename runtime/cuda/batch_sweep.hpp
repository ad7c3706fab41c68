/**
 * @file batch_sweep.hpp
 * The single-source core of the batched Jacobi and Jacobi-Newton sweeps: one node's update and
 * one problem's decision after a sweep, as PARDEL_HD functions that the device solver
 * (batch_device.cuh) runs one node at a time per thread and once per problem in the problem's
 * last block to finish a sweep, and that host_sweeps()
 * below runs in plain loops (the host path, compiled by any C++ compiler and tested on every
 * build). The arithmetic of a node's update and the stopping rules are those of the CPU solver
 * (runtime/src/jacobi.cpp and runtime/src/iteration.cpp) for problems without knots or a clock:
 * the same closed-form 1x1 and 2x2 solves, the same inner Newton of the nonlinear sweep, the same
 * residual, relative and per-component tests, stall, divergence and non-finite rules.
 */
#ifndef PARDEL_CUDA_BATCH_SWEEP_HPP
#define PARDEL_CUDA_BATCH_SWEEP_HPP

#include <math.h>

#include "pardel/kernel_abi.h"

namespace pardel::batch_sweep {

/** What a problem is doing; the values after `running` follow pardel::Termination's names. */
enum Status : int {
  running = -1,
  converged = 0,
  max_iterations = 1,
  diverged = 2,
  non_finite = 3,
  stalled = 6,
  not_started = 100  ///< left out of the sweeps (its input was refused on the host)
};

/** Settings of the sweeps, shared by every problem of a batch (pardel::Options' fields). */
struct Settings {
  double keep = 1;        ///< 1 - damping
  int steps = 1;          ///< Newton steps per node per sweep (the nonlinear sweep: up to 50)
  int nonlinear = 0;      ///< 1: Jacobi (inner Newton to a tenth of the tolerance), 0: Jacobi-Newton
  double tol = 0, rtol = 1e-10;
  long max_iterations = 1000000;
  double divergence_factor = 1e8;
  int difference = 1;     ///< Newton: the shift's metric is the kinetic form (1) or the identity (0)
};

/** One interval's sweep-kernel outputs. */
template <int D>
struct Interval {
  double D1[D], D2[D], D11[D * D], D22[D * D];
};

/** What the nodes of one problem found in a sweep (maxima over the nodes; -1: no such node). */
template <int D>
struct Stats {
  double residual, scale, qmax;
  double comp_residual[D], comp_scale[D];
  int bad_residual, singular, bad_value;
};

template <int D>
PARDEL_HD inline void clear(Stats<D>& s) {
  s.residual = s.scale = s.qmax = 0;
  for (int i = 0; i < D; ++i) s.comp_residual[i] = s.comp_scale[i] = 0;
  s.bad_residual = s.singular = s.bad_value = -1;
}

/** std::max's rule (a NaN in b is ignored, as the CPU solver's reductions do). */
PARDEL_HD inline double larger(double a, double b) { return a < b ? b : a; }
PARDEL_HD inline int first_node(int a, int b) { return a < 0 ? b : (b < 0 ? a : (a < b ? a : b)); }

/** Folds `b` into `a` (the reduction over nodes, in any order: maxima and minima only). */
template <int D>
PARDEL_HD inline void merge(Stats<D>& a, const Stats<D>& b) {
  a.residual = larger(a.residual, b.residual);
  a.scale = larger(a.scale, b.scale);
  a.qmax = larger(a.qmax, b.qmax);
  for (int i = 0; i < D; ++i) {
    a.comp_residual[i] = larger(a.comp_residual[i], b.comp_residual[i]);
    a.comp_scale[i] = larger(a.comp_scale[i], b.comp_scale[i]);
  }
  a.bad_residual = first_node(a.bad_residual, b.bad_residual);
  a.singular = first_node(a.singular, b.singular);
  a.bad_value = first_node(a.bad_value, b.bad_value);
}

/** The Jacobi scaling of a diagonal entry m: |m|^-1/2, 1 where m is zero or not finite. */
PARDEL_HD inline double jacobi_scale(double m) {
  const double a = fabs(m);
  return a > 0 && isfinite(a) ? 1 / sqrt(a) : 1.0;
}

/** x <- x - M^{-1} r; false when M is singular or not finite: the reciprocal condition number in
 *  the 1-norm of S M S, S = diag(|M_aa|^-1/2), at most 1e-14 (a change of a coordinate's units is
 *  no singularity). Closed forms for 1x1 and 2x2 (those of the CPU solver, operation for
 *  operation, whose solve is M's own); larger blocks as S (S M S)^-1 S r, by Gaussian elimination
 *  with partial pivoting and the exact 1-norm condition number from the inverse. */
template <int D>
PARDEL_HD inline bool newton_step(double* M, double* r, double* x) {
  if constexpr (D == 1) {
    const double m = M[0];
    if (!(fabs(m) > 0) || !isfinite(m)) return false;
    x[0] -= r[0] / m;
    return true;
  } else if constexpr (D == 2) {
    const double a = M[0], b = M[1], c = M[2], e = M[3];
    const double det = a * e - b * c;
    const double sa = jacobi_scale(a), se = jacobi_scale(e);
    const double as = a * sa * sa, bs = b * sa * se, cs = c * sa * se, es = e * se * se;
    const double det_s = as * es - bs * cs;
    const double na = fabs(as) + fabs(cs), nb = fabs(bs) + fabs(es);
    const double norm = na < nb ? nb : na;
    const double ma = fabs(es) + fabs(cs), mb = fabs(bs) + fabs(as);
    const double norm_adj = ma < mb ? mb : ma;
    if (!(fabs(det_s) > 1e-14 * (norm * norm_adj)) || !isfinite(det)) return false;
    const double inv = 1 / det;
    x[0] -= (e * r[0] - b * r[1]) * inv;
    x[1] -= (a * r[1] - c * r[0]) * inv;
    return true;
  } else {
    double sc[D], rs[D];
    for (int i = 0; i < D; ++i) sc[i] = jacobi_scale(M[i * D + i]);
    for (int i = 0; i < D; ++i) {
      for (int j = 0; j < D; ++j) M[i * D + j] *= sc[i] * sc[j];
      rs[i] = sc[i] * r[i];
    }
    double norm = 0;
    for (int j = 0; j < D; ++j) {
      double col = 0;
      for (int i = 0; i < D; ++i) col += fabs(M[i * D + j]);
      norm = larger(norm, col);
    }
    // LU with partial pivoting of M (in place) and the inverse's columns from it.
    int perm[D];
    for (int i = 0; i < D; ++i) perm[i] = i;
    for (int c = 0; c < D; ++c) {
      int p = c;
      for (int i = c + 1; i < D; ++i)
        if (fabs(M[i * D + c]) > fabs(M[p * D + c])) p = i;
      if (!(fabs(M[p * D + c]) > 0) || !isfinite(M[p * D + c])) return false;
      if (p != c) {
        for (int j = 0; j < D; ++j) {
          const double t = M[c * D + j];
          M[c * D + j] = M[p * D + j];
          M[p * D + j] = t;
        }
        const int t = perm[c];
        perm[c] = perm[p];
        perm[p] = t;
      }
      for (int i = c + 1; i < D; ++i) {
        const double f = M[i * D + c] / M[c * D + c];
        M[i * D + c] = f;
        for (int j = c + 1; j < D; ++j) M[i * D + j] -= f * M[c * D + j];
      }
    }
    auto solve = [&](const double* b, double* y) {
      for (int i = 0; i < D; ++i) {
        double v = b[perm[i]];
        for (int j = 0; j < i; ++j) v -= M[i * D + j] * y[j];
        y[i] = v;
      }
      for (int i = D - 1; i >= 0; --i) {
        double v = y[i];
        for (int j = i + 1; j < D; ++j) v -= M[i * D + j] * y[j];
        y[i] = v / M[i * D + i];
      }
    };
    double inv_norm = 0, e[D], col[D];
    for (int j = 0; j < D; ++j) {
      for (int i = 0; i < D; ++i) e[i] = i == j ? 1.0 : 0.0;
      solve(e, col);
      double s = 0;
      for (int i = 0; i < D; ++i) s += fabs(col[i]);
      inv_norm = larger(inv_norm, s);
    }
    if (!(1 / (norm * inv_norm) > 1e-14)) return false;
    double dx[D];
    solve(rs, dx);
    for (int i = 0; i < D; ++i) x[i] -= sc[i] * dx[i];
    return true;
  }
}

/** The DEL residual r = D2 of interval k-1 + D1 of interval k at interior node k, folded into
 *  `stats` (its size, the size of its terms, per component; the node if it is not finite). False
 *  when it is not finite. */
template <int D>
PARDEL_HD inline bool node_residual(int k, const double* left_D2, const double* right_D1, double* r, Stats<D>& stats) {
  double mx = 0, scale = 0;
  bool finite = true;
  for (int i = 0; i < D; ++i) {
    const double a = left_D2[i], b = right_D1[i];
    const double v = a + b;
    if (!isfinite(v)) finite = false;
    scale = larger(scale, fabs(a) + fabs(b));
    stats.comp_residual[i] = larger(stats.comp_residual[i], fabs(v));
    stats.comp_scale[i] = larger(stats.comp_scale[i], fabs(a) + fabs(b));
    r[i] = v;
    mx = larger(mx, fabs(v));
  }
  if (!finite) stats.bad_residual = first_node(stats.bad_residual, k);
  stats.residual = larger(stats.residual, mx);
  stats.scale = larger(stats.scale, scale);
  return finite;
}

/**
 * The update of interior node k of one problem: q, t, h of the problem's N+1 nodes and N
 * intervals, its params p; `left` and `right` the sweep kernel of intervals k-1 and k at the
 * iterate. Writes the next value of the node to `out` and folds the node's residual terms into
 * `stats`. `Kernel::sweep(h, t0, t1, q0, q1, p, D1, D2, D11, D22)` is the model's sweep kernel.
 */
template <class Kernel, int D>
PARDEL_HD inline void update_node(int k, const double* q, const double* t, const double* h, const double* p,
                                  const Interval<D>& left, const Interval<D>& right, const Settings& set,
                                  double* out, Stats<D>& stats) {
  const double eps = 2.220446049250313e-16;
  const double* qk = q + static_cast<long>(k) * D;
  double r[D], x[D], M[D * D];
  const bool finite = node_residual<D>(k, left.D2, right.D1, r, stats);
  for (int i = 0; i < D * D; ++i) M[i] = left.D22[i] + right.D11[i];
  for (int i = 0; i < D; ++i) x[i] = qk[i];
  bool fine = newton_step<D>(M, r, x);
  const int steps = set.nonlinear ? 50 : set.steps;
  Interval<D> a, b;
  for (int m = 1; fine && m < steps; ++m) {
    Kernel::sweep(h[k - 1], t[k - 1], t[k], qk - D, x, p, a.D1, a.D2, a.D11, a.D22);
    Kernel::sweep(h[k], t[k], t[k + 1], x, qk + D, p, b.D1, b.D2, b.D11, b.D22);
    bool inner_done = true;
    for (int i = 0; i < D; ++i) {
      r[i] = a.D2[i] + b.D1[i];
      const double terms = fabs(a.D2[i]) + fabs(b.D1[i]);
      const double floor = 0.1 * set.rtol < 160 * eps ? 160 * eps : 0.1 * set.rtol;
      const double inner_tol = set.tol > 0 ? 0.1 * set.tol : floor * terms;
      if (!(fabs(r[i]) <= inner_tol)) inner_done = false;
    }
    if (set.nonlinear && inner_done) break;
    for (int i = 0; i < D * D; ++i) M[i] = a.D22[i] + b.D11[i];
    fine = newton_step<D>(M, r, x);
  }
  if (!fine && finite) stats.singular = first_node(stats.singular, k);
  double probe = 0;
  for (int i = 0; i < D; ++i) {
    out[i] = qk[i] + set.keep * (x[i] - qk[i]);
    probe += out[i] * 0.0;
    stats.qmax = larger(stats.qmax, fabs(out[i]));
  }
  if (!(probe == 0)) stats.bad_value = first_node(stats.bad_value, k);
}

/** One problem's record between sweeps. */
template <int D>
struct ProblemState {
  int status;           ///< a Status
  int answer;           ///< the buffer (0 or 1) holding the returned iterate once stopped
  long iterations;      ///< the returned iterate's index
  int node;             ///< the node named by a non-finite or singular stop (-1: none)
  int unresolved;       ///< a component above its own target at the stop (-1: none)
  double residual, scale, target;
  double r_initial, best_distance;
  long best_iteration;
  double start_scale[D];  ///< per component, the size of its terms at the first iterate
  double comp_residual[D], comp_target[D];
};

template <int D>
PARDEL_HD inline void start(ProblemState<D>& s) {
  s.status = running;
  s.answer = 0;
  s.iterations = 0;
  s.node = -1;
  s.unresolved = -1;
  s.residual = s.scale = s.target = 0;
  s.r_initial = 0;
  s.best_distance = INFINITY;
  s.best_iteration = 0;
  for (int i = 0; i < D; ++i) s.start_scale[i] = s.comp_residual[i] = s.comp_target[i] = 0;
}

/**
 * The decision after the sweep that read iterate `it` (in buffer it % 2) and wrote iterate it+1:
 * the CPU solver's order of tests (non-finite residual, converged, progress, stalled at round-off,
 * max_iterations, diverged, then the new iterate's singular block, non-finite value or explosion).
 * Stops the problem (status, answer, iterations) or leaves it running.
 */
template <int D>
PARDEL_HD inline void decide(ProblemState<D>& s, const Stats<D>& st, long it, const Settings& set) {
  const double eps = 2.220446049250313e-16;
  const int here = static_cast<int>(it % 2), before = 1 - here;
  if (st.bad_residual >= 0) {
    s.status = non_finite;
    s.node = st.bad_residual;
    s.answer = it > 0 ? before : here;
    s.iterations = it > 0 ? it - 1 : 0;
    s.residual = NAN;
    return;
  }
  if (it == 0)
    for (int i = 0; i < D; ++i) s.start_scale[i] = st.comp_scale[i];
  const double r = st.residual, floor = 16 * eps * st.scale;
  const double target = set.tol > 0 ? set.tol : larger(set.rtol * st.scale, 10 * floor);
  if (it == 0) s.r_initial = r;
  s.residual = r;
  s.scale = st.scale;
  s.target = target;
  int unresolved = -1;
  double distance = r == 0 ? 0 : (target > 0 ? r / target : INFINITY);
  for (int i = 0; i < D; ++i) {
    const double ct = set.tol > 0 ? set.tol
                                  : larger(larger(set.rtol * st.comp_scale[i], 10 * 16 * eps * st.comp_scale[i]),
                                           160 * eps * s.start_scale[i]);
    s.comp_residual[i] = st.comp_residual[i];
    s.comp_target[i] = ct;
    if (!(st.comp_residual[i] <= ct) && unresolved < 0) unresolved = i;
    const double ratio = st.comp_residual[i] == 0 ? 0 : (ct > 0 ? st.comp_residual[i] / ct : INFINITY);
    distance = larger(distance, ratio);
  }
  s.unresolved = unresolved;
  s.answer = here;
  s.iterations = it;
  if (r <= target && unresolved < 0) {
    s.status = converged;
    return;
  }
  if (distance < 0.99 * s.best_distance) {
    s.best_distance = distance;
    s.best_iteration = it;
  }
  if (r <= 10 * floor && it - s.best_iteration >= 200) {
    s.status = stalled;
    return;
  }
  if (it >= set.max_iterations) {
    s.status = max_iterations;
    return;
  }
  if (it > 0 && s.r_initial > 0 && r > set.divergence_factor * s.r_initial) {
    s.status = diverged;
    return;
  }
  if (st.singular >= 0 || st.bad_value >= 0) {
    s.status = non_finite;
    s.node = st.singular >= 0 ? st.singular : st.bad_value;
    return;
  }
  if (st.qmax > 1e150) s.status = diverged;
}

/**
 * The host path: B problems of N intervals each (q: two buffers of B (N+1) D values, the first
 * holding the guesses with their boundary values; t, h shared; p: B x np params), swept until
 * every problem has stopped. Returns the sweeps run. The device solver runs the same two
 * functions on the device (batch_device.cuh).
 */
template <class Kernel, int D>
long host_sweeps(int B, int N, double* q0, double* q1, const double* t, const double* h, const double* p, int np,
                 const Settings& set, ProblemState<D>* state) {
  const long nodes = static_cast<long>(N) + 1;
  for (int b = 0; b < B; ++b) start(state[b]);
  long it = 0;
  for (;; ++it) {
    double* in = it % 2 == 0 ? q0 : q1;
    double* out = it % 2 == 0 ? q1 : q0;
    int running_left = 0;
    for (int b = 0; b < B; ++b) {
      if (state[b].status != running) continue;
      const double* q = in + b * nodes * D;
      double* o = out + b * nodes * D;
      const double* pb = p + static_cast<long>(b) * np;
      Stats<D> st;
      clear(st);
      for (int i = 0; i < D; ++i) {
        o[i] = q[i];
        o[N * D + i] = q[static_cast<long>(N) * D + i];
      }
      for (int k = 1; k < N; ++k) {
        Interval<D> left, right;
        Kernel::sweep(h[k - 1], t[k - 1], t[k], q + (k - 1) * D, q + k * D, pb, left.D1, left.D2, left.D11,
                      left.D22);
        Kernel::sweep(h[k], t[k], t[k + 1], q + k * D, q + (k + 1) * D, pb, right.D1, right.D2, right.D11,
                      right.D22);
        Stats<D> node;
        clear(node);
        update_node<Kernel, D>(k, q, t, h, pb, left, right, set, o + static_cast<long>(k) * D, node);
        merge(st, node);
      }
      decide(state[b], st, it, set);
      if (state[b].status == running) ++running_left;
    }
    if (running_left == 0) return it + 1;
  }
}

}  // namespace pardel::batch_sweep

#endif  // PARDEL_CUDA_BATCH_SWEEP_HPP
