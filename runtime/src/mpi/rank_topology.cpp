/**
 * @file rank_topology.cpp
 * The topology of a solve over MPI ranks (rank_topology.hpp): the reductions and agreements of the
 * iteration, and a level's context built from a whole trajectory on every rank, gathered back, and
 * assessed, over all ranks.
 */
#include "rank_topology.hpp"

#include <algorithm>
#include <climits>
#include <cmath>

#include "../assessment.hpp"
#include "distributed_newton.hpp"

namespace pardel::mpi::detail {

using pardel::detail::Positions;
using pardel::detail::StepOutcome;

RankTopology::RankTopology(MPI_Comm comm, int ranks, int rank) : ranks_(ranks), rank_(rank) { local_.comm = comm; }

void RankTopology::update_times(Context&, Positions positions) { update_times_distributed(local_, positions); }

int RankTopology::agree_on_residual(Context&, int local_bad) { return globalize_residual(local_, local_bad); }

/** Whether no rank's iterate failed; otherwise `outcome` becomes the failure of the lowest failing rank. */
bool RankTopology::agree_on_outcome(StepOutcome& outcome) {
  const Layout& L = local_.layout;
  const int failing = min_all(outcome.ok() ? L.ranks : L.rank, local_.comm);
  if (failing == L.ranks) return true;
  int code = static_cast<int>(outcome.failure);
  MPI_Bcast(&code, 1, MPI_INT, failing, local_.comm);
  std::string message = outcome.message;
  if (L.rank == failing && L.has_left())
    message += " (node numbers of rank " + std::to_string(L.rank) + ", whose local node 0 is node " +
               std::to_string(L.lo) + ")";
  broadcast_text(message, failing, local_.comm);
  outcome.failure = static_cast<Termination>(code);
  outcome.message = message;
  return false;
}

void RankTopology::check_next(const Context& ctx, const StepOutcome&, int* node, double* qmax) {
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

void RankTopology::iterate_changed(Context& ctx) { exchange_halos(local_.layout, ctx.q.data(), ctx.dim, local_.comm); }

double RankTopology::action(Context& ctx) { return global_action(local_, ctx.q); }

bool RankTopology::all(bool yes) { return all_true(yes, local_.comm); }

int RankTopology::global_N(const Context&) const { return local_.layout.N; }

double RankTopology::final_time(const Context& ctx) {
  double t = ctx.t.back();  // t_N, held by the last rank
  MPI_Bcast(&t, 1, MPI_DOUBLE, local_.layout.ranks - 1, local_.comm);
  return t;
}

std::string RankTopology::unsupported(const Problem& problem, const Options& options) const {
  std::string message;
  return distributed_supported(problem, options, ranks_, &message) ? std::string() : message;
}

std::string RankTopology::level_misfit() const {
  return " is too small for " + std::to_string(ranks_) +
         " ranks: every rank needs at least 3 nodes (N + 1 >= 3 ranks); resume it on fewer ranks";
}

std::string RankTopology::coarse_solve_refusal() const {
  return "over MPI ranks the estimate uses the solve's own grid levels only (a solve on a coarse grid of its "
         "own runs in one process)";
}

void RankTopology::share_estimate(Summary& summary) {
  const int root = 0;  // holds_result()
  double reals[4] = {summary.error_estimate, summary.error_observed_order, summary.error_seconds,
                     summary.error_time_estimate};
  int ints[4] = {summary.error_coarse_N, summary.error_reliable ? 1 : 0, summary.extrapolated ? 1 : 0,
                 static_cast<int>(summary.error_by_coordinate.size())};
  MPI_Bcast(reals, 4, MPI_DOUBLE, root, local_.comm);
  MPI_Bcast(ints, 4, MPI_INT, root, local_.comm);
  summary.error_estimate = reals[0];
  summary.error_observed_order = reals[1];
  summary.error_seconds = reals[2];
  summary.error_time_estimate = reals[3];
  summary.error_coarse_N = ints[0];
  summary.error_reliable = ints[1] != 0;
  summary.extrapolated = ints[2] != 0;
  summary.error_by_coordinate.resize(static_cast<std::size_t>(ints[3]));
  if (ints[3] > 0) MPI_Bcast(summary.error_by_coordinate.data(), ints[3], MPI_DOUBLE, root, local_.comm);
  broadcast_text(summary.error_note, root, local_.comm);
}

std::unique_ptr<pardel::detail::Method_> RankTopology::make_newton(const Options& options, int dim) {
  return make_distributed_newton(options, dim, local_);
}

/** None: its indefinite block factorization has no counterpart in the Schur-complement split
 *  (unsupported() refuses it). */
std::unique_ptr<pardel::detail::Method_> RankTopology::make_stationary_newton(const Options&, int) { return nullptr; }

bool RankTopology::set_up(const Problem& problem, int N, int threads, const Trajectory& from, std::string* message) {
  local_.layout = make_layout(N, ranks_, rank_);
  return all_true(setup_local(problem, N, threads, from, local_, message), local_.comm);
}

/** This rank's context at the state's level from the state's iterate and node times (every rank
 *  holds the whole state). */
bool RankTopology::set_up_resumed(const Problem& problem, const SolverState& st, int threads, std::string* message) {
  local_.layout = make_layout(st.N, ranks_, rank_);
  if (!all_true(setup_local(problem, st.N, threads, st.trajectory, local_, message), local_.comm)) return false;
  const Layout& L = local_.layout;
  Context& ctx = local_.ctx;
  std::copy(st.trajectory.t.begin() + L.lo, st.trajectory.t.begin() + L.hi + 1, ctx.t.begin());
  if (problem.clock == ClockMode::fixed_total_time) pardel::detail::steps_from_times(ctx);
  return true;
}

bool RankTopology::lagrangian_regular(const Problem& problem, std::string* message) {
  return lagrangian_regular_over_ranks(problem, local_, message);
}

void RankTopology::gather(bool everywhere, Trajectory& out) { gather_trajectory(local_, everywhere, out); }

/** Iterative refinement runs in one process only: over ranks a converged solution is returned as
 *  the iteration left it. */
void RankTopology::refine(const Options&, Summary&) {}

void RankTopology::assess(const Options& options, PointAssessment& out) { assess_distributed(options, local_, out); }

void RankTopology::interior_inertia(pardel::detail::Inertia& out) {
  out = pardel::detail::interior_inertia(local_.ctx, local_.layout.local(local_.layout.first_interval()),
                                         local_.owned_intervals());
  long counts[3] = {out.positive, out.negative, out.zero};
  MPI_Allreduce(MPI_IN_PLACE, counts, 3, MPI_LONG, MPI_SUM, local_.comm);
  out.positive = counts[0];
  out.negative = counts[1];
  out.zero = counts[2];
}

}  // namespace pardel::mpi::detail
