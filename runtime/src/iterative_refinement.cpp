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
#include <string>

#include "block_tridiagonal.hpp"
#include "constants.hpp"
#include "extended_node_system.hpp"

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

/** What one phase of refinement did. */
struct Phase {
  int steps = 0;          ///< corrections kept
  double first = 0;       ///< size of the first correction
  double residual = 0;    ///< max DEL residual in extended precision at the phase's start
  bool settled = false;   ///< ended at corrections below the rounding of the nodes (or not needed)
  std::string failure;    ///< why the phase could not run, if it could not
};

/**
 * Corrections q += delta while each is at most half the one before; the first is kept only when
 * the second confirms it. `correct` computes delta at q and returns its size (NaN: could not).
 * Where the Hessian is too ill-conditioned for the precision it is solved in, the second correction
 * is mostly not smaller than the first and the iterate returns to where the phase started (a test,
 * not a proof: docs/solvers.md gives a grid where two bad corrections passed it).
 */
template <class Correct>
Phase run_phase(Context& ctx, const Options& options, Correct&& correct) {
  const double eps = std::numeric_limits<double>::epsilon();
  const std::size_t first = static_cast<std::size_t>(ctx.dim), last = static_cast<std::size_t>(ctx.N) * first;
  const double q_max = std::max(max_abs(ctx.q, 0, ctx.q.size()), std::numeric_limits<double>::min());
  const std::vector<double> start = ctx.q;
  std::vector<double> delta(ctx.q.size(), 0.0);
  Phase phase;
  double previous = std::numeric_limits<double>::infinity();
  bool contracting = false;  // a correction was at most half the one before: the iteration converges
  for (int it = 0; it <= kMaxRefinementSteps; ++it) {
    double residual = 0;
    const double norm = correct(delta, &residual);
    if (it == 0) {
      phase.residual = residual;
      phase.first = norm;
      if (options.iterative_refinement == Refinement::automatic && norm <= kRefinementThreshold * eps * q_max) {
        phase.settled = true;
        break;
      }
    }
    if (!std::isfinite(norm) || (it > 0 && !(norm <= 0.5 * previous))) break;
    if (it > 0) contracting = true;
    if (norm <= eps * q_max) {
      phase.settled = true;
      break;
    }
    if (it == kMaxRefinementSteps) break;
    for (std::size_t i = first; i < last; ++i) ctx.q[i] += ctx.is_free[i] ? delta[i] : 0.0;
    ++phase.steps;
    previous = norm;
  }
  if (!contracting) {  // the first correction is not confirmed: undone
    ctx.q = start;
    phase.steps = 0;
  }
  return phase;
}

/** Corrections from the extended residual and the double Hessian at the solve's point. */
template <int D>
Phase double_phase(Context& ctx, const Options& options) {
  const int N = ctx.N;
  ensure_interval_arrays(ctx, Evaluated::full);
  if (ctx.evaluated != Evaluated::full) eval_full(ctx, ctx.q);
  BlockTridiagonal<D> H;
  H.resize(N, ctx.dim);
  H.assemble(ctx, 0.0);
  if (!H.factor_ldlt() && !H.factor_indefinite()) {
    Phase phase;
    phase.failure = "the Hessian at the solution is singular to working precision";
    return phase;
  }
  const std::size_t first = static_cast<std::size_t>(ctx.dim), last = static_cast<std::size_t>(N) * first;
  std::vector<double> pairs, res;
  return run_phase(ctx, options, [&](std::vector<double>& delta, double* residual) {
    if (extended_residual(ctx, ctx.q, pairs, res) >= 0) return std::numeric_limits<double>::quiet_NaN();
    *residual = max_abs(res, first, last);
    for (std::size_t i = first; i < last; ++i) res[i] = -res[i];
    H.solve_ldlt(res.data() + first, delta.data() + first);
    return max_abs(delta, first, last);
  });
}

/** Newton corrections with residual and Hessian in extended precision, the Hessian re-evaluated
 *  at every iterate. */
