/**
 * @file engine.cpp
 * The solve context and what every method shares: kernel evaluation over all intervals in
 * parallel (each interval once, shared by its two nodes), the DEL residual on free components,
 * the discrete action summed in a fixed order, constraints (boundaries, knots) and node times.
 */
#include "engine.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pardel::detail {

int resolve_threads(int requested) {
#ifdef _OPENMP
  if (requested <= 0) return std::max(1, omp_get_num_procs());
  return requested;
#else
  (void)requested;
  return 1;
#endif
}

void setup_grid(const Problem& problem, int N, int threads, Grid& grid) {
  const pardel_model& m = *problem.model;
  grid.model = problem.model;
  grid.disc = problem.discretization;
  grid.dim = m.dim;
  grid.ncoords = m.ncoords;
  grid.order = m.order;
  grid.N = N;
  grid.threads = threads;
  grid.params = problem.params;
  if (grid.params.empty() && m.nparams > 0) grid.params.assign(m.param_defaults, m.param_defaults + m.nparams);
  grid.clock = problem.clock;
  grid.t0 = problem.t0;
  grid.T = problem.T;
  const std::size_t n1 = static_cast<std::size_t>(N) + 1, d = static_cast<std::size_t>(m.dim);
  auto fit = [&grid](auto& v, std::size_t n, auto value) { assign_within(v, n, grid.capacity(n), value); };
  fit(grid.t, n1, 0.0);
  fit(grid.hk, static_cast<std::size_t>(N), problem.T / N);
  for (int k = 0; k <= N; ++k) grid.t[static_cast<std::size_t>(k)] = problem.t0 + problem.T * k / N;
  grid.t[static_cast<std::size_t>(N)] = problem.t0 + problem.T;
  if (!problem.times.empty() && N == problem.N) {  // a non-uniform grid (Problem::times)
    for (int k = 0; k <= N; ++k) grid.t[static_cast<std::size_t>(k)] = problem.times[static_cast<std::size_t>(k)];
    steps_from_times(grid);
  }
  fit(grid.is_free, n1 * d, static_cast<unsigned char>(1));
  fit(grid.free_count, n1, m.dim);
}

void setup_workspace(const Grid& grid, Workspace& work) {
  const std::size_t n1 = static_cast<std::size_t>(grid.N) + 1, d = static_cast<std::size_t>(grid.dim);
  auto fit = [&grid](auto& v, std::size_t n, auto value) { assign_within(v, n, grid.capacity(n), value); };
  fit(work.q, n1 * d, 0.0);
  fit(work.q_next, n1 * d, 0.0);
  // Interval arrays: allocated by the first evaluation that needs them (ensure_interval_arrays);
  // released here unless a finer level will reuse them.
  for (std::vector<double>* v : {&work.Ld, &work.D1, &work.D2, &work.D11, &work.D12, &work.D22}) {
    if (grid.reserve_N > grid.N)
      v->clear();
    else
      std::vector<double>().swap(*v);
  }
  fit(work.res, n1 * d, 0.0);
  fit(work.node_scratch, n1, 0.0);
  work.comp_residual.assign(d, 0.0);
  work.comp_scale.assign(d, 0.0);
  work.comp_hq.assign(d, 0.0);
  work.evaluated = Evaluated::nothing;
  work.residual = 0;
  work.action = 0;
  work.action_known = false;
}

void setup_context(const Problem& problem, int N, int threads, Context& ctx) {
  setup_grid(problem, N, threads, ctx);
  setup_workspace(ctx, ctx);
}

