/**
 * @file distributed.cpp
 * The domain-decomposed solve (distributed.hpp): each rank builds a solve context over its own
 * nodes plus one halo node per neighbour (the halos are fixed in that context, so the seed's
 * Jacobi methods run on it unchanged), and runs the iteration of iteration.hpp, the one-process
 * solve's, over a partition that takes every decision from values reduced over all ranks:
 * the residual and its round-off level by max (order-independent), the action by a sum in node
 * order, failures by the lowest failing node or rank. Node times under a clock are prefix sums
 * carried from rank to rank; under fixed_total_time the nodes then move to their new times,
 * interpolated from the old nodes that the ranks exchange (an Alltoallv). Newton's
 * block-tridiagonal solves (also those of hybrid) are distributed by the Schur-complement split
 * of schur_solver.hpp. The levels of coarse-to-fine refinement and of the automatic method's grid
 * sequencing are the one-process solve's (levels.hpp): each level but the last is set up from the
 * whole start trajectory, which every rank holds, and its solution is gathered on every rank to
 * start the next; the last level releases the whole trajectory before it iterates. An interrupted
 * solve's state (SolverState) is the one-process state, gathered on rank 0; a resumed state (of
 * one process or of any number of ranks) is checked as in one process (levels.hpp) and each rank
 * sets up its own nodes at the state's level from it.
 */
#include "pardel/distributed.hpp"

#include <string>

#ifdef PARDEL_HAVE_MPI
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "../assessment.hpp"
#include "../engine.hpp"
#include "../error_estimate.hpp"
#include "../iteration.hpp"
#include "../levels.hpp"
#include "../trust_region.hpp"
#include "decomposition.hpp"
#include "schur_solver.hpp"
#endif

namespace pardel::mpi {

NodeRange owned_nodes(int N, int ranks, int rank) {
  const long nodes = static_cast<long>(N) + 1;
  NodeRange range;
  range.first = static_cast<int>(nodes * rank / ranks);
  range.last = static_cast<int>(nodes * (rank + 1) / ranks) - 1;
  return range;
}

namespace {

/** Whether every one of `ranks` ranks owns at least 3 of the N + 1 nodes. */
bool fits_ranks(int N, int ranks) { return static_cast<long>(N) + 1 >= 3L * ranks; }

}  // namespace

bool distributed_supported(const Problem& problem, const Options& options, int ranks, std::string* message) {
  if (ranks <= 1) return true;
  auto fail = [&](std::string text) {
    if (message) *message = std::move(text);
    return false;
  };
  if (options.method == Method::stationary_newton)
    return fail("solver.method = \"stationary-newton\" runs in one process only: its indefinite block "
                "factorization has no counterpart in the distributed Schur-complement solver (run it without "
                "mpirun, or use \"newton\" or \"auto\" over ranks)");
  if (!problem.times.empty() || options.accuracy > 0)
    return fail("a given non-uniform grid (problem.times) and an adaptive grid (grid.accuracy) run in one process "
                "only: the distributed solver places its nodes uniformly (run it without mpirun)");
  if (!fits_ranks(problem.N, ranks))
    return fail("grid.N = " + std::to_string(problem.N) + " is too small for " + std::to_string(ranks) +
                " ranks: every rank needs at least 3 nodes (N + 1 >= 3 ranks)");
  return true;
}

#ifndef PARDEL_HAVE_MPI

Summary solve_distributed(const Problem& problem, const Options& options, Trajectory& trajectory) {
  return solve(problem, options, trajectory);
}

#else

namespace {

using pardel::detail::Context;
using pardel::detail::Evaluated;
using pardel::detail::Positions;
using pardel::detail::StepOutcome;
using detail::Layout;

/** Everything a rank holds: its layout, its local context and the true constraint pattern of its
 *  nodes (the context marks the halo nodes fixed; `global_free` says which of their components are
 *  unknowns of the whole problem). */
struct Local {
  Layout layout;
  MPI_Comm comm = MPI_COMM_WORLD;
  Context ctx;
  std::vector<unsigned char> global_free;  ///< (hi-lo+1)*dim
  std::vector<double> interval_scratch;    ///< one value per owned interval
  int u0 = 0, u1 = -1;                     ///< owned unknown nodes (global), u0 >= 1, u1 <= N-1
  std::vector<double> reduce_buffer;       ///< the residual reduction's in and out (globalize_residual)

