/**
 * @file certificate.cpp
 * The convergence certificate at a trajectory: the hypotheses of the seed's theorem
 * prp:discrete_positive_def interval by interval (H^{Ld}_k p.s.d., A_k = D11 or B_k = D22 p.d.),
 * the inertia of the full block-tridiagonal Hessian by block LDL^T (Sylvester's law of inertia),
 * and the spectral radius of the Jacobi iteration matrix J = -D^{-1} C by Lanczos on the
 * symmetric form L^{-1} C L^{-T} (D_k = L_k L_k^T), matrix-free and O(N) per step.
 * Knots and boundaries restrict every matrix to the free components.
 */
#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "block_tridiagonal.hpp"
#include "engine.hpp"

namespace pardel {
namespace {

using detail::Context;

/** Eigenvalues are compared with this fraction of the largest |eigenvalue| of their matrix. */
constexpr double kRelTol = 1e-10;

struct IntervalCheck {
  double min_h = 0, min_a = 0, min_b = 0;
  bool psd = true, a_pd = true, b_pd = true;
};

/** Minimum eigenvalue and spectral scale of the symmetric matrix restricted to `idx`. */
void restricted_eigs(const Eigen::MatrixXd& H, const std::vector<int>& idx, double* min_eig, double* scale) {
  if (idx.empty()) {
    *min_eig = std::numeric_limits<double>::infinity();
    *scale = 0;
    return;
  }
  const int n = static_cast<int>(idx.size());
  Eigen::MatrixXd R(n, n);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) R(a, b) = H(idx[static_cast<std::size_t>(a)], idx[static_cast<std::size_t>(b)]);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(R, Eigen::EigenvaluesOnly);
  const auto& ev = es.eigenvalues();
  *min_eig = ev.minCoeff();
  *scale = ev.cwiseAbs().maxCoeff();
}

template <int D>
void inertia_and_radius(Context& ctx, Certificate& c) {
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;
  detail::BlockTridiagonal<D> H;
  H.resize(ctx.N, ctx.dim);
  H.assemble(ctx, 0.0);
  const int n = H.blocks(), d = ctx.dim;
  // Block LDL^T with eigen-decomposed pivots: inertia(H) = sum of inertias of the pivots.
  long pos = 0, neg = 0, zero = 0;
  Mat S = H.diag(0), Sinv = Mat::Zero(d, d);
  for (int i = 0; i < n; ++i) {
    if (i > 0) S = H.diag(i) - H.off(i - 1).transpose() * Sinv * H.off(i - 1);
    Eigen::SelfAdjointEigenSolver<Mat> es(S);
    const auto& ev = es.eigenvalues();
    const double scale = std::max(ev.cwiseAbs().maxCoeff(), std::numeric_limits<double>::min());
    Vec inv = Vec::Zero(d);
    for (int a = 0; a < d; ++a) {
      if (ev[a] > kRelTol * scale) {
        ++pos;
        inv[a] = 1 / ev[a];
      } else if (ev[a] < -kRelTol * scale) {
        ++neg;
        inv[a] = 1 / ev[a];
      } else {
        ++zero;  // pseudo-inverse: the count is then approximate
      }
    }
    Sinv = es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
  }
  const long fixed = static_cast<long>(n) * d - ctx.free_total;  // identity rows of fixed components
  c.inertia_positive = pos - fixed;
  c.inertia_negative = neg;
  c.inertia_zero = zero;
  c.free_components = ctx.free_total;
  c.hessian_positive_definite = neg == 0 && zero == 0;

  // Spectral radius of J = -D^{-1} C. With every D_k p.d., J is similar to the symmetric
  // M = L^{-1} C L^{-T}; Lanczos on M. Otherwise the power method on J (an estimate).
  // Constructed in place: a copy of an Eigen::LLT built with a size reads its uninitialized status.
  std::vector<Eigen::LLT<Mat>> chol;
  chol.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) chol.emplace_back(d);
  bool all_pd = true;
  for (int i = 0; i < n; ++i) {
    chol[static_cast<std::size_t>(i)].compute(H.diag(i));
    if (chol[static_cast<std::size_t>(i)].info() != Eigen::Success) all_pd = false;
  }
  const std::size_t len = static_cast<std::size_t>(n) * d;
  if (len == 0) return;
  std::vector<double> v(len), w(len), vprev(len, 0.0), z(len);
  unsigned long long seed = 0x9E3779B97F4A7C15ull;
  for (std::size_t i = 0; i < len; ++i) {
    seed = seed * 6364136223846793005ull + 1442695040888963407ull;
    v[i] = static_cast<double>(seed >> 11) / 9007199254740992.0 - 0.5;
  }
  auto blk = [&](std::vector<double>& a, int i) { return Eigen::Map<Vec>(a.data() + static_cast<std::size_t>(i) * d, d); };
  auto norm = [&](const std::vector<double>& a) {
    double s = 0;
    for (double x : a) s += x * x;
    return std::sqrt(s);
  };
  if (all_pd) {
    // y = M x: z_j = L_j^{-T} x_j, y_k = L_k^{-1} (C_{k-1}^T z_{k-1} + C_k z_{k+1}).
    auto apply = [&](std::vector<double>& x, std::vector<double>& y) {
      for (int i = 0; i < n; ++i) blk(z, i) = chol[static_cast<std::size_t>(i)].matrixU().solve(blk(x, i));
      for (int i = 0; i < n; ++i) {
        Vec acc = Vec::Zero(d);
        if (i > 0) acc.noalias() += H.off(i - 1).transpose() * blk(z, i - 1);
        if (i + 1 < n) acc.noalias() += H.off(i) * blk(z, i + 1);
        blk(y, i) = chol[static_cast<std::size_t>(i)].matrixL().solve(acc);
      }
    };
    double nv = norm(v);
    for (double& x : v) x /= nv;
    std::vector<double> alpha, beta;
    const int max_steps = static_cast<int>(std::min<std::size_t>(len, 1000));
    double estimate = 0, previous = -1;
    double b_prev = 0;
    for (int j = 0; j < max_steps; ++j) {
      apply(v, w);
      double a = 0;
      for (std::size_t i = 0; i < len; ++i) a += w[i] * v[i];
      for (std::size_t i = 0; i < len; ++i) w[i] -= a * v[i] + b_prev * vprev[i];
      const double b = norm(w);
      alpha.push_back(a);
      const bool breakdown = !(b > 1e-14 * (std::fabs(a) + b_prev + 1e-300));
      if ((j + 1) % 10 == 0 || breakdown || j + 1 == max_steps) {
        const int m = static_cast<int>(alpha.size());
        Eigen::VectorXd diag = Eigen::Map<Eigen::VectorXd>(alpha.data(), m);
        Eigen::VectorXd sub = Eigen::VectorXd::Zero(std::max(m - 1, 1));
        for (int i = 0; i + 1 < m; ++i) sub[i] = beta[static_cast<std::size_t>(i)];
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es;
        es.computeFromTridiagonal(diag, sub.head(std::max(m - 1, 0)), Eigen::EigenvaluesOnly);
        estimate = es.eigenvalues().cwiseAbs().maxCoeff();
        // Converged: settled, an invariant subspace found, or the whole space spanned.
        if (breakdown || m == static_cast<int>(len) || std::fabs(estimate - previous) <= 1e-12 * estimate) {
          c.spectral_radius_converged = true;
          break;
        }
        previous = estimate;
      }
      beta.push_back(b);
      for (std::size_t i = 0; i < len; ++i) {
        vprev[i] = v[i];
        v[i] = w[i] / b;
      }
      b_prev = b;
    }
    c.jacobi_spectral_radius = estimate;
  } else {
    std::vector<Eigen::PartialPivLU<Mat>> lu;
    for (int i = 0; i < n; ++i) lu.emplace_back(H.diag(i));
    auto apply = [&](std::vector<double>& x, std::vector<double>& y) {
      for (int i = 0; i < n; ++i) {
        Vec acc = Vec::Zero(d);
        if (i > 0) acc.noalias() += H.off(i - 1).transpose() * blk(x, i - 1);
        if (i + 1 < n) acc.noalias() += H.off(i) * blk(x, i + 1);
        blk(y, i) = -lu[static_cast<std::size_t>(i)].solve(acc);
      }
    };
    // rho ~ (|J^2 x| / |x|)^(1/2) over normalized iterates (two steps: J's spectrum is symmetric).
    double estimate = 0, previous = -1;
    for (int j = 0; j < 2000; ++j) {
      const double nv = norm(v);
      for (double& x : v) x /= nv;
      apply(v, w);
      apply(w, v);
      estimate = std::sqrt(norm(v));
      if (!std::isfinite(estimate)) break;
      if (std::fabs(estimate - previous) <= 1e-10 * estimate) {
        c.spectral_radius_converged = true;
        break;
      }
      previous = estimate;
    }
    c.jacobi_spectral_radius = estimate;
  }
}

}  // namespace

