/**
 * @file certificate.cpp
 * The convergence certificate at a trajectory: the hypotheses of the seed's sufficient condition
 * for a positive definite discrete Hessian, interval by interval (H^{Ld}_k p.s.d., A_k = D11 or
 * B_k = D22 p.d.),
 * the inertia of the full block-tridiagonal Hessian by block LDL^T (Sylvester's law of inertia),
 * and the spectral radius rho of the Jacobi iteration matrix J = -D^{-1} C. The Hessian is first
 * equilibrated by powers of two (exact; inertia and J's eigenvalues unchanged), since the jets of
 * high-order models span many orders of magnitude. Where H is positive definite, 1 - rho is the
 * smallest eigenvalue of D^{-1/2} H D^{-1/2}, found by inverse iteration through H's block
 * Cholesky factorization (forming 1 - rho from a rho near 1 would cancel every digit), with its
 * round-off level; otherwise rho comes from Lanczos on L^{-1} C L^{-T} (D_k = L_k L_k^T) or the
 * power method on J^2. Matrix-free, O(N) per step. Knots and boundaries restrict every matrix to
 * the free components.
 */
#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "block_tridiagonal.hpp"
#include "constants.hpp"
#include "engine.hpp"
#include "lanczos.hpp"

namespace pardel {
namespace {

using detail::Context;


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

/**
 * Scales H symmetrically by a power of two per component, close to |H_aa|^(-1/2) (1 where the
 * diagonal entry is zero): exact in floating point, a congruence (inertia unchanged) and a
 * similarity of J. The blocks of order-gamma jets otherwise span h^(2 - 2 gamma) to 1/h.
 */
template <int D>
void equilibrate(detail::BlockTridiagonal<D>& H, int d) {
  const int n = H.blocks();
  std::vector<double> s(static_cast<std::size_t>(n) * d, 1.0);
  for (int i = 0; i < n; ++i)
    for (int a = 0; a < d; ++a) {
      const double x = std::fabs(H.diag(i)(a, a));
      if (x > 0 && std::isfinite(x)) {
        int e = 0;
        std::frexp(x, &e);
        s[static_cast<std::size_t>(i) * d + a] = std::ldexp(1.0, -e / 2);
      }
    }
  for (int i = 0; i < n; ++i) {
    const double* si = s.data() + static_cast<std::size_t>(i) * d;
    for (int a = 0; a < d; ++a)
      for (int b = 0; b < d; ++b) {
        H.diag(i)(a, b) *= si[a] * si[b];
        if (i + 1 < n) H.off(i)(a, b) *= si[a] * si[static_cast<std::size_t>(d) + b];
      }
  }
}

/**
 * The inertia of the equilibrated Hessian and the spectral radius rho of the Jacobi iteration
 * matrix J = -D^{-1} C. With every D_k p.d., J is similar to the symmetric M = L^{-1} C L^{-T},
 * whose spectrum is symmetric about 0 (H is block tridiagonal), so rho = lambda_max(M) and
 * 1 - rho = lambda_min(I + M) = lambda_min(L^{-1} H L^{-T}): by inverse iteration where H + sigma D
 * factors for a small shift sigma, by Lanczos on M where it does not, and by the power method on
 * J^2 where a D_k is not p.d.
 */
template <int D>
class JacobiRadius {
 public:
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;

  explicit JacobiRadius(Context& ctx) : ctx_(ctx), d_(ctx.dim) {
    H_.resize(ctx.N, ctx.dim);
    H_.assemble(ctx, 0.0);
    n_ = H_.blocks();
    len_ = static_cast<std::size_t>(n_) * d_;
    equilibrate(H_, d_);
  }

  void run(Certificate& c) {
    // The inertia by the block elimination and zero rule of every count (inertia.hpp); the
    // equilibration by powers of two changes neither H's inertia nor its Jacobi-scaled form.
    const detail::Inertia in = H_.inertia();
    const long fixed = static_cast<long>(len_) - ctx_.free_total;  // identity rows of fixed components
    c.inertia_positive = in.positive - fixed;
    c.inertia_negative = in.negative;
    c.inertia_zero = in.zero;
    c.free_components = ctx_.free_total;
    c.hessian_positive_definite = in.negative == 0 && in.zero == 0;
    // Constructed in place: a copy of an Eigen::LLT built with a size reads its uninitialized status.
    chol_.reserve(static_cast<std::size_t>(n_));
    for (int i = 0; i < n_; ++i) chol_.emplace_back(d_);
    bool all_pd = true;
    for (int i = 0; i < n_; ++i) {
      chol_[static_cast<std::size_t>(i)].compute(H_.diag(i));
      if (chol_[static_cast<std::size_t>(i)].info() != Eigen::Success) all_pd = false;
    }
    if (len_ == 0) {  // no unknowns: J is empty
      c.jacobi_one_minus_rho = 1;
      c.spectral_radius_resolved = true;
      return;
    }
    v_.resize(len_);
    w_.resize(len_);
    vprev_.assign(len_, 0.0);
    z_.resize(len_);
    unsigned long long seed = 0x9E3779B97F4A7C15ull;
    for (std::size_t i = 0; i < len_; ++i) {
      seed = seed * 6364136223846793005ull + 1442695040888963407ull;
      v_[i] = static_cast<double>(seed >> 11) / 9007199254740992.0 - 0.5;
    }
    double sigma = 0;
    if (all_pd && shifted_factorization(&sigma))
      inverse_iteration(sigma, c);
    else if (all_pd)
      lanczos_on_m(c);
    else
      power_method(c);
  }