  int owned_intervals() const { return layout.last_interval() - layout.first_interval() + 1; }
  int owned_unknowns() const { return u1 - u0 + 1; }
};

/** Builds the local context of `local.layout` (a grid of N intervals, a level of the solve) from
 *  the full initial guess on that grid; false with `message` for a knot off the grid (the same
 *  test and text as the one-process constraints). */
bool setup_local(const Problem& problem, int N, int threads, const Trajectory& guess, Local& local,
                 std::string* message) {
  const Layout& L = local.layout;
  Context& ctx = local.ctx;
  const int Nl = L.local_intervals();
  pardel::detail::setup_context(problem, Nl, threads, ctx);
  const std::size_t d = static_cast<std::size_t>(ctx.dim);
  // Node times and steps of the whole grid (the same expressions as setup_context at N); under a
  // clock the guess's times when it has them, as solve.cpp's enter_level takes them.
  const bool guess_times = problem.clock != ClockMode::none && guess.t.size() == static_cast<std::size_t>(N) + 1;
  for (int j = 0; j <= Nl; ++j) {
    const int g = L.lo + j;
    ctx.t[static_cast<std::size_t>(j)] = guess_times ? guess.t[static_cast<std::size_t>(g)]
                                         : g == N    ? problem.t0 + problem.T
                                                     : problem.t0 + problem.T * g / N;
  }
  std::fill(ctx.hk.begin(), ctx.hk.end(), problem.T / N);
  // The guess on the local nodes, boundaries replaced by the problem's.
  std::copy(guess.q.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(L.lo) * d),
            guess.q.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(L.hi + 1) * d), ctx.q.begin());
  if (L.lo == 0)
    for (std::size_t i = 0; i < d; ++i) ctx.q[i] = problem.q0[i];
  if (L.hi == N)
    for (std::size_t i = 0; i < d; ++i) ctx.q[static_cast<std::size_t>(Nl) * d + i] = problem.qN[i];
  // Constraints of the whole problem on the local nodes.
  local.global_free.assign(static_cast<std::size_t>(Nl + 1) * d, 1);
  auto fix = [&](int g, int from, int to) {
    if (g < L.lo || g > L.hi) return;
    for (int i = from; i < to; ++i) local.global_free[static_cast<std::size_t>(L.local(g)) * d + i] = 0;
  };
  fix(0, 0, ctx.dim);
  fix(N, 0, ctx.dim);
  for (std::size_t a = 0; a < problem.knots.size(); ++a) {
    const Knot& knot = problem.knots[a];
    const int k = pardel::detail::knot_node(problem, a, N, message);
    if (k < 0) return false;
    fix(k, 0, ctx.order == 1 ? ctx.dim : ctx.ncoords);
    if (k >= L.lo && k <= L.hi) {
      double* qk = ctx.node(ctx.q, L.local(k));
      for (int i = 0; i < ctx.ncoords; ++i) qk[i] = knot.q[static_cast<std::size_t>(i)];
    }
  }
  // The local context: the whole pattern, with the halo nodes fixed (their values come from the neighbours).
  ctx.is_free = local.global_free;
  if (L.has_left()) std::fill(ctx.is_free.begin(), ctx.is_free.begin() + static_cast<std::ptrdiff_t>(d), 0);
  if (L.has_right()) std::fill(ctx.is_free.end() - static_cast<std::ptrdiff_t>(d), ctx.is_free.end(), 0);
  ctx.free_total = 0;
  for (int j = 0; j <= Nl; ++j) {
    int count = 0;
    for (std::size_t i = 0; i < d; ++i) count += ctx.is_free[static_cast<std::size_t>(j) * d + i];
    ctx.free_count[static_cast<std::size_t>(j)] = count;
    ctx.free_total += count;
  }
  local.interval_scratch.assign(static_cast<std::size_t>(local.owned_intervals()), 0.0);
  local.u0 = std::max(L.first, 1);
  local.u1 = std::min(L.last, N - 1);
  return true;
}

/** The owned nodes' values of `values`, an array in the local node layout with `per_node` values
 *  a node, in node order over all ranks ((N+1) per_node values): in `out` on every rank
 *  (`everywhere`) or on rank 0 alone, the other ranks' `out` emptied. Collective. */
void gather_nodes(const Local& local, const double* values, int per_node, bool everywhere, std::vector<double>& out) {
  const Layout& L = local.layout;
  const std::size_t R = static_cast<std::size_t>(L.ranks);
  std::vector<int> counts(R), displs(R);
  for (int r = 0; r < L.ranks; ++r) {
    const NodeRange range = owned_nodes(L.N, L.ranks, r);
    counts[static_cast<std::size_t>(r)] = range.last - range.first + 1;
    displs[static_cast<std::size_t>(r)] = range.first;
  }
  if (everywhere || L.rank == 0)
    out.assign((static_cast<std::size_t>(L.N) + 1) * static_cast<std::size_t>(per_node), 0.0);
  else
    std::vector<double>().swap(out);
  const int owned = L.last - L.first + 1;
  const double* mine = values + static_cast<std::size_t>(L.local(L.first)) * static_cast<std::size_t>(per_node);
  MPI_Datatype node_type;
  MPI_Type_contiguous(per_node, MPI_DOUBLE, &node_type);
  MPI_Type_commit(&node_type);
  if (everywhere)
    MPI_Allgatherv(mine, owned, node_type, out.data(), counts.data(), displs.data(), node_type, local.comm);
  else
    MPI_Gatherv(mine, owned, node_type, out.data(), counts.data(), displs.data(), node_type, 0, local.comm);
  MPI_Type_free(&node_type);
}

/** The whole iterate of the current level and its node times in `out`, from the owned nodes of
 *  every rank: on every rank (`everywhere`) or on rank 0 alone, the other ranks' `out` emptied.
 *  Collective. */
void gather_trajectory(const Local& local, bool everywhere, Trajectory& out) {
  gather_nodes(local, local.ctx.t.data(), 1, everywhere, out.t);
  gather_nodes(local, local.ctx.q.data(), local.ctx.dim, everywhere, out.q);
  out.N = local.layout.N;
  out.dim = local.ctx.dim;
}