Phase extended_phase(Context& ctx, const Options& options) {
  ExtendedNodeSystem system;
  const std::size_t first = static_cast<std::size_t>(ctx.dim), last = static_cast<std::size_t>(ctx.N) * first;
  return run_phase(ctx, options, [&](std::vector<double>& delta, double* residual) {
    if (!system.evaluate(ctx, ctx.q) || !system.factor()) return std::numeric_limits<double>::quiet_NaN();
    system.solve(delta);
    *residual = system.residual_norm();
    return max_abs(delta, first, last);
  });
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

namespace {

/** Whether refine_solution runs under `mode` at all (its first correction may still keep nothing):
 *  not off, N >= 2, order >= 2 under automatic, node times outside the problem (no clock, or the
 *  free final time of a model that does not depend on t), an extended kernel. */
bool refines(const Context& ctx, Refinement mode) {
  return mode != Refinement::off && ctx.N >= 2 && !(mode == Refinement::automatic && ctx.order < 2) &&
         times_outside_the_problem(ctx) && ctx.disc && ctx.disc->grad_extended;
}

}  // namespace

bool extend_residual(Context& ctx) {
  if (!refines(ctx, Refinement::automatic)) return false;
  std::vector<double> pairs, res;
  if (extended_residual(ctx, ctx.q, pairs, res) >= 0) return false;
  ctx.res.swap(res);
  return true;
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
  if (!times_outside_the_problem(ctx)) {  // the node times move with q: not a fixed residual to refine
    if (options.iterative_refinement == Refinement::on) summary.refinement_note = "not run: the model has a clock";
    return;
  }
  if (!ctx.disc || !ctx.disc->grad_extended) {
    if (options.iterative_refinement == Refinement::on)
      summary.refinement_note = "not run: the discretization has no extended-precision kernel";
    return;
  }
  const std::vector<double> start = ctx.q;
  const Phase plain =
      dispatch_dim_cold(ctx.dim, [&](auto D) { return double_phase<decltype(D)::value>(ctx, options); });
  Phase wide;
  const bool extended = !plain.settled && ctx.disc->full_extended;
  if (extended) wide = extended_phase(ctx, options);
  const int steps = plain.steps + wide.steps;
  double change = 0;
  for (std::size_t i = 0; i < ctx.q.size(); ++i) change = std::max(change, std::fabs(ctx.q[i] - start[i]));
  summary.refinement_steps = steps;
  summary.refinement_change = change;
  char buf[500];
  const double eps = std::numeric_limits<double>::epsilon();
  const double q_max = std::max(max_abs(start, 0, start.size()), std::numeric_limits<double>::min());
  if (steps == 0) {
    if (options.iterative_refinement == Refinement::automatic && plain.failure.empty() &&
        plain.first <= kRefinementThreshold * eps * q_max)
      return;  // nothing to say: round-off does not matter here
    if (!plain.failure.empty() && !extended) {
      summary.refinement_note = "not run: " + plain.failure;
      return;
    }
    std::snprintf(buf, sizeof buf,
                  "no correction kept: the first, %.2e, was not followed by one half its size (the Hessian is too "
                  "ill-conditioned for a double solve here%s), or was below the rounding of the nodes",
                  plain.failure.empty() ? plain.first : wide.first,
                  extended ? ", and the extended-precision one gave none either" : "");
    summary.refinement_note = buf;
    return;
  }
  char wide_part[80] = "";
  if (wide.steps > 0)
    std::snprintf(wide_part, sizeof wide_part, " (%d with the Hessian in extended precision)", wide.steps);
  std::snprintf(buf, sizeof buf,
                "%d correction%s%s, largest node change %.2e (the first %.2e; DEL residual in extended precision "
                "%.2e at the solve's point)",
                steps, steps == 1 ? "" : "s", wide_part, change, plain.steps > 0 ? plain.first : wide.first,
                plain.failure.empty() ? plain.residual : wide.residual);
  summary.refinement_note = buf;
  update_times(ctx, Positions::stay);  // under free_final_time the travel time of the refined path
  eval_full(ctx, ctx.q);
  compute_residual(ctx);
  ctx.action = sum_action(ctx);
  ctx.action_known = true;
}

}  // namespace pardel::detail
