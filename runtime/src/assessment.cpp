/**
 * @file assessment.cpp
 * What a returned trajectory is as a stationary point of the discrete action: the inertia of the
 * Hessian from its block LDL^T (minimum, saddle of index k, degenerate) and, at a minimum, its two
 * smallest eigenvalues by Lanczos on the inverse (the second one with the first deflated) against
 * Gershgorin's bound on the largest, which tells a well-posed minimum from a nearly degenerate one.
 * O(N) work: one factorization (or Newton's last one, at the same point) and at most 3 x 24 solves. Also the check that refuses a degenerate Lagrangian before solving.
 */
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <vector>

#include "assessment.hpp"
#include "block_tridiagonal.hpp"

namespace pardel::detail {
namespace {

std::string format(const char* fmt, double a, double b = 0, double c = 0, double d = 0) {
  char buf[512];
  std::snprintf(buf, sizeof buf, fmt, a, b, c, d);
  return buf;
}

/** The budget of Lanczos steps for each of the two smallest eigenvalues at a minimum. */
constexpr int kLanczosSteps = 24;

/** Scales the rows, then the columns, of a d x d row-major block by their largest |entry| (a zero
 *  row or column is left as it is): a congruence of diagonal matrices, which keeps the rank. */
void equilibrate(double* block, int d) {
  const std::size_t dz = static_cast<std::size_t>(d);
  for (std::size_t i = 0; i < dz; ++i) {
    double m = 0;
    for (std::size_t j = 0; j < dz; ++j) m = std::max(m, std::fabs(block[i * dz + j]));
    if (m > 0)
      for (std::size_t j = 0; j < dz; ++j) block[i * dz + j] /= m;
  }
  for (std::size_t j = 0; j < dz; ++j) {
    double m = 0;
    for (std::size_t i = 0; i < dz; ++i) m = std::max(m, std::fabs(block[i * dz + j]));
    if (m > 0)
      for (std::size_t i = 0; i < dz; ++i) block[i * dz + j] /= m;
  }
}

/** The smallest singular value of a d x d row-major block against its largest. */
double relative_smallest_singular_value(const double* block, int d) {
  Eigen::MatrixXd A = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(block, d, d);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A);
  const auto& s = svd.singularValues();
  if (!(s(0) > 0)) return 0;
  return s(d - 1) / s(0);
}

/** Sum over the rank's free components of a[i] b[i], reduced over the ranks. */
double dot(const LanczosOperator& op, const double* a, const double* b) {
  double s = 0;
  for (std::size_t i = 0; i < op.n; ++i) s += op.free[i] ? a[i] * b[i] : 0.0;
  op.reduce(&s, 1);
  return s;
}

/** The largest eigenvalue of the tridiagonal T (diagonal alpha, off-diagonal beta), its unit
 *  eigenvector and the next eigenvalue (-infinity for T of order 1). */
double top_ritz(const std::vector<double>& alpha, const std::vector<double>& beta, Eigen::VectorXd* vector,
                double* second) {
  const Eigen::Index k = static_cast<Eigen::Index>(alpha.size());
  Eigen::VectorXd d = Eigen::Map<const Eigen::VectorXd>(alpha.data(), k);
  Eigen::VectorXd e = Eigen::Map<const Eigen::VectorXd>(beta.data(), k - 1);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig;
  eig.computeFromTridiagonal(d, e, Eigen::ComputeEigenvectors);
  if (eig.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  *vector = eig.eigenvectors().col(k - 1);
  *second = k > 1 ? eig.eigenvalues()(k - 2) : -std::numeric_limits<double>::infinity();
  return eig.eigenvalues()(k - 1);
}

/**
 * Lanczos on A = H^-1 over the free components, projected against the unit vector y where y is
 * not null (A restricted to y's complement), from the start vector in v[1] (any norm): the largest
 * eigenvalue mu of A there, by the largest Ritz value of T_j, and 1/mu, an upper bound on the
 * smallest eigenvalue of H there. v holds three vectors of n (v[0] must be zero). Stops when the
 * residual bound puts mu within `settle` (relative) of an eigenvalue (after 3 steps at least) or
 * the Krylov space is invariant. With `replay` (the alpha, beta and Ritz vector s of an earlier run
 * from the same start) it recomputes the same basis with those coefficients instead and
 * accumulates the Ritz vector sum_j s_j v_j into y_out.
 */
struct Lanczos {
  std::vector<double> alpha, beta;
  Eigen::VectorXd s;  ///< the top Ritz vector of T
  double lambda = 0;  ///< 1 / (largest Ritz value)
  bool settled = false;
};
Lanczos lanczos(const LanczosOperator& op, double* v[3], const double* y, double settle, const Lanczos* replay,
                double* y_out) {
  const std::size_t n = op.n;
  const unsigned char* free = op.free;
  Lanczos run;
  double* prev = v[0];
  double* cur = v[1];
  double* next = v[2];
  if (y) {
    const double c = dot(op, y, cur);
    for (std::size_t i = 0; i < n; ++i) cur[i] -= c * y[i];
  }
  const double norm = std::sqrt(dot(op, cur, cur));
  if (!(norm > 0) || !std::isfinite(norm)) return run;
  for (std::size_t i = 0; i < n; ++i) cur[i] = free[i] ? cur[i] / norm : 0.0;
  if (y_out) std::fill(y_out, y_out + n, 0.0);
  const int steps = replay ? static_cast<int>(replay->alpha.size()) : kLanczosSteps;
  for (int j = 0; j < steps; ++j) {
    const double s_j = y_out ? replay->s(j) : 0.0;
    if (replay && j + 1 == steps) {  // the last basis vector is in
      for (std::size_t i = 0; i < n; ++i) y_out[i] += s_j * cur[i];
      break;
    }
    op.solve(cur, next);
    // W = P A v_j - beta_{j-1} v_{j-1} - alpha_j v_j (P the projection off y; fixed components
    // zero), in two passes over the vectors: the first removes y and v_{j-1} and forms
    // alpha_j = v_j.W, the second removes alpha_j v_j and forms |W|^2 (with a replay, the recorded
    // alpha and beta instead, and the Ritz vector's term of v_j).
    double c = 0;
    if (y) {
      for (std::size_t i = 0; i < n; ++i) c += free[i] ? y[i] * next[i] : 0.0;
      op.reduce(&c, 1);
    }
    const double b_prev = j > 0 ? (replay ? replay->beta[j - 1] : run.beta[j - 1]) : 0.0;
    double a = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double w = free[i] ? next[i] - (y ? c * y[i] : 0.0) - b_prev * prev[i] : 0.0;
      next[i] = w;
      a += cur[i] * w;
    }
    if (replay) {
      a = replay->alpha[j];
      const double inv_b = 1 / replay->beta[j];
      for (std::size_t i = 0; i < n; ++i) {
        next[i] = (next[i] - a * cur[i]) * inv_b;
        y_out[i] += s_j * cur[i];
      }
    } else {
      op.reduce(&a, 1);
      double bb = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const double w = next[i] - a * cur[i];
        next[i] = w;
        bb += w * w;
      }
      op.reduce(&bb, 1);
      run.alpha.push_back(a);
      double second = 0;
      const double mu = top_ritz(run.alpha, run.beta, &run.s, &second);
      if (!(mu > 0)) break;
      run.lambda = 1 / mu;
      const double b = std::sqrt(bb);
      // The Ritz pair's residual |A x - mu x| is b |s_j|; with the gap to the next Ritz value it
      // bounds the distance of mu to an eigenvalue by r^2 / gap (Kato-Temple, the gap estimated
      // from T). Settled when that is below `settle` of mu, or when the Krylov space is one that
      // A maps into itself (W vanishes against A's scale).
      const double r = b * std::fabs(run.s(run.s.size() - 1)), gap = mu - second;
      if ((run.alpha.size() >= 3 && r * r <= settle * mu * gap) || !(b > 1e-12 * mu)) {
        run.settled = true;
        break;
      }
      run.beta.push_back(b);
      const double inv_b = 1 / b;
      for (std::size_t i = 0; i < n; ++i) next[i] *= inv_b;
    }
    double* recycled = prev;
    prev = cur;
    cur = next;
    next = recycled;
  }
  return run;
}

