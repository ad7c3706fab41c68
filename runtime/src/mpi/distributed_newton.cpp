/**
 * @file distributed_newton.cpp
 * Newton over MPI ranks (distributed_newton.hpp): a rank's unknowns as the Space of the
 * trust-region Newton of trust_region.hpp, the Newton over it with checkpoints in the one-process
 * layout, and the point assessment over the ranks.
 */
#include "distributed_newton.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "../assessment.hpp"
#include "../trust_region.hpp"
#include "schur_solver.hpp"

namespace pardel::mpi::detail {
namespace {

using pardel::detail::Evaluated;

/**
 * The unknowns of one rank for the trust-region Newton of trust_region.hpp: its owned unknown
 * nodes u0..u1, the Hessian rows of those nodes solved by the Schur-complement split, every sum
 * and verdict reduced over all ranks. Vectors hold the owned unknowns in node layout; the metric
 * and the quadratic form, which couple neighbouring nodes, read the neighbours' values through a
 * halo exchange.
 */
template <int D>
class DistributedSpace {
 public:
  using Mat = Eigen::Matrix<double, D, D>;
  using Vec = Eigen::Matrix<double, D, 1>;
  using RowMap = Eigen::Map<const Eigen::Matrix<double, D, D, (D == 1 ? Eigen::ColMajor : Eigen::RowMajor)>>;

  DistributedSpace(const Options& o, Local& local)
      : local_(local), difference_(o.newton_shift == NewtonShift::difference) {}

  void resize(Context& ctx) {
    const Layout& L = local_.layout;
    solver_.resize(local_.owned_unknowns(), ctx.dim, L.rank, L.ranks);
    dz_ = static_cast<std::size_t>(ctx.dim);
    n_ = static_cast<std::size_t>(local_.owned_unknowns()) * dz_;
    off0_ = static_cast<std::size_t>(L.local(local_.u0)) * dz_;
    halo_.assign(ctx.q.size(), 0.0);
  }
  std::size_t size() const { return n_; }
  std::size_t offset() const { return off0_; }
  bool is_free(const Context&, std::size_t i) const { return local_.global_free[off0_ + i] != 0; }
  int first_node() const { return local_.u0; }
  int intervals() const { return local_.layout.N; }
  double sum(double v) const {
    double out = 0;
    MPI_Allreduce(&v, &out, 1, MPI_DOUBLE, MPI_SUM, local_.comm);
    return out;
  }
  double max(double v) const { return detail::max_all(v, local_.comm); }
  /** The largest diagonal entry of the unshifted Hessian (1 on fixed components), over all ranks. */
  double max_abs_diagonal(const Context& ctx) const {
    const Layout& L = local_.layout;
    const std::size_t dd = dz_ * dz_;
    double scale = 0;
    for (int g = local_.u0; g <= local_.u1; ++g) {
      const std::size_t j = static_cast<std::size_t>(L.local(g));
      const unsigned char* f = local_.global_free.data() + j * dz_;
      for (std::size_t a = 0; a < dz_; ++a) {
        const std::size_t aa = a * (dz_ + 1);
        scale = std::max(scale, f[a] ? std::fabs(ctx.D22[(j - 1) * dd + aa] + ctx.D11[j * dd + aa]) : 1.0);
      }
    }
    return detail::max_all(scale, local_.comm);
  }

  bool factor(const Context& ctx, double lambda, const double* b, double* x) {
    assemble(ctx, lambda);
    return solver_.solve(b, x, local_.comm);
  }
  /** The split refactors on every solve (its factorization is not kept between calls). */
  void solve(const Context&, const double* in, double* out) { solver_.solve(in, out, local_.comm); }
  double quadratic_form(const double* x) {
    const double* h = with_halos(x);
    const Layout& L = local_.layout;
    double part = 0;
    for (int g = local_.u0; g <= local_.u1; ++g) {
      const double* xg = h + static_cast<std::size_t>(L.local(g)) * dz_;
      const int i = g - local_.u0;
      const Eigen::Map<const Vec> xi(xg, static_cast<int>(dz_));
      part += xi.dot(solver_.diag(i) * xi);
      if (g < L.N - 1) part += 2 * xi.dot(solver_.off(i) * Eigen::Map<const Vec>(xg + dz_, static_cast<int>(dz_)));
    }
    return sum(part);
  }
  /** Of the unshifted Hessian, over all ranks (the split's inertia with eigen-split pivots). */
  long negative_eigenvalues(const Context& ctx) { return inertia(ctx).negative; }
  /** The inertia of the unshifted Hessian at the full evaluation in ctx, fixed components (identity
   *  rows) taken out of the positive count; collective. */
  typename detail::SchurBlockSolver<D>::Inertia inertia(const Context& ctx) {
    assemble(ctx, 0.0);
    auto in = solver_.inertia(local_.comm);
    long fixed = 0;
    for (std::size_t i = 0; i < n_; ++i) fixed += local_.global_free[off0_ + i] ? 0 : 1;
    MPI_Allreduce(MPI_IN_PLACE, &fixed, 1, MPI_LONG, MPI_SUM, local_.comm);
    in.positive -= fixed;
    return in;
  }

