/**
 * @file iterative_refinement.cpp
 * Iterative refinement of a converged solution with the DEL residual in extended precision
 * (iterative_refinement.hpp; docs/solvers.md, "Iterative refinement").
 */
#include "iterative_refinement.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "block_tridiagonal.hpp"

namespace pardel::detail {
namespace {

/** s + e = a + b exactly (Knuth's two-sum). */
inline void two_sum(double a, double b, double* s, double* e) {
  *s = a + b;
  const double bb = *s - a;
  *e = (a - (*s - bb)) + (b - bb);
}

/** (ah + al) + (bh + bl) in double-double, rounded once to double. */
inline double dd_sum(double ah, double al, double bh, double bl) {
  double s = 0, e = 0;
  two_sum(ah, bh, &s, &e);
  return s + (e + al + bl);
}

double max_abs(const std::vector<double>& v, std::size_t from, std::size_t to) {
  double m = 0;
  for (std::size_t i = from; i < to; ++i) m = std::max(m, std::fabs(v[i]));
  return m;
}

template <int D>
void refine_dim(Context& ctx, const Options& options, Summary& summary) {
  const int d = ctx.dim, N = ctx.N;
  const std::size_t dz = static_cast<std::size_t>(d), nodes = static_cast<std::size_t>(N) + 1;
  const double eps = std::numeric_limits<double>::epsilon();
  char buf[400];
  ensure_interval_arrays(ctx, Evaluated::full);
  if (ctx.evaluated != Evaluated::full) eval_full(ctx, ctx.q);
  BlockTridiagonal<D> H;
  H.resize(N, d);
  H.assemble(ctx, 0.0);
  if (!H.factor_ldlt() && !H.factor_indefinite(1e-12)) {
    summary.refinement_note = "not run: the Hessian at the solution is singular to working precision";
    return;
  }
  std::vector<double> pairs, res, delta(nodes * dz, 0.0), start = ctx.q;
  const std::size_t first = dz, last = static_cast<std::size_t>(N) * dz;  // unknowns: nodes 1..N-1
  const double q_max = std::max(max_abs(ctx.q, 0, ctx.q.size()), std::numeric_limits<double>::min());
  double previous = std::numeric_limits<double>::infinity(), r_first = 0, r_last = 0, first_norm = 0;
  int steps = 0;
  bool contracting = false;  // a correction was at most half the one before: the iteration converges
  // Corrections are kept while each is at most half the one before. Where the double Hessian is too
  // ill-conditioned to give corrections of the right size (order 4 at large N) the second is mostly
  // not smaller than the first, and the iterate returns to the solve's point (a test, not a proof:
  // docs/solvers.md gives a grid where two bad corrections passed it).
  for (int it = 0; it <= kMaxRefinementSteps; ++it) {
    if (extended_residual(ctx, ctx.q, pairs, res) >= 0) {
      if (!contracting) {
        ctx.q = start;
        steps = 0;
      }
      break;
    }
    r_last = max_abs(res, first, last);
    if (it == 0) r_first = r_last;
    for (std::size_t i = first; i < last; ++i) res[i] = -res[i];
    H.solve_ldlt(res.data() + first, delta.data() + first);
    const double norm = max_abs(delta, first, last);
    if (it == 0) {
      first_norm = norm;
      if (options.iterative_refinement == Refinement::automatic && norm <= kRefinementThreshold * eps * q_max) break;
    }
    if (it > 0 && !(norm <= 0.5 * previous)) {
      if (!contracting) {  // the first correction is not confirmed: undone
        ctx.q = start;
        steps = 0;
      }
      break;
    }
    if (it > 0) contracting = true;
    if (!std::isfinite(norm) || it == kMaxRefinementSteps || norm <= eps * q_max) break;
    for (std::size_t i = first; i < last; ++i) ctx.q[i] += ctx.is_free[i] ? delta[i] : 0.0;
    ++steps;
    previous = norm;
  }
  double change = 0;
  for (std::size_t i = 0; i < ctx.q.size(); ++i) change = std::max(change, std::fabs(ctx.q[i] - start[i]));
  summary.refinement_steps = steps;
  summary.refinement_change = change;
  if (steps == 0) {
    if (options.iterative_refinement == Refinement::automatic && first_norm <= kRefinementThreshold * eps * q_max)
      return;  // nothing to say: round-off does not matter here
    std::snprintf(buf, sizeof buf,
                  "no correction kept: the first, %.2e, was not followed by one half its size (the Hessian is too "
                  "ill-conditioned for a double solve here), or was below the rounding of the nodes",
                  first_norm);
    summary.refinement_note = buf;
    return;
  }
  std::snprintf(buf, sizeof buf,
                "%d correction%s, largest node change %.2e (the first %.2e; DEL residual in extended precision "
                "%.2e at the solve's point)",
                steps, steps == 1 ? "" : "s", change, first_norm, r_first);
  summary.refinement_note = buf;
  eval_full(ctx, ctx.q);
  compute_residual(ctx);
  ctx.action = sum_action(ctx);
  ctx.action_known = true;
}

}  // namespace

int extended_residual(const Context& ctx, const std::vector<double>& q, std::vector<double>& pairs,
                      std::vector<double>& res) {
  const int d = ctx.dim, N = ctx.N;
  const std::size_t dz = static_cast<std::size_t>(d), stride = 2 + 4 * dz;  // Ld pair, D1 pairs, D2 pairs
  pairs.resize(static_cast<std::size_t>(N) * stride);
  res.assign((static_cast<std::size_t>(N) + 1) * dz, 0.0);
  const pardel_extended_grad_kernel kern = ctx.disc->grad_extended;
  const double* p = ctx.p();
#pragma omp parallel for if (ctx.parallel(N)) num_threads(ctx.threads) schedule(static)
  for (int k = 0; k < N; ++k) {
    const std::size_t kk = static_cast<std::size_t>(k);
    double* out = pairs.data() + kk * stride;
    kern(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], q.data() + kk * dz, q.data() + (kk + 1) * dz, p, out, out + 2,
         out + 2 + 2 * dz);
  }
  int bad = -1;
  for (int k = 1; k < N; ++k) {
    const std::size_t kk = static_cast<std::size_t>(k);
    const double* D2 = pairs.data() + (kk - 1) * stride + 2 + 2 * dz;  // of interval k-1
    const double* D1 = pairs.data() + kk * stride + 2;                 // of interval k
    for (std::size_t i = 0; i < dz; ++i) {
      const std::size_t at = kk * dz + i;
      if (!ctx.is_free[at]) continue;
      res[at] = dd_sum(D2[2 * i], D2[2 * i + 1], D1[2 * i], D1[2 * i + 1]);
      if (bad < 0 && !std::isfinite(res[at])) bad = k;
    }
  }
  return bad;
}

void refine_solution(Context& ctx, const Options& options, Summary& summary) {
  summary.refinement_steps = 0;
  summary.refinement_change = 0;
  summary.refinement_note.clear();
  if (options.iterative_refinement == Refinement::off || ctx.N < 2) return;
  // Automatic: models of order >= 2, whose round-off grows like eps N^(2 order); an order-1 model
  // would pay the extended residual and a factorization for an error of eps N^2 (measured in
  // docs/solvers.md), negligible below N of about 1e5.
  if (options.iterative_refinement == Refinement::automatic && ctx.order < 2) return;
  if (ctx.clock != ClockMode::none) {  // the node times move with q: not a fixed residual to refine
    if (options.iterative_refinement == Refinement::on) summary.refinement_note = "not run: the model has a clock";
    return;
  }
  if (!ctx.disc || !ctx.disc->grad_extended) {
    if (options.iterative_refinement == Refinement::on)
      summary.refinement_note = "not run: the discretization has no extended-precision kernel";
    return;
  }
  dispatch_dim(ctx.dim, [&](auto D) { refine_dim<decltype(D)::value>(ctx, options, summary); });
}

}  // namespace pardel::detail