Certificate certify(const Problem& problem, const Trajectory& trajectory, int threads, double tol) {
  Certificate c;
  c.tol = tol;
  Context ctx;
  if (!detail::context_at(problem, trajectory, threads, ctx, &c.error)) return c;
  detail::eval_full(ctx, ctx.q);
  detail::compute_residual(ctx);
  c.residual = ctx.residual;

  // Theorem prp:discrete_positive_def, interval by interval.
  const int d = ctx.dim, N = ctx.N;
  std::vector<IntervalCheck> checks(static_cast<std::size_t>(N));
#pragma omp parallel for if (ctx.parallel(N)) num_threads(ctx.threads) schedule(static)
  for (int k = 0; k < N; ++k) {
    const std::size_t kk = static_cast<std::size_t>(k), dd = static_cast<std::size_t>(d) * d;
    Eigen::MatrixXd Hk(2 * d, 2 * d);
    for (int a = 0; a < d; ++a)
      for (int b = 0; b < d; ++b) {
        Hk(a, b) = ctx.D11[kk * dd + static_cast<std::size_t>(a * d + b)];
        Hk(a, d + b) = ctx.D12[kk * dd + static_cast<std::size_t>(a * d + b)];
        Hk(d + b, a) = Hk(a, d + b);
        Hk(d + a, d + b) = ctx.D22[kk * dd + static_cast<std::size_t>(a * d + b)];
      }
    Hk = 0.5 * (Hk + Hk.transpose()).eval();
    std::vector<int> idx, ia, ib;
    for (int a = 0; a < d; ++a)
      if (ctx.is_free[kk * d + a]) {
        idx.push_back(a);
        ia.push_back(a);
      }
    for (int b = 0; b < d; ++b)
      if (ctx.is_free[(kk + 1) * d + b]) {
        idx.push_back(d + b);
        ib.push_back(d + b);
      }
    IntervalCheck& ch = checks[kk];
    double scale_h, scale_a, scale_b;
    restricted_eigs(Hk, idx, &ch.min_h, &scale_h);
    restricted_eigs(Hk, ia, &ch.min_a, &scale_a);
    restricted_eigs(Hk, ib, &ch.min_b, &scale_b);
    ch.psd = ch.min_h >= -kRelTol * scale_h;
    ch.a_pd = ch.min_a > kRelTol * scale_h;
    ch.b_pd = ch.min_b > kRelTol * scale_h;
  }
  c.all_intervals_psd = c.all_A_pd = c.all_B_pd = true;
  for (int k = 0; k < N; ++k) {
    const IntervalCheck& ch = checks[static_cast<std::size_t>(k)];
    c.all_intervals_psd = c.all_intervals_psd && ch.psd;
    c.all_A_pd = c.all_A_pd && ch.a_pd;
    c.all_B_pd = c.all_B_pd && ch.b_pd;
    if (!ch.psd || !ch.a_pd || !ch.b_pd) {
      ++c.intervals_violating;
      if (c.violations.size() < 100) {
        IntervalViolation v;
        v.k = k;
        v.hessian_psd = ch.psd;
        v.A_pd = ch.a_pd;
        v.B_pd = ch.b_pd;
        v.min_eig_hessian = ch.min_h;
        v.min_eig_A = ch.min_a;
        v.min_eig_B = ch.min_b;
        c.violations.push_back(v);
      }
    }
  }
  c.theorem_holds = c.all_intervals_psd && (c.all_A_pd || c.all_B_pd);

  // Not a hot path: one dynamic-size instantiation keeps the build light.
  inertia_and_radius<Eigen::Dynamic>(ctx, c);
  const double rho = c.jacobi_spectral_radius;
  if (c.residual <= tol)
    c.expected_iterations = 0;
  else if (rho > 0 && rho < 1)
    c.expected_iterations = std::log(tol / c.residual) / std::log(rho);
  else
    c.expected_iterations = std::numeric_limits<double>::infinity();
  return c;
}