double diagonal_spread(const Context& ctx) {
  const std::size_t d = static_cast<std::size_t>(ctx.dim), dd = d * d;
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  for (int k = 1; k < ctx.N; ++k) {
    const std::size_t kk = static_cast<std::size_t>(k);
    if (ctx.D11.size() < (kk + 1) * dd || ctx.D22.size() < kk * dd) return 1;
    for (std::size_t a = 0; a < d; ++a) {
      if (!ctx.is_free[kk * d + a]) continue;
      const double v = std::fabs(ctx.D22[(kk - 1) * dd + a * (d + 1)] + ctx.D11[kk * dd + a * (d + 1)]);
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  return hi > 0 && lo > 0 && std::isfinite(hi) ? hi / lo : 1;
}

int knot_node(const Problem& problem, std::size_t a, int N, std::string* message) {
  const Knot& knot = problem.knots[a];
  if (!problem.times.empty() && N == problem.N) {  // a given grid: the node at the knot's time
    const std::vector<double>& t = problem.times;
    const double tol = 1e-9 * std::max(1.0, std::fabs(knot.t));
    const int k = static_cast<int>(std::lower_bound(t.begin(), t.end(), knot.t - tol) - t.begin());
    if (k > 0 && k < N && std::fabs(t[static_cast<std::size_t>(k)] - knot.t) <= tol) return k;
    char buf[320];
    const int hi = std::min(N, std::max(1, k)), lo = hi - 1;
    std::snprintf(buf, sizeof buf,
                  "knot %zu at t = %.12g is not on an interior node of the given grid (problem.times); nearest "
                  "nodes: %d (t = %.12g) and %d (t = %.12g)",
                  a, knot.t, lo, t[static_cast<std::size_t>(lo)], hi, t[static_cast<std::size_t>(hi)]);
    if (message) *message = buf;
    return -1;
  }
  const double s = (knot.t - problem.t0) / problem.T * N;
  const double k_near = std::floor(s);
  const int k = static_cast<int>(std::lround(s));
  if (std::fabs(s - k) <= 1e-9 * std::max(1.0, std::fabs(s)) && k > 0 && k < N) return k;
  char buf[320];
  const int lo = static_cast<int>(std::max(0.0, std::min<double>(N, k_near)));
  const int hi = std::min(N, lo + 1);
  std::snprintf(buf, sizeof buf,
                "knot %zu at t = %.12g is not on an interior grid node with N = %d; nearest nodes: "
                "%d (t = %.12g) and %d (t = %.12g)",
                a, knot.t, N, lo, problem.t0 + problem.T * lo / N, hi, problem.t0 + problem.T * hi / N);
  if (message) *message = buf;
  return -1;
}

bool apply_constraints(const Problem& problem, Context& ctx, std::string* message) {
  std::fill(ctx.is_free.begin(), ctx.is_free.end(), 1);
  if (!constrain_nodes(problem, ctx, ctx.N, 0, ctx.N, ctx.is_free.data(), ctx.q.data(), message)) return false;
  count_free(ctx);
  return true;
}

bool constrain_nodes(const Problem& problem, const Grid& grid, int N, int lo, int hi, unsigned char* free, double* q,
                     std::string* message) {
  const std::size_t d = static_cast<std::size_t>(grid.dim);
  auto fix = [&](int k, int from, int to) {
    if (k < lo || k > hi) return;
    for (int i = from; i < to; ++i) free[static_cast<std::size_t>(k - lo) * d + static_cast<std::size_t>(i)] = 0;
  };
  fix(0, 0, grid.dim);
  fix(N, 0, grid.dim);
  for (std::size_t a = 0; a < problem.knots.size(); ++a) {
    const Knot& knot = problem.knots[a];
    const int k = knot_node(problem, a, N, message);
    if (k < 0) return false;
    // Order 1: the whole node is fixed; order >= 2: only the coordinates (seed eq2-interpolation).
    fix(k, 0, grid.order == 1 ? grid.dim : grid.ncoords);
    if (k < lo || k > hi) continue;
    double* qk = q + static_cast<std::size_t>(k - lo) * d;
    for (int i = 0; i < grid.ncoords; ++i) qk[i] = knot.q[static_cast<std::size_t>(i)];
  }
  return true;
}

void place_end_points(const Problem& problem, int N, int lo, int hi, int dim, double* q) {
  const std::size_t d = static_cast<std::size_t>(dim);
  for (std::size_t i = 0; i < d; ++i) {
    if (lo == 0) q[i] = problem.q0[i];
    if (hi == N) q[static_cast<std::size_t>(N - lo) * d + i] = problem.qN[i];
  }
}

void count_free(Grid& grid) {
  const std::size_t d = static_cast<std::size_t>(grid.dim);
  grid.free_total = 0;
  for (std::size_t j = 0; j < grid.free_count.size(); ++j) {
    int count = 0;
    for (std::size_t i = 0; i < d; ++i) count += grid.is_free[j * d + i];
    grid.free_count[j] = count;
    grid.free_total += count;
  }
}

void steps_from_times(Grid& grid) {
  for (std::size_t k = 0; k < grid.hk.size(); ++k) grid.hk[k] = grid.t[k + 1] - grid.t[k];
}

bool take_times(const Problem& problem, const Trajectory& trajectory, Grid& grid) {
  if (trajectory.t.size() != grid.t.size()) return false;
  grid.t = trajectory.t;
  if (problem.clock == ClockMode::fixed_total_time) steps_from_times(grid);
  return true;
}

void ensure_interval_arrays(Context& ctx, Evaluated kind) {
  const std::size_t N = static_cast<std::size_t>(ctx.N), d = static_cast<std::size_t>(ctx.dim);
  auto size = [&ctx](std::vector<double>& v, std::size_t n) {
    if (v.size() != n) assign_within(v, n, ctx.capacity(n), 0.0);
  };
  size(ctx.D1, N * d);
  size(ctx.D2, N * d);
  if (kind != Evaluated::sweep) size(ctx.Ld, N);
  if (kind != Evaluated::grad) {
    size(ctx.D11, N * d * d);
    size(ctx.D22, N * d * d);
  }
  if (kind == Evaluated::full) size(ctx.D12, N * d * d);
}

void eval_sweep(Context& ctx, const std::vector<double>& q) {
  ensure_interval_arrays(ctx, Evaluated::sweep);
  const int d = ctx.dim, N = ctx.N;
  const std::size_t dd = static_cast<std::size_t>(d) * d;
  const pardel_sweep_kernel kern = ctx.disc->sweep;
  const double* p = ctx.p();
#pragma omp parallel for if (ctx.parallel(N)) num_threads(ctx.threads) schedule(static)
  for (int k = 0; k < N; ++k) {
    const std::size_t kk = static_cast<std::size_t>(k);
    kern(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], q.data() + kk * d, q.data() + (kk + 1) * d, p,
         ctx.D1.data() + kk * d, ctx.D2.data() + kk * d, ctx.D11.data() + kk * dd, ctx.D22.data() + kk * dd);
  }
  ctx.evaluated = Evaluated::sweep;
}

void eval_full(Context& ctx, const std::vector<double>& q) {
  ensure_interval_arrays(ctx, Evaluated::full);
  const int d = ctx.dim, N = ctx.N;
  const std::size_t dd = static_cast<std::size_t>(d) * d;
  const pardel_full_kernel kern = ctx.disc->full;
  const double* p = ctx.p();
#pragma omp parallel for if (ctx.parallel(N)) num_threads(ctx.threads) schedule(static)
  for (int k = 0; k < N; ++k) {
    const std::size_t kk = static_cast<std::size_t>(k);
    kern(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], q.data() + kk * d, q.data() + (kk + 1) * d, p, &ctx.Ld[kk],
         ctx.D1.data() + kk * d, ctx.D2.data() + kk * d, ctx.D11.data() + kk * dd, ctx.D12.data() + kk * dd,
         ctx.D22.data() + kk * dd);
  }
  ctx.evaluated = Evaluated::full;
}