/** The discrete action at the local iterate through the action kernel, summed in node order over all ranks. */
double global_action(Local& local, const std::vector<double>& q) {
  Context& ctx = local.ctx;
  const int d = ctx.dim, j0 = local.layout.local(local.layout.first_interval()), n = local.owned_intervals();
  const pardel_action_kernel kern = ctx.disc->action;
  const double* p = ctx.p();
  double* out = local.interval_scratch.data();
#pragma omp parallel for if (ctx.parallel(n)) num_threads(ctx.threads) schedule(static)
  for (int i = 0; i < n; ++i) {
    const std::size_t kk = static_cast<std::size_t>(j0 + i);
    out[i] = kern(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], q.data() + kk * d, q.data() + (kk + 1) * d, p);
  }
  return detail::ordered_sum(local.layout, out, n, local.comm);
}

/** The sum of the Ld array over the owned intervals in node order over all ranks (after a full or grad evaluation). */
double global_sum_Ld(const Local& local) {
  const int j0 = local.layout.local(local.layout.first_interval());
  return detail::ordered_sum(local.layout, local.ctx.Ld.data() + j0, local.owned_intervals(), local.comm);
}

/**
 * Moves the owned interior nodes u0..u1 to their new times in ctx.t through the old trajectory
 * (engine.cpp's update_times with Positions::follow_times): `t_old` holds the old times of the
 * owned nodes, ctx.q still the old iterate. The old nodes a rank needs may lie on any rank: every
 * rank publishes the new times of its first and last interior node; for each such time x every
 * rank finds the first of its old owned nodes m >= 1 later than x, and a min over the ranks gives
 * the first on the whole grid (N if none). Rank s then needs old nodes m_lo - 2 .. m_hi + 1 (the
 * old intervals holding its new times and one node beyond on each side, retime_nodes's contract),
 * which one Alltoallv of times and one of values bring. retime_nodes then makes on that range the
 * one-process search and arithmetic, so the values are the same bit for bit as long as old and new
 * times do not decrease (a positive clock). The received range has one NaN node on each side, so
 * that unordered times give non-finite values rather than reads out of bounds. A component held
 * fixed keeps its value. Collective; memory O(N / ranks) apart from the nodes received.
 */
void retime_owned_nodes(Local& local, const std::vector<double>& t_old) {
  Context& ctx = local.ctx;
  const Layout& L = local.layout;
  const int d = ctx.dim, N = L.N, R = L.ranks;
  const std::size_t dz = static_cast<std::size_t>(d), R2 = 2 * static_cast<std::size_t>(R);
  const double mine[2] = {ctx.t[static_cast<std::size_t>(L.local(local.u0))],
                          ctx.t[static_cast<std::size_t>(L.local(local.u1))]};
  std::vector<double> spans(R2);
  MPI_Allgather(mine, 2, MPI_DOUBLE, spans.data(), 2, MPI_DOUBLE, local.comm);
  std::vector<int> later(R2), first_later(R2);
  const int m0 = std::max(L.first, 1);  // node 0 ends no interval on its right
  const auto from = t_old.begin() + (m0 - L.first);
  for (std::size_t i = 0; i < R2; ++i) {
    const auto it = std::upper_bound(from, t_old.end(), spans[i]);
    later[i] = it == t_old.end() ? N : L.first + static_cast<int>(it - t_old.begin());
  }
  MPI_Allreduce(later.data(), first_later.data(), static_cast<int>(R2), MPI_INT, MPI_MIN, local.comm);
  // The old nodes rank s needs: A(s)..B(s), at least one interval.
  auto needed = [&](int s, int* a, int* b) {
    const std::size_t ss = static_cast<std::size_t>(s);
    *a = std::min(std::max(0, first_later[2 * ss] - 2), N - 1);
    *b = std::max(std::min(N, first_later[2 * ss + 1] + 1), *a + 1);
  };
  std::vector<int> send_counts(static_cast<std::size_t>(R)), send_displs(send_counts.size());
  std::vector<int> recv_counts(send_counts.size()), recv_displs(send_counts.size());
  int a = 0, b = 0;
  needed(L.rank, &a, &b);
  for (int s = 0; s < R; ++s) {
    const std::size_t ss = static_cast<std::size_t>(s);
    int as = 0, bs = 0;
    needed(s, &as, &bs);
    const int lo = std::max(as, L.first), hi = std::min(bs, L.last);  // my old nodes that s needs
    send_counts[ss] = std::max(0, hi - lo + 1);
    send_displs[ss] = send_counts[ss] > 0 ? lo - L.first : 0;
    const NodeRange owned = owned_nodes(N, R, s);  // the old nodes I need from s
    const int rlo = std::max(a, owned.first), rhi = std::min(b, owned.last);
    recv_counts[ss] = std::max(0, rhi - rlo + 1);
    recv_displs[ss] = recv_counts[ss] > 0 ? rlo - a : 0;
  }
  const std::size_t n_old = static_cast<std::size_t>(b - a + 1);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> old_t(n_old + 2, nan), old_q((n_old + 2) * dz, nan);
  MPI_Alltoallv(t_old.data(), send_counts.data(), send_displs.data(), MPI_DOUBLE, old_t.data() + 1,
                recv_counts.data(), recv_displs.data(), MPI_DOUBLE, local.comm);
  MPI_Datatype node_type;
  MPI_Type_contiguous(d, MPI_DOUBLE, &node_type);
  MPI_Type_commit(&node_type);
  MPI_Alltoallv(ctx.q.data() + static_cast<std::size_t>(L.local(L.first)) * dz, send_counts.data(),
                send_displs.data(), node_type, old_q.data() + dz, recv_counts.data(), recv_displs.data(), node_type,
                local.comm);
  MPI_Type_free(&node_type);
  const pardel::detail::RetimeGrid old{old_t.data() + 1, old_q.data() + dz, a, b, N, d, ctx.model->ncoords};
  const std::size_t j0 = static_cast<std::size_t>(L.local(local.u0));
  std::vector<double> moved(static_cast<std::size_t>(local.owned_unknowns()) * dz);
  pardel::detail::retime_nodes(old, ctx.t.data() + j0, local.u0, local.u1, moved.data());
  for (std::size_t i = 0; i < moved.size(); ++i)
    if (local.global_free[j0 * dz + i]) ctx.q[j0 * dz + i] = moved[i];
  detail::exchange_halos(L, ctx.q.data(), d, local.comm);
}

