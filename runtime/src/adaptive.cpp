/**
 * @file adaptive.cpp
 * Adaptive grids (Options::accuracy): solve, estimate the error (Richardson, error_estimate.hpp),
 * and while the estimate is above the requested accuracy place a new grid whose nodes
 * equidistribute a monitor of the solution's curvature, with N chosen from the estimate and the
 * discretization's order; the previous solution, interpolated onto the new grid, starts the next
 * solve. Knots stay on (even) nodes. docs/solvers.md, "Adaptive grids".
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
constexpr double kSmoothing = 1.5;  ///< largest ratio of neighbouring steps the monitor allows
constexpr double kMaxGrowth = 2.0;  ///< largest ratio of the N of two successive grids
constexpr double kFloorShare = 0.1; ///< share of the monitor's mean added everywhere

std::string number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

/**
 * The fallback monitor, where the residual one cannot be formed (the first grid with an odd N):
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
 * The monitor from the local truncation error: the DEL residual of the coarse grid (every other
 * node of `sol`'s grid) at `sol`'s values there, which the finer solution satisfies to its own
 * much smaller error, so the residual at a coarse node measures the coarse scheme's local error
 * there (each component over the size of its terms, compute_residual's comp_scale). On each fine
 * interval, rho = ind^(1/(order+1)) / H with ind the larger indicator of the enclosing coarse
 * interval's ends and H its step: equidistributing rho equalizes H^(order+1) |x^(order+1)|.
 * Empty when it cannot be formed (N odd or below 4, or a residual that is not finite).
 */