void eval_grad(Context& ctx, const std::vector<double>& q) {
  ensure_interval_arrays(ctx, Evaluated::grad);
  const int d = ctx.dim, N = ctx.N;
  const pardel_grad_kernel kern = ctx.disc->grad;
  const double* p = ctx.p();
#pragma omp parallel for if (ctx.parallel(N)) num_threads(ctx.threads) schedule(static)
  for (int k = 0; k < N; ++k) {
    const std::size_t kk = static_cast<std::size_t>(k);
    kern(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], q.data() + kk * d, q.data() + (kk + 1) * d, p, &ctx.Ld[kk],
         ctx.D1.data() + kk * d, ctx.D2.data() + kk * d);
  }
  ctx.evaluated = Evaluated::grad;
}

int compute_residual(Context& ctx, const std::vector<double>& q) {
  const int d = ctx.dim, N = ctx.N;
  const std::size_t dz = static_cast<std::size_t>(d);
  // The Hessian term of the round-off level needs the full kernel's arrays at q.
  const bool hessian = ctx.evaluated == Evaluated::full && ctx.D12.size() >= static_cast<std::size_t>(N) * dz * dz;
  ctx.comp_residual.assign(dz, 0.0);
  ctx.comp_scale.assign(dz, 0.0);
  ctx.comp_hq.assign(dz, 0.0);
  // Maxima and the first non-finite node by reductions (max and min are exact in any order: the
  // same for any team), in the one pass that writes res.
  double* c_res = ctx.comp_residual.data();
  double* c_scale = ctx.comp_scale.data();
  double* c_hq = ctx.comp_hq.data();
  double mx = 0, scale = 0, hq = 0;
  int bad = N + 1;
#pragma omp parallel for if (ctx.parallel(N)) num_threads(ctx.threads) schedule(static) \
    reduction(max : c_res[:d], c_scale[:d], c_hq[:d], mx, scale, hq) reduction(min : bad)
  for (int k = 0; k <= N; ++k) {
    const std::size_t kk = static_cast<std::size_t>(k);
    double* r = ctx.res.data() + kk * dz;
    const unsigned char* f = ctx.is_free.data() + kk * dz;
    bool finite = true;
    for (int i = 0; i < d; ++i) {
      double v = 0;
      if (f[i]) {
        const double a = ctx.D2[(kk - 1) * dz + i], b = ctx.D1[kk * dz + i];
        v = a + b;
        if (!std::isfinite(v)) finite = false;
        scale = std::max(scale, std::fabs(a) + std::fabs(b));
        c_res[i] = std::max(c_res[i], std::fabs(v));
        c_scale[i] = std::max(c_scale[i], std::fabs(a) + std::fabs(b));
      }
      r[i] = v;
      mx = std::max(mx, std::fabs(v));
    }
    if (!finite) bad = std::min(bad, k);
    if (hessian && k > 0 && k < N) {
      // |H_k| |q| over the node's row of the Hessian: D22(k-1), D11(k), D12(k-1)^T, D12(k).
      const std::size_t dd = dz * dz;
      const double* A = ctx.D22.data() + (kk - 1) * dd;
      const double* B = ctx.D11.data() + kk * dd;
      const double* Cm = ctx.D12.data() + (kk - 1) * dd;
      const double* Cp = ctx.D12.data() + kk * dd;
      const double* qm = q.data() + (kk - 1) * dz;
      const double* q0 = q.data() + kk * dz;
      const double* qp = q.data() + (kk + 1) * dz;
      for (int i = 0; i < d; ++i) {
        if (!f[i]) continue;
        double row = 0;
        for (int j = 0; j < d; ++j)
          row += std::fabs(A[i * d + j] * q0[j]) + std::fabs(B[i * d + j] * q0[j]) + std::fabs(Cm[j * d + i] * qm[j]) +
                 std::fabs(Cp[i * d + j] * qp[j]);
        hq = std::max(hq, row);
        c_hq[i] = std::max(c_hq[i], row);
      }
    }
  }
  const double eps = std::numeric_limits<double>::epsilon();
  ctx.residual_scale = scale;
  ctx.residual_floor = 16 * eps * scale + 2 * eps * hq;
  for (double measured : ctx.comp_floor_measured) ctx.residual_floor = std::max(ctx.residual_floor, measured);
  if (bad <= N) {
    ctx.residual = std::numeric_limits<double>::quiet_NaN();
    return bad;
  }
  ctx.residual = mx;
  return -1;
}