 private:
  Eigen::Map<Vec> blk(std::vector<double>& a, int i) const {
    return Eigen::Map<Vec>(a.data() + static_cast<std::size_t>(i) * d_, d_);
  }
  double norm(const std::vector<double>& a) const {
    double s = 0;
    for (double x : a) s += x * x;
    return std::sqrt(s);
  }
  double dot(const std::vector<double>& a, const std::vector<double>& b) const {
    double s = 0;
    for (std::size_t i = 0; i < len_; ++i) s += a[i] * b[i];
    return s;
  }

  /** The smallest shift sigma (0, then 2^-50 doubling up to 2^-12) for which H + sigma D, i.e. the
   *  diagonal blocks times 1 + sigma, has a block Cholesky factorization; false (H restored,
   *  unshifted) where none does. A shift above round-off is needed only where H has an eigenvalue
   *  lambda_min(L^{-1} H L^{-T}) = 1 - rho < 0. */
  bool shifted_factorization(double* sigma) {
    bool factored = false;
    for (int k = 0; k <= 39 && !factored; ++k) {
      if (k > 0) {
        const double scale = 1 + std::ldexp(1.0, k - 51);
        *sigma = scale - 1;  // exact
        if (k > 1) {  // the unshifted H again: one rounding of each entry
          H_.assemble(ctx_, 0.0);
          equilibrate(H_, d_);
        }
        for (int i = 0; i < n_; ++i) H_.diag(i) *= scale;
      }
      factored = H_.factor_ldlt();
    }
    if (!factored) {  // restore H for Lanczos
      H_.assemble(ctx_, 0.0);
      equilibrate(H_, d_);
      *sigma = 0;
    }
    return factored;
  }

  /** H + sigma D p.d.: inverse iteration on K = (L^{-1} (H + sigma D) L^{-T})^{-1}, whose largest
   *  eigenvalue is 1 / (1 - rho + sigma) and well separated (the next is 1 / (lambda_2 + sigma)).
   *  theta, the Rayleigh quotient of K, rises to it: 1 / theta - sigma bounds 1 - rho from above.
   *  Round-off level of 1 - rho: entries of H off by a unit in their last place move it by up to
   *  eps |y|^T |H| |y| / y^T D y (y = L^{-T} v the generalized eigenvector, y^T D y = 1); block
   *  elimination over 3d terms a row: the factor 3d. */
  void inverse_iteration(double sigma, Certificate& c) {
    const double eps = std::numeric_limits<double>::epsilon();
    double nv = norm(v_);
    for (double& x : v_) x /= nv;
    double theta = 0, previous = 0, roundoff = 0;
    for (int j = 0; j < 1000; ++j) {
      for (int i = 0; i < n_; ++i) blk(z_, i) = chol_[static_cast<std::size_t>(i)].matrixL() * blk(v_, i);
      H_.solve_ldlt(z_.data(), w_.data());
      for (int i = 0; i < n_; ++i) blk(w_, i) = chol_[static_cast<std::size_t>(i)].matrixU() * blk(w_, i).eval();
      theta = dot(v_, w_);
      const double nw = norm(w_);
      if (!(theta > 0) || !std::isfinite(nw)) break;
      // |y|^T |H| |y| at the current vector
      for (int i = 0; i < n_; ++i) blk(z_, i) = chol_[static_cast<std::size_t>(i)].matrixU().solve(blk(v_, i));
      double abs_form = 0;
      for (int i = 0; i < n_; ++i) {
        const Vec yi = blk(z_, i).cwiseAbs();
        abs_form += yi.dot(H_.diag(i).cwiseAbs() * yi);
        if (i + 1 < n_) abs_form += 2 * yi.dot(H_.off(i).cwiseAbs() * blk(z_, i + 1).cwiseAbs());
      }
      roundoff = 3.0 * d_ * eps * abs_form / (1 + sigma);
      for (std::size_t i = 0; i < len_; ++i) v_[i] = w_[i] / nw;
      // Settled: to 1e-12, or to the round-off level of 1 - rho.
      if (j > 0 && std::fabs(theta - previous) <= std::max(1e-12, roundoff * theta) * theta) {
        c.spectral_radius_converged = true;
        break;
      }
      previous = theta;
    }
    const double gap = theta > 0 ? 1 / theta - sigma : 0;
    c.jacobi_one_minus_rho = gap;
    c.jacobi_spectral_radius = 1 - gap;
    c.jacobi_one_minus_rho_roundoff = roundoff;
    c.spectral_radius_resolved = theta > 0 && std::fabs(gap) > roundoff;
  }