/**
 * Node times from the model's clock (engine.cpp's update_times) over the ranks: the prefix sums
 * run as a chain from rank to rank (each rank receives the times of its left halo and first node,
 * continues the sums over its intervals and passes its last two times on), so every addition
 * happens in the one-process order and the times are the same bit for bit. Under
 * fixed_total_time the clock is first evaluated on every rank's intervals and totalled in node
 * order, and with Positions::follow_times the interior nodes then move to their new times
 * (retime_owned_nodes); under free_final_time a node keeps its values.
 */
void update_times_distributed(Local& local, Positions positions) {
  Context& ctx = local.ctx;
  if (ctx.clock == ClockMode::none || ctx.model->clock == nullptr) return;
  const Layout& L = local.layout;
  const int d = ctx.dim, N = L.N, Nl = L.local_intervals();
  const double hs = ctx.T / N;
  const double* p = ctx.p();
  const std::vector<double>& q = ctx.q;
  const int jf = L.local(L.first), j_end = L.local(L.last_interval()) + 1;  // owned intervals jf..j_end-1
  double* c = local.interval_scratch.data();
  double total = 0;
  if (ctx.clock == ClockMode::fixed_total_time) {
    // Clock of each owned interval at the previous times, then their total in node order.
    for (int j = jf; j < j_end; ++j) {
      const std::size_t jj = static_cast<std::size_t>(j);
      c[j - jf] = ctx.model->clock(hs, ctx.t[jj], q.data() + jj * d, q.data() + (jj + 1) * d, p);
    }
    total = detail::ordered_sum(L, c, j_end - jf, local.comm);
  }
  std::vector<double> t_old;  // the old times of the owned nodes (fixed_total_time)
  if (ctx.clock == ClockMode::fixed_total_time)
    t_old.assign(ctx.t.begin() + L.local(L.first), ctx.t.begin() + L.local(L.last) + 1);
  double carried[2] = {ctx.t0, ctx.t0};  // times of the left halo and of the first owned node
  if (L.has_left()) MPI_Recv(carried, 2, MPI_DOUBLE, L.rank - 1, 104, local.comm, MPI_STATUS_IGNORE);
  if (L.has_left()) ctx.t[0] = carried[0];
  ctx.t[static_cast<std::size_t>(jf)] = carried[1];
  for (int j = jf; j < j_end; ++j) {
    const std::size_t jj = static_cast<std::size_t>(j);
    if (ctx.clock == ClockMode::free_final_time) {
      ctx.t[jj + 1] = ctx.t[jj] + ctx.model->clock(hs, ctx.t[jj], q.data() + jj * d, q.data() + (jj + 1) * d, p);
    } else {
      ctx.t[jj + 1] = ctx.t[jj] + ctx.T * c[j - jf] / total;
    }
  }
  if (ctx.clock == ClockMode::fixed_total_time && !L.has_right()) ctx.t[static_cast<std::size_t>(Nl)] = ctx.t0 + ctx.T;
  if (L.has_right()) {
    const double send[2] = {ctx.t[static_cast<std::size_t>(Nl - 1)], ctx.t[static_cast<std::size_t>(Nl)]};
    MPI_Send(send, 2, MPI_DOUBLE, L.rank + 1, 104, local.comm);
  }
  if (ctx.clock == ClockMode::fixed_total_time && positions == Positions::follow_times)
    retime_owned_nodes(local, t_old);
  for (int j = 0; j < Nl; ++j) {
    const std::size_t jj = static_cast<std::size_t>(j);
    ctx.hk[jj] = ctx.clock == ClockMode::free_final_time ? hs : ctx.t[jj + 1] - ctx.t[jj];
  }
  ctx.evaluated = Evaluated::nothing;
}

/** Residual of the whole problem after a local evaluation: the lowest global node with a
 *  non-finite residual (or -1), with ctx.residual and ctx.residual_floor set to the global values. */