std::vector<double> residual_monitor(const Problem& current, const Trajectory& sol, double order) {
  if (current.N < 4 || current.N % 2 != 0) return {};
  Problem coarse = current;
  coarse.N = current.N / 2;
  coarse.times.resize(static_cast<std::size_t>(coarse.N) + 1);
  for (int m = 0; m <= coarse.N; ++m) coarse.times[static_cast<std::size_t>(m)] = sol.t[static_cast<std::size_t>(2 * m)];
  const Trajectory restricted = every_other_node(sol, 2);
  Context ctx;
  setup_context(coarse, coarse.N, 1, ctx);
  std::string error;
  if (!apply_constraints(coarse, ctx, &error)) return {};
  ctx.q = restricted.q;
  eval_grad(ctx, ctx.q);
  if (compute_residual(ctx) >= 0) return {};
  const int d = ctx.dim, Nc = coarse.N;
  std::vector<double> ind(static_cast<std::size_t>(Nc) + 1, 0.0);
  for (int m = 1; m < Nc; ++m) {
    double v = 0;
    for (int i = 0; i < d; ++i) {
      const double scale = ctx.comp_scale[static_cast<std::size_t>(i)];
      if (ctx.is_free[static_cast<std::size_t>(m) * d + i] && scale > 0)
        v = std::max(v, std::fabs(ctx.res[static_cast<std::size_t>(m) * d + i]) / scale);
    }
    ind[static_cast<std::size_t>(m)] = v;
  }
  ind[0] = ind[1];
  ind[static_cast<std::size_t>(Nc)] = ind[static_cast<std::size_t>(Nc) - 1];
  std::vector<double> rho(static_cast<std::size_t>(current.N));
  for (int m = 0; m < Nc; ++m) {
    const double H = coarse.times[static_cast<std::size_t>(m) + 1] - coarse.times[static_cast<std::size_t>(m)];
    const double r = std::pow(std::max(ind[static_cast<std::size_t>(m)], ind[static_cast<std::size_t>(m) + 1]), 1 / (order + 1)) / H;
    rho[static_cast<std::size_t>(2 * m)] = rho[static_cast<std::size_t>(2 * m) + 1] = r;
  }
  return rho;
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
 * between the fixed times (ends and knots), each segment between two fixed times getting an even
 * number of intervals (at least 2) in proportion to its share of the monitor's integral.
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
    count[s] = std::max(2, 2 * static_cast<int>(std::lround(share * N_new / 2)));
    total += count[s];
  }
  // Adjust to N_new (even) in steps of 2 on the segments with the largest (smallest) step.
  while (total != N_new) {
    std::size_t pick = 0;
    double best = total < N_new ? -1 : std::numeric_limits<double>::infinity();
    for (std::size_t s = 0; s < segments; ++s) {
      const double per = (W[static_cast<std::size_t>(fixed_nodes[s + 1])] - W[static_cast<std::size_t>(fixed_nodes[s])]) / count[s];
      if (total < N_new ? per > best : (count[s] > 2 && per < best)) {
        best = per;
        pick = s;
      }
    }
    if (total > N_new && count[pick] <= 2) break;  // every segment at its minimum
    count[pick] += total < N_new ? 2 : -2;
    total += total < N_new ? 2 : -2;
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
  std::string error;
  if (!requested.is_valid(&error)) return refuse(error);
  if (!requested.error_estimate)
    return refuse("an adaptive grid (accuracy = " + number(accuracy) + ") needs the error estimate (error_estimate = true)");
  if (problem.clock != ClockMode::none)
    return refuse("an adaptive grid cannot be combined with a clock (the clock sets the node times)");
  if (requested.resume_from != nullptr)
    return refuse("an adaptive solve cannot be resumed from a state: solve again with the same accuracy");
  Options options = requested;
  options.accuracy = 0;
  Problem current = problem;
  Trajectory guess = trajectory;
  std::vector<int> sizes;
  long iterations = 0;
  const double p = problem.discretization ? problem.discretization->consistency_order : 2;
  std::string outcome;
  for (int round = 0;; ++round) {
    summary = solve(current, options, guess);  // options.accuracy = 0: one grid
    sizes.push_back(current.N);
    iterations += summary.iterations;
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
    const double estimate = summary.error_estimate;
    if (std::isfinite(estimate) && estimate <= accuracy) {
      outcome = "accuracy " + number(accuracy) + " reached on N = " + std::to_string(current.N) + " (estimate " +
                number(estimate) + ") after " + std::to_string(sizes.size()) + " grid" + (sizes.size() == 1 ? "" : "s");
      break;
    }
    const int max_N = requested.accuracy_max_N - requested.accuracy_max_N % 2;
    if (current.N >= max_N || round + 1 >= kMaxGrids) {
      outcome = "accuracy " + number(accuracy) + " not reached: estimate " + number(estimate) + " on N = " +
                std::to_string(current.N) + ", " +
                (current.N >= max_N ? "the largest N allowed (accuracy_max_N = " + std::to_string(requested.accuracy_max_N) + ")"
                                    : "after " + std::to_string(kMaxGrids) + " grids");
      break;
    }
    // The next grid: N from the estimate and the order (with a margin), within [1.25 N, 2 N]
    // (each grid's monitor comes from the previous solution, so a grid far finer than the last
    // one would be placed from a solution that did not resolve what it needs).
    const double growth = std::isfinite(estimate) ? 1.2 * std::pow(estimate / accuracy, 1.0 / p) : 2.0;
    int N_new = static_cast<int>(std::ceil(current.N * std::min(kMaxGrowth, std::max(1.25, growth))));
    N_new = std::min(max_N, std::max(4, N_new + N_new % 2));
    const std::vector<int> fixed = fixed_nodes(current);
    if (N_new < 2 * static_cast<int>(fixed.size() - 1)) N_new = 2 * static_cast<int>(fixed.size() - 1);
    std::vector<double> rho = residual_monitor(current, guess, p);
    const bool from_residual = !rho.empty();
    if (!from_residual) rho = monitor(guess, problem.model->ncoords, p);
    floor_and_smooth(guess.t, rho, from_residual ? kFloorShare : 1.0);
    std::vector<double> times = equidistribute(guess.t, rho, fixed, N_new);
    PARDEL_INVARIANT(times.size() >= 3 && times.front() == problem.t0 && times.back() == guess.t.back(),
                     "the new grid spans the problem's interval");
    times.back() = problem.t0 + problem.T;
    guess = interpolate(guess, times);
    current.N = static_cast<int>(times.size()) - 1;
    current.times = std::move(times);
  }
  trajectory = guess;
  summary.iterations = iterations;
  summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary.grid_sizes = sizes;
  summary.grid_note = outcome;
  return summary;
}

}  // namespace pardel::detail