double sum_action(const Context& ctx) {
  double s = 0;
  for (double v : ctx.Ld) s += v;
  return s;
}

double action_at(Context& ctx, const std::vector<double>& q) {
  const int d = ctx.dim, N = ctx.N;
  const pardel_action_kernel kern = ctx.disc->action;
  const double* p = ctx.p();
  std::vector<double>& out = ctx.node_scratch;  // N+1 scratch, only the first N used here
#pragma omp parallel for if (ctx.parallel(N)) num_threads(ctx.threads) schedule(static)
  for (int k = 0; k < N; ++k) {
    const std::size_t kk = static_cast<std::size_t>(k);
    out[kk] = kern(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], q.data() + kk * d, q.data() + (kk + 1) * d, p);
  }
  double s = 0;
  for (int k = 0; k < N; ++k) s += out[static_cast<std::size_t>(k)];
  return s;
}

void retime_nodes(const RetimeGrid& old, const double* t_new, int k_first, int k_last, double* q_new) {
  const int d = old.dim, nc = old.ncoords;
  const bool has_derivative = d >= 2 * nc;
  auto t = [&](int j) { return old.t[j - old.j_first]; };
  auto node = [&](int j) { return old.q + static_cast<std::size_t>(j - old.j_first) * d; };
  auto slope = [&](int j, int i) {  // d q_i / dt by central differences of the old nodes
    const int a = std::max(0, j - 1), b = std::min(old.N, j + 1);
    return (node(b)[i] - node(a)[i]) / (t(b) - t(a));
  };
  int j = std::max(old.j_first, 0);
  const int j_max = std::min(old.j_last, old.N) - 1;  // the last interval whose both ends are given
  for (int k = k_first; k <= k_last; ++k) {
    const double tk = t_new[k - k_first];
    while (j < j_max && t(j + 1) <= tk) ++j;
    const double dt = t(j + 1) - t(j);
    const double u = dt > 0 ? std::clamp((tk - t(j)) / dt, 0.0, 1.0) : 0.0;
    const double u2 = u * u, u3 = u2 * u;
    const double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
    const double a00 = 6 * u2 - 6 * u, a10 = 3 * u2 - 4 * u + 1, a11 = 3 * u2 - 2 * u;  // d/du of the basis
    const double* a = node(j);
    const double* b = node(j + 1);
    double* q = q_new + static_cast<std::size_t>(k - k_first) * d;
    for (int i = 0; i < d; ++i) {
      if (has_derivative && i < nc) {
        q[i] = h00 * a[i] + h10 * a[nc + i] * dt + h01 * b[i] + h11 * b[nc + i] * dt;
      } else if (has_derivative && i < 2 * nc) {
        const int c = i - nc;
        q[i] = dt > 0 ? (a00 * (a[c] - b[c]) + a10 * a[i] * dt + a11 * b[i] * dt) / dt : a[i];
      } else if (has_derivative) {
        q[i] = (1 - u) * a[i] + u * b[i];
      } else {
        q[i] = h00 * a[i] + h10 * slope(j, i) * dt + h01 * b[i] + h11 * slope(j + 1, i) * dt;
      }
    }
  }
}