std::string Certificate::report() const {
  if (!error.empty()) return "certificate not computed: " + error + "\n";
  std::string out;
  char buf[512];
  std::snprintf(buf, sizeof buf, "DEL residual at the trajectory: %.3e (%ld free components)\n", residual,
                free_components);
  out += buf;
  out += "Theorem prp:discrete_positive_def (interval Hessians H^Ld_k):\n";
  std::snprintf(buf, sizeof buf, "  all H^Ld_k positive semi-definite: %s\n  all A_k = D11 positive definite: %s\n"
                "  all B_k = D22 positive definite: %s\n  hypotheses hold: %s%s\n",
                all_intervals_psd ? "yes" : "no", all_A_pd ? "yes" : "no", all_B_pd ? "yes" : "no",
                theorem_holds ? "yes" : "no",
                theorem_holds ? " (the Hessian is positive definite; Jacobi and Jacobi-Newton converge locally)" : "");
  out += buf;
  if (intervals_violating > 0) {
    std::snprintf(buf, sizeof buf, "  %ld interval(s) violate a hypothesis; the first:\n", intervals_violating);
    out += buf;
    for (std::size_t i = 0; i < violations.size() && i < 10; ++i) {
      const IntervalViolation& v = violations[i];
      std::snprintf(buf, sizeof buf, "    interval %d: min eig H^Ld %.3e%s, A %.3e%s, B %.3e%s\n", v.k,
                    v.min_eig_hessian, v.hessian_psd ? "" : " (not psd)", v.min_eig_A, v.A_pd ? "" : " (not pd)",
                    v.min_eig_B, v.B_pd ? "" : " (not pd)");
      out += buf;
    }
  }
  std::snprintf(buf, sizeof buf,
                "Inertia of the Hessian of the action (block LDL^T): %ld positive, %ld negative, %ld zero: %s\n",
                inertia_positive, inertia_negative, inertia_zero,
                hessian_positive_definite ? "positive definite (a strict local minimum of the action if a solution)"
                                          : "NOT positive definite (no local convergence guarantee; Newton's "
                                            "minimization cannot stop at a saddle)");
  out += buf;
  std::snprintf(buf, sizeof buf,
                "Jacobi iteration matrix J = -D^-1 C: spectral radius %.9f%s; expected Jacobi-Newton sweeps to reach "
                "%.1e: %.4g\n",
                jacobi_spectral_radius, spectral_radius_converged ? "" : " (estimate, not settled)", tol,
                expected_iterations);
  out += buf;
  return out;
}

}  // namespace pardel