/** Start vectors: smooth shapes, even (shape 0) and odd (shape 1) about the middle (the lowest
 *  modes of a string), with per-component weights of no pattern, plus a pseudo-random tenth, so
 *  that every eigenvector, whatever the mix of components in it, is in the start (a smooth shape
 *  alike in every component misses the modes whose components move against each other). The same
 *  on every rank (a function of the global index). */
void start_vector(const LanczosOperator& op, int shape, double* v) {
  std::vector<double> weights(static_cast<std::size_t>(op.dim));
  for (int a = 0; a < op.dim; ++a) weights[static_cast<std::size_t>(a)] = std::cos(1.3 + 2.1 * a + 0.7 * shape);
  for (std::size_t i = 0; i < op.n; ++i) {
    const int node = op.first_node + static_cast<int>(i / op.dim), a = static_cast<int>(i % op.dim);
    const double s = static_cast<double>(node) / op.N;
    const double smooth = shape == 0 ? s * (1 - s) : s * (1 - s) * (1 - 2 * s);
    const double weight = weights[static_cast<std::size_t>(a)];
    std::uint64_t x = (static_cast<std::uint64_t>(node) * static_cast<std::uint64_t>(op.dim) +
                       static_cast<std::uint64_t>(a) + 1) * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(shape);
    x ^= x >> 31;
    x *= 0xBF58476D1CE4E5B9ull;
    x ^= x >> 29;
    const double noise = static_cast<double>(x >> 11) / 9007199254740992.0 * 2 - 1;  // [-1, 1)
    v[i] = op.free[i] ? smooth * (weight + 0.1 * noise) : 0.0;
  }
}

}  // namespace

