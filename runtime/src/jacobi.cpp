/**
 * @file jacobi.cpp
 * The seed's parallel methods: nonlinear block Jacobi (eq. pDEL: each interior block solved for
 * qbar_k with its neighbours frozen, by Newton to a tolerance) and the m-step block Jacobi-Newton
 * (eq. NewtonRaphson), both with damping q <- q + (1 - eps)(qbar - q).
 *
 * One sweep is one fused pass over the nodes: each thread walks a contiguous range of nodes,
 * evaluates the sweep kernel of interval k once (kept in a two-interval rolling buffer, shared by
 * nodes k and k+1), forms the residual of node k, updates the node and checks the new value, all
 * while the node's data is in cache. No interval arrays are stored; a thread recomputes the one
 * interval left of its range. The pass runs in evaluate() (the driver needs the residual before it
 * decides to iterate) and writes the next iterate into a buffer of the method; iterate() hands it
 * over. Every node's update reads only the previous iterate and the reductions are maxima and
 * minima, so results are bit for bit the same for any thread count.
 */
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "constants.hpp"
#include "engine.hpp"
#include "inertia.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pardel::detail {
namespace {

/** One interval's sweep-kernel outputs. */
struct IntervalDerivatives {
  std::vector<double> D1, D2, D11, D22;
  explicit IntervalDerivatives(int d)
      : D1(static_cast<std::size_t>(d)), D2(D1.size()), D11(D1.size() * d), D22(D11.size()) {}
};

/** Per-thread scratch of the fused pass (allocated by reset(), never in a sweep). */
template <int D>
struct NodeScratch {
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;
  Mat M;
  Vec r, x, dx, jscale, rs;  // jscale, rs: the Jacobi scaling of M and the scaled r (blocks over 2x2)
  Eigen::PartialPivLU<Mat> lu;
  IntervalDerivatives left, right, ahead, a, b;  // rolling buffer; a, b: the node's own re-evaluations
  // What the thread found in its range.
  double residual = 0, scale = 0, qmax = 0, hq = 0;
  /** Per component: max |r_i|, max |D2_i| + |D1_i| and max of the diagonal block's row of |H| |q|. */
  std::vector<double> comp_residual, comp_scale, comp_hq;
  int bad_residual = -1, singular = -1, bad_value = -1;
  explicit NodeScratch(int d)
      : M(Mat::Zero(d, d)), r(Vec::Zero(d)), x(Vec::Zero(d)), dx(Vec::Zero(d)), jscale(Vec::Ones(d)), rs(Vec::Zero(d)), lu(d), left(d), right(d), ahead(d),
        a(d), b(d), comp_residual(static_cast<std::size_t>(d)), comp_scale(static_cast<std::size_t>(d)),
        comp_hq(static_cast<std::size_t>(d)) {}
};

/** Solves M dx = r for a node block and subtracts dx from x; false when M is singular or not
 *  finite: the reciprocal condition number in the 1-norm of S M S, S = diag(|M_aa|^-1/2) (1 where
 *  M_aa is zero or not finite), at most 1e-14, so that a change of a coordinate's units (a block
 *  diag(1e14, 1e-10)) is no singularity. Closed forms for 1x1 and 2x2, whose solve is M's own;
 *  larger blocks are solved as S (S M S)^-1 S r. */
template <int D>
bool node_newton_step(NodeScratch<D>& s, int d) {
  if constexpr (D == 1) {
    const double m = s.M(0, 0);
    if (!(std::fabs(m) > 0) || !std::isfinite(m)) return false;
    s.x[0] -= s.r[0] / m;
    return true;
  } else if constexpr (D == 2) {
    const double a = s.M(0, 0), b = s.M(0, 1), c = s.M(1, 0), e = s.M(1, 1);
    const double det = a * e - b * c;
    const double sa = jacobi_scale(a), se = jacobi_scale(e);
    const double as = a * sa * sa, bs = b * sa * se, cs = c * sa * se, es = e * se * se;
    const double det_s = as * es - bs * cs;
    const double norm = std::max(std::fabs(as) + std::fabs(cs), std::fabs(bs) + std::fabs(es));
    const double norm_adj = std::max(std::fabs(es) + std::fabs(cs), std::fabs(bs) + std::fabs(as));
    // rcond(S M S) = |det_s| / (|S M S|_1 |adj S M S|_1) > 1e-14, without a division on the way.
    if (!(std::fabs(det_s) > kJacobiMinRcond * (norm * norm_adj)) || !std::isfinite(det)) return false;
    const double inv = 1 / det;
    s.x[0] -= (e * s.r[0] - b * s.r[1]) * inv;
    s.x[1] -= (a * s.r[1] - c * s.r[0]) * inv;
    return true;
  } else {
    (void)d;
    const Eigen::Index n = s.M.rows();
    for (Eigen::Index i = 0; i < n; ++i) s.jscale[i] = jacobi_scale(s.M(i, i));
    for (Eigen::Index i = 0; i < n; ++i) {
      for (Eigen::Index j = 0; j < n; ++j) s.M(i, j) *= s.jscale[i] * s.jscale[j];
      s.rs[i] = s.jscale[i] * s.r[i];
    }
    s.lu.compute(s.M);
    const double rc = s.lu.rcond();
    if (!(rc > kJacobiMinRcond)) return false;
    s.dx.noalias() = s.lu.solve(s.rs);
    for (Eigen::Index i = 0; i < n; ++i) s.x[i] -= s.jscale[i] * s.dx[i];
    return true;
  }
}

template <int D>
class JacobiSweeps : public Method_ {
 public:
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;
  using RowMap = Eigen::Map<const Eigen::Matrix<double, D, D, (D == 1 ? Eigen::ColMajor : Eigen::RowMajor)>>;

