/**
 * @file batch_newton.hpp
 * The single-source core of the batched Newton solver: one problem's Newton iteration on the
 * whole DEL system, as PARDEL_HD functions that the device solver (batch_device.cuh) runs with
 * one thread per problem, and that host_newton() below runs in plain loops over the same layout
 * (the host path, compiled by any C++ compiler and tested on every build).
 *
 * Each iteration follows the CPU solver's trust-region Newton (runtime/src/trust_region.hpp, its
 * constants in runtime/src/constants.hpp): the full Newton step of a positive definite Hessian
 * first, whatever the radius; then steps of the trust-region subproblem (|s|_M <= delta, M the
 * CPU solver's shift metric) at a shrinking radius; acceptance by the ratio of actual to predicted
 * decrease of the action, by a lower residual where the predicted decrease is at the action's
 * round-off, or for a Newton step by a residual below 0.9 of the best; the CPU solver's radius
 * updates; and near a solution its watchdog (a refused Newton step taken anyway, four more Newton
 * steps to bring the action below the reference point's, or back there). Only the subproblem is
 * solved more simply: the shift by bisection on log lambda to within 10 % of the radius (the CPU
 * solver: Newton on the secular equation), and no step along negative curvature where the
 * Hessian is indefinite at the boundary (the hard case) or to escape a saddle, so that the device
 * finds minima only. The Newton system is solved by block LDL^T over the interior nodes, each pivot
 * Cholesky-factored so that success certifies H + lambda M positive definite; the model's full
 * kernel is evaluated once per interval per trial (action, residual and Hessian, streamed interval
 * by interval) into the second of two sets of arrays, which becomes the iterate's when the step is
 * accepted, so that a refusal costs no evaluation of the iterate again. The stopping rules after
 * each accepted step are the sweeps' (batch_sweep::decide: the CPU solver's residual, relative and
 * per-component tests).
 *
 * A problem's arrays are Views with a stride: a batch's problems interleaved (stride B, element i
 * of problem b at i B + b), so that the threads of a warp, one problem each, read consecutive
 * addresses (the device, and host_newton), or one problem's values contiguous (stride 1).
 */
#ifndef PARDEL_CUDA_BATCH_NEWTON_HPP
#define PARDEL_CUDA_BATCH_NEWTON_HPP

#include <math.h>

#include "batch_sweep.hpp"
#include "constants.hpp"
#include "cyclic_reduction.hpp"
#include "pardel/kernel_abi.h"

