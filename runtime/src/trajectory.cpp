/**
 * @file trajectory.cpp
 * Initial guesses (straight line, polyline) and resampling of a trajectory onto another grid
 * (coarse-to-fine refinement): cubic Hermite in time when derivatives are stored (order >= 2),
 * cubic Hermite with finite-difference slopes otherwise.
 */
#include <algorithm>
#include <cmath>

#include "pardel/pardel.hpp"

namespace pardel {
namespace {

Trajectory empty_for(const Problem& problem, int N) {
  Trajectory tr;
  tr.N = N;
  tr.dim = problem.model ? problem.model->dim : static_cast<int>(problem.q0.size());
  tr.t.resize(static_cast<std::size_t>(N) + 1);
  for (int k = 0; k <= N; ++k) tr.t[static_cast<std::size_t>(k)] = problem.t0 + problem.T * k / N;
  if (!problem.times.empty() && problem.times.size() == tr.t.size()) tr.t = problem.times;
  tr.q.assign((static_cast<std::size_t>(N) + 1) * tr.dim, 0.0);
  return tr;
}

/** Cubic Hermite basis on [0,1] with values y0, y1 and slopes m0, m1 (per unit of u). */
double hermite(double u, double y0, double y1, double m0, double m1) {
  const double u2 = u * u, u3 = u2 * u;
  return (2 * u3 - 3 * u2 + 1) * y0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * y1 + (u3 - u2) * m1;
}
double hermite_derivative(double u, double y0, double y1, double m0, double m1) {
  const double u2 = u * u;
  return (6 * u2 - 6 * u) * y0 + (3 * u2 - 4 * u + 1) * m0 + (-6 * u2 + 6 * u) * y1 + (3 * u2 - 2 * u) * m1;
}

/** Node k's fraction of the way along the grid: k/N on a uniform grid (exactly, so that uniform
 *  guesses do not depend on the rounding of the node times), the time's fraction on a given one. */
double path_fraction(const Problem& problem, const Trajectory& tr, int k, int N) {
  if (problem.times.empty()) return static_cast<double>(k) / N;
  return (tr.t[static_cast<std::size_t>(k)] - tr.t.front()) / (tr.t.back() - tr.t.front());
}

}  // namespace

Trajectory linear_guess(const Problem& problem) {
  Trajectory tr = empty_for(problem, problem.N);
  const int d = tr.dim, N = problem.N;
  for (int k = 0; k <= N; ++k) {
    const double s = path_fraction(problem, tr, k, N);
    for (int i = 0; i < d; ++i)
      tr.node(k)[i] = (1 - s) * problem.q0[static_cast<std::size_t>(i)] + s * problem.qN[static_cast<std::size_t>(i)];
  }
  return tr;
}

Trajectory polyline_guess(const Problem& problem, const std::vector<std::vector<double>>& points) {
  Trajectory tr = empty_for(problem, problem.N);
  const int d = tr.dim, N = problem.N;
  const int nc = problem.model ? problem.model->ncoords : d;
  std::vector<std::vector<double>> P = points;
  if (P.size() < 2) return linear_guess(problem);
  P.front().assign(problem.q0.begin(), problem.q0.begin() + nc);
  P.back().assign(problem.qN.begin(), problem.qN.begin() + nc);
  const int segments = static_cast<int>(P.size()) - 1;
  for (int k = 0; k <= N; ++k) {
    const double u = path_fraction(problem, tr, k, N) * segments;
    const int j = std::min(segments - 1, static_cast<int>(std::floor(u)));
    const double w = u - j;
    double* q = tr.node(k);
    for (int i = 0; i < nc; ++i) {
      const double a = P[static_cast<std::size_t>(j)][static_cast<std::size_t>(i)];
      const double b = P[static_cast<std::size_t>(j) + 1][static_cast<std::size_t>(i)];
      q[i] = (1 - w) * a + w * b;
      // d/dt along the polyline parametrized by node index: each segment takes T/segments.
      if (d > nc) q[nc + i] = (b - a) * segments / problem.T;
    }
  }
  for (int i = 0; i < d; ++i) {
    tr.node(0)[i] = problem.q0[static_cast<std::size_t>(i)];
    tr.node(N)[i] = problem.qN[static_cast<std::size_t>(i)];
  }
  return tr;
}

Trajectory resample(const Problem& problem, const Trajectory& from, int N) {
  Trajectory tr = empty_for(problem, N);
  const int d = from.dim, M = from.N;
  tr.dim = d;
  const std::size_t size = (static_cast<std::size_t>(N) + 1) * static_cast<std::size_t>(d);
  if (tr.q.size() != size) tr.q.assign(size, 0.0);  // empty_for's zeros otherwise
  const int nc = problem.model ? problem.model->ncoords : d;
  const bool has_derivative = d >= 2 * nc;
  // Old node times (uniform when absent); interpolate in the node parameter s = k/M.
  std::vector<double> told(static_cast<std::size_t>(M) + 1);
  for (int k = 0; k <= M; ++k)
    told[static_cast<std::size_t>(k)] =
        from.t.size() == told.size() ? from.t[static_cast<std::size_t>(k)] : problem.t0 + problem.T * k / M;
  // Without stored derivatives, d q_i / d s at each old node by finite differences of its
  // neighbours, once per old node (each is the slope of every new node on its two intervals).
  std::vector<double> slope;
  if (!has_derivative) {
    slope.resize((static_cast<std::size_t>(M) + 1) * static_cast<std::size_t>(d));
    for (int k = 0; k <= M; ++k) {
      const int a = std::max(0, k - 1), b = std::min(M, k + 1);
      const double span = static_cast<double>(b - a) / M;
      for (int i = 0; i < d; ++i)
        slope[static_cast<std::size_t>(k) * static_cast<std::size_t>(d) + static_cast<std::size_t>(i)] =
            (from.node(b)[i] - from.node(a)[i]) / span;
    }
  }
  auto slope_fd = [&](int k, int i) {
    return slope[static_cast<std::size_t>(k) * static_cast<std::size_t>(d) + static_cast<std::size_t>(i)];
  };
  for (int k = 0; k <= N; ++k) {
    const double s = static_cast<double>(k) / N;
    const double x = s * M;
    const int j = std::min(M - 1, static_cast<int>(std::floor(x)));
    const double u = x - j;
    const double ds = 1.0 / M;                // s-length of the old interval
    const double* a = from.node(j);
    const double* b = from.node(j + 1);
    const double dt = told[static_cast<std::size_t>(j) + 1] - told[static_cast<std::size_t>(j)];
    double* q = tr.node(k);
    tr.t[static_cast<std::size_t>(k)] = told[static_cast<std::size_t>(j)] + u * dt;
    for (int i = 0; i < d; ++i) {
      if (has_derivative && i < nc) {
        // Cubic Hermite in time with the stored first derivatives (slopes per unit u: q' * dt).
        q[i] = hermite(u, a[i], b[i], a[nc + i] * dt, b[nc + i] * dt);
      } else if (has_derivative && i < 2 * nc) {
        const int c = i - nc;
        q[i] = dt != 0 ? hermite_derivative(u, a[c], b[c], a[i] * dt, b[i] * dt) / dt : (1 - u) * a[i] + u * b[i];
      } else if (has_derivative) {
        q[i] = (1 - u) * a[i] + u * b[i];
      } else {
        q[i] = hermite(u, a[i], b[i], slope_fd(j, i) * ds, slope_fd(j + 1, i) * ds);
      }
    }
  }
  tr.t[0] = told.front();
  tr.t[static_cast<std::size_t>(N)] = told.back();
  for (int i = 0; i < d; ++i) {
    tr.node(0)[i] = from.node(0)[i];
    tr.node(N)[i] = from.node(M)[i];
  }
  return tr;
}

}  // namespace pardel