  JacobiSweeps(const Options& o, bool nonlinear)
      : nonlinear_(nonlinear), damping_(o.damping), substeps_(o.newton_substeps), tol_(o.tol), rtol_(o.rtol) {}

  void reset(Context& ctx) override {
    scratch_.clear();
    scratch_.reserve(static_cast<std::size_t>(ctx.threads));  // built in place, never copied
    for (int i = 0; i < ctx.threads; ++i) scratch_.emplace_back(ctx.dim);
    next_.assign(ctx.q.size(), 0.0);
    have_next_ = false;
  }

  /** The fused pass at ctx.q: residual, round-off floor and the next iterate (into next_). */
  int evaluate(Context& ctx) override {
    const int N = ctx.N;
    const bool parallel = ctx.parallel(N + 1);
#pragma omp parallel if (parallel) num_threads(ctx.threads)
    {
#ifdef _OPENMP
      const int tid = omp_get_thread_num(), nt = omp_get_num_threads();
#else
      const int tid = 0, nt = 1;
#endif
      NodeScratch<D>& s = scratch_[static_cast<std::size_t>(tid)];
      if (tid == 0) team_ = nt;
      const long nodes = static_cast<long>(N) + 1;
      const int first = static_cast<int>(nodes * tid / nt), last = static_cast<int>(nodes * (tid + 1) / nt);
      pass(ctx, s, first, last);
    }
    double residual = 0, scale = 0, hq = 0;
    int bad = -1;
    singular_ = -1;
    bad_value_ = -1;
    qmax_ = 0;
    for (int i = 0; i < team_; ++i) {
      const NodeScratch<D>& s = scratch_[static_cast<std::size_t>(i)];
      residual = std::max(residual, s.residual);
      scale = std::max(scale, s.scale);
      hq = std::max(hq, s.hq);
      qmax_ = std::max(qmax_, s.qmax);
      if (s.bad_residual >= 0 && (bad < 0 || s.bad_residual < bad)) bad = s.bad_residual;
      if (s.singular >= 0 && (singular_ < 0 || s.singular < singular_)) singular_ = s.singular;
      if (s.bad_value >= 0 && (bad_value_ < 0 || s.bad_value < bad_value_)) bad_value_ = s.bad_value;
    }
    const double eps = std::numeric_limits<double>::epsilon();
    ctx.residual_floor = 16 * eps * scale + 2 * eps * hq;  // as engine.cpp's, with the diagonal blocks' |H| |q|
    ctx.residual_scale = scale;
    const std::size_t d = static_cast<std::size_t>(ctx.dim);
    ctx.comp_residual.assign(d, 0.0);
    ctx.comp_scale.assign(d, 0.0);
    ctx.comp_hq.assign(d, 0.0);
    for (int t = 0; t < team_; ++t) {
      const NodeScratch<D>& s = scratch_[static_cast<std::size_t>(t)];
      for (std::size_t i = 0; i < d; ++i) {
        ctx.comp_residual[i] = std::max(ctx.comp_residual[i], s.comp_residual[i]);
        ctx.comp_scale[i] = std::max(ctx.comp_scale[i], s.comp_scale[i]);
        ctx.comp_hq[i] = std::max(ctx.comp_hq[i], s.comp_hq[i]);
      }
    }
    ctx.residual = bad >= 0 ? std::numeric_limits<double>::quiet_NaN() : residual;
    ctx.action_known = false;
    have_next_ = true;
    return bad;
  }

