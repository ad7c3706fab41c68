/**
 * @file rank_topology.hpp
 * The topology of a solve over the MPI ranks of a communicator (topology.hpp): each rank holds a
 * contiguous share of the nodes plus one halo node per neighbour (rank_context.hpp); every
 * reduction and every decision is agreed over all ranks; the whole-system Newton is the
 * distributed one of distributed_newton.hpp.
 */
#ifndef PARDEL_RUNTIME_MPI_RANK_TOPOLOGY_HPP
#define PARDEL_RUNTIME_MPI_RANK_TOPOLOGY_HPP

#include <mpi.h>

#include "../topology.hpp"
#include "rank_context.hpp"

namespace pardel::mpi::detail {

/** Whether every one of `ranks` ranks owns at least 3 of the N + 1 nodes (distributed.cpp). */
bool fits_ranks(int N, int ranks);

class RankTopology final : public pardel::detail::Topology {
 public:
  RankTopology(MPI_Comm comm, int ranks, int rank);

  // Partition: reductions, agreement on failures and the halo exchange over all ranks
  void update_times(Context& ctx, pardel::detail::Positions positions) override;
  int agree_on_residual(Context& ctx, int local_bad) override;
  bool agree_on_outcome(pardel::detail::StepOutcome& outcome) override;
  void check_next(const Context& ctx, const pardel::detail::StepOutcome& outcome, int* node, double* qmax) override;
  void iterate_changed(Context& ctx) override;
  double action(Context& ctx) override;
  bool all(bool yes) override;
  int global_N(const Context& ctx) const override;
  double final_time(const Context& ctx) override;

  // Topology
  Context& context() override { return local_.ctx; }
  std::string unsupported(const Problem& problem, const Options& options) const override;
  bool level_fits(int N) const override { return fits_ranks(N, ranks_); }
  std::string level_misfit() const override;
  std::string coarse_solve_refusal() const override;
  void share_estimate(Summary& summary) override;
  std::unique_ptr<pardel::detail::Method_> make_newton(const Options& options, int dim) override;
  std::unique_ptr<pardel::detail::Method_> make_stationary_newton(const Options& options, int dim) override;
  bool set_up(const Problem& problem, int N, int threads, const Trajectory& from, std::string* message) override;
  bool set_up_resumed(const Problem& problem, const SolverState& st, int threads, std::string* message) override;
  bool lagrangian_regular(const Problem& problem, std::string* message) override;
  void gather(bool everywhere, Trajectory& out) override;
  bool holds_result() const override { return rank_ == 0; }
  bool releases_whole_trajectories() const override { return true; }
  void refine(const Options& options, Summary& summary) override;
  void assess(const Options& options, PointAssessment& out) override;
  void interior_inertia(pardel::detail::Inertia& out) override;

 private:
  Local local_;
  int ranks_, rank_;
};

}  // namespace pardel::mpi::detail

#endif  // PARDEL_RUNTIME_MPI_RANK_TOPOLOGY_HPP
