/**
 * @file jacobi.cpp
 * The seed's parallel methods: nonlinear block Jacobi (eq. pDEL: each interior block solved for
 * qbar_k with its neighbours frozen, by Newton to a tolerance) and the m-step block Jacobi-Newton
 * (eq. NewtonRaphson), both with damping q <- q + (1 - eps)(qbar - q). All nodes in parallel; the
 * first Newton step of every node uses the interval arrays evaluated once per sweep.
 */
#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <vector>

#include "engine.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pardel::detail {
namespace {

/** Per-thread scratch for the node solves (no allocation in the sweep). */
template <int D>
struct NodeScratch {
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;
  Mat M;
  Vec r, x, dx;
  Eigen::PartialPivLU<Mat> lu;
  std::vector<double> d1a, d2a, d11a, d22a, d1b, d2b, d11b, d22b;
  explicit NodeScratch(int d)
      : M(Mat::Zero(d, d)), r(Vec::Zero(d)), x(Vec::Zero(d)), dx(Vec::Zero(d)), lu(d) {
    const std::size_t n = static_cast<std::size_t>(d), nn = n * n;
    d1a.assign(n, 0); d2a.assign(n, 0); d1b.assign(n, 0); d2b.assign(n, 0);
    d11a.assign(nn, 0); d22a.assign(nn, 0); d11b.assign(nn, 0); d22b.assign(nn, 0);
  }
};

/** Node status after a sweep. */
enum : signed char { node_ok = 0, node_singular = 1 };

template <int D>
class JacobiSweeps : public Method_ {
 public:
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;
  using RowMap = Eigen::Map<const Eigen::Matrix<double, D, D, (D == 1 ? Eigen::ColMajor : Eigen::RowMajor)>>;

  JacobiSweeps(const Options& o, bool nonlinear)
      : nonlinear_(nonlinear), damping_(o.damping), substeps_(o.newton_substeps),
        inner_tol_(0.1 * o.tol) {}

  void reset(Context& ctx) override {
    scratch_.clear();
    for (int i = 0; i < ctx.threads; ++i) scratch_.emplace_back(ctx.dim);
    status_.assign(static_cast<std::size_t>(ctx.N) + 1, node_ok);
  }

  int evaluate(Context& ctx) override {
    if (ctx.evaluated == Evaluated::nothing || ctx.evaluated == Evaluated::grad) eval_sweep(ctx, ctx.q);
    ctx.action_known = false;
    return compute_residual(ctx);
  }

  StepOutcome iterate(Context& ctx, long iteration) override {
    const int d = ctx.dim, N = ctx.N;
    const std::size_t dz = static_cast<std::size_t>(d), dd = dz * dz;
    const double keep = 1.0 - damping_;
#pragma omp parallel if (ctx.parallel(N)) num_threads(ctx.threads)
    {
#ifdef _OPENMP
      NodeScratch<D>& s = scratch_[static_cast<std::size_t>(omp_get_thread_num())];
#else
      NodeScratch<D>& s = scratch_[0];
#endif
#pragma omp for schedule(static)
      for (int k = 0; k <= N; ++k) {
        const std::size_t kk = static_cast<std::size_t>(k);
        const double* qk = ctx.q.data() + kk * dz;
        double* out = ctx.q_next.data() + kk * dz;
        status_[kk] = node_ok;
        if (ctx.free_count[kk] == 0) {
          for (int a = 0; a < d; ++a) out[a] = qk[a];
          continue;
        }
        const unsigned char* f = ctx.is_free.data() + kk * dz;
        // First Newton step from the shared interval arrays.
        s.M = RowMap(ctx.D22.data() + (kk - 1) * dd, d, d);
        s.M += RowMap(ctx.D11.data() + kk * dd, d, d);
        s.r = Eigen::Map<const Vec>(ctx.res.data() + kk * dz, d);
        for (int a = 0; a < d; ++a) s.x[a] = qk[a];
        bool fine = newton_step(s, f, d);
        const int steps = nonlinear_ ? 50 : substeps_;
        for (int m = 1; fine && m < steps; ++m) {
          // Re-evaluate the node's two intervals with the neighbours frozen.
          const double* qa = ctx.q.data() + (kk - 1) * dz;
          const double* qb = ctx.q.data() + (kk + 1) * dz;
          ctx.disc->sweep(ctx.hk[kk - 1], ctx.t[kk - 1], ctx.t[kk], qa, s.x.data(), ctx.p(), s.d1a.data(),
                          s.d2a.data(), s.d11a.data(), s.d22a.data());
          ctx.disc->sweep(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], s.x.data(), qb, ctx.p(), s.d1b.data(),
                          s.d2b.data(), s.d11b.data(), s.d22b.data());
          double rmax = 0;
          for (int a = 0; a < d; ++a) {
            s.r[a] = f[a] ? s.d2a[static_cast<std::size_t>(a)] + s.d1b[static_cast<std::size_t>(a)] : 0.0;
            rmax = std::max(rmax, std::fabs(s.r[a]));
          }
          if (nonlinear_ && rmax <= inner_tol_) break;
          s.M = RowMap(s.d22a.data(), d, d);
          s.M += RowMap(s.d11b.data(), d, d);
          fine = newton_step(s, f, d);
        }
        if (!fine) status_[kk] = node_singular;
        for (int a = 0; a < d; ++a) out[a] = qk[a] + keep * (s.x[a] - qk[a]);
      }
    }
    StepOutcome outcome;
    for (int k = 1; k < N; ++k) {
      if (status_[static_cast<std::size_t>(k)] == node_singular) {
        char buf[200];
        std::snprintf(buf, sizeof buf,
                      "singular diagonal block D_%d = D22(%d) + D11(%d) at node %d in iteration %ld", k, k - 1, k,
                      k, iteration);
        outcome.failure = Termination::non_finite;
        outcome.message = buf;
        return outcome;
      }
    }
    return outcome;
  }

 private:
  /** x <- x - M^{-1} r on free components (fixed rows/cols replaced by identity); false if singular. */
  static bool newton_step(NodeScratch<D>& s, const unsigned char* f, int d) {
    for (int a = 0; a < d; ++a) {
      if (!f[a]) {
        s.M.row(a).setZero();
        s.M.col(a).setZero();
        s.M(a, a) = 1;
        s.r[a] = 0;
      }
    }
    s.lu.compute(s.M);
    const double rc = s.lu.rcond();
    if (!(rc > 1e-14)) return false;
    s.dx.noalias() = s.lu.solve(s.r);
    s.x -= s.dx;
    return true;
  }

  bool nonlinear_;
  double damping_;
  int substeps_;
  double inner_tol_;
  std::vector<NodeScratch<D>> scratch_;
  std::vector<signed char> status_;
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
