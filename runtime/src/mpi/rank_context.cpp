/**
 * @file rank_context.cpp
 * A rank's share of a solve over MPI ranks (rank_context.hpp): its local context set up from a
 * whole trajectory, the whole trajectory gathered back from the ranks, and the residual, the
 * action and the regularity check over all ranks.
 */
#include "rank_context.hpp"

#include <algorithm>
#include <limits>

#include "../assessment.hpp"

namespace pardel::mpi::detail {

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
  pardel::detail::place_end_points(problem, N, L.lo, L.hi, ctx.dim, ctx.q.data());
  // Constraints of the whole problem on the local nodes.
  local.global_free.assign(static_cast<std::size_t>(Nl + 1) * d, 1);
  if (!pardel::detail::constrain_nodes(problem, ctx, N, L.lo, L.hi, local.global_free.data(), ctx.q.data(), message))
    return false;
  // The local context: the whole pattern, with the halo nodes fixed (their values come from the neighbours).
  ctx.is_free = local.global_free;
  if (L.has_left()) std::fill(ctx.is_free.begin(), ctx.is_free.begin() + static_cast<std::ptrdiff_t>(d), 0);
  if (L.has_right()) std::fill(ctx.is_free.end() - static_cast<std::ptrdiff_t>(d), ctx.is_free.end(), 0);
  pardel::detail::count_free(ctx);
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
  ctx.residual_scale = out[3];
  double hq = 0;
  for (std::size_t i = 0; i < d; ++i) {
    ctx.comp_residual[i] = out[4 + i];
    ctx.comp_scale[i] = out[4 + d + i];
    ctx.comp_hq[i] = out[4 + 2 * d + i];
    hq = std::max(hq, ctx.comp_hq[i]);
  }
  // The floor of one process, 16 eps max scale + 2 eps max |H||q| (engine.cpp, jacobi.cpp), from
  // the global maxima: the ranks' own floors sum maxima that may lie on different ranks, and their
  // largest can fall below it (a measured floor, in out[1], stays).
  const double eps = std::numeric_limits<double>::epsilon();
  ctx.residual_floor = std::max(out[1], 16 * eps * out[3] + 2 * eps * hq);
  if (out[2] > -1e300) {
    ctx.residual = std::numeric_limits<double>::quiet_NaN();
    return static_cast<int>(-out[2]);
  }
  ctx.residual = out[0];
  return -1;
}


bool lagrangian_regular_over_ranks(const Problem& problem, const Local& local, std::string* message) {
  Trajectory whole;
  gather_trajectory(local, false, whole);
  int regular = 1;
  std::string text;
  if (local.layout.rank == 0) {
    // The one-process context of the whole level: its grid, node times and steps, and its iterate.
    Context probe;
    pardel::detail::setup_context(problem, whole.N, 1, probe);
    pardel::detail::take_times(problem, whole, probe);
    probe.q = std::move(whole.q);
    regular = pardel::detail::lagrangian_regular(probe, &text) ? 1 : 0;
  }
  MPI_Bcast(&regular, 1, MPI_INT, 0, local.comm);
  if (regular) return true;
  detail::broadcast_text(text, 0, local.comm);
  *message = text;
  return false;
}

}  // namespace pardel::mpi::detail