  StepOutcome iterate(Context& ctx, long iteration) override {
    StepOutcome outcome;
    if (!have_next_) evaluate(ctx);
    have_next_ = false;
    if (singular_ >= 0) {
      const int k = singular_;
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "singular diagonal block D_%d = D22(%d) + D11(%d) at node %d in iteration %ld", k, k - 1, k, k,
                    iteration);
      outcome.failure = Termination::non_finite;
      outcome.message = buf;
      return outcome;
    }
    std::swap(ctx.q_next, next_);
    outcome.next_checked = true;
    outcome.next_non_finite_node = bad_value_;
    outcome.next_max_abs = qmax_;
    return outcome;
  }

 private:
  /** Nodes first..last-1: kernels, residuals and node updates in one walk. */
  void pass(const Context& ctx, NodeScratch<D>& s, int first, int last) {
    const int d = D > 0 ? D : ctx.dim, N = ctx.N;  // a compile-time size unrolls the node loops
    const std::size_t dz = static_cast<std::size_t>(d);
    const double keep = 1.0 - damping_;
    const double* p = ctx.p();
    const pardel_sweep_kernel kern = ctx.disc->sweep;
    const double* q = ctx.q.data();
    // What this range finds, in locals (the scratch is written once at the end).
    double residual = 0, residual_scale = 0, qmax = 0, hq = 0;
    int bad_residual = -1, singular = -1, bad_value = -1;
    double probe = 0;
    std::fill(s.comp_residual.begin(), s.comp_residual.end(), 0.0);
    std::fill(s.comp_scale.begin(), s.comp_scale.end(), 0.0);
    std::fill(s.comp_hq.begin(), s.comp_hq.end(), 0.0);
    auto eval = [&](int k, IntervalDerivatives& out) {
      const std::size_t kk = static_cast<std::size_t>(k);
      kern(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], q + kk * dz, q + (kk + 1) * dz, p, out.D1.data(), out.D2.data(),
           out.D11.data(), out.D22.data());
    };
    // Three interval buffers: the kernel of interval k+1 runs before node k is updated, so the
    // update never waits on results that were just written.
    IntervalDerivatives* left = &s.left;    // interval k-1
    IntervalDerivatives* right = &s.right;  // interval k
    IntervalDerivatives* ahead = &s.ahead;  // interval k+1
    if (first > 0 && first <= N) eval(first - 1, *left);
    if (first < N && first < last) eval(first, *right);
    for (int k = first; k < last; ++k) {
      const std::size_t kk = static_cast<std::size_t>(k);
      if (k + 1 < N && k + 1 < last) eval(k + 1, *ahead);
      const double* qk = q + kk * dz;
      double* out = next_.data() + kk * dz;
      const unsigned char* f = ctx.is_free.data() + kk * dz;
      if (ctx.free_count[kk] == 0) {
        for (int i = 0; i < d; ++i) out[i] = qk[i];
      } else {
        // Residual r_k = D2(k-1) + D1(k) on free components, and its round-off scale.
        double mx = 0, scale = 0;
        bool finite = true;
        for (int i = 0; i < d; ++i) {
          double v = 0;
          if (f[i]) {
            const double a = left->D2[static_cast<std::size_t>(i)], b = right->D1[static_cast<std::size_t>(i)];
            v = a + b;
            if (!std::isfinite(v)) finite = false;
            scale = std::max(scale, std::fabs(a) + std::fabs(b));
            s.comp_residual[static_cast<std::size_t>(i)] = std::max(s.comp_residual[static_cast<std::size_t>(i)], std::fabs(v));
            s.comp_scale[static_cast<std::size_t>(i)] = std::max(s.comp_scale[static_cast<std::size_t>(i)], std::fabs(a) + std::fabs(b));
          }
          s.r[i] = v;
          mx = std::max(mx, std::fabs(v));
        }
        if (!finite && bad_residual < 0) bad_residual = k;
        residual = std::max(residual, mx);
        residual_scale = std::max(residual_scale, scale);
        // First Newton step from the shared interval derivatives.
        s.M = RowMap(left->D22.data(), d, d);
        s.M += RowMap(right->D11.data(), d, d);
        // The rounding of the node's values seen through its diagonal block, |H_kk| |q_k| (the
        // sweep kernel has no D12: the neighbours' blocks, of the same size for kinetic terms, are
        // left out, so this part of the round-off level is low by a factor of 2 to 3 there).
        for (int i = 0; i < d; ++i) {
          if (!f[i]) continue;
          double row = 0;
          for (int j = 0; j < d; ++j) row += std::fabs(s.M(i, j)) * std::fabs(qk[j]);
          s.comp_hq[static_cast<std::size_t>(i)] = std::max(s.comp_hq[static_cast<std::size_t>(i)], row);
          hq = std::max(hq, row);
        }
        for (int i = 0; i < d; ++i) s.x[i] = qk[i];
        bool fine = step(s, f, d);
        const int steps = nonlinear_ ? 50 : substeps_;
        for (int m = 1; fine && m < steps; ++m) {
          // Re-evaluate the node's two intervals with the neighbours frozen.
          const double* qa = q + (kk - 1) * dz;
          const double* qb = q + (kk + 1) * dz;
          kern(ctx.hk[kk - 1], ctx.t[kk - 1], ctx.t[kk], qa, s.x.data(), p, s.a.D1.data(), s.a.D2.data(),
               s.a.D11.data(), s.a.D22.data());
          kern(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], s.x.data(), qb, p, s.b.D1.data(), s.b.D2.data(), s.b.D11.data(),
               s.b.D22.data());
          // The inner Newton stops when every component of the node's equations is a tenth of the
          // way to the outer test: 0.1 tol, or 0.1 rtol of the component's own terms (never below
          // their rounding).
          bool inner_done = true;
          for (int i = 0; i < d; ++i) {
            const std::size_t ii = static_cast<std::size_t>(i);
            s.r[i] = f[i] ? s.a.D2[ii] + s.b.D1[ii] : 0.0;
            const double terms = f[i] ? std::fabs(s.a.D2[ii]) + std::fabs(s.b.D1[ii]) : 0.0;
            const double inner_tol =
                tol_ > 0 ? 0.1 * tol_ : std::max(0.1 * rtol_, 160 * std::numeric_limits<double>::epsilon()) * terms;
            if (!(std::fabs(s.r[i]) <= inner_tol)) inner_done = false;
          }
          if (nonlinear_ && inner_done) break;
          s.M = RowMap(s.a.D22.data(), d, d);
          s.M += RowMap(s.b.D11.data(), d, d);
          fine = step(s, f, d);
        }
        if (!fine && singular < 0 && finite) singular = k;
        for (int i = 0; i < d; ++i) out[i] = qk[i] + keep * (s.x[i] - qk[i]);
      }
      for (int i = 0; i < d; ++i) {
        probe += out[i] * 0.0;  // NaN once any value is not finite
        qmax = std::max(qmax, std::fabs(out[i]));
      }
      IntervalDerivatives* done = left;
      left = right;
      right = ahead;
      ahead = done;
    }
    if (!(probe == 0)) {  // rare: find the first non-finite value of the range
      for (int k = first; k < last && bad_value < 0; ++k)
        for (int i = 0; i < d; ++i)
          if (!std::isfinite(next_[static_cast<std::size_t>(k) * dz + static_cast<std::size_t>(i)])) bad_value = k;
    }
    s.residual = residual;
    s.scale = residual_scale;
    s.hq = hq;
    s.qmax = qmax;
    s.bad_residual = bad_residual;
    s.singular = singular;
    s.bad_value = bad_value;
  }

  /** x <- x - M^{-1} r on free components (fixed rows/cols replaced by identity); false if singular. */
  static bool step(NodeScratch<D>& s, const unsigned char* f, int d) {
    for (int a = 0; a < d; ++a) {
      if (!f[a]) {
        s.M.row(a).setZero();
        s.M.col(a).setZero();
        s.M(a, a) = 1;
        s.r[a] = 0;
      }
    }
    return node_newton_step<D>(s, d);
  }

  bool nonlinear_;
  double damping_;
  int substeps_;
  double tol_, rtol_;  ///< the outer tolerances; the inner Newton of the nonlinear sweep stops at a tenth of them
  std::vector<NodeScratch<D>> scratch_;
  std::vector<double> next_;  ///< the next iterate, written by evaluate()
  bool have_next_ = false;
  int team_ = 1;  ///< threads of the last pass
  int singular_ = -1, bad_value_ = -1;
  double qmax_ = 0;
};

}  // namespace

std::unique_ptr<Method_> make_jacobi(const Options& options, int dim) {
  return dispatch_dim(dim, [&](auto D) -> std::unique_ptr<Method_> {
    return std::make_unique<JacobiSweeps<decltype(D)::value>>(options, true);
  });
}

std::unique_ptr<Method_> make_jacobi_newton(const Options& options, int dim) {
  return dispatch_dim(dim, [&](auto D) -> std::unique_ptr<Method_> {
    return std::make_unique<JacobiSweeps<decltype(D)::value>>(options, false);
  });
}

}  // namespace pardel::detail