long fixed_components(const Context& ctx) {
  const std::size_t n = static_cast<std::size_t>(std::max(ctx.N - 1, 0)) * ctx.dim;
  const std::size_t dz = static_cast<std::size_t>(ctx.dim);
  long fixed = 0;
  for (std::size_t i = 0; i < n; ++i) fixed += ctx.is_free[dz + i] ? 0 : 1;
  return fixed;
}

SmallestEigenvalues smallest_eigenvalues(const LanczosOperator& op, long positive) {
  // lambda_1 by Lanczos on H^-1; its Ritz vector y by replaying that run, refined by one inverse
  // iteration; then lambda_2 by Lanczos on H^-1 restricted to the complement of y. The deflation
  // keeps the converged lambda_1 out of the second run: without it, a Lanczos basis that loses
  // orthogonality once lambda_1 converges returns it a second time (a "ghost"), which a lambda_1
  // far below lambda_2 (a nearly degenerate minimum) does at once. A repeated lambda_1 is found
  // again in the complement.
  const std::size_t n = op.n;
  std::unique_ptr<double[]> store;
  double* w[4] = {op.work[0], op.work[1], op.work[2], op.work[3]};
  if (!(w[0] && w[1] && w[2] && w[3])) {
    store.reset(new double[4 * n]);
    for (std::size_t k = 0; k < 4; ++k) w[k] = store.get() + k * n;
  }
  double* v[3] = {w[0], w[1], w[2]};
  double* y = w[3];
  SmallestEigenvalues out;
  std::fill(v[0], v[0] + n, 0.0);
  start_vector(op, 0, v[1]);
  const Lanczos first = lanczos(op, v, nullptr, 1e-4, nullptr, nullptr);
  out.lambda[0] = first.lambda;
  if (positive < 2 || first.alpha.empty()) {
    out.settled = first.settled;
    return out;
  }
  std::fill(v[0], v[0] + n, 0.0);
  start_vector(op, 0, v[1]);
  lanczos(op, v, nullptr, 0, &first, y);
  // One inverse iteration from the Ritz vector, z = H^-1 y: the Rayleigh quotient of H at z,
  // z.H z / z.z = z.y / z.z (as H z = y), is an upper bound on lambda_1 whose error is the square
  // of z's angle to the eigenvector (a factor lambda_1 / lambda_2 below y's), and z/|z| is the
  // vector deflated below.
  op.solve(y, v[2]);
  const double zy = dot(op, v[2], y), zz = dot(op, v[2], v[2]);
  if (zz > 0 && zy > 0 && std::isfinite(zz)) {
    out.lambda[0] = std::min(out.lambda[0], zy / zz);
    const double nz = std::sqrt(zz);
    for (std::size_t i = 0; i < n; ++i) y[i] = op.free[i] ? v[2][i] / nz : 0.0;
  } else {
    const double ny = std::sqrt(dot(op, y, y));
    for (std::size_t i = 0; i < n; ++i) y[i] /= ny;
  }
  std::fill(v[0], v[0] + n, 0.0);
  start_vector(op, 1, v[1]);
  const Lanczos second = lanczos(op, v, y, 3e-3, nullptr, nullptr);
  out.lambda[1] = std::max(second.lambda, first.lambda);
  out.settled = first.settled && second.settled;
  return out;
}

