/**
 * @file adaptive.cpp
 * Adaptive grids (Options::accuracy): solve, estimate the error (Richardson, error_estimate.hpp),
 * and place a new grid whose nodes equidistribute the local-error density of the last solution
 * (per interval, from the impulses of the coarse and the fine steps), with the N predicted to meet
 * the request: a larger grid while the estimate is above the requested accuracy (or not confirmed
 * by a third grid level), and after a grid that met it with room a smaller one, until one misses
 * it; the previous solution, interpolated onto the new grid, starts the next solve. Knots stay on
 * nodes that are multiples of 4, from the first grid on. docs/solvers.md, "Adaptive grids".
 */
#include "adaptive.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "engine.hpp"
#include "error_estimate.hpp"
#include "invariant.hpp"

namespace pardel::detail {
namespace {

constexpr int kMaxGrids = 12;
/// Largest ratio of neighbouring values of the monitor (and so of neighbouring steps).
constexpr double kSmoothing = 1.5;
/// Largest ratio of the N of two successive grids: each grid is placed from the last solution,
/// which may not resolve what a much finer grid needs.
constexpr double kMaxGrowth = 4.0;
/// Least growth of N after a grid that missed the request: the prediction may be optimistic, and
/// a grid barely larger than the last may be too coarse for its estimate (with 1.1, Troesch's
/// problem of tools/benchmarks/adaptive_layer.py ended on 18 nodes of galerkin_gauss(s=4) whose
/// estimate was 44 times below the true error).
constexpr double kMinGrowth = 1.5;
/// Share of the monitor's mean added everywhere, so that no stretch is left without nodes where
/// the local error vanishes (0.03 measured better than 0.1 on the boundary layer of
/// tools/benchmarks/adaptive_layer.py: fewer nodes outside the layers).
constexpr double kFloorShare = 0.03;
/// The next grid's N is predicted for this share of the requested accuracy; a solve's own error
/// above this share of it is reduced by a smaller tolerance (or is round-off, and ends the solve).
constexpr double kTargetShare = 0.5;
/// Solves again on one grid with a smaller tolerance, at most.
constexpr int kMaxTightening = 3;
/// A grid that met the request is followed by one of the predicted N when that is at most this
/// share of its N ...
constexpr double kShrink = 0.8;
/// ... and at least its N over this factor (and at least the first grid's N).
constexpr double kMaxShrink = 2.0;
/// Every stretch between fixed nodes gets a multiple of this many intervals, so that the grid,
/// its every other node and its every 4th node all hold the knots: the estimate's coarse grid and
/// the third level that checks it (error_estimate.hpp).
constexpr int kMultiple = 4;

std::string number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

/**
 * The fallback monitor, where the local-error density or the estimate cannot be formed (a grid
 * with an odd N):
 * on each interval of `sol`, the largest second divided difference of the coordinates (each over
 * its range) at the interval's ends, to the power 1/(order + 1).
 */
std::vector<double> monitor(const Trajectory& sol, int ncoords, double order) {
  const int N = sol.N;
  const std::vector<double>& t = sol.t;
  std::vector<double> range(static_cast<std::size_t>(ncoords), 0.0);
  for (int i = 0; i < ncoords; ++i) {
    double lo = sol.node(0)[i], hi = lo;
    for (int k = 1; k <= N; ++k) {
      lo = std::min(lo, sol.node(k)[i]);
      hi = std::max(hi, sol.node(k)[i]);
    }
    range[static_cast<std::size_t>(i)] = hi - lo > 0 ? hi - lo : std::max(std::fabs(hi), 1.0);
  }
  std::vector<double> curvature(static_cast<std::size_t>(N) + 1, 0.0);
  for (int k = 1; k < N; ++k) {
    const double h0 = t[static_cast<std::size_t>(k)] - t[static_cast<std::size_t>(k) - 1];
    const double h1 = t[static_cast<std::size_t>(k) + 1] - t[static_cast<std::size_t>(k)];
    double m = 0;
    for (int i = 0; i < ncoords; ++i) {
      const double s0 = (sol.node(k)[i] - sol.node(k - 1)[i]) / h0, s1 = (sol.node(k + 1)[i] - sol.node(k)[i]) / h1;
      m = std::max(m, std::fabs(2 * (s1 - s0) / (h0 + h1)) / range[static_cast<std::size_t>(i)]);
    }
    curvature[static_cast<std::size_t>(k)] = m;
  }
  curvature[0] = curvature[1];
  curvature[static_cast<std::size_t>(N)] = curvature[static_cast<std::size_t>(N) - 1];
  std::vector<double> rho(static_cast<std::size_t>(N));
  for (int j = 0; j < N; ++j)
    rho[static_cast<std::size_t>(j)] = std::pow(
        std::max(curvature[static_cast<std::size_t>(j)], curvature[static_cast<std::size_t>(j) + 1]), 1 / (order + 1));
  return rho;
}

/**
 * The local-error density of `sol`'s grid, per interval (empty when it cannot be formed: N odd or
 * below 4, or a value that is not finite). On the coarse interval [t_2m, t_2m+2] of the grid of
 * every other node, the impulse D1 Ld + D2 Ld of the one coarse step at the solution's values is
 * compared with the sum of those of the two fine steps inside it:
 *   theta_m = F_H(x_2m, x_2m+2) - F_h1(x_2m, x_2m+1) - F_h2(x_2m+1, x_2m+2),  F = D1 Ld + D2 Ld.
 * Each F differs from the exact impulse by kappa(t) h^(p+1) + O(h^(p+2)) (p the consistency order),
 * so theta_m / (H^(p+1) - h1^(p+1) - h2^(p+1)) estimates kappa there: the local error of a step h
 * is kappa h^(p+1), its density per unit time kappa h^p. Unlike the node residual of the coarse
 * grid, theta_m involves one coarse interval only, so a change of step between neighbouring
 * intervals adds nothing to it. Each component is measured against the size of its terms (the
 * largest |D2(k-1)| + |D1(k)| over the fine nodes); the density is the largest over the components.
 */
std::vector<double> local_error_density(const Problem& current, const Trajectory& sol, double order) {
  const int N = current.N;
  if (N < 4 || N % 2 != 0 || sol.N != N || sol.t.size() != static_cast<std::size_t>(N) + 1) return {};
  Problem fine_problem = current;
  fine_problem.knots.clear();
  fine_problem.times = sol.t;
  Problem coarse_problem = fine_problem;
  coarse_problem.N = N / 2;
  coarse_problem.times.resize(static_cast<std::size_t>(coarse_problem.N) + 1);
  for (int m = 0; m <= coarse_problem.N; ++m)
    coarse_problem.times[static_cast<std::size_t>(m)] = sol.t[static_cast<std::size_t>(2 * m)];
  const Trajectory restricted = every_other_node(sol, 2);
  Context fine, coarse;
  setup_context(fine_problem, N, 1, fine);
  setup_context(coarse_problem, coarse_problem.N, 1, coarse);
  eval_grad(fine, sol.q);
  eval_grad(coarse, restricted.q);
  const int d = fine.dim;
  const std::size_t dz = static_cast<std::size_t>(d);
  std::vector<double> scale(dz, 0.0);
  for (int k = 0; k <= N; ++k)
    for (std::size_t i = 0; i < dz; ++i) {
      double s = 0;
      if (k > 0) s += std::fabs(fine.D2[(static_cast<std::size_t>(k) - 1) * dz + i]);
      if (k < N) s += std::fabs(fine.D1[static_cast<std::size_t>(k) * dz + i]);
      scale[i] = std::max(scale[i], s);
    }
  std::vector<double> g(static_cast<std::size_t>(N));
  for (int m = 0; m < N / 2; ++m) {
    const std::size_t c = static_cast<std::size_t>(m) * dz, f0 = static_cast<std::size_t>(2 * m) * dz, f1 = f0 + dz;
    double v = 0;
    for (std::size_t i = 0; i < dz; ++i) {
      const double theta = (coarse.D1[c + i] + coarse.D2[c + i]) - (fine.D1[f0 + i] + fine.D2[f0 + i]) -
                           (fine.D1[f1 + i] + fine.D2[f1 + i]);
      if (scale[i] > 0) v = std::max(v, std::fabs(theta) / scale[i]);
    }
    const double h1 = fine.hk[static_cast<std::size_t>(2 * m)], h2 = fine.hk[static_cast<std::size_t>(2 * m) + 1];
    const double H = h1 + h2;
    const double weight = std::pow(H, order + 1) - std::pow(h1, order + 1) - std::pow(h2, order + 1);
    const double density = v / weight;
    if (!std::isfinite(density) || !(weight > 0)) return {};
    g[static_cast<std::size_t>(2 * m)] = g[static_cast<std::size_t>(2 * m) + 1] = density;
  }
  return g;
}

/** Replaces the monitor's value on each interval of a pair (the two fine intervals of one coarse
 *  interval, which share one value) by the linear interpolation in time between the values of the
 *  neighbouring pairs at the interval's midpoint, so that the next grid's steps change gradually
 *  instead of in steps from pair to pair. */
void interpolate_pairs(const std::vector<double>& t, std::vector<double>& rho) {
  const int pairs = static_cast<int>(rho.size()) / 2;
  if (pairs < 2) return;
  const std::vector<double> value = [&] {
    std::vector<double> v(static_cast<std::size_t>(pairs));
    for (int m = 0; m < pairs; ++m) v[static_cast<std::size_t>(m)] = rho[static_cast<std::size_t>(2 * m)];
    return v;
  }();
  auto centre = [&](int m) { return 0.5 * (t[static_cast<std::size_t>(2 * m)] + t[static_cast<std::size_t>(2 * m) + 2]); };
  for (int j = 0; j < 2 * pairs; ++j) {
    const int m = j / 2;
    const double x = 0.5 * (t[static_cast<std::size_t>(j)] + t[static_cast<std::size_t>(j) + 1]);
    const int other = x < centre(m) ? std::max(0, m - 1) : std::min(pairs - 1, m + 1);
    if (other == m) continue;
    const double u = (x - centre(m)) / (centre(other) - centre(m));
    rho[static_cast<std::size_t>(j)] = (1 - u) * value[static_cast<std::size_t>(m)] + u * value[static_cast<std::size_t>(other)];
  }
}

/** Adds a share of the mean of rho over [t0, tN] to every interval (so that no part of the
 *  interval is left without nodes where the indicator vanishes) and limits neighbouring values to
 *  a ratio of kSmoothing. */
void floor_and_smooth(const std::vector<double>& t, std::vector<double>& rho, double share) {
  const int N = static_cast<int>(rho.size());
  double integral = 0;
  for (int j = 0; j < N; ++j)
    integral += rho[static_cast<std::size_t>(j)] * (t[static_cast<std::size_t>(j) + 1] - t[static_cast<std::size_t>(j)]);
  const double mean = integral / (t.back() - t.front());
  for (double& r : rho) r += mean > 0 ? share * mean : 1.0;
  for (int pass = 0; pass < 2; ++pass) {
    for (int j = 1; j < N; ++j)
      rho[static_cast<std::size_t>(j)] = std::max(rho[static_cast<std::size_t>(j)], rho[static_cast<std::size_t>(j) - 1] / kSmoothing);
    for (int j = N - 2; j >= 0; --j)
      rho[static_cast<std::size_t>(j)] = std::max(rho[static_cast<std::size_t>(j)], rho[static_cast<std::size_t>(j) + 1] / kSmoothing);
  }
}

/**
 * N_new + 1 node times that equidistribute `rho` (piecewise constant on the intervals of `t`)
 * between the fixed times (ends and knots), each segment between two fixed times getting a
 * multiple of kMultiple intervals (at least kMultiple) in proportion to its share of the
 * monitor's integral.
 */
std::vector<double> equidistribute(const std::vector<double>& t, const std::vector<double>& rho,
                                   const std::vector<int>& fixed_nodes, int N_new) {
  const int N = static_cast<int>(rho.size());
  std::vector<double> W(static_cast<std::size_t>(N) + 1, 0.0);  // the monitor's integral up to node k
  for (int j = 0; j < N; ++j)
    W[static_cast<std::size_t>(j) + 1] =
        W[static_cast<std::size_t>(j)] + rho[static_cast<std::size_t>(j)] * (t[static_cast<std::size_t>(j) + 1] - t[static_cast<std::size_t>(j)]);
  const std::size_t segments = fixed_nodes.size() - 1;
  std::vector<int> count(segments);
  int total = 0;
  for (std::size_t s = 0; s < segments; ++s) {
    const double share = (W[static_cast<std::size_t>(fixed_nodes[s + 1])] - W[static_cast<std::size_t>(fixed_nodes[s])]) / W.back();
    count[s] = std::max(kMultiple, kMultiple * static_cast<int>(std::lround(share * N_new / kMultiple)));
    total += count[s];
  }
  // Adjust to N_new (a multiple of kMultiple) in such steps on the segments with the largest
  // (smallest) step.
  while (total != N_new) {
    std::size_t pick = 0;
    double best = total < N_new ? -1 : std::numeric_limits<double>::infinity();
    for (std::size_t s = 0; s < segments; ++s) {
      const double per = (W[static_cast<std::size_t>(fixed_nodes[s + 1])] - W[static_cast<std::size_t>(fixed_nodes[s])]) / count[s];
      if (total < N_new ? per > best : (count[s] > kMultiple && per < best)) {
        best = per;
        pick = s;
      }
    }
    if (total > N_new && count[pick] <= kMultiple) break;  // every segment at its minimum
    count[pick] += total < N_new ? kMultiple : -kMultiple;
    total += total < N_new ? kMultiple : -kMultiple;
  }
  std::vector<double> out;
  out.reserve(static_cast<std::size_t>(total) + 1);
  out.push_back(t.front());
  for (std::size_t s = 0; s < segments; ++s) {
    const int a = fixed_nodes[s], b = fixed_nodes[s + 1];
    const double Wa = W[static_cast<std::size_t>(a)], Wb = W[static_cast<std::size_t>(b)];
    int j = a;
    for (int m = 1; m < count[s]; ++m) {
      const double target = Wa + (Wb - Wa) * m / count[s];
      while (j < b - 1 && W[static_cast<std::size_t>(j) + 1] < target) ++j;
      const double u = (target - W[static_cast<std::size_t>(j)]) /
                       (W[static_cast<std::size_t>(j) + 1] - W[static_cast<std::size_t>(j)]);
      out.push_back(t[static_cast<std::size_t>(j)] + u * (t[static_cast<std::size_t>(j) + 1] - t[static_cast<std::size_t>(j)]));
    }
    out.push_back(t[static_cast<std::size_t>(b)]);
  }
  return out;
}

/** `sol` at the times `times` (inside [t_0, t_N]): every component by the cubic Hermite
 *  interpolant with three-point slopes in time. */
Trajectory interpolate(const Trajectory& sol, const std::vector<double>& times) {
  const int N = sol.N, d = sol.dim;
  const std::vector<double>& t = sol.t;
  auto slope = [&](int k, int i) {
    if (k == 0) return (sol.node(1)[i] - sol.node(0)[i]) / (t[1] - t[0]);
    if (k == N) return (sol.node(N)[i] - sol.node(N - 1)[i]) / (t[static_cast<std::size_t>(N)] - t[static_cast<std::size_t>(N) - 1]);
    const double h0 = t[static_cast<std::size_t>(k)] - t[static_cast<std::size_t>(k) - 1];
    const double h1 = t[static_cast<std::size_t>(k) + 1] - t[static_cast<std::size_t>(k)];
    const double s0 = (sol.node(k)[i] - sol.node(k - 1)[i]) / h0, s1 = (sol.node(k + 1)[i] - sol.node(k)[i]) / h1;
    return (s0 * h1 + s1 * h0) / (h0 + h1);
  };
  Trajectory out;
  out.N = static_cast<int>(times.size()) - 1;
  out.dim = d;
  out.t = times;
  out.q.resize(times.size() * static_cast<std::size_t>(d));
  int j = 0;
  for (int k = 0; k <= out.N; ++k) {
    const double x = times[static_cast<std::size_t>(k)];
    while (j < N - 1 && t[static_cast<std::size_t>(j) + 1] < x) ++j;
    const double h = t[static_cast<std::size_t>(j) + 1] - t[static_cast<std::size_t>(j)];
    const double u = std::min(1.0, std::max(0.0, (x - t[static_cast<std::size_t>(j)]) / h));
    const double u2 = u * u, u3 = u2 * u;
    for (int i = 0; i < d; ++i) {
      out.node(k)[i] = (2 * u3 - 3 * u2 + 1) * sol.node(j)[i] + (u3 - 2 * u2 + u) * h * slope(j, i) +
                       (-2 * u3 + 3 * u2) * sol.node(j + 1)[i] + (u3 - u2) * h * slope(j + 1, i);
    }
  }
  std::copy(sol.node(0), sol.node(0) + d, out.node(0));
  std::copy(sol.node(N), sol.node(N) + d, out.node(out.N));
  return out;
}

/** The nodes of the ends and the knots of `problem` on the grid of `sol`, ascending. */
std::vector<int> fixed_nodes(const Problem& problem) {
  std::vector<int> nodes{0, problem.N};
  for (std::size_t a = 0; a < problem.knots.size(); ++a) nodes.push_back(knot_node(problem, a, problem.N, nullptr));
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  return nodes;
}

/**
 * The first grid of an adaptive solve whose knots are not all on nodes of the uniform grid of N
 * that are multiples of kMultiple: each stretch between the ends and the knots split uniformly
 * into a multiple of kMultiple intervals (at least kMultiple) in proportion to its length, N
 * rounded up to a multiple of kMultiple. Empty where the uniform grid serves, where the problem
 * gives its own times, or where a knot is outside the interval or shares its time with another
 * (those are reported by the solve, naming the knot).
 */
std::vector<double> first_grid(const Problem& problem) {
  if (problem.knots.empty() || !problem.times.empty() || !(problem.T > 0) || problem.N < 1) return {};
  bool aligned = true;
  for (std::size_t a = 0; a < problem.knots.size(); ++a) {
    const int k = knot_node(problem, a, problem.N, nullptr);
    aligned = aligned && k > 0 && k % kMultiple == 0;
  }
  if (aligned) return {};
  const double t_end = problem.t0 + problem.T;
  std::vector<double> fixed{problem.t0, t_end};
  for (const Knot& knot : problem.knots) fixed.push_back(knot.t);
  std::sort(fixed.begin(), fixed.end());
  const double tol = time_tolerance(problem);
  if (!(fixed.front() == problem.t0 && fixed.back() == t_end)) return {};
  for (std::size_t j = 1; j < fixed.size(); ++j)
    if (!(fixed[j] - fixed[j - 1] > tol)) return {};
  const int spans = static_cast<int>(fixed.size()) - 1;
  const int N = std::max(kMultiple * spans, problem.N + (kMultiple - problem.N % kMultiple) % kMultiple);
  std::vector<int> fixed_index(fixed.size());
  for (std::size_t j = 0; j < fixed.size(); ++j) fixed_index[j] = static_cast<int>(j);
  std::vector<double> times = equidistribute(fixed, std::vector<double>(static_cast<std::size_t>(spans), 1.0), fixed_index, N);
  times.back() = t_end;
  return times;
}

/** The outcome of an adaptive solve whose last grid, N intervals, missed the request: at the
 *  largest N allowed (`at_max_N`) or after kMaxGrids grids. */
std::string not_reached(const Summary& summary, int N, const Options& requested, bool at_max_N) {
  const std::string unconfirmed =
      summary.error_reliable ? ""
      : summary.error_at_round_off
          ? " (the grid levels agree to round-off, which is not confirmed where L depends on t)"
      : std::isfinite(summary.error_observed_order)
          ? " (not confirmed: observed order " + number(summary.error_observed_order) + " on three grid levels)"
          : " (not confirmed by a third grid level)";
  return "accuracy " + number(requested.accuracy) + " not reached: estimate " + number(summary.error_estimate) +
         unconfirmed + " on N = " + std::to_string(N) +
         ", " +
         (at_max_N ? "the largest N allowed (accuracy_max_N = " + std::to_string(requested.accuracy_max_N) + ")"
                   : "after " + std::to_string(kMaxGrids) + " grids");
}

/** Whether the solve of one grid (`a`) is a better answer than `b`'s: converged with an estimate
 *  where `b` is not; else of a better kind of estimate, a confirmed one (Summary::error_reliable)
 *  first, then one made with an observed order short of the nominal `p` (larger than the nominal
 *  estimate), last the others (an observed order above p, an agreement to round-off that is not
 *  confirmed: the finer grids agree more than the error allows, which says little of it); else of
 *  a smaller estimate. */
bool better_grid(const Summary& a, const Summary& b, double p) {
  const bool a_has = a.converged() && std::isfinite(a.error_estimate);
  const bool b_has = b.converged() && std::isfinite(b.error_estimate);
  if (!a_has || !b_has) return a_has && !b_has;
  auto kind = [p](const Summary& s) {
    return s.error_reliable ? 2 : std::isfinite(s.error_observed_order) && s.error_observed_order <= p ? 1 : 0;
  };
  if (kind(a) != kind(b)) return kind(a) > kind(b);
  return a.error_estimate < b.error_estimate;
}

/** Why an adaptive solve of `problem` with `requested` cannot be made ("" when it can). */
std::string adaptive_refusal(const Problem& problem, const Options& requested) {
  std::string error;
  if (!requested.is_valid(&error)) return error;
  if (!requested.error_estimate)
    return "an adaptive grid (accuracy = " + number(requested.accuracy) +
           ") needs the error estimate (error_estimate = true)";
  if (problem.clock != ClockMode::none)
    return "an adaptive grid cannot be combined with a clock (the clock sets the node times)";
  if (requested.resume_from != nullptr)
    return "an adaptive solve cannot be resumed from a state: solve again with the same accuracy";
  if (problem.N > requested.accuracy_max_N)
    return "the first grid's N = " + std::to_string(problem.N) + " is above accuracy_max_N = " +
           std::to_string(requested.accuracy_max_N) + ", the largest N an adaptive solve may use";
  return {};
}

/** The next grid's monitor and size from a solved one (N = 0: no prediction). */
struct Prediction {
  std::vector<double> rho;
  long N = 0;
};

/**
 * The local-error density g of the grid of `sol` (local error g h^(p+1) of a step h), the monitor
 * rho = g^(1/(p+1)), and the N at which the next grid's error is predicted to be kTargetShare *
 * accuracy: the estimate scaled by the largest error density g h^p, from this grid's to the next
 * one's, whose steps are h = I / (N rho), I the monitor's integral. The exponent 1/(p+1) (rather
 * than the 1/p that equalizes g h^p) grades the grid less steeply; it needed fewer nodes on both
 * problems of tools/benchmarks/adaptive_layer.py.
 */
Prediction predict_grid(const Problem& current, const Trajectory& sol, double p, double estimate, double accuracy) {
  const std::vector<double> density = local_error_density(current, sol, p);
  Prediction out;
  if (density.empty() || !std::isfinite(estimate)) return out;
  std::vector<double>& rho = out.rho;
  rho.resize(density.size());
  double largest = 0;
  for (std::size_t j = 0; j < density.size(); ++j) {
    largest = std::max(largest, density[j] * std::pow(sol.t[j + 1] - sol.t[j], p));
    rho[j] = std::pow(density[j], 1 / (p + 1));
  }
  interpolate_pairs(sol.t, rho);
  floor_and_smooth(sol.t, rho, kFloorShare);
  double integral = 0, worst = 0;
  for (std::size_t j = 0; j < rho.size(); ++j) {
    integral += rho[j] * (sol.t[j + 1] - sol.t[j]);
    worst = std::max(worst, density[j] / std::pow(rho[j], p));
  }
  const double n = integral * std::pow(estimate * worst / (largest * kTargetShare * accuracy), 1 / p);
  if (largest > 0 && std::isfinite(n) && n > 0) out.N = static_cast<long>(std::min(n, 1e9));
  return out;
}

/** The node times of `sol`, the solution on `current`'s grid: its own, or uniform where it has none. */
std::vector<double> node_times(const Problem& current, const Trajectory& sol) {
  std::vector<double> t(static_cast<std::size_t>(current.N) + 1);
  for (int k = 0; k <= current.N; ++k) t[static_cast<std::size_t>(k)] = level_time(current, sol, k);
  return t;
}

/**
 * The node times of a grid whose nodes shared by all three of its levels (every 4th node, the
 * levels of the estimate and its check) lie midway between those of `current` (solved as `sol`,
 * whose times it uses): in each stretch of n intervals between the ends and the knots, those
 * nodes move from t_0, t_4, ..., t_n to t_0, t_2, t_6, ..., t_{n-2}, t_n, each interval between
 * them split into 4 equal ones (n + 4 intervals). A jump or kink in t that the grid levels miss
 * alike lies within an interval of a node all three share; the two grids' such nodes are 2
 * intervals apart, so it cannot lie so near nodes of both (unless at an end or a knot, which both
 * hold).
 */
std::vector<double> moved_grid(const Problem& current, const Trajectory& sol) {
  const std::vector<double> t = node_times(current, sol);
  const std::vector<int> fixed = fixed_nodes(current);
  std::vector<double> out{t.front()};
  auto split = [&out](double from, double to) {
    for (int m = 1; m <= kMultiple; ++m) out.push_back(from + (to - from) * m / kMultiple);
  };
  for (std::size_t s = 0; s + 1 < fixed.size(); ++s) {
    const int a = fixed[s], b = fixed[s + 1];
    PARDEL_INVARIANT((b - a) % kMultiple == 0, "every stretch has a multiple of kMultiple intervals");
    double from = t[static_cast<std::size_t>(a)];
    for (int k = a + kMultiple / 2; k < b; k += kMultiple) {
      split(from, t[static_cast<std::size_t>(k)]);
      from = t[static_cast<std::size_t>(k)];
    }
    split(from, t[static_cast<std::size_t>(b)]);
    out.back() = t[static_cast<std::size_t>(b)];
  }
  return out;
}

/**
 * The node times of the check grid of a solve where L depends on t: the grading of `current`'s
 * grid (solved as `sol`) kept, each stretch of n intervals between the ends and the knots split
 * into n + kMultiple, the node m of a stretch at the fractional node index m n / (n + kMultiple)
 * of the old one (the times linear between old nodes): every spacing shrinks by n / (n + 4), so
 * the nodes sample t at other times than the grid's and its nested levels' all along.
 */
std::vector<double> respaced_grid(const Problem& current, const Trajectory& sol) {
  const std::vector<double> t = node_times(current, sol);
  const std::vector<int> fixed = fixed_nodes(current);
  std::vector<double> out{t.front()};
  for (std::size_t s = 0; s + 1 < fixed.size(); ++s) {
    const int a = fixed[s], n = fixed[s + 1] - a, n_new = n + kMultiple;
    for (int m = 1; m < n_new; ++m) {
      const double x = static_cast<double>(m) * n / n_new;
      const int j = std::min(n - 1, static_cast<int>(x));
      const double w = x - j;
      out.push_back((1 - w) * t[static_cast<std::size_t>(a + j)] + w * t[static_cast<std::size_t>(a + j + 1)]);
    }
    out.push_back(t[static_cast<std::size_t>(fixed[s + 1])]);
  }
  return out;
}

/** The node times of the next grid of about N_new intervals (a multiple of kMultiple, at most
 *  max_N, at least kMultiple per span between fixed nodes), equidistributing `rho` (the predicted
 *  monitor; null: the solution's own monitor) over the solution `sol` of `current`, with the ends
 *  and knots on nodes. */
std::vector<double> place_grid(const Problem& problem, const Problem& current, const Trajectory& sol, double p,
                               const std::vector<double>* rho, int N_new, int max_N) {
  N_new = std::min(max_N, std::max(2 * kMultiple, N_new + (kMultiple - N_new % kMultiple) % kMultiple));
  const std::vector<int> fixed = fixed_nodes(current);
  N_new = std::max(N_new, kMultiple * static_cast<int>(fixed.size() - 1));
  std::vector<double> own;
  if (!rho) {
    own = monitor(sol, problem.model->ncoords, p);
    floor_and_smooth(sol.t, own, 1.0);
    rho = &own;
  }
  std::vector<double> times = equidistribute(sol.t, *rho, fixed, N_new);
  PARDEL_INVARIANT(times.size() >= 3 && times.front() == problem.t0 && times.back() == sol.t.back(),
                   "the new grid spans the problem's interval");
  times.back() = problem.t0 + problem.T;
  return times;
}

}  // namespace

Summary solve_adaptive(const Problem& problem, const Options& requested, Trajectory& trajectory) {
  const auto start = std::chrono::steady_clock::now();
  Summary summary;
  const double accuracy = requested.accuracy;
  auto refuse = [&](const std::string& message) {
    summary.termination = Termination::invalid_input;
    summary.message = message;
    summary.grid_note = "not adapted: " + message;
    return summary;
  };
  const std::string refusal = adaptive_refusal(problem, requested);
  if (!refusal.empty()) return refuse(refusal);
  Options options = requested;
  options.accuracy = 0;
  Problem current = problem;
  Trajectory guess = trajectory;
  std::vector<double> first;
  if (validate(problem, trajectory, nullptr) && trajectory.N == problem.N) first = first_grid(problem);
  if (!first.empty()) {
    if (static_cast<long>(first.size()) - 1 > requested.accuracy_max_N)
      return refuse("the first grid with a multiple of " + std::to_string(kMultiple) +
                    " intervals between the ends and each knot has N = " + std::to_string(first.size() - 1) +
                    ", above accuracy_max_N = " + std::to_string(requested.accuracy_max_N));
    if (guess.t.size() != static_cast<std::size_t>(guess.N) + 1) {
      guess.t.resize(static_cast<std::size_t>(guess.N) + 1);
      for (int k = 0; k <= guess.N; ++k) guess.t[static_cast<std::size_t>(k)] = problem.t0 + problem.T * k / guess.N;
    }
    guess = interpolate(guess, first);
    current.N = static_cast<int>(first.size()) - 1;
    current.times = std::move(first);
  }
  std::vector<int> sizes;
  long iterations = 0;
  const double p = problem.discretization ? problem.discretization->consistency_order : 2;
  std::string outcome;
  bool shrinking = false, shrink_failed = false;
  Problem met_problem;       // the last grid that met the request, before a smaller one
  Trajectory met_solution;  // and its solution
  Summary best;             // the converged grid with the smallest estimate, and its solution
  Trajectory best_solution;
  int tightened = 0;        // solves again on one grid with a smaller tolerance
  int moved_from = 0;       // the N of the grid whose agreement to round-off this one checks (moved_grid)
  bool move_refuted = false;  // a moved grid did not confirm an agreement to round-off
  int check_of = 0;         // the N of the grid that met the request and that this one checks (L depends on t)
  bool reached = false;
  for (int round = 0;; ++round) {
    summary = solve(current, options, guess);  // options.accuracy = 0: one grid
    sizes.push_back(current.N);
    iterations += summary.iterations;
    const bool improved = better_grid(summary, best, p);
    if (improved) {
      best = summary;
      best_solution = guess;
    }
    if (summary.termination == Termination::invalid_input && round == 0) {
      trajectory = guess;
      summary.grid_sizes = sizes;
      summary.grid_note = "not adapted: " + summary.message;
      return summary;
    }
    if (!summary.converged()) {
      outcome = "accuracy " + number(accuracy) + " not reached: the solve on N = " + std::to_string(current.N) +
                " ended " + to_string(summary.termination);
      break;
    }
    // A grid meets the request when its estimate does and a third grid level confirmed the
    // estimate (Summary::error_reliable): on a coarse grid of a high order the error need not yet
    // fall with the nominal order, and the estimate from two grids can be far below it.
    const double estimate = summary.error_estimate;
    // The grid levels agree to round-off where L depends on t (Summary::error_at_round_off), which
    // nested grids cannot confirm: a jump or kink in t that their quadrature points miss alike
    // near a node they share gives the same agreement. A grid whose nodes shared by its levels lie
    // midway between this one's (moved_grid) confirms it when its own levels agree to round-off too.
    const bool agreement = summary.error_at_round_off && !summary.error_reliable && std::isfinite(estimate) &&
                           estimate <= accuracy;
    const bool confirmed_agreement = agreement && moved_from > 0;
    if (confirmed_agreement) confirm_round_off(summary, moved_from);
    // A moved grid that did not confirm the agreement showed a feature in t that nested grids
    // miss: later agreements are not checked again (each check costs a grid).
    if (moved_from > 0 && !confirmed_agreement) move_refuted = true;
    moved_from = 0;
    if (agreement && !confirmed_agreement && !move_refuted && round + 1 < kMaxGrids) {
      std::vector<double> times = moved_grid(current, guess);
      if (static_cast<long>(times.size()) - 1 <= requested.accuracy_max_N) {
        moved_from = current.N;
        guess = interpolate(guess, times);
        current.N = static_cast<int>(times.size()) - 1;
        current.times = std::move(times);
        continue;
      }
    }
    const bool met = std::isfinite(estimate) && estimate <= accuracy && summary.error_reliable;
    if (!met && shrinking) {
      // The smaller grid missed the request: solve once more on the last grid that met it (from its
      // own solution) and end there, so that the returned grid is one solved on and meeting it.
      shrink_failed = true;
      shrinking = false;
      current = met_problem;
      guess = met_solution;
      continue;
    }
    const double own = summary.solve_error;
    if (!met && std::isfinite(own) && own > kTargetShare * accuracy) {
      // The solve's own error (the Newton correction at the answer) takes most of the request, and
      // a finer grid would not reduce it. Above round-off the tolerance left it: solve again on
      // this grid with the tolerance scaled down to leave a tenth of the request. At round-off,
      // which grows on finer grids, the grids go on only while the estimate falls.
      const bool round_off = !(summary.residual > 10 * summary.residual_floor);
      if (!round_off && tightened < kMaxTightening && round + 1 < kMaxGrids) {
        const double factor = std::max(1e-6, 0.1 * accuracy / own);
        options.rtol *= factor;
        if (options.tol > 0) options.tol *= factor;
        ++tightened;
        continue;
      }
      if (round_off && !improved && best.converged()) {
        outcome = "accuracy " + number(accuracy) + " not reached: the estimate stopped falling (" + number(estimate) +
                  " on N = " + std::to_string(current.N) + ", of which the solve's own error at the round-off " +
                  "level " + number(own) + ", which finer grids make larger)";
        break;
      }
    }
    const Prediction next = predict_grid(current, guess, p, estimate, accuracy);
    const long N_predicted = next.N;
    const int max_N = requested.accuracy_max_N - requested.accuracy_max_N % kMultiple;
    int N_new = 0;
    if (met && problem.model->time_dependent && !confirmed_agreement) {
      // Where L depends on t, nested grids sample it at the same times: a forcing whose period
      // divides the step (or a jump they miss alike) gives three levels that converge at full
      // order to one wrong problem. The request counts as reached when a second grid, of other
      // node spacings all along (respaced_grid), meets it too.
      if (check_of > 0) {
        outcome = "accuracy " + number(accuracy) + " reached on N = " + std::to_string(current.N) + " (estimate " +
                  number(estimate) + ") after " + std::to_string(sizes.size()) + " grids, checked against N = " +
                  std::to_string(check_of) + " before it, whose nodes sample t elsewhere";
        reached = true;
        break;
      }
      const int N_check = current.N + kMultiple * static_cast<int>(fixed_nodes(current).size() - 1);  // respaced_grid's
      if (round + 1 >= kMaxGrids || N_check > max_N) {
        outcome = "accuracy " + number(accuracy) + " reached on N = " + std::to_string(current.N) + " (estimate " +
                  number(estimate) + ") after " + std::to_string(sizes.size()) + " grid" +
                  (sizes.size() == 1 ? "" : "s") + ", not checked on a second grid, which L's dependence on t asks for (" +
                  (N_check > max_N ? "it would exceed accuracy_max_N"
                                   : "this was the last of the " + std::to_string(kMaxGrids) + " grids allowed") +
                  ")";
        reached = true;
        break;
      }
      check_of = current.N;
      shrinking = false;
      std::vector<double> times = respaced_grid(current, guess);
      guess = interpolate(guess, times);
      current.N = static_cast<int>(times.size()) - 1;
      current.times = std::move(times);
      continue;
    }
    check_of = 0;
    if (met) {
      // A grid that meets the request with room is followed by a smaller one placed from its
      // well-resolved solution, unless a smaller one already failed or there is no room left for
      // it and a solve again on this grid within kMaxGrids.
      const long smaller = std::max({N_predicted, static_cast<long>(std::ceil(current.N / kMaxShrink)),
                                     static_cast<long>(problem.N)});
      if (N_predicted == 0 || shrink_failed || confirmed_agreement || smaller > kShrink * current.N ||
          round + 2 >= kMaxGrids) {
        outcome = "accuracy " + number(accuracy) + " reached on N = " + std::to_string(current.N) + " (estimate " +
                  number(estimate) + ") after " + std::to_string(sizes.size()) + " grid" + (sizes.size() == 1 ? "" : "s");
        reached = true;
        break;
      }
      shrinking = true;
      met_problem = current;
      met_solution = guess;
      N_new = static_cast<int>(smaller);
    } else {
      if (current.N >= max_N || round + 1 >= kMaxGrids) {
        outcome = not_reached(summary, current.N, requested, current.N >= max_N);
        break;
      }
      shrinking = false;
      // The predicted N, at least kMinGrowth and at most kMaxGrowth times this one (each grid is
      // placed from the last solution, which may not resolve what a much finer grid needs);
      // without a prediction, N from the estimate and the order with a margin.
      double growth = N_predicted > 0 ? static_cast<double>(N_predicted) / current.N
                                      : (std::isfinite(estimate) ? 1.2 * std::pow(estimate / accuracy, 1.0 / p) : 2.0);
      growth = std::min(kMaxGrowth, std::max(kMinGrowth, growth));
      N_new = static_cast<int>(std::ceil(current.N * growth));
    }
    std::vector<double> times = place_grid(problem, current, guess, p, N_predicted > 0 ? &next.rho : nullptr, N_new, max_N);
    guess = interpolate(guess, times);
    current.N = static_cast<int>(times.size()) - 1;
    current.times = std::move(times);
  }
  if (!reached && best.converged() && better_grid(best, summary, p)) {
    // Not reached: the grid with the smallest estimate (a confirmed one first) is returned, not a
    // later, worse one (finer grids whose round-off grows).
    outcome += std::string("; the grid with the smallest estimate") +
               (best.error_reliable ? " among the confirmed ones" : "") + ", N = " + std::to_string(best_solution.N) +
               " (estimate " + number(best.error_estimate) + "), is returned";
    summary = best;
    guess = best_solution;
  }
  trajectory = guess;
  summary.iterations = iterations;
  summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary.grid_sizes = sizes;
  summary.grid_note = outcome;
  return summary;
}

}  // namespace pardel::detail
