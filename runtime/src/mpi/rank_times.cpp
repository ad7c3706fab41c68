/**
 * @file rank_times.cpp
 * Node times from the model's clock over MPI ranks (rank_context.hpp update_times_distributed):
 * prefix sums carried from rank to rank, and under fixed_total_time the nodes moved to their new
 * times through old nodes that the ranks exchange.
 */
#include <algorithm>
#include <limits>
#include <vector>

#include "rank_context.hpp"

namespace pardel::mpi::detail {
namespace {

using pardel::detail::Evaluated;
using pardel::detail::Positions;


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

}  // namespace


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
  double start_before = ctx.t[static_cast<std::size_t>(jf)];  // each interval's previous duration starts its step
  ctx.t[static_cast<std::size_t>(jf)] = carried[1];
  for (int j = jf; j < j_end; ++j) {
    const std::size_t jj = static_cast<std::size_t>(j);
    if (ctx.clock == ClockMode::free_final_time) {
      const double end_before = ctx.t[jj + 1];
      ctx.t[jj + 1] = ctx.t[jj] + pardel::detail::free_time_step(ctx, ctx.t[jj], q.data() + jj * d,
                                                                  q.data() + (jj + 1) * d, hs, end_before - start_before);
      start_before = end_before;
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
  ctx.action_known = false;
}

}  // namespace pardel::mpi::detail