int globalize_residual(Local& local, int local_bad) {
  Context& ctx = local.ctx;
  // One reduction: max residual, max round-off level (non-finite nodes are skipped by both, as
  // in compute_residual) and the lowest non-finite node as the max of its negative.
  // The per-component maxima (residual, scale, |H||q| row) travel in the same reduction.
  const bool bad_here = local_bad >= 0;
  const std::size_t d = static_cast<std::size_t>(ctx.dim), n = 4 + 3 * d;
  std::vector<double>& buf = local.reduce_buffer;
  if (buf.size() != 2 * n) buf.assign(2 * n, 0.0);  // once: the size never changes
  double* in = buf.data();
  double* out = buf.data() + n;
  in[0] = bad_here ? 0.0 : ctx.residual;
  in[1] = ctx.residual_floor;
  in[2] = bad_here ? -static_cast<double>(local.layout.lo + local_bad) : -1e300;
  in[3] = ctx.residual_scale;
  for (std::size_t i = 0; i < d; ++i) {
    in[4 + i] = ctx.comp_residual[i];
    in[4 + d + i] = ctx.comp_scale[i];
    in[4 + 2 * d + i] = ctx.comp_hq[i];
  }
  MPI_Allreduce(in, out, static_cast<int>(n), MPI_DOUBLE, MPI_MAX, local.comm);
  ctx.residual_floor = out[1];
  ctx.residual_scale = out[3];
  for (std::size_t i = 0; i < d; ++i) {
    ctx.comp_residual[i] = out[4 + i];
    ctx.comp_scale[i] = out[4 + d + i];
    ctx.comp_hq[i] = out[4 + 2 * d + i];
  }
  if (out[2] > -1e300) {
    ctx.residual = std::numeric_limits<double>::quiet_NaN();
    return static_cast<int>(-out[2]);
  }
  ctx.residual = out[0];
  return -1;
}

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
    auto in = solver_.inertia(kZeroPivot, local_.comm);
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
    return globalize_residual(local_, pardel::detail::compute_residual(ctx));
  }
  double action(const Context&) const { return global_sum_Ld(local_); }
  bool assess_factored(Context&, PointAssessment&, double* const*) { return false; }  // assess_distributed does it over the ranks

 private:
  /** The blocks of the owned unknowns (and the coupling from the left separator), as
   *  BlockTridiagonal::assemble builds them for the whole problem. */
  void assemble(const Context& ctx, double mu) {
    const Layout& L = local_.layout;
    const int d = ctx.dim;
    const std::size_t dd = static_cast<std::size_t>(d) * d;
    const int n = solver_.owned();
#pragma omp parallel for if (ctx.parallel(n)) num_threads(ctx.threads) schedule(static)
    for (int i = 0; i < n; ++i) {
      const int g = local_.u0 + i;
      const std::size_t j = static_cast<std::size_t>(L.local(g));
      Mat& Dk = solver_.diag(i);
      Dk = RowMap(ctx.D22.data() + (j - 1) * dd, d, d);
      Dk += RowMap(ctx.D11.data() + j * dd, d, d);
      coupling(ctx, g, mu, solver_.off(i), &Dk);
    }
    if (L.has_left()) coupling(ctx, local_.u0 - 1, mu, solver_.left_coupling(), nullptr);
  }

  /** C_k = D12(k) between nodes k and k+1 with the constraint and shift rules of assemble; with
   *  Dk also the shift and constraint rows of the diagonal block of node k. */
  void coupling(const Context& ctx, int g, double mu, Mat& Ck, Mat* Dk) const {
    const Layout& L = local_.layout;
    const int d = ctx.dim;
    const std::size_t dd = static_cast<std::size_t>(d) * d;
    const std::size_t j = static_cast<std::size_t>(L.local(g));
    if (g < L.N - 1)
      Ck = RowMap(ctx.D12.data() + j * dd, d, d);
    else
      Ck.setZero();
    const unsigned char* f = local_.global_free.data() + j * d;
    const unsigned char* fn = local_.global_free.data() + (j + 1) * d;
    for (int a = 0; a < d; ++a) {
      if (!f[a]) {
        if (Dk) {
          Dk->row(a).setZero();
          Dk->col(a).setZero();
          (*Dk)(a, a) = 1;
        }
        Ck.row(a).setZero();
      } else if (difference_) {
        if (Dk) (*Dk)(a, a) += 2 * mu;
        if (g < L.N - 1 && fn[a]) Ck(a, a) -= mu;
      } else {
        if (Dk) (*Dk)(a, a) += mu;
      }
      if (!fn[a]) Ck.col(a).setZero();
    }
  }

  /** x (owned unknowns) in the local node layout with the neighbours' unknowns in the halo slots
   *  and zeros at nodes 0 and N. */
  const double* with_halos(const double* x) {
    std::copy(x, x + n_, halo_.begin() + static_cast<std::ptrdiff_t>(off0_));
    detail::exchange_halos(local_.layout, halo_.data(), static_cast<int>(dz_), local_.comm);
    return halo_.data();
  }

  /** Pivot eigenvalues below this fraction of the largest block entry count as zero (inertia). */
  static constexpr double kZeroPivot = 1e-12;

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

/** What the returned point is, over the ranks: the kind and inertia of the Hessian and, at a
 *  minimum, its smallest eigenvalues by the one-process assessment's Lanczos iterations
 *  (assessment.hpp) with the distributed solve. Collective. */
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

/** hybrid.cpp over the ranks: Jacobi-Newton sweeps until the distributed factorization certifies
 *  a positive definite Hessian (checked every 10 sweeps, as in one process), then Newton. */
template <int D>
class DistributedHybrid : public pardel::detail::Method_ {
 public:
  DistributedHybrid(const Options& o, int dim, Local& local)
      : local_(local), sweeps_(pardel::detail::make_jacobi_newton(o, dim)), newton_(o, local) {}

  void reset(Context& ctx) override {
    sweeps_->reset(ctx);
    newton_.reset(ctx);
    newton_mode_ = false;
    since_check_ = check_every;
  }

  int evaluate(Context& ctx) override { return newton_mode_ ? newton_.evaluate(ctx) : sweeps_->evaluate(ctx); }

