/**
 * @file assessment.cpp
 * What a returned trajectory is as a stationary point of the discrete action: the inertia of the
 * Hessian from its block LDL^T (minimum, saddle of index k, degenerate) and, at a minimum, its two
 * smallest eigenvalues by block Lanczos on the inverse against Gershgorin's bound on the largest,
 * which tells a well-posed minimum from a nearly degenerate one. O(N) work: one factorization (or
 * Newton's last one, at the same point) and at most 2 x 24 solves. Also the check that refuses a degenerate Lagrangian before solving.
 */
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

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

/**
 * Block Lanczos with M vectors per block on A = H^-1 restricted to the free components (see
 * smallest_eigenvalues). store holds 3 M n values: V_{j-1}, V_j and W, M vectors of n each.
 */
template <int M>
SmallestEigenvalues block_lanczos(const LanczosOperator& op, double* store) {
  const std::size_t n = op.n;
  double* prev = store;
  double* cur = store + M * n;
  double* next = store + 2 * M * n;
  const double* no_input = nullptr;
  double* no_output = nullptr;
  auto solve = [&](const double* in, double* out) {
    op.solve(in, M == 2 ? in + n : no_input, out, M == 2 ? out + n : no_output);
  };
  SmallestEigenvalues result;
  // Smooth start vectors, even and odd about the middle (the shapes of the lowest modes of a
  // string), slightly different per component, made orthonormal (Cholesky QR).
  double gram[3] = {0, 0, 0};  // v0.v0, v0.v1, v1.v1
  for (std::size_t i = 0; i < n; ++i) {
    double v[2] = {0, 0};
    if (op.free[i]) {
      const double s = static_cast<double>(op.first_node + static_cast<int>(i / op.dim)) / op.N;
      const double a = static_cast<double>(i % op.dim);
      v[0] = s * (1 - s) * (1 + 0.1 * a);
      v[1] = s * (1 - s) * (1 - 2 * s) + 0.05 * a * s * (1 - s);
    }
    for (int c = 0; c < M; ++c) cur[c * n + i] = v[c];
    gram[0] += v[0] * v[0];
    gram[1] += v[0] * v[1];
    gram[2] += v[1] * v[1];
  }
  op.reduce(gram, 3);
  // R of the Cholesky QR of a block with Gram matrix {g00, g01, g11}: V <- V R^-1.
  auto orthonormalize = [&](double* V, const double* g, double R[2][2]) {
    R[0][0] = std::sqrt(g[0]);
    R[0][1] = M == 2 ? g[1] / R[0][0] : 0;
    R[1][0] = 0;
    const double r11 = M == 2 ? g[2] - R[0][1] * R[0][1] : 1;
    if (!(R[0][0] > 0) || !(r11 > 1e-24 * g[0]) || !std::isfinite(r11)) return false;
    R[1][1] = std::sqrt(r11);
    const double i00 = 1 / R[0][0], i11 = 1 / R[1][1], i01 = -R[0][1] * i00 * i11;
    for (std::size_t i = 0; i < n; ++i) {
      const double w0 = V[i];
      V[i] = w0 * i00;
      if (M == 2) V[n + i] = w0 * i01 + V[n + i] * i11;
    }
    return true;
  };
  double R[2][2];
  if (!orthonormalize(cur, gram, R)) return result;
  std::vector<Eigen::Matrix<double, M, M>> diagonal, below;  // the blocks A_j and B_j of T
  double Bp[2][2] = {{0, 0}, {0, 0}};                         // B_{j-1}
  double previous[2] = {-1, -1};
  for (int j = 0; j < kLanczosSteps; ++j) {
    solve(cur, next);
    // W = A V_j - V_{j-1} B_{j-1}^T, then A_j = V_j^T W.
    double Aj[2][2] = {{0, 0}, {0, 0}};
    for (std::size_t i = 0; i < n; ++i) {
      if (!op.free[i]) {
        for (int c = 0; c < M; ++c) next[c * n + i] = 0;
        continue;
      }
      for (int c = 0; c < M; ++c) {
        double w = next[c * n + i];
        for (int r = 0; r < M; ++r) w -= prev[r * n + i] * Bp[c][r];
        next[c * n + i] = w;
        for (int r = 0; r < M; ++r) Aj[r][c] += cur[r * n + i] * w;
      }
    }
    double reduced[4] = {Aj[0][0], Aj[0][1], Aj[1][0], Aj[1][1]};
    op.reduce(reduced, 4);
    Aj[0][0] = reduced[0];
    Aj[1][1] = reduced[3];
    Aj[0][1] = Aj[1][0] = 0.5 * (reduced[1] + reduced[2]);
    // W -= V_j A_j, and the Gram matrix of W for its QR (W = V_{j+1} B_j).
    double g[3] = {0, 0, 0};
    for (std::size_t i = 0; i < n; ++i) {
      double w[2] = {0, 0};
      for (int c = 0; c < M; ++c) {
        w[c] = next[c * n + i];
        for (int r = 0; r < M; ++r) w[c] -= cur[r * n + i] * Aj[r][c];
        next[c * n + i] = w[c];
      }
      g[0] += w[0] * w[0];
      g[1] += w[0] * w[1];
      g[2] += w[1] * w[1];
    }
    op.reduce(g, 3);
    Eigen::Matrix<double, M, M> block;
    for (int r = 0; r < M; ++r)
      for (int c = 0; c < M; ++c) block(r, c) = Aj[r][c];
    diagonal.push_back(block);
    // The Ritz values: eigenvalues of T_j (order M (j + 1)).
    const int order = M * static_cast<int>(diagonal.size());
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(order, order);
    for (std::size_t k = 0; k < diagonal.size(); ++k) {
      const int o = M * static_cast<int>(k);
      T.block(o, o, M, M) = diagonal[k];
      if (k + 1 < diagonal.size()) {
        T.block(o + M, o, M, M) = below[k];
        T.block(o, o + M, M, M) = below[k].transpose();
      }
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(T, Eigen::EigenvaluesOnly);
    if (eig.info() != Eigen::Success) break;
    const auto& mu = eig.eigenvalues();  // ascending
    if (!(mu(order - 1) > 0)) break;
    result.lambda[0] = 1 / mu(order - 1);
    result.lambda[1] = M == 2 ? 1 / mu(order - 2) : 0;
    result.steps = j + 1;
    // Settled when the smallest Ritz value moves by less than 1e-4 (the notes print 3 digits) and
    // the next by less than 3e-3 (within about 1% of the eigenvalue).
    const bool settled = std::fabs(result.lambda[0] - previous[0]) <= 1e-4 * result.lambda[0] &&
                         (M < 2 || std::fabs(result.lambda[1] - previous[1]) <= 3e-3 * result.lambda[1]);
    previous[0] = result.lambda[0];
    previous[1] = result.lambda[1];
    // A Krylov space that A maps into itself (W vanishes) holds exact eigenvalues: nothing
    // further to find from this start.
    if (settled || !orthonormalize(next, g, R) || !(g[0] > 1e-24 * mu(order - 1) * mu(order - 1))) {
      result.settled = true;
      break;
    }
    Eigen::Matrix<double, M, M> Bj;
    for (int r = 0; r < M; ++r)
      for (int c = 0; c < M; ++c) Bj(r, c) = R[r][c];
    below.push_back(Bj);  // A V_j = V_{j-1} B_{j-1}^T + V_j A_j + V_{j+1} B_j
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 2; ++c) Bp[r][c] = R[r][c];
    double* recycled = prev;
    prev = cur;
    cur = next;
    next = recycled;
  }
  return result;
}

}  // namespace