  /** Gershgorin's bound on the largest |eigenvalue| of the Hessian as last assembled, over all
   *  ranks (the one-process BlockTridiagonal::gershgorin_bound). Collective. */
  double gershgorin_bound() const {
    const int owned = solver_.owned(), N = local_.layout.N;
    double bound = 0;
    for (int i = 0; i < owned; ++i) {
      const int g = local_.u0 + i;
      const Mat* previous = i > 0 ? &solver_.off(i - 1) : local_.layout.has_left() ? &solver_.left_coupling() : nullptr;
      bound = std::max(bound, pardel::detail::BlockTridiagonal<D>::gershgorin_rows(
                                  solver_.diag(i), g < N - 1 ? &solver_.off(i) : nullptr, previous));
    }
    return detail::max_all(bound, local_.comm);
  }

  void apply_metric(const Context&, const double* x, double* y) {
    if (!difference_) {
      std::copy(x, x + n_, y);
      return;
    }
    const double* h = with_halos(x) + off0_;  // node u0's first value; neighbours at -dz and +dz
    for (std::size_t i = 0; i < n_; ++i)
      y[i] = local_.global_free[off0_ + i] ? 2 * h[i] - h[static_cast<std::ptrdiff_t>(i) - static_cast<std::ptrdiff_t>(dz_)] - h[i + dz_] : 0.0;
  }
  double metric_norm(const double* x) {
    if (!difference_) {
      double s = 0;
      for (std::size_t i = 0; i < n_; ++i) s += x[i] * x[i];
      return std::sqrt(sum(s));
    }
    // |x|_M^2 = sum over intervals of |x_{k+1} - x_k|^2 with x = 0 at nodes 0 and N; this rank
    // counts the intervals ending at its unknowns and, on the rank of node N-1, the last one.
    const double* h = with_halos(x) + off0_;
    const Layout& L = local_.layout;
    double s = 0;
    for (std::size_t i = 0; i < n_; ++i) {
      const double step = h[i] - h[static_cast<std::ptrdiff_t>(i) - static_cast<std::ptrdiff_t>(dz_)];
      s += step * step;
    }
    if (local_.u1 == L.N - 1)
      for (std::size_t i = n_ - dz_; i < n_; ++i) s += h[i] * h[i];
    return std::sqrt(sum(s));
  }

  void trial_point(Context& ctx, const double* step) const {
    ctx.q_next = ctx.q;
    for (std::size_t i = 0; i < n_; ++i) ctx.q_next[off0_ + i] = ctx.q[off0_ + i] + step[i];
    detail::exchange_halos(local_.layout, ctx.q_next.data(), ctx.dim, local_.comm);
  }
  int evaluate(Context& ctx, const std::vector<double>& q) const {
    pardel::detail::eval_full(ctx, q);
    return globalize_residual(local_, pardel::detail::compute_residual(ctx, q));
  }
  double action(const Context&) const { return global_sum_Ld(local_); }
  bool newton_correction(Context&, std::vector<double>&) { return false; }  // the solve error is made in one process
  bool assess_factored(Context&, PointAssessment&, double* const*) { return false; }  // assess_distributed does it over the ranks
  void level_settled(Context&, double* const*) {}  // the assessment over ranks starts from its own vectors

 private:
  /** The blocks of the owned unknowns (and the coupling from the left separator), as
   *  BlockTridiagonal::assemble builds them for the whole problem. */
  void assemble(const Context& ctx, double mu) {
    const Layout& L = local_.layout;
    const int n = solver_.owned();
#pragma omp parallel for if (ctx.parallel(n)) num_threads(ctx.threads) schedule(static)
    for (int i = 0; i < n; ++i) node_blocks(ctx, local_.u0 + i, mu, &solver_.diag(i), solver_.off(i));
    if (L.has_left()) node_blocks(ctx, local_.u0 - 1, mu, nullptr, solver_.left_coupling());
  }

  /** The blocks of the global node g from the rank's derivative arrays (BlockTridiagonal's rule). */
  void node_blocks(const Context& ctx, int g, double mu, Mat* Dk, Mat& Ck) const {
    const Layout& L = local_.layout;
    const int d = ctx.dim;
    const std::size_t dd = static_cast<std::size_t>(d) * d;
    const std::size_t j = static_cast<std::size_t>(L.local(g));
    pardel::detail::BlockTridiagonal<D>::node_blocks(
        Dk ? ctx.D22.data() + (j - 1) * dd : nullptr, ctx.D11.data() + j * dd, ctx.D12.data() + j * dd,
        local_.global_free.data() + j * d, g == L.N - 1, mu, difference_, d, Dk, Ck);
  }