  /** H + 2^-12 D not p.d. (rho > 1 + 2^-12): Lanczos on M, y = M x: z_j = L_j^{-T} x_j,
   *  y_k = L_k^{-1} (C_{k-1}^T z_{k-1} + C_k z_{k+1}). */
  void lanczos_on_m(Certificate& c) {
    auto apply = [&](std::vector<double>& x, std::vector<double>& y) {
      for (int i = 0; i < n_; ++i) blk(z_, i) = chol_[static_cast<std::size_t>(i)].matrixU().solve(blk(x, i));
      for (int i = 0; i < n_; ++i) {
        Vec acc = Vec::Zero(d_);
        if (i > 0) acc.noalias() += H_.off(i - 1).transpose() * blk(z_, i - 1);
        if (i + 1 < n_) acc.noalias() += H_.off(i) * blk(z_, i + 1);
        blk(y, i) = chol_[static_cast<std::size_t>(i)].matrixL().solve(acc);
      }
    };
    double nv = norm(v_);
    for (double& x : v_) x /= nv;
    std::vector<double> alpha, beta;
    const int max_steps = static_cast<int>(std::min<std::size_t>(len_, 1000));
    double estimate = 0, previous = -1;
    double b_prev = 0;
    for (int j = 0; j < max_steps; ++j) {
      apply(v_, w_);
      const detail::LanczosStep step = detail::lanczos_recurrence(len_, nullptr, vprev_.data(), b_prev, v_.data(),
                                                                  w_.data(), [](double*, int) {});
      const double a = step.alpha, b = std::sqrt(step.norm2);
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
        if (breakdown || m == static_cast<int>(len_) || std::fabs(estimate - previous) <= 1e-12 * estimate) {
          c.spectral_radius_converged = true;
          break;
        }
        previous = estimate;
      }
      beta.push_back(b);
      for (std::size_t i = 0; i < len_; ++i) {
        vprev_[i] = v_[i];
        v_[i] = w_[i] / b;
      }
      b_prev = b;
    }
    c.jacobi_spectral_radius = estimate;
    c.jacobi_one_minus_rho = 1 - estimate;
    c.spectral_radius_resolved = true;
  }

  /** A D_k not p.d.: rho ~ (|J^2 x| / |x|)^(1/2) over normalized iterates (two steps: J's spectrum
   *  is symmetric), J x through each D_k's LU. */
  void power_method(Certificate& c) {
    std::vector<Eigen::PartialPivLU<Mat>> lu;
    for (int i = 0; i < n_; ++i) lu.emplace_back(H_.diag(i));
    auto apply = [&](std::vector<double>& x, std::vector<double>& y) {
      for (int i = 0; i < n_; ++i) {
        Vec acc = Vec::Zero(d_);
        if (i > 0) acc.noalias() += H_.off(i - 1).transpose() * blk(x, i - 1);
        if (i + 1 < n_) acc.noalias() += H_.off(i) * blk(x, i + 1);
        blk(y, i) = -lu[static_cast<std::size_t>(i)].solve(acc);
      }
    };
    // rho ~ (|J^2 x| / |x|)^(1/2) over normalized iterates (two steps: J's spectrum is symmetric).
    double estimate = 0, previous = -1;
    for (int j = 0; j < 2000; ++j) {
      const double nv = norm(v_);
      for (double& x : v_) x /= nv;
      apply(v_, w_);
      apply(w_, v_);
      estimate = std::sqrt(norm(v_));
      if (!std::isfinite(estimate)) break;
      if (std::fabs(estimate - previous) <= 1e-10 * estimate) {
        c.spectral_radius_converged = true;
        break;
      }
      previous = estimate;
    }
    c.jacobi_spectral_radius = estimate;
    c.jacobi_one_minus_rho = 1 - estimate;
    c.spectral_radius_resolved = true;
  }