  StepOutcome iterate(Context& ctx, long iteration) override {
    if (!newton_mode_ && ++since_check_ >= check_every) {
      since_check_ = 0;
      pardel::detail::eval_full(ctx, ctx.q);
      globalize_residual(local_, pardel::detail::compute_residual(ctx));
      ctx.action = global_sum_Ld(local_);
      ctx.action_known = true;
      newton_mode_ = newton_.hessian_positive_definite(ctx);
    }
    return newton_mode_ ? newton_.iterate(ctx, iteration) : sweeps_->iterate(ctx, iteration);
  }

  bool accept_stop(Context& ctx, bool final_level) override {
    return newton_mode_ ? newton_.accept_stop(ctx, final_level) : true;
  }
  void times_changed() override { newton_.times_changed(); }

  /** hybrid.cpp's layout: {phase (0 sweeps, 1 newton), sweeps since the last check, then
   *  Newton's state} (Newton's gathered on rank 0). Collective. */
  std::vector<double> save_state() const override {
    std::vector<double> state = {newton_mode_ ? 1.0 : 0.0, static_cast<double>(since_check_)};
    const std::vector<double> newton = newton_.save_state();
    state.insert(state.end(), newton.begin(), newton.end());
    return state;
  }
  bool load_state(const std::vector<double>& state) override {
    if (state.size() < 2 || (state[0] != 0 && state[0] != 1) || !(state[1] >= 0 && state[1] <= check_every))
      return false;
    if (!newton_.load_state(std::vector<double>(state.begin() + 2, state.end()))) return false;
    newton_mode_ = state[0] == 1;
    since_check_ = static_cast<int>(state[1]);
    return true;
  }

 private:
  static constexpr int check_every = 10;
  Local& local_;
  std::unique_ptr<pardel::detail::Method_> sweeps_;
  DistributedNewton<D> newton_;
  bool newton_mode_ = false;
  int since_check_ = 0;
};

/** The nodes of this rank: reductions, agreement on failures and the halo exchange over all ranks. */
class RankPartition final : public pardel::detail::Partition {
 public:
  explicit RankPartition(Local& local) : local_(local) {}
  void update_times(Context&, Positions positions) override { update_times_distributed(local_, positions); }
  int agree_on_residual(Context&, int local_bad) override { return globalize_residual(local_, local_bad); }
  /** Whether no rank's iterate failed; otherwise `outcome` becomes the failure of the lowest failing rank. */
  bool agree_on_outcome(StepOutcome& outcome) override {
    const Layout& L = local_.layout;
    const int failing = detail::min_all(outcome.ok() ? L.ranks : L.rank, local_.comm);
    if (failing == L.ranks) return true;
    int code = static_cast<int>(outcome.failure);
    MPI_Bcast(&code, 1, MPI_INT, failing, local_.comm);
    std::string message = outcome.message;
    if (L.rank == failing && L.has_left())
      message += " (node numbers of rank " + std::to_string(L.rank) + ", whose local node 0 is node " +
                 std::to_string(L.lo) + ")";
    detail::broadcast_text(message, failing, local_.comm);
    outcome.failure = static_cast<Termination>(code);
    outcome.message = message;
    return false;
  }

  void check_next(const Context& ctx, const StepOutcome&, int* node, double* qmax) override {
    const Layout& L = local_.layout;
    const std::size_t d = static_cast<std::size_t>(ctx.dim);
    int first = INT_MAX;
    double m = 0;
    for (int g = L.first; g <= L.last; ++g) {
      const double* v = ctx.q_next.data() + static_cast<std::size_t>(L.local(g)) * d;
      for (std::size_t i = 0; i < d; ++i) {
        if (!std::isfinite(v[i]) && first == INT_MAX) first = g;
        m = std::max(m, std::fabs(v[i]));
      }
    }
    double in[2] = {-static_cast<double>(first), m}, out[2] = {0, 0};
    MPI_Allreduce(in, out, 2, MPI_DOUBLE, MPI_MAX, local_.comm);
    first = static_cast<int>(-out[0]);
    *node = first == INT_MAX ? -1 : first;
    *qmax = out[1];
  }
  void iterate_changed(Context& ctx) override {
    detail::exchange_halos(local_.layout, ctx.q.data(), ctx.dim, local_.comm);
  }
  double action(Context& ctx) override { return global_action(local_, ctx.q); }
  bool all(bool yes) override { return detail::all_true(yes, local_.comm); }
  int global_N(const Context&) const override { return local_.layout.N; }
  double final_time(const Context& ctx) override {
    double t = ctx.t.back();  // t_N, held by the last rank
    MPI_Bcast(&t, 1, MPI_DOUBLE, local_.layout.ranks - 1, local_.comm);
    return t;
  }

 private:
  Local& local_;
};

/** The distributed solve: the shared iteration over this rank's nodes, at each level. */
class Driver : public pardel::detail::Iteration {
 public:
  Driver(const Options& options, pardel::detail::Method_& method, RankPartition& partition, Local& local,
         Summary& summary)
      : pardel::detail::Iteration(options, method, partition, local.ctx, summary), local_(local) {}

  /** Fills the summary's numbers (the same on every rank) and gathers the iterate of the current
   *  level on rank 0. */
  void write_result(Trajectory& out) {
    summarize();
    gather_trajectory(local_, false, out);
    s_.wall_seconds = seconds();
  }