  /** x (owned unknowns) in the local node layout with the neighbours' unknowns in the halo slots
   *  and zeros at nodes 0 and N. */
  const double* with_halos(const double* x) {
    std::copy(x, x + n_, halo_.begin() + static_cast<std::ptrdiff_t>(off0_));
    detail::exchange_halos(local_.layout, halo_.data(), static_cast<int>(dz_), local_.comm);
    return halo_.data();
  }

  Local& local_;
  bool difference_;
  detail::SchurBlockSolver<D> solver_;
  std::size_t dz_ = 0, n_ = 0, off0_ = 0;
  std::vector<double> halo_;
};

/**
 * The trust-region Newton of trust_region.hpp over the ranks, with its state in the one-process
 * layout (checkpoints move between one process and the ranks): the head of trust_region.hpp's
 * save_state (the same on every rank), then, while its watchdog is active, the reference point
 * of the whole grid in node order, of which each rank holds its local nodes.
 */
template <int D>
class DistributedNewton : public pardel::detail::TrustRegionNewton<DistributedSpace<D>> {
  using Base = pardel::detail::TrustRegionNewton<DistributedSpace<D>>;

 public:
  DistributedNewton(const Options& options, Local& local) : Base(options, local), local_(local) {}

  /** The state on rank 0, the reference point gathered there; the other ranks return the head
   *  alone. Collective. */
  std::vector<double> save_state() const override {
    std::vector<double> s = Base::save_state();
    if (s.size() <= kHead) return s;
    std::vector<double> whole;
    gather_nodes(local_, s.data() + kHead, local_.ctx.dim, false, whole);
    s.resize(kHead);
    s.insert(s.end(), whole.begin(), whole.end());
    return s;
  }

  /** From the one-process layout (on every rank): the head and this rank's local nodes of the
   *  reference point. */
  bool load_state(const std::vector<double>& s) override {
    const Layout& L = local_.layout;
    const std::size_t d = static_cast<std::size_t>(local_.ctx.dim);
    const std::size_t whole = (static_cast<std::size_t>(L.N) + 1) * d;
    if (s.size() <= kHead) return Base::load_state(s);
    if (s.size() != kHead + whole) return false;
    std::vector<double> mine(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(kHead));
    const auto from = s.begin() + static_cast<std::ptrdiff_t>(kHead + static_cast<std::size_t>(L.lo) * d);
    mine.insert(mine.end(), from, from + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(L.hi - L.lo + 1) * d));
    return Base::load_state(mine);
  }

 private:
  static constexpr std::size_t kHead = Base::kStateHead;
  Local& local_;
};

}  // namespace

std::unique_ptr<pardel::detail::Method_> make_distributed_newton(const Options& options, int dim, Local& local) {
  return pardel::detail::dispatch_dim(dim, [&](auto D) -> std::unique_ptr<pardel::detail::Method_> {
    return std::make_unique<DistributedNewton<decltype(D)::value>>(options, local);
  });
}

void assess_distributed(const Options& options, Local& local, PointAssessment& out) {
  Context& ctx = local.ctx;
  out = PointAssessment{};
  pardel::detail::ensure_interval_arrays(ctx, Evaluated::full);
  pardel::detail::eval_full(ctx, ctx.q);
  bool described = false;
  pardel::detail::SmallestEigenvalues eigenvalues;
  pardel::detail::dispatch_dim(ctx.dim, [&](auto D) {
    DistributedSpace<decltype(D)::value> space(options, local);
    space.resize(ctx);
    const auto in = space.inertia(ctx);
    out.positive = in.positive;
    out.negative = in.negative;
    out.zero = in.zero;
    if (in.negative != 0 || in.zero != 0 || in.positive <= 0) return;
    out.lambda_max = space.gershgorin_bound();  // of the unshifted Hessian that inertia() assembled
    std::vector<double> b(space.size(), 0.0), x(space.size(), 0.0);
    if (!space.factor(ctx, 0.0, b.data(), x.data())) return;
    pardel::detail::LanczosOperator op;
    op.n = space.size();
    op.dim = ctx.dim;
    op.first_node = space.first_node();
    op.N = space.intervals();
    op.free = local.global_free.data() + space.offset();
    op.solve = [&](const double* b, double* x) { space.solve(ctx, b, x); };
    op.reduce = [&local](double* values, int count) {
      MPI_Allreduce(MPI_IN_PLACE, values, count, MPI_DOUBLE, MPI_SUM, local.comm);
    };
    eigenvalues = pardel::detail::smallest_eigenvalues(op, in.positive);
    described = true;
  });
  if (pardel::detail::classify_indefinite(out)) return;
  if (described) {
    pardel::detail::describe_minimum(eigenvalues, global_sum_Ld(local), out);
    return;
  }
  out.kind = PointKind::minimum;
  out.note = "a strict local minimum: Hessian positive definite (its inertia; the factorization for its smallest "
             "eigenvalues failed)";
}

}  // namespace pardel::mpi::detail