void describe_minimum(const SmallestEigenvalues& e, double action, PointAssessment& out) {
  out.kind = PointKind::minimum;
  out.lambda_min = e.lambda[0];
  out.lambda_next = e.lambda[1];
  out.lambda_settled = e.settled;
  if (out.positive >= 2 && out.lambda_min < 1e-4 * out.lambda_next) {
    out.nearly_degenerate = true;
    out.soft_motion = std::sqrt(2 * 1e-16 * std::max(std::fabs(action), 1e-300) / std::max(out.lambda_min, 1e-300));
    out.note = format("a nearly degenerate minimum: the smallest eigenvalue of the Hessian, %.3g, is %.2g of the "
                      "next (%.3g); the action is determined to round-off, the trajectory only up to a motion of "
                      "size about %.2g along one direction",
                      out.lambda_min, out.lambda_min / out.lambda_next, out.lambda_next, out.soft_motion);
  } else if (out.lambda_settled) {
    out.note = format("a strict local minimum: Hessian positive definite, eigenvalues from %.3g (next %.3g) to at "
                      "most %.3g",
                      out.lambda_min, out.lambda_next, out.lambda_max);
  } else {
    out.note = format("a strict local minimum: Hessian positive definite, eigenvalues from at most %.3g (next at "
                      "most %.3g) to at most %.3g",
                      out.lambda_min, out.lambda_next, out.lambda_max);
  }
  if (!out.lambda_settled)
    out.note += format("; the two smallest are upper bounds: Ritz values of %.0f Lanczos steps that had not "
                       "settled",
                       static_cast<double>(kLanczosSteps));
  // Round-off in the DEL residual moves a solution by up to the condition number times 1e-16
  // (relative): say so where that exceeds 1e-3 (high orders at large N: the condition grows like
  // N^(2 order)).
  const double condition = out.lambda_max / out.lambda_min;
  if (out.lambda_min > 0 && condition * 1e-16 > 1e-3) {
    out.note += format("; the Hessian's condition number is about %.2g, so round-off alone can move the trajectory by "
                       "up to %.2g relative",
                       condition, condition * 1e-16);
  }
}

void assess_minimum(Context& ctx, double lambda_max, const std::function<void(const double* b, double* x)>& solve,
                    PointAssessment& out, double* const* work) {
  out = PointAssessment{};
  out.lambda_max = lambda_max;
  const std::size_t n = static_cast<std::size_t>(std::max(ctx.N - 1, 0)) * ctx.dim;
  const std::size_t dz = static_cast<std::size_t>(ctx.dim);
  out.positive = static_cast<long>(n) - fixed_components(ctx);
  out.kind = PointKind::minimum;
  if (out.positive <= 0) {
    out.note = "no unknowns";
    return;
  }
  LanczosOperator op;
  op.n = n;
  op.dim = ctx.dim;
  op.first_node = 1;
  op.N = ctx.N;
  op.free = ctx.is_free.data() + dz;
  // An interruption after convergence stops the assessment at its next block solve.
  struct Interrupted {};
  op.solve = [&solve, &ctx](const double* b, double* x) {
    if (ctx.keep_going && !ctx.keep_going()) throw Interrupted{};
    solve(b, x);
  };
  op.reduce = [](double*, int) {};
  if (work)
    for (int k = 0; k < 4; ++k) op.work[k] = work[k];
  try {
    describe_minimum(smallest_eigenvalues(op, out.positive), sum_action(ctx), out);
  } catch (const Interrupted&) {
    out = PointAssessment{};
    out.note = "not assessed: interrupted during the assessment of the converged point";
  }
}