  /** solve.cpp's resume_level over the ranks: this rank's context at the state's level from the
   *  state's iterate and node times (every rank holds the whole state, checked by check_state),
   *  its share of the method's state and every counter. False with `error` on every rank when
   *  the state does not fit on any. Collective. */
  bool resume_level(const Problem& problem, const SolverState& st, int ranks, int rank, std::string* error) {
    local_.layout = detail::make_layout(st.N, ranks, rank);
    const Layout& L = local_.layout;
    std::string message;
    if (!detail::all_true(setup_local(problem, st.N, s_.threads, st.trajectory, local_, &message), local_.comm)) {
      *error = "resume: " + message;
      return false;
    }
    std::copy(st.trajectory.t.begin() + L.lo, st.trajectory.t.begin() + L.hi + 1, ctx_.t.begin());
    if (problem.clock == ClockMode::fixed_total_time)
      for (std::size_t j = 0; j + 1 < ctx_.t.size(); ++j) ctx_.hk[j] = ctx_.t[j + 1] - ctx_.t[j];
    method_.reset(ctx_);
    if (!detail::all_true(method_.load_state(st.method_state), local_.comm)) {
      *error = pardel::detail::method_state_misfit(st);
      return false;
    }
    resume_counters(st);
    return true;
  }

  /** The state of the interrupted solve on rank 0, as one process captures it: the iterate and
   *  its node times (`result`, which write_result gathered there) and the method's state in node
   *  order; the other ranks' `st` stays empty. Collective. */
  void capture(SolverState& st, int level, const Trajectory& result) {
    std::vector<double> method_state = method_.save_state();
    if (local_.layout.rank != 0) return;
    capture_counters(st);
    st.level = level;
    st.N = result.N;
    st.trajectory = result;
    st.method_state = std::move(method_state);
  }

 private:
  Local& local_;
};

/** solve.cpp's check that the Lagrangian is regular (assessment.hpp lagrangian_regular) at the
 *  current iterate and node times of the ranks: made on rank 0 from the whole level gathered
 *  there (for the length of the check), its verdict and message sent to every rank. Collective. */
bool lagrangian_regular_over_ranks(const Local& local, std::string* message) {
  Trajectory whole;
  gather_trajectory(local, false, whole);
  int regular = 1;
  std::string text;
  if (local.layout.rank == 0) {
    // What lagrangian_regular reads: the model and discretization, the grid and its steps, the iterate.
    const Context& ctx = local.ctx;
    Context probe;
    probe.model = ctx.model;
    probe.disc = ctx.disc;
    probe.dim = ctx.dim;
    probe.ncoords = ctx.ncoords;
    probe.order = ctx.order;
    probe.params = ctx.params;
    probe.clock = ctx.clock;
    probe.t0 = ctx.t0;
    probe.T = ctx.T;
    probe.N = whole.N;
    probe.t = std::move(whole.t);
    probe.q = std::move(whole.q);
    probe.hk.assign(static_cast<std::size_t>(whole.N), ctx.T / whole.N);
    if (ctx.clock == ClockMode::fixed_total_time)
      for (std::size_t k = 0; k < probe.hk.size(); ++k) probe.hk[k] = probe.t[k + 1] - probe.t[k];
    regular = pardel::detail::lagrangian_regular(probe, &text) ? 1 : 0;
  }
  MPI_Bcast(&regular, 1, MPI_INT, 0, local.comm);
  if (regular) return true;
  detail::broadcast_text(text, 0, local.comm);
  *message = text;
  return false;
}

std::unique_ptr<pardel::detail::Method_> make_method(const Options& options, int dim, Local& local) {
  switch (options.method) {
    case Method::jacobi: return pardel::detail::make_jacobi(options, dim);
    case Method::jacobi_newton: return pardel::detail::make_jacobi_newton(options, dim);
    case Method::newton:
      return pardel::detail::dispatch_dim(dim, [&](auto D) -> std::unique_ptr<pardel::detail::Method_> {
        return std::make_unique<DistributedNewton<decltype(D)::value>>(options, local);
      });
    case Method::hybrid:
      return pardel::detail::dispatch_dim(dim, [&](auto D) -> std::unique_ptr<pardel::detail::Method_> {
        return std::make_unique<DistributedHybrid<decltype(D)::value>>(options, dim, local);
      });
    default: return nullptr;
  }
}