SmallestEigenvalues smallest_eigenvalues(const LanczosOperator& op, long positive) {
  // Left uninitialized (every value is written before it is read) but V_{j-1} of the first step,
  // which is zero.
  const int m = positive >= 2 ? 2 : 1;
  std::unique_ptr<double[]> store(new double[3 * static_cast<std::size_t>(m) * op.n]);
  std::fill(store.get(), store.get() + static_cast<std::size_t>(m) * op.n, 0.0);
  return m == 2 ? block_lanczos<2>(op, store.get()) : block_lanczos<1>(op, store.get());
}

void describe_minimum(const SmallestEigenvalues& e, double action, bool pair, PointAssessment& out) {
  out.kind = PointKind::minimum;
  out.lambda_min = e.lambda[0];
  out.lambda_next = e.lambda[1];
  out.lambda_settled = e.settled;
  if (pair && out.lambda_min < 1e-4 * out.lambda_next) {
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
  LanczosOperator op;
  op.n = n;
  op.dim = ctx.dim;
  op.first_node = 1;
  op.N = ctx.N;
  op.free = ctx.is_free.data() + dz;
  op.solve = [&H](const double* b0, const double* b1, double* x0, double* x1) {
    if (b1)
      H.solve_ldlt(b0, b1, x0, x1);
    else
      H.solve_ldlt(b0, x0);
  };
  op.reduce = [](double*, int) {};
  describe_minimum(smallest_eigenvalues(op, out.positive), sum_action(ctx), out.positive >= 2, out);
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