double free_time_step(const Grid& ctx, double t0, const double* q0, const double* q1, double hs, double guess) {
  const pardel_action_kernel travel = ctx.disc ? ctx.disc->travel : nullptr;
  if (!travel) return ctx.model->clock(hs, t0, q0, q1, ctx.p());
  if (!end_times_are_fixed_points(ctx)) return travel(hs, t0, t0, q0, q1, ctx.p());
  // dt = travel(t0, t0 + dt): a contraction by about hs |dF/dt|, from the interval's previous
  // duration where there is one (a few steps near a solution), else the left rule's.
  constexpr int kTravelIterations = 100;
  double dt = guess > 0 && std::isfinite(guess) ? guess : ctx.model->clock(hs, t0, q0, q1, ctx.p());
  // Fixed-point steps, each after the first taken by the secant through the last two (the map's
  // slope estimated from them) while that slope is a contraction's; where the secant's point does
  // not lower the fixed-point residual |travel - dt| (or has no travel time), the plain step it
  // replaced is taken instead.
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  double before = nan, image_before = nan, plain = nan, residual_before = std::numeric_limits<double>::infinity();
  for (int it = 0; it < kTravelIterations && std::isfinite(dt); ++it) {
    const double image = travel(hs, t0, t0 + dt, q0, q1, ctx.p());
    const double residual = std::fabs(image - dt);
    if (!(residual < residual_before) && std::isfinite(plain)) {
      dt = plain;
      plain = nan;
      continue;
    }
    if (std::isfinite(image) &&
        residual <= 4 * std::numeric_limits<double>::epsilon() * std::max(std::fabs(t0), std::fabs(image)))
      return image;
    residual_before = residual;
    double next = image;
    plain = nan;
    const double slope = (image - image_before) / (dt - before);
    if (std::isfinite(slope) && std::fabs(slope) < 0.9) {
      next = dt + (image - dt) / (1 - slope);
      plain = image;
    }
    before = dt;
    image_before = image;
    dt = next;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

double time_shift(const Context& ctx, const std::vector<double>& delta) {
  const std::size_t d = static_cast<std::size_t>(ctx.dim), N = static_cast<std::size_t>(ctx.N);
  if (ctx.clock != ClockMode::free_final_time || !ctx.model->clock || delta.size() != (N - 1) * d) return 0;
  std::vector<double> moved = ctx.q;
  for (std::size_t i = 0; i < delta.size(); ++i) moved[d + i] += delta[i];
  const double hs = ctx.T / ctx.N;
  double t = ctx.t0, shift = 0;  // the moved path's time at node k + 1
  for (std::size_t k = 0; k < N; ++k) {
    t += free_time_step(ctx, t, moved.data() + k * d, moved.data() + (k + 1) * d, hs, ctx.t[k + 1] - ctx.t[k]);
    shift = std::max(shift, std::fabs(t - ctx.t[k + 1]));
  }
  return shift;
}

void update_times(Context& ctx, Positions positions) {
  const std::vector<double>& q = ctx.q;
  if (ctx.clock == ClockMode::none || ctx.model->clock == nullptr) return;
  const int d = ctx.dim, N = ctx.N;
  const double hs = ctx.T / N;
  const double* p = ctx.p();
  if (ctx.clock == ClockMode::free_final_time) {
    // A sequential prefix sum: each step needs the time reached so far.
    // Each interval's previous duration (0 where the times are not yet set) starts its step.
    double start_before = ctx.t[0];
    ctx.t[0] = ctx.t0;
    for (int k = 0; k < N; ++k) {
      const std::size_t kk = static_cast<std::size_t>(k);
      const double end_before = ctx.t[kk + 1];
      ctx.t[kk + 1] = ctx.t[kk] + free_time_step(ctx, ctx.t[kk], q.data() + kk * d, q.data() + (kk + 1) * d, hs,
                                                  end_before - start_before);
      start_before = end_before;
      ctx.hk[kk] = hs;
    }
  } else {
    // Sundman adaptive step: dt_k proportional to the clock of interval k (evaluated at the
    // previous times), normalized so that the steps sum to T.
    std::vector<double>& c = ctx.hk;
    double total = 0;
    for (int k = 0; k < N; ++k) {
      const std::size_t kk = static_cast<std::size_t>(k);
      c[kk] = ctx.model->clock(hs, ctx.t[kk], q.data() + kk * d, q.data() + (kk + 1) * d, p);
      total += c[kk];
    }
    std::vector<double>& t_old = ctx.node_scratch;  // N+1 scratch
    if (positions == Positions::follow_times) {
      t_old = ctx.t;
      ctx.q_old = ctx.q;
    }
    ctx.t[0] = ctx.t0;
    for (int k = 0; k < N; ++k) {
      const std::size_t kk = static_cast<std::size_t>(k);
      ctx.t[kk + 1] = ctx.t[kk] + ctx.T * c[kk] / total;
    }
    ctx.t[static_cast<std::size_t>(N)] = ctx.t0 + ctx.T;
    if (positions == Positions::follow_times) {
      const RetimeGrid old{t_old.data(), ctx.q_old.data(), 0, N, N, d, ctx.model->ncoords};
      // Interior nodes only; a component held fixed (is_free 0) keeps its value.
      retime_nodes(old, ctx.t.data() + 1, 1, N - 1, ctx.q.data() + d);
      for (std::size_t i = static_cast<std::size_t>(d); i < static_cast<std::size_t>(N) * d; ++i)
        if (!ctx.is_free[i]) ctx.q[i] = ctx.q_old[i];
    }
    for (int k = 0; k < N; ++k) {
      const std::size_t kk = static_cast<std::size_t>(k);
      ctx.hk[kk] = ctx.t[kk + 1] - ctx.t[kk];
    }
  }
  ctx.evaluated = Evaluated::nothing;
  ctx.action_known = false;
}

int first_non_finite_node(const Context& ctx, const std::vector<double>& q) {
  const std::size_t d = static_cast<std::size_t>(ctx.dim);
  for (int k = 0; k <= ctx.N; ++k)
    for (std::size_t i = 0; i < d; ++i)
      if (!std::isfinite(q[static_cast<std::size_t>(k) * d + i])) return k;
  return -1;
}

bool context_at(const Problem& problem, const Trajectory& trajectory, int threads, Context& ctx, std::string* error) {
  if (!validate(problem, trajectory, error)) return false;
  if (trajectory.N != problem.N) {
    *error = "trajectory.N = " + std::to_string(trajectory.N) + " differs from problem.N = " + std::to_string(problem.N);
    return false;
  }
  setup_context(problem, problem.N, resolve_threads(threads), ctx);
  if (!apply_constraints(problem, ctx, error)) return false;
  ctx.q = trajectory.q;
  if (problem.clock != ClockMode::none && !take_times(problem, trajectory, ctx)) update_times(ctx, Positions::stay);
  return true;
}

}  // namespace pardel::detail