Summary solve_over_ranks(const Problem& problem, const Options& requested, Trajectory& trajectory, int ranks,
                         int rank) {
  const auto start = std::chrono::steady_clock::now();
  // The automatic method is Newton with grid sequencing, as in one process.
  const bool automatic = requested.method == Method::automatic;
  Summary summary;
  const Options options = pardel::detail::resolved_options(requested, problem, summary);
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  auto refuse = [&](std::string message) {
    summary.termination = Termination::invalid_input;
    summary.message = std::move(message);
    summary.wall_seconds = elapsed();
    return summary;
  };
  const SolverState* resume = options.resume_from;
  const SolverState* warm = resume && options.warm_start ? resume : nullptr;
  if (warm) resume = nullptr;
  std::string error;
  bool valid = distributed_supported(problem, options, ranks, &error) && options.is_valid(&error) &&
               (resume || warm || validate(problem, trajectory, &error));
  // The one-process levels (a state's level is an index into them); the solve starts at the first
  // on which every rank owns 3 nodes (the last one does).
  std::vector<int> levels;
  if (valid) levels = pardel::detail::refinement_levels(problem, options, automatic);
  const std::size_t first_fit = static_cast<std::size_t>(
      std::find_if(levels.begin(), levels.end(), [ranks](int n) { return fits_ranks(n, ranks); }) - levels.begin());
  if (valid && (resume || warm))
    valid = pardel::detail::check_state(problem, options, resume ? *resume : *warm, levels, &error);
  if (valid && resume && static_cast<std::size_t>(resume->level) < first_fit) {
    valid = false;
    error = "resume: refinement level " + std::to_string(resume->level) + " with N = " + std::to_string(resume->N) +
            " is too small for " + std::to_string(ranks) +
            " ranks: every rank needs at least 3 nodes (N + 1 >= 3 ranks); resume it on fewer ranks";
  }
  // Every rank was given the same input; agree anyway, so that no rank iterates alone.
  if (!detail::all_true(valid, MPI_COMM_WORLD)) return refuse(valid ? "invalid input on another rank" : error);
  Local local;
  local.comm = MPI_COMM_WORLD;
  std::unique_ptr<pardel::detail::Method_> method = make_method(options, problem.model->dim, local);
  RankPartition partition(local);
  Driver driver(options, *method, partition, local, summary);
  pardel::detail::LevelStarts starts(problem, options);
  if (resume) starts.previous() = resume->previous_level;
  Trajectory resampled;
  bool checked_regular = false;
  // Sets up this rank's context at the level of N intervals from `from`, a whole trajectory that
  // every rank holds (resampled to N when it lies on another grid), as solve.cpp's enter_level.
  auto enter_level = [&](const Trajectory& from, int N) {
    const Trajectory& src = from.N == N ? from : (resampled = resample(problem, from, N));
    local.layout = detail::make_layout(N, ranks, rank);
    const bool constrained = setup_local(problem, N, summary.threads, src, local, &error);
    if (!detail::all_true(constrained, MPI_COMM_WORLD)) return false;
    if (problem.clock != ClockMode::none) update_times_distributed(local, Positions::follow_times);
    if (!checked_regular) {
      checked_regular = true;
      if (!lagrangian_regular_over_ranks(local, &error)) return false;
    }
    method->reset(local.ctx);
    return true;
  };
  pardel::detail::LevelSteps steps;
  steps.resume = [&] { return driver.resume_level(problem, *resume, ranks, rank, &error); };
  steps.warm = [&](int N) {
    if (!enter_level(warm->trajectory, N)) return false;
    driver.continue_count(*warm);
    return true;
  };
  steps.enter = [&](int N) { return starts.enter(trajectory, N, enter_level); };
  steps.entered = [&](bool last) {
    resampled = Trajectory{};
    if (!last) return;
    // From here on a rank holds O(N / ranks) values; rank 0 keeps the previous level's solution
    // that an interruption's state carries for Newton's extrapolation, as in one process.
    std::vector<double>().swap(trajectory.q);
    std::vector<double>().swap(trajectory.t);
    Trajectory previous = std::move(starts.previous());
    starts.release();
    if (rank == 0 && starts.extrapolates()) starts.previous() = std::move(previous);
  };
  steps.run = [&](bool last) { return driver.run_level(last); };
  steps.settled = [&] {
    // The level's solution on every rank: the start of the next level.
    Trajectory solution;
    gather_trajectory(local, true, solution);
    starts.settled(std::move(solution));
  };
  const long l = pardel::detail::run_levels(levels, first_fit, resume, warm, steps);
  if (l < 0) return refuse(error);
  driver.write_result(trajectory);
  if (summary.termination == Termination::interrupted) {
    driver.capture(summary.state, static_cast<int>(l), trajectory);
    if (rank == 0 && starts.extrapolates()) summary.state.previous_level = starts.previous();
  }
  pardel::detail::note_stopped_level(problem, trajectory, summary);
  // What the returned point is; the method's storage is released first, as in one process.
  method.reset();
  if (pardel::detail::point_assessed(summary.termination))
    assess_distributed(options, local, summary.point);
  else
    summary.point = pardel::detail::not_assessed(summary.termination);
  if (warm) pardel::detail::note_warm_start(*warm, summary);
  pardel::detail::not_estimated(summary, options.error_estimate ? "the error estimate is made in one process only, "
                                                                  "not over MPI ranks"
                                                                : "switched off (error_estimate = false)");
  return summary;
}

}  // namespace

Summary solve_distributed(const Problem& problem, const Options& options, Trajectory& trajectory) {
  int initialized = 0;
  MPI_Initialized(&initialized);
  int ranks = 1, rank = 0;
  if (initialized) {
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  }
  if (ranks <= 1) return solve(problem, options, trajectory);
  if (options.device != Device::cpu) {
    Summary refused;
    refused.method = options.method;
    refused.N = problem.N;
    refused.message = std::string("device ") + to_string(options.device) + ": a solve over " + std::to_string(ranks) +
                      " MPI ranks runs on their CPU cores; solve on the device in one process";
    return refused;
  }
  try {
    return solve_over_ranks(problem, options, trajectory, ranks, rank);
  } catch (const std::exception& error) {
    // A rank that cannot go on must not leave the others waiting in a collective.
    std::fprintf(stderr, "pardel: rank %d: distributed solve failed: %s; aborting all ranks\n", rank, error.what());
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  return Summary{};
}

#endif  // PARDEL_HAVE_MPI

}  // namespace pardel::mpi
