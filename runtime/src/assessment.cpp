/**
 * @file assessment.cpp
 * What a returned trajectory is as a stationary point of the discrete action: the inertia of the
 * Hessian from its block LDL^T (minimum, saddle of index k, degenerate) and, at a minimum, its two
 * smallest eigenvalues by inverse subspace iteration against Gershgorin's bound on the largest,
 * which tells a well-posed minimum from a nearly degenerate one. O(N) work: one factorization and
 * at most 2 x 12 solves. Also the check that refuses a degenerate Lagrangian before solving.
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

template <int D>
void assess_dim(Context& ctx, PointAssessment& out) {
  BlockTridiagonal<D> H;
  H.resize(ctx.N, ctx.dim);
  H.assemble(ctx, 0.0);
  out.lambda_max = H.gershgorin_bound();
  const std::size_t n = static_cast<std::size_t>(std::max(ctx.N - 1, 0)) * ctx.dim;
  const std::size_t dz = static_cast<std::size_t>(ctx.dim);
  // Fixed components are identity rows of the assembled matrix: they add +1 eigenvalues that are
  // not the action's; they are taken out of the counts.
  long fixed = 0;
  for (std::size_t i = 0; i < n; ++i) fixed += ctx.is_free[dz + i] ? 0 : 1;
  if (!H.factor_ldlt()) {
    const auto in = H.inertia(kZeroPivot);
    out.positive = in.positive - fixed;
    out.negative = in.negative;
    out.zero = in.zero;
    if (!classify_indefinite(out)) {  // a failed Cholesky pivot that the inertia counts positive
      out.kind = PointKind::degenerate;
      out.note = "degenerate to working precision: the factorization of the Hessian failed";
    }
    return;
  }
  out.positive = static_cast<long>(n) - fixed;
  out.kind = PointKind::minimum;
  if (out.positive <= 0) {
    out.note = "no unknowns";
    return;
  }
  // Inverse subspace iteration with two vectors and Rayleigh-Ritz on the free components. With
  // Y = H^-1 X, H Y = X: the Gram-Schmidt steps that orthonormalize Y, applied to X as well, give
  // H Y without a multiplication by H.
  const int m = out.positive >= 2 ? 2 : 1;
  std::vector<double> X(2 * n, 0.0), Y(2 * n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    if (!ctx.is_free[dz + i]) continue;
    const double s = static_cast<double>(i / dz + 1) / static_cast<double>(n / dz + 1);
    const double a = static_cast<double>(i % dz);
    X[i] = std::sin(3.14159265358979 * s) * (1 + 0.1 * a);
    X[n + i] = std::sin(2 * 3.14159265358979 * s) + 0.05 * a;
  }
  auto dot = [&](const double* a, const double* b) {
    double s = 0;
    for (std::size_t i = 0; i < n; ++i) s += a[i] * b[i];
    return s;
  };
  /** Orthonormalizes v0, v1 (Gram-Schmidt) and applies the same steps to w0, w1 when given. */
  auto orthonormalize = [&](double* v0, double* v1, double* w0, double* w1) {
    const double n0 = std::sqrt(dot(v0, v0));
    for (std::size_t i = 0; i < n; ++i) v0[i] /= n0;
    if (w0)
      for (std::size_t i = 0; i < n; ++i) w0[i] /= n0;
    if (m < 2) return;
    const double c = dot(v0, v1);
    for (std::size_t i = 0; i < n; ++i) v1[i] -= c * v0[i];
    if (w1)
      for (std::size_t i = 0; i < n; ++i) w1[i] -= c * w0[i];
    const double n1 = std::sqrt(dot(v1, v1));
    for (std::size_t i = 0; i < n; ++i) v1[i] /= n1;
    if (w1)
      for (std::size_t i = 0; i < n; ++i) w1[i] /= n1;
  };
  orthonormalize(X.data(), X.data() + n, nullptr, nullptr);
  double theta[2] = {0, 0}, previous[2] = {-1, -1};
  for (int it = 0; it < 12; ++it) {
    for (int j = 0; j < m; ++j) {
      H.solve_ldlt(X.data() + j * n, Y.data() + j * n);
      for (std::size_t i = 0; i < n; ++i)
        if (!ctx.is_free[dz + i]) Y[j * n + i] = 0;
    }
    orthonormalize(Y.data(), Y.data() + n, X.data(), X.data() + n);  // X is now H Y
    Eigen::Matrix2d A = Eigen::Matrix2d::Identity();
    A(0, 0) = dot(Y.data(), X.data());
    if (m == 2) {
      A(0, 1) = A(1, 0) = 0.5 * (dot(Y.data(), X.data() + n) + dot(Y.data() + n, X.data()));
      A(1, 1) = dot(Y.data() + n, X.data() + n);
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(A);
    const Eigen::Matrix2d V = m == 2 ? eig.eigenvectors() : Eigen::Matrix2d::Identity();
    theta[0] = m == 2 ? eig.eigenvalues()(0) : A(0, 0);
    theta[1] = m == 2 ? eig.eigenvalues()(1) : 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double y0 = Y[i], y1 = m == 2 ? Y[n + i] : 0;
      X[i] = V(0, 0) * y0 + V(1, 0) * y1;
      if (m == 2) X[n + i] = V(0, 1) * y0 + V(1, 1) * y1;
    }
    const bool settled = std::fabs(theta[0] - previous[0]) <= 1e-5 * std::fabs(theta[0]) &&
                         (m < 2 || std::fabs(theta[1] - previous[1]) <= 3e-3 * std::fabs(theta[1]));
    previous[0] = theta[0];
    previous[1] = theta[1];
    if (settled) break;
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
  } else {
    out.note = format("a strict local minimum: Hessian positive definite, eigenvalues from %.3g (next %.3g) to at "
                      "most %.3g",
                      out.lambda_min, out.lambda_next, out.lambda_max);
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