  Context& ctx_;
  const int d_;
  int n_ = 0;
  std::size_t len_ = 0;
  detail::BlockTridiagonal<D> H_;
  std::vector<Eigen::LLT<Mat>> chol_;
  std::vector<double> v_, w_, vprev_, z_;
};

}  // namespace

Certificate certify(const Problem& problem, const Trajectory& trajectory, int threads, double tol) {
  Certificate c;
  c.tol = tol;
  Context ctx;
  if (!detail::context_at(problem, trajectory, threads, ctx, &c.error)) return c;
  detail::eval_full(ctx, ctx.q);
  detail::compute_residual(ctx);
  c.residual = ctx.residual;

  // The seed's sufficient condition for a positive definite Hessian, interval by interval.
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
    double scale;
    restricted_eigs(Hk, idx, &ch.min_h, &scale);
    restricted_eigs(Hk, ia, &ch.min_a, &scale);
    restricted_eigs(Hk, ib, &ch.min_b, &scale);
    // Decided on the Jacobi-scaled J H J (J = |H_aa|^(-1/2), a congruence: the same signs), so that
    // coordinates in very different units (blocks diag(8e12, 8e-12)) are judged to working
    // precision, not against the largest entry; the eigenvalues reported are H's own.
    Eigen::VectorXd J(2 * d);
    for (int a = 0; a < 2 * d; ++a) J(a) = detail::jacobi_scale(Hk(a, a));
    const Eigen::MatrixXd Hs = J.asDiagonal() * Hk * J.asDiagonal();
    double scaled_h, scaled_a, scaled_b, scale_h;
    restricted_eigs(Hs, idx, &scaled_h, &scale_h);
    restricted_eigs(Hs, ia, &scaled_a, &scale);
    restricted_eigs(Hs, ib, &scaled_b, &scale);
    ch.psd = scaled_h >= -detail::kCertificateRelTol * scale_h;
    ch.a_pd = scaled_a > detail::kCertificateRelTol * scale_h;
    ch.b_pd = scaled_b > detail::kCertificateRelTol * scale_h;
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
  JacobiRadius<Eigen::Dynamic>(ctx).run(c);
  // log(rho) as log1p(-(1 - rho)): rho near 1 would cancel the digits of 1 - rho. Where 1 - rho is
  // below its round-off level, it is at most |1 - rho| + that level: a lower bound on the sweeps.
  const double rho = c.jacobi_spectral_radius, gap = c.jacobi_one_minus_rho;
  if (c.residual <= tol)
    c.expected_iterations = 0;
  else if (!c.spectral_radius_resolved && c.jacobi_one_minus_rho_roundoff > 0)
    c.expected_iterations = std::log(tol / c.residual) / std::log1p(-(std::fabs(gap) + c.jacobi_one_minus_rho_roundoff));
  else if (rho > 0 && gap > 0)
    c.expected_iterations = std::log(tol / c.residual) / std::log1p(-gap);
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
  out += "Sufficient condition for a positive definite Hessian (seed, interval Hessians H^Ld_k):\n";
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
  if (!spectral_radius_resolved) {
    std::snprintf(buf, sizeof buf,
                  "Jacobi iteration matrix J = -D^-1 C: spectral radius 1 to within round-off: 1 - rho = %.2e is below "
                  "its round-off level %.1e and not determined in double precision; Jacobi-Newton sweeps to reach "
                  "%.1e: at least %.4g\n",
                  jacobi_one_minus_rho, jacobi_one_minus_rho_roundoff, tol, expected_iterations);
  } else if (jacobi_one_minus_rho_roundoff > 0) {
    // enough decimals to show where rho leaves 1
    const int digits = std::clamp(static_cast<int>(std::ceil(-std::log10(std::fabs(jacobi_one_minus_rho)))) + 2, 9, 16);
    std::snprintf(buf, sizeof buf,
                  "Jacobi iteration matrix J = -D^-1 C: spectral radius %.*f (1 - rho = %.6e, round-off level "
                  "%.1e)%s; expected Jacobi-Newton sweeps to reach %.1e: %.4g\n",
                  digits, jacobi_spectral_radius, jacobi_one_minus_rho, jacobi_one_minus_rho_roundoff,
                  spectral_radius_converged ? "" : " (estimate, not settled: a lower bound)", tol, expected_iterations);
  } else {
    std::snprintf(buf, sizeof buf,
                  "Jacobi iteration matrix J = -D^-1 C: spectral radius %.9f%s; expected Jacobi-Newton sweeps to reach "
                  "%.1e: %.4g\n",
                  jacobi_spectral_radius, spectral_radius_converged ? "" : " (estimate, not settled)", tol,
                  expected_iterations);
  }
  out += buf;
  return out;
}

}  // namespace pardel
