/**
 * @file assessment.cpp
 * What a returned trajectory is as a stationary point of the discrete action: the inertia of the
 * Hessian from its block LDL^T (minimum, saddle of index k, degenerate) and, at a minimum, its two
 * smallest eigenvalues by block Lanczos on the inverse against Gershgorin's bound on the largest,
 * which tells a well-posed minimum from a nearly degenerate one. O(N) work: one factorization (or
 * Newton's last one, at the same point) and at most 2 x 24 solves. Also the check that refuses a degenerate Lagrangian before solving.
 */
#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <limits>

#include "assessment.hpp"
#include "block_tridiagonal.hpp"

namespace pardel::detail {
namespace {

std::string format(const char* fmt, double a, double b = 0, double c = 0, double d = 0) {
  char buf[512];
  std::snprintf(buf, sizeof buf, fmt, a, b, c, d);
  return buf;
}

/** Pivot eigenvalues below this fraction of their block's size count as zero. */
constexpr double kZeroPivot = 1e-12;
/** The budget of block Lanczos steps for the two smallest eigenvalues at a minimum. */
constexpr int kLanczosSteps = 24;

/** Fixed components are identity rows of the assembled matrix: they add +1 eigenvalues that are
 *  not the action's; they are taken out of the counts. */
long fixed_components(const Context& ctx) {
  const std::size_t n = static_cast<std::size_t>(std::max(ctx.N - 1, 0)) * ctx.dim;
  const std::size_t dz = static_cast<std::size_t>(ctx.dim);
  long fixed = 0;
  for (std::size_t i = 0; i < n; ++i) fixed += ctx.is_free[dz + i] ? 0 : 1;
  return fixed;
}

template <int D>
void assess_dim(Context& ctx, PointAssessment& out) {
  BlockTridiagonal<D> H;
  H.resize(ctx.N, ctx.dim);
  H.assemble(ctx, 0.0);
  if (H.factor_ldlt()) {
    assess_positive_definite(ctx, H, out);
    return;
  }
  const auto in = H.inertia(kZeroPivot);
  out.lambda_max = H.gershgorin_bound();
  out.positive = in.positive - fixed_components(ctx);
  out.negative = in.negative;
  out.zero = in.zero;
  if (!classify_indefinite(out)) {  // a failed Cholesky pivot that the inertia counts positive
    out.kind = PointKind::degenerate;
    out.note = "degenerate to working precision: the factorization of the Hessian failed";
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

}  // namespace

template <int D>
void assess_positive_definite(Context& ctx, BlockTridiagonal<D>& H, PointAssessment& out) {
  out = PointAssessment{};
  out.lambda_max = H.gershgorin_bound();
  const std::size_t n = static_cast<std::size_t>(std::max(ctx.N - 1, 0)) * ctx.dim;
  const std::size_t dz = static_cast<std::size_t>(ctx.dim);
  out.positive = static_cast<long>(n) - fixed_components(ctx);
  out.kind = PointKind::minimum;
  if (out.positive <= 0) {
    out.note = "no unknowns";
    return;
  }
  // Block Lanczos (block size m = 2: a double smallest eigenvalue, as in models whose components
  // move alike, is found as two) on A = H^-1 restricted to the free components: the largest
  // eigenvalues mu of the block tridiagonal T_j = V^T A V of the Krylov space converge to 1/lambda
  // from below, so theta = 1/mu are upper bounds on the smallest eigenvalues of H (interlacing),
  // and they converge far faster than an inverse iteration where the lowest eigenvalues cluster.
  // No reorthogonalization beyond the three-term recurrence: the iteration stops as soon as the
  // values settle, well before converged Ritz vectors make the basis lose orthogonality.
  const int m = out.positive >= 2 ? 2 : 1;
  std::vector<double> store(6 * n, 0.0);
  // Each of the three blocks holds m vectors of length n: V_{j-1}, V_j and the new W.
  double* prev = store.data();
  double* cur = store.data() + 2 * n;
  double* next = store.data() + 4 * n;
  {
    double norm[2] = {0, 0};
    for (std::size_t i = 0; i < n; ++i) {
      if (!ctx.is_free[dz + i]) continue;
      const double s = static_cast<double>(i / dz + 1) / static_cast<double>(n / dz + 1);
      const double a = static_cast<double>(i % dz);
      // Smooth start vectors, even and odd about the middle (the shapes of the lowest modes of a
      // string), slightly different per component.
      cur[i] = s * (1 - s) * (1 + 0.1 * a);
      cur[n + i] = m == 2 ? s * (1 - s) * (1 - 2 * s) + 0.05 * a * s * (1 - s) : 0.0;
      norm[0] += cur[i] * cur[i];
      norm[1] += cur[n + i] * cur[n + i];
    }
    // Orthonormal start block: the two shapes are orthogonal up to the per-component terms.
    double c01 = 0;
    for (std::size_t i = 0; i < n; ++i) cur[i] /= std::sqrt(norm[0]);
    if (m == 2) {
      for (std::size_t i = 0; i < n; ++i) c01 += cur[i] * cur[n + i];
      double r = 0;
      for (std::size_t i = 0; i < n; ++i) {
        cur[n + i] -= c01 * cur[i];
        r += cur[n + i] * cur[n + i];
      }
      for (std::size_t i = 0; i < n; ++i) cur[n + i] /= std::sqrt(r);
    }
  }
  std::vector<Eigen::MatrixXd> diagonal, below;  // the blocks A_j and B_j of T
  Eigen::MatrixXd B_prev = Eigen::MatrixXd::Zero(m, m);
  double theta[2] = {0, 0}, previous[2] = {-1, -1};
  for (int j = 0; j < kLanczosSteps; ++j) {
    if (m == 2)
      H.solve_ldlt(cur, cur + n, next, next + n);
    else
      H.solve_ldlt(cur, next);
    // W = A V_j - V_{j-1} B_{j-1}^T, then A_j = V_j^T W.
    Eigen::MatrixXd Aj = Eigen::MatrixXd::Zero(m, m);
    for (std::size_t i = 0; i < n; ++i) {
      if (!ctx.is_free[dz + i]) {
        for (int c = 0; c < m; ++c) next[c * n + i] = 0;
        continue;
      }
      for (int c = 0; c < m; ++c) {
        double w = next[c * n + i];
        for (int r = 0; r < m; ++r) w -= prev[r * n + i] * B_prev(c, r);
        next[c * n + i] = w;
        for (int r = 0; r < m; ++r) Aj(r, c) += cur[r * n + i] * w;
      }
    }
    Aj = 0.5 * (Aj + Aj.transpose()).eval();
    // W -= V_j A_j, and W^T W for the QR of W (Cholesky QR: W = V_{j+1} B_j, B_j upper triangular).
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(m, m);
    for (std::size_t i = 0; i < n; ++i) {
      double w[2];
      for (int c = 0; c < m; ++c) {
        w[c] = next[c * n + i];
        for (int r = 0; r < m; ++r) w[c] -= cur[r * n + i] * Aj(r, c);
        next[c * n + i] = w[c];
      }
      for (int r = 0; r < m; ++r)
        for (int c = 0; c < m; ++c) G(r, c) += w[r] * w[c];
    }
    diagonal.push_back(Aj);
    // The Ritz values: eigenvalues of T_j (order m (j + 1)).
    const int order = m * static_cast<int>(diagonal.size());
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(order, order);
    for (std::size_t b = 0; b < diagonal.size(); ++b) {
      const int o = m * static_cast<int>(b);
      T.block(o, o, m, m) = diagonal[b];
      if (b + 1 < diagonal.size()) {
        T.block(o + m, o, m, m) = below[b];
        T.block(o, o + m, m, m) = below[b].transpose();
      }
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(T, Eigen::EigenvaluesOnly);
    if (eig.info() != Eigen::Success) break;
    const auto& mu = eig.eigenvalues();  // ascending
    if (!(mu(order - 1) > 0)) break;
    theta[0] = 1 / mu(order - 1);
    theta[1] = m == 2 ? 1 / mu(order - 2) : 0;
    // Settled when the smallest Ritz value moves by less than 1e-4 (the notes print 3 digits) and
    // the next by less than 3e-3 (within about 1% of the eigenvalue).
    const bool settled = std::fabs(theta[0] - previous[0]) <= 1e-4 * std::fabs(theta[0]) &&
                         (m < 2 || std::fabs(theta[1] - previous[1]) <= 3e-3 * std::fabs(theta[1]));
    previous[0] = theta[0];
    previous[1] = theta[1];
    // A Krylov space that A maps into itself (W vanishes against the scale of A_j) holds exact
    // eigenvalues: nothing further to find from this start.
    const double scale = std::fabs(mu(order - 1));
    Eigen::LLT<Eigen::MatrixXd> chol(G);
    const bool invariant = chol.info() != Eigen::Success || !(G.diagonal().minCoeff() > 1e-24 * scale * scale);
    if (settled || invariant) {
      out.lambda_settled = true;
      break;
    }
    const Eigen::MatrixXd R = chol.matrixU();  // G = R^T R
    const Eigen::MatrixXd Rinv = R.inverse();
    for (std::size_t i = 0; i < n; ++i) {
      double w[2] = {next[i], m == 2 ? next[n + i] : 0.0};
      for (int c = 0; c < m; ++c) {
        double v = 0;
        for (int r = 0; r < m; ++r) v += w[r] * Rinv(r, c);
        next[c * n + i] = v;
      }
    }
    below.push_back(R);  // A V_j = V_{j-1} B_{j-1}^T + V_j A_j + V_{j+1} B_j, with B_j = R
    B_prev = R;
    double* recycled = prev;
    prev = cur;
    cur = next;
    next = recycled;
  }
  out.lambda_min = theta[0];
  out.lambda_next = theta[1];
  if (m == 2 && out.lambda_min < 1e-4 * out.lambda_next) {
    out.nearly_degenerate = true;
    const double action = std::fabs(sum_action(ctx));
    out.soft_motion = std::sqrt(2 * 1e-16 * std::max(action, 1e-300) / std::max(out.lambda_min, 1e-300));
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

template void assess_positive_definite<1>(Context&, BlockTridiagonal<1>&, PointAssessment&);
template void assess_positive_definite<2>(Context&, BlockTridiagonal<2>&, PointAssessment&);
template void assess_positive_definite<4>(Context&, BlockTridiagonal<4>&, PointAssessment&);
template void assess_positive_definite<6>(Context&, BlockTridiagonal<6>&, PointAssessment&);
template void assess_positive_definite<Eigen::Dynamic>(Context&, BlockTridiagonal<Eigen::Dynamic>&,
                                                       PointAssessment&);

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
                      "are zero within 1e-12 of its largest and no negative one; either the solution is not "
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
  dispatch_dim(ctx.dim, [&](auto D) { assess_dim<decltype(D)::value>(ctx, out); });
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