namespace pardel::batch_newton {

namespace bs = pardel::batch_sweep;

/** Element i of one problem's array: at[i * stride]. */
struct View {
  double* at;
  long stride;
  PARDEL_HD double& operator[](long i) const { return at[i * stride]; }
};

/** One problem's arrays over its N + 1 nodes: two sets (the iterate's and a trial point's) of the
 *  values, the DEL residual at each node, and per node the diagonal Hessian block and the coupling
 *  block D12 of the interval to its right; then the step and the elimination's S_k^-1 B_k. */
template <int D>
struct Arrays {
  View x[2], r[2], A[2], B[2], step, C, ref;  ///< ref: the watchdog's reference point
};

/** Values per problem: (N + 1)(6 D + 5 D^2). */
template <int D>
PARDEL_HD inline long values_per_problem(int N) {
  return (static_cast<long>(N) + 1) * (6 * D + 5 * D * D);
}

/** Problem b's arrays in `base`, which holds `stride` problems' values interleaved (stride 1: one
 *  problem's, contiguous, with b = 0). */
template <int D>
PARDEL_HD inline Arrays<D> arrays(double* base, int N, long stride, long b) {
  const long n1 = static_cast<long>(N) + 1, v = n1 * D, m = n1 * D * D;
  Arrays<D> a;
  const long offsets[11] = {0,         v,         2 * v,     3 * v,     4 * v,    5 * v,
                            6 * v,     6 * v + m, 6 * v + 2 * m, 6 * v + 3 * m, 6 * v + 4 * m};
  View* views[11] = {&a.x[0], &a.x[1], &a.r[0], &a.r[1], &a.step, &a.ref, &a.A[0], &a.A[1], &a.B[0], &a.B[1], &a.C};
  for (int i = 0; i < 11; ++i) *views[i] = View{base + offsets[i] * stride + b, stride};
  return a;
}

/** Why a problem stopped as stalled or non-finite, beyond the sweeps' reasons. */
enum Reason : int {
  none = 0,
  no_descent = 1,      ///< stalled: no step, down to a vanishing radius, was acceptable
  no_definite_shift = 2,  ///< non_finite: no shift made the Hessian positive definite (it is not finite)
  domain_edge = 3         ///< non_finite: trial steps down to a vanishing radius reach non-finite values
};

/** One problem's record between iterations. */
template <int D>
struct State {
  bs::ProblemState<D> s;  ///< status, iterations and the residual tests (batch_sweep::decide)
  int current;            ///< the set of arrays (0 or 1) holding the iterate and its evaluation
  int reason;             ///< a Reason
  double action;          ///< the discrete action at the iterate
  double best_residual;   ///< the smallest DEL residual of the accepted iterates
  double lambda;          ///< the last shift taken, where the next subproblem's search starts
  double delta;           ///< the trust radius in the shift's metric (0: not set yet)
  int wd_active;          ///< the watchdog: Newton steps are being taken past a refused one
  int wd_failed;          ///< the last watchdog was reverted: this iteration solves the subproblem
  int wd_steps;           ///< Newton steps taken under the watchdog
  double wd_action, wd_pred, wd_norm;  ///< at the reference point: action, predicted decrease, step size
  double shift;           ///< the shift of the last accepted step (0: the full Newton step)
  int shifted;            ///< the accepted steps that were shifted
  double rho;             ///< the last accepted step's ratio of actual to predicted decrease
  int refused;            ///< the trial steps refused in the last iteration
};

/**
 * Evaluates the problem at set `which`'s values: the action (returned), and at each interior node
 * the DEL residual (r), the diagonal Hessian block (A) and the coupling block to the next interior
 * node (B) of that set, with the residual's sizes folded into `st` as the sweeps fold them (and
 * the largest |x|, the first node whose value is not finite). `Kernel::full` is the model's full
 * kernel.
 */
template <class Kernel, int D>
PARDEL_HD inline double evaluate(int N, const double* t, const double* h, const double* p, const Arrays<D>& a,
                                 int which, bs::Stats<D>& st) {
  const View x = a.x[which];
  double x0[D], x1[D], Ld, D1[D], D2[D], D11[D * D], D12[D * D], D22[D * D], left_D2[D], left_D22[D * D], r[D];
  double action = 0;
  for (int i = 0; i < D; ++i) x0[i] = x[i];
  for (int j = 0; j < N; ++j) {
    double probe = 0;
    for (int i = 0; i < D; ++i) {
      x1[i] = x[(static_cast<long>(j) + 1) * D + i];
      probe += x1[i] * 0.0;
      st.qmax = bs::larger(st.qmax, fabs(x1[i]));
    }
    if (!(probe == 0)) st.bad_value = bs::first_node(st.bad_value, j + 1);
    Kernel::full(h[j], t[j], t[j + 1], x0, x1, p, &Ld, D1, D2, D11, D12, D22);
    action += Ld;
    if (j >= 1) {  // node j: interval j-1 to its left, j to its right
      bs::node_residual<D>(j, left_D2, D1, r, st);
      const long at = static_cast<long>(j) * D, block = static_cast<long>(j) * D * D;
      for (int i = 0; i < D; ++i) a.r[which][at + i] = r[i];
      for (int i = 0; i < D * D; ++i) a.A[which][block + i] = left_D22[i] + D11[i];
      if (j + 1 <= N - 1)
        for (int i = 0; i < D * D; ++i) a.B[which][block + i] = D12[i];
    }
    for (int i = 0; i < D; ++i) {
      left_D2[i] = D2[i];
      x0[i] = x1[i];
    }
    for (int i = 0; i < D * D; ++i) left_D22[i] = D22[i];
  }
  return action;
}

/** Cholesky factor of the symmetric D x D matrix S in place (lower triangle); false when a pivot is
 *  not a positive finite number (cyclic_reduction.hpp's, the block operations of both solvers). */
template <int D>
PARDEL_HD inline bool cholesky(double* S) {
  return cyclic_reduction::factor_block<D>(S, D);
}

/** y <- (L L^T)^-1 y for the factor L of cholesky(). */
template <int D>
PARDEL_HD inline void cholesky_solve(const double* L, double* y) {
  cyclic_reduction::solve_block<D>(L, y, 1, D);
}

/**
 * step = -(H + shift M)^-1 r over the interior nodes 1 .. N-1 by block LDL^T (block Thomas), M the
 * metric of the shift: the identity, or (difference = 1) the kinetic form tridiag(-1, 2, -1) per
 * component, as the CPU solver's Options::newton_shift. With the shifted blocks A'_k and B'_k:
 * S_1 = A'_1, S_k = A'_k - B'_{k-1}^T C_{k-1} with C_k = S_k^-1 B'_k, each S_k Cholesky-factored.
 * False, with the step unfinished, where a pivot is not positive definite.
 */
template <int D>
PARDEL_HD inline bool direction(int N, double shift, int difference, const Arrays<D>& a, int set = 0) {
  const double diagonal = difference ? 2 * shift : shift, off = difference ? shift : 0.0;
  const View A = a.A[set], B = a.B[set], r = a.r[set];
  double S[D * D], y[D], z[D], col[D];
  for (int i = 0; i < D; ++i) z[i] = 0;
  for (int k = 1; k <= N - 1; ++k) {
    const long at = static_cast<long>(k) * D, block = static_cast<long>(k) * D * D;
    const long before = block - static_cast<long>(D) * D;
    for (int i = 0; i < D * D; ++i) S[i] = A[block + i];
    for (int i = 0; i < D; ++i) {
      S[i * D + i] += diagonal;
      y[i] = r[at + i];
    }
    if (k >= 2) {
      // S -= B'_{k-1}^T C_{k-1};  y -= B'_{k-1}^T z_{k-1}
      for (int i = 0; i < D; ++i) {
        for (int j = 0; j < D; ++j) {
          double v = 0;
          for (int m = 0; m < D; ++m) v += (B[before + m * D + i] - (m == i ? off : 0.0)) * a.C[before + m * D + j];
          S[i * D + j] -= v;
        }
        double w = 0;
        for (int m = 0; m < D; ++m) w += (B[before + m * D + i] - (m == i ? off : 0.0)) * z[m];
        y[i] -= w;
      }
    }
    if (!cholesky<D>(S)) return false;
    cholesky_solve<D>(S, y);
    for (int i = 0; i < D; ++i) {
      z[i] = y[i];
      a.step[at + i] = y[i];
    }
    if (k <= N - 2) {
      for (int j = 0; j < D; ++j) {
        for (int i = 0; i < D; ++i) col[i] = B[block + i * D + j] - (i == j ? off : 0.0);
        cholesky_solve<D>(S, col);
        for (int i = 0; i < D; ++i) a.C[block + i * D + j] = col[i];
      }
    }
  }
  // Back substitution: x_k = z_k - C_k x_{k+1}; then the step is -x.
  for (int k = N - 2; k >= 1; --k) {
    const long at = static_cast<long>(k) * D, block = static_cast<long>(k) * D * D;
    for (int i = 0; i < D; ++i) {
      double v = 0;
      for (int j = 0; j < D; ++j) v += a.C[block + i * D + j] * a.step[at + D + j];
      a.step[at + i] -= v;
    }
  }
  for (long i = D; i < static_cast<long>(N) * D; ++i) a.step[i] = -a.step[i];
  for (int i = 0; i < D; ++i) a.step[i] = a.step[static_cast<long>(N) * D + i] = 0;
  return true;
}

/** s^T H s for the step s and the Hessian of set `which` (A on the diagonal, B above, B^T below). */
template <int D>
PARDEL_HD inline double curvature(int N, const Arrays<D>& a, int which) {
  const View A = a.A[which], B = a.B[which], s = a.step;
  double sum = 0;
  for (int k = 1; k <= N - 1; ++k) {
    const long at = static_cast<long>(k) * D, block = static_cast<long>(k) * D * D;
    for (int i = 0; i < D; ++i) {
      double row = 0;
      for (int j = 0; j < D; ++j) row += A[block + i * D + j] * s[at + j];
      if (k <= N - 2)
        for (int j = 0; j < D; ++j) row += 2 * B[block + i * D + j] * s[at + D + j];
      sum += s[at + i] * row;
    }
  }
  return sum;
}

/** The first evaluation of a problem whose guess (with its boundary values) is in set 0, and the
 *  decision on it (iteration 0). */
template <class Kernel, int D>
PARDEL_HD inline void start(int N, const double* t, const double* h, const double* p, const bs::Settings& set,
                            const Arrays<D>& a, State<D>& ns) {
  bs::start(ns.s);
  ns.current = 0;
  ns.reason = none;
  ns.lambda = 0;
  ns.delta = 0;
  ns.wd_active = ns.wd_failed = ns.wd_steps = 0;
  ns.wd_action = ns.wd_pred = ns.wd_norm = 0;
  ns.shift = 0;
  ns.shifted = 0;
  ns.rho = 0;
  ns.refused = 0;
  bs::Stats<D> st;
  bs::clear(st);
  ns.action = evaluate<Kernel, D>(N, t, h, p, a, 0, st);
  ns.best_residual = st.residual;
  if (st.bad_value >= 0 || !isfinite(ns.action)) st.bad_residual = bs::first_node(st.bad_residual, st.bad_value);
  bs::decide(ns.s, st, 0, set);
}

/** |v|_M over the interior nodes (v taken as zero at nodes 0 and N): sqrt(v^T M v), M the
 *  kinetic form (difference = 1) or the identity. */
PARDEL_HD inline double metric_norm(int N, int D, const View& v, int difference) {
  double sum = 0;
  for (long i = D; i < static_cast<long>(N) * D; ++i) {
    const double d = difference && i >= 2L * D ? v[i] - v[i - D] : v[i];
    sum += d * d;
  }
  if (difference)
    for (long i = (static_cast<long>(N) - 1) * D; i < static_cast<long>(N) * D; ++i) sum += v[i] * v[i];
  return sqrt(sum);
}

/**
 * The step of the trust-region subproblem at radius delta (|s|_M <= delta) into a.step: the shift
 * lambda of H + lambda M whose step has |s|_M within 10 % of delta, by bisection on log lambda
 * from the last shift (grown 4-fold until bracketed); a step still longer than delta is cut back
 * to it (still a descent direction of the model). Returns its norm, 0 where no positive definite
 * shift was found; *lambda is the shift taken.
 */
template <int D>
PARDEL_HD inline double radius_step(int N, int difference, double delta, double largest, const Arrays<D>& a, int here,
                                    double* lambda) {
  const double tiny = 1e-14 * largest;
  double lo = 0, hi = INFINITY, best = -1, best_norm = 0, l = bs::larger(*lambda, tiny);
  bool step_is_best = false;  // a.step holds the step of `best`
  for (int it = 0; it < 40; ++it) {
    step_is_best = false;
    if (!direction<D>(N, l, difference, a, here)) {
      lo = l;
    } else {
      const double norm = metric_norm(N, D, a.step, difference);
      best = l;
      best_norm = norm;
      step_is_best = true;
      if (fabs(norm - delta) <= 0.1 * delta) break;
      if (norm > delta) {
        lo = l;
      } else {
        hi = l;
        if (hi <= tiny) break;  // inside the radius at the smallest shift
      }
    }
    if (isfinite(hi) && hi - lo <= 1e-9 * hi) break;
    l = isfinite(hi) ? (lo > 0 ? sqrt(lo * hi) : 0.5 * hi) : 4 * l;
  }
  if (best < 0) return 0;
  if (!step_is_best) {
    if (!direction<D>(N, best, difference, a, here)) return 0;
    best_norm = metric_norm(N, D, a.step, difference);
  }
  *lambda = best;
  if (best_norm > 1.1 * delta) {
    const double c = delta / best_norm;
    for (long i = D; i < static_cast<long>(N) * D; ++i) a.step[i] *= c;
    best_norm = delta;
  }
  return best_norm;
}

/** The iterate becomes the point in set `to`, already evaluated (`st`, `action`), and is decided
 *  on as iteration iterations + 1. */
template <int D>
PARDEL_HD inline void take(State<D>& ns, int to, double action, const bs::Stats<D>& st, const bs::Settings& set) {
  ns.current = to;
  ns.action = action;
  if (st.residual < ns.best_residual) ns.best_residual = st.residual;
  bs::decide(ns.s, st, ns.s.iterations + 1, set);
}

/**
 * One Newton iteration of a running problem whose evaluation at the iterate is in set
 * ns.current, by the rules of the CPU solver's trust-region Newton (runtime/src/trust_region.hpp),
 * which differ here only in how the subproblem is solved (radius_step, with no step along
 * negative curvature): the full Newton step of a positive definite Hessian first, whatever the
 * radius; then trust-region steps at a shrinking radius; acceptance by the ratio of actual to
 * predicted decrease of the action, by a decrease of the residual where the predicted decrease is
 * at the action's round-off, or for a Newton step by a residual below 0.9 of the best; near a
 * solution a refused Newton step taken anyway under the watchdog (four more Newton steps must
 * bring the action below the reference point's, or the iteration returns there).
 */
template <class Kernel, int D>
PARDEL_HD inline void iterate(int N, const double* t, const double* h, const double* p, const bs::Settings& set,
                              const Arrays<D>& a, State<D>& ns) {
  using namespace pardel::detail;  // the CPU solver's constants
  const int here = ns.current, there = 1 - here;
  double largest = 0;
  for (int k = 1; k <= N - 1; ++k)
    for (int i = 0; i < D; ++i)
      largest = bs::larger(largest, fabs(a.A[here][static_cast<long>(k) * D * D + i * D + i]));
  if (!(largest > 0) || !isfinite(largest)) largest = 1;
  const View q = a.x[here], trial = a.x[there], r = a.r[here];
  const long n = (static_cast<long>(N) + 1) * D;
  for (int i = 0; i < D; ++i) {
    trial[i] = q[i];
    trial[n - D + i] = q[n - D + i];
  }
  const double F = ns.action, r0 = ns.s.residual;
  if (r0 < ns.best_residual) ns.best_residual = r0;
  bool newton = !ns.wd_failed && direction<D>(N, 0, set.difference, a, here);
  ns.wd_failed = 0;
  if (ns.wd_active && (ns.wd_steps >= kWatchdogSteps || !newton)) {
    // The watchdog found no decrease: back to its reference point, whose next step is solved
    // within a radius below the refused Newton step.
    ns.wd_active = 0;
    ns.wd_failed = 1;
    for (long i = 0; i < n; ++i) trial[i] = a.ref[i];
    ns.delta = bs::larger(0, ns.delta < 0.5 * ns.wd_norm ? ns.delta : 0.5 * ns.wd_norm);
    bs::Stats<D> st;
    bs::clear(st);
    const double action = evaluate<Kernel, D>(N, t, h, p, a, there, st);
    take(ns, there, action, st, set);
    return;
  }
  bool definite = newton, all_nonfinite = true;  // every trial so far reached a non-finite value
  int nonfinite_trials = 0, nonfinite_node = -1;
  for (int attempt = 0; attempt < 60; ++attempt) {
    double lambda = 0, norm = 0;
    const bool is_newton = newton;
    if (newton) {
      newton = false;  // tried once per iteration
      norm = metric_norm(N, D, a.step, set.difference);
      if (ns.delta <= 0) ns.delta = norm;
    } else if (ns.delta <= 0) {
      // An indefinite Hessian at the first step: the first positive definite shift, growing
      // 4-fold from 1e-6 of the largest diagonal entry, sets the radius.
      lambda = bs::larger(ns.lambda, 1e-6 * largest);
      bool ok = false;
      for (int i = 0; i < 60 && !(ok = direction<D>(N, lambda, set.difference, a, here)); ++i) lambda *= 4;
      if (!ok) break;
      norm = ns.delta = metric_norm(N, D, a.step, set.difference);
      definite = true;
    } else {
      lambda = ns.lambda;
      norm = radius_step<D>(N, set.difference, ns.delta, largest, a, here, &lambda);
      if (!(norm > 0)) break;
      definite = true;
    }
    double slope = 0;  // r . step
    for (long i = D; i < n - D; ++i) slope += r[i] * a.step[i];
    const double pred = -(slope + 0.5 * curvature<D>(N, a, here));  // the model's decrease
    for (long i = D; i < n - D; ++i) trial[i] = q[i] + a.step[i];
    bs::Stats<D> st;
    bs::clear(st);
    const double Fn = evaluate<Kernel, D>(N, t, h, p, a, there, st);
    const bool finite = st.bad_residual < 0 && st.bad_value < 0 && isfinite(Fn);
    // The CPU solver's judgement (trust_region.hpp, judge()).
    bool accepted = false, by_residual = false;
    double rho = 0;
    if (finite) {
      const double ared = F - Fn, roundoff = 1e-13 * (1 + fabs(F));
      if (!(pred > roundoff)) {
        accepted = (st.residual < r0) && (ared > -roundoff);
        rho = accepted ? 1 : 0;
      } else {
        rho = ared / pred;
        if (rho >= kAcceptRatio) {
          accepted = true;
        } else if (is_newton && st.residual <= kResidualAccept * ns.best_residual) {
          accepted = by_residual = true;
        }
      }
    }
    if (is_newton && finite && ns.wd_active) {
      // Newton steps are taken as they come until the action falls below the reference point's by
      // a fraction of what was predicted there, or the budget is spent.
      ++ns.wd_steps;
      if (Fn < ns.wd_action - 1e-4 * ns.wd_pred) {
        ns.wd_active = 0;
        accepted = true;
      } else if (ns.wd_steps < kWatchdogSteps) {
        accepted = true;
      }
    } else if (is_newton && finite && !accepted && !ns.wd_active && r0 <= kWatchdogResidual * ns.s.scale) {
      // A full Newton step that the action refuses (a curved valley): taken anyway, with the
      // present point kept as the reference to return to.
      ns.wd_active = 1;
      ns.wd_steps = 0;
      ns.wd_action = F;
      ns.wd_pred = pred;
      ns.wd_norm = norm;
      for (long i = 0; i < n; ++i) a.ref[i] = q[i];
      accepted = true;
      rho = 1;
    }
    if (accepted) {
      if (rho < kShrinkRatio && !by_residual)
        ns.delta = 0.5 * norm;
      else if (rho > kExpandRatio && norm >= kBoundaryShare * ns.delta)
        ns.delta = bs::larger(ns.delta, 2 * norm);
      else if (by_residual || is_newton)
        ns.delta = bs::larger(ns.delta, norm);
      if (lambda > 0) {
        ns.lambda = lambda;
        ++ns.shifted;
      }
      ns.shift = lambda;
      ns.rho = rho;
      ns.refused = attempt;
      take(ns, there, Fn, st, set);
      return;
    }
    if (!finite) {
      if (nonfinite_trials++ == 0) nonfinite_node = st.bad_residual >= 0 ? st.bad_residual : st.bad_value;
    } else {
      all_nonfinite = false;
    }
    if (is_newton && norm > ns.delta) continue;  // the full step beyond the radius: now within it
    ns.delta = 0.25 * (ns.delta < norm ? ns.delta : norm);
    if (!(ns.delta > 1e-15 * bs::larger(1.0, metric_norm(N, D, q, set.difference)))) break;
  }
  // The iterate stays in set `here`; its record (residual, tests) is the last decision's. As the CPU
  // solver decides: steps down to a vanishing one that reach non-finite values (all of them, or some
  // while the residual is above its round-off level) mean the model's domain ends next to the
  // iterate; otherwise the iteration stalled.
  const double eps = 2.220446049250313e-16;
  if (!definite) {
    ns.s.status = bs::non_finite;
    ns.reason = no_definite_shift;
  } else if (nonfinite_trials > 0 && (all_nonfinite || r0 > 10 * 16 * eps * ns.s.scale)) {
    ns.s.status = bs::non_finite;
    ns.reason = domain_edge;
    ns.s.node = nonfinite_node;
  } else {
    ns.s.status = bs::stalled;
    ns.reason = no_descent;
  }
}

/** Up to `count` iterations of a problem, fewer when it stops. */
template <class Kernel, int D>
PARDEL_HD inline void advance(int N, const double* t, const double* h, const double* p, const bs::Settings& set,
                              const Arrays<D>& a, State<D>& ns, int count) {
  for (int c = 0; c < count && ns.s.status == bs::running; ++c) iterate<Kernel, D>(N, t, h, p, set, a, ns);
}

/**
 * The host path: B problems of N intervals each (q: B (N+1) D values, the guesses with their
 * boundary values in, the answers out; t, h shared; p: B x np params), laid out and advanced as
 * the device solver does it with one thread per problem (batch_device.cuh): the batch's arrays
 * interleaved in `work` (B values_per_problem<D>(N) doubles, element i of problem b at i B + b),
 * each problem started, then advanced `check_every` iterations at a time until none runs.
 * Returns the rounds of check_every iterations.
 */
template <class Kernel, int D>
long host_newton(int B, int N, double* q, const double* t, const double* h, const double* p, int np,
                 const bs::Settings& set, int check_every, double* work, State<D>* state) {
  const long n = (static_cast<long>(N) + 1) * D;
  for (int b = 0; b < B; ++b) {
    const Arrays<D> a = arrays<D>(work, N, B, b);
    for (long i = 0; i < n; ++i) a.x[0][i] = q[b * n + i];
    start<Kernel, D>(N, t, h, p + static_cast<long>(b) * np, set, a, state[b]);
  }
  long rounds = 0;
  for (bool running = true; running; ++rounds) {
    running = false;
    for (int b = 0; b < B; ++b) {
      if (state[b].s.status != bs::running) continue;
      advance<Kernel, D>(N, t, h, p + static_cast<long>(b) * np, set, arrays<D>(work, N, B, b), state[b], check_every);
      running = running || state[b].s.status == bs::running;
    }
  }
  for (int b = 0; b < B; ++b) {
    const Arrays<D> a = arrays<D>(work, N, B, b);
    for (long i = 0; i < n; ++i) q[b * n + i] = a.x[state[b].current][i];
  }
  return rounds;
}

}  // namespace pardel::batch_newton

#endif  // PARDEL_CUDA_BATCH_NEWTON_HPP