bool classify_indefinite(PointAssessment& out) {
  if (out.negative > 0) {
    out.kind = PointKind::saddle;
    out.note = format("a saddle of the action: the Hessian has %.0f negative eigenvalue(s) (index %.0f)",
                      static_cast<double>(out.negative), static_cast<double>(out.negative));
    if (out.zero > 0) out.note += format(" and %.0f zero one(s)", static_cast<double>(out.zero));
    return true;
  }
  if (out.zero > 0) {
    out.kind = PointKind::degenerate;
    out.note = format("degenerate to working precision: the Hessian of the action has %.0f eigenvalue(s) that "
                      "are zero within 1e-12 of its largest (Jacobi-scaled) and no negative one; either the solution is not "
                      "isolated (a family of trajectories, or a Lagrangian that does not determine the motion) "
                      "or the Hessian is too ill-conditioned for double precision to tell (high-order models "
                      "at large N)",
                      static_cast<double>(out.zero));
    return true;
  }
  return false;
}

void assess(Context& ctx, PointAssessment& out) {
  out = PointAssessment{};
  if (ctx.N < 2) return;
  ensure_interval_arrays(ctx, Evaluated::full);
  if (ctx.evaluated != Evaluated::full) eval_full(ctx, ctx.q);
  for (double v : ctx.D11)
    if (!std::isfinite(v)) return;
  for (double v : ctx.D12)
    if (!std::isfinite(v)) return;
  for (double v : ctx.D22)
    if (!std::isfinite(v)) return;
  dispatch_dim_cold(ctx.dim, [&](auto D) {
    BlockTridiagonal<decltype(D)::value> H;
    H.resize(ctx.N, ctx.dim);
    H.assemble(ctx, 0.0);
    assess_hessian(ctx, H, false, out);
  });
}

bool lagrangian_regular(const Context& ctx, std::string* message) {
  // Up to 64 intervals spread over the grid, each evaluated alone with the full kernel.
  const int d = ctx.dim, N = ctx.N;
  const std::size_t dz = static_cast<std::size_t>(d), dd = dz * dz;
  std::vector<double> D1(dz), D2(dz), D11(dd), D12(dd), D22(dd);
  const int samples = std::min(N, 64);
  int singular = 0;
  for (int s = 0; s < samples; ++s) {
    const int k = static_cast<int>((static_cast<long>(s) * N) / samples);
    const std::size_t kk = static_cast<std::size_t>(k);
    double Ld = 0;
    ctx.disc->full(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], ctx.q.data() + kk * dz, ctx.q.data() + (kk + 1) * dz, ctx.p(),
                   &Ld, D1.data(), D2.data(), D11.data(), D12.data(), D22.data());
    bool finite = true;
    for (double v : D12) finite = finite && std::isfinite(v);
    if (!finite) return true;  // non-finite values are reported by the solve itself
    // Component i of a point is the k_i = (i / ncoords)-th derivative, and the entries of D12
    // pairing derivatives k and l scale like h^(k + l + 1 - 2 order): D12 is equilibrated by
    // h^-(k_i + k_j) before its singular values are compared (unscaled, their spread at order 4
    // fell below 1e-12 at h = 1/16 on a regular model; scaled it is 6e-6 at every h).
    const int nc = std::max(ctx.model->ncoords, 1);
    const double h = std::fabs(ctx.hk[kk]) > 0 ? std::fabs(ctx.hk[kk]) : 1.0;
    for (int i = 0; i < d; ++i)
      for (int j = 0; j < d; ++j) D12[static_cast<std::size_t>(i * d + j)] *= std::pow(h, -(i / nc + j / nc));
    // Then rows and columns by their largest entries (the rank is unchanged): coordinates in units
    // whose terms differ by 10^12 (W = diag(1e12, 1)) are not taken for a singular D12.
    equilibrate(D12.data(), d);
    if (relative_smallest_singular_value(D12.data(), d) <= 1e-12) ++singular;
  }
  if (singular < samples) return true;
  *message = "model '" + std::string(ctx.model->name ? ctx.model->name : "?") +
             "' is degenerate: the mixed derivative D12 Ld of its discrete Lagrangian is singular on every one of the " +
             std::to_string(samples) +
             " intervals checked at the initial guess, so the DEL equations do not determine the motion "
             "(the Lagrangian's Hessian in the highest derivatives is singular: does L depend on the "
             "derivatives of every coordinate?)";
  return false;
}

}  // namespace pardel::detail

namespace pardel {

PointAssessment assess_point(const Problem& problem, const Trajectory& trajectory, int threads) {
  PointAssessment out;
  detail::Context ctx;
  std::string error;
  if (!detail::context_at(problem, trajectory, threads, ctx, &error)) {
    out.note = error;
    return out;
  }
  detail::assess(ctx, out);
  return out;
}

}  // namespace pardel
