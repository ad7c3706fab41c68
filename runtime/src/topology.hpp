/**
 * @file topology.hpp
 * Internal: where the nodes of a solve live, as one object. The solve (solve.cpp: validation, the
 * levels, resume and capture, the result, the point assessment, the automatic method's second
 * attempt and the error estimate) and the method factory are written once over a Topology; a
 * topology builds each level's context from a whole trajectory, gathers the iterate back, makes
 * the reductions and agreements of the iteration (the Partition it is), builds the whole-system
 * Newton of its nodes and assesses the returned point. OneProcess (one_process.cpp): every node
 * in this process. The MPI ranks: mpi/rank_topology.hpp, a contiguous share of the nodes per rank.
 */
#ifndef PARDEL_RUNTIME_TOPOLOGY_HPP
#define PARDEL_RUNTIME_TOPOLOGY_HPP

#include <functional>
#include <memory>
#include <string>

#include "engine.hpp"
#include "iteration.hpp"

namespace pardel::detail {

struct Inertia;

/** Where the nodes of one solve live; made fresh for each solve (it owns the solve's context). */
class Topology : public Partition {
 public:
  /** The context of this process's nodes, on which the iteration runs. */
  virtual Context& context() = 0;

  // ---- what it can run
  /** Why this topology cannot run the problem with these options (empty: it can). */
  virtual std::string unsupported(const Problem& problem, const Options& options) const {
    (void)problem;
    (void)options;
    return {};
  }
  /** Whether a refinement level of N intervals fits (the solve starts at the first that does). */
  virtual bool level_fits(int N) const {
    (void)N;
    return true;
  }
  /** The end of a resumed state's refusal when its level does not fit: " is too small for ...". */
  virtual std::string level_misfit() const { return {}; }
  /** Why the error estimate makes no solve of its own over this topology (a coarse grid, a third
   *  level), empty where it does: the estimate is then made from the solve's own grid levels alone,
   *  on the process that holds the result, and shared (share_estimate). */
  virtual std::string coarse_solve_refusal() const { return {}; }
  /** The summary's error estimate (error_* and extrapolated) of the process that holds the result
   *  on every process. Collective. */
  virtual void share_estimate(Summary& summary) { (void)summary; }

  // ---- the methods that depend on where the unknowns live (make_method picks among them)
  /** The trust-region Newton over all unknowns of this topology. */
  virtual std::unique_ptr<Method_> make_newton(const Options& options, int dim) = 0;
  /** Newton on the DEL residual (stationary.cpp); null where unsupported() refuses it. */
  virtual std::unique_ptr<Method_> make_stationary_newton(const Options& options, int dim) = 0;

  // ---- the levels
  /** Levels up to N intervals allocate their arrays for N at once (where the topology can). */
  virtual void reserve(int N) { (void)N; }
  /** Builds the context of a level of N intervals from `from`, a whole trajectory on that grid
   *  that every process holds: its iterate with the problem's end points and knots, the
   *  constraints, and under a clock its node times where it has them. False (on every process)
   *  with `message` where the constraints do not fit the grid. Collective. */
  virtual bool set_up(const Problem& problem, int N, int threads, const Trajectory& from, std::string* message) = 0;
  /** The same at an interrupted solve's level from its state (checked by check_state): its
   *  iterate and its node times as they were. Collective. */
  virtual bool set_up_resumed(const Problem& problem, const SolverState& st, int threads, std::string* message) = 0;
  /** lagrangian_regular (assessment.hpp) at the context's iterate and node times over the whole
   *  grid, the same verdict and message on every process. Collective. */
  virtual bool lagrangian_regular(const Problem& problem, std::string* message) = 0;
  /** The whole iterate of the current level and its node times in `out`: on every process
   *  (`everywhere`) or on the one that holds the result alone (the others' `out` emptied).
   *  Collective. */
  virtual void gather(bool everywhere, Trajectory& out) = 0;
  /** Whether this process holds the solve's result (the gathered trajectory, a captured state). */
  virtual bool holds_result() const { return true; }
  /** Whether the whole trajectories (the guess, the previous levels' solutions) are released
   *  once the last level is entered, so that a process holds only its share while it iterates. */
  virtual bool releases_whole_trajectories() const { return false; }

  // ---- the converged point
  /** Iterative refinement of a converged solution (iterative_refinement.hpp), where the topology
   *  has it. */
  void refine(const Options& options, Summary& summary) override = 0;
  /** The point assessment at the context's iterate from a new factorization (the method's storage
   *  released before). Collective. */
  virtual void assess(const Options& options, PointAssessment& out) = 0;
  /** The inertia of the interior blocks of all intervals at the context's iterate (assessment.hpp's
   *  interior_inertia over this process's intervals, summed over processes). Collective. */
  virtual void interior_inertia(Inertia& out) = 0;
  /** The point assessment at the context's iterate with the Hessian in extended precision
   *  (extended_assessment.hpp), where the topology has it; false, `out` unchanged, elsewhere. */
  virtual bool assess_extended(PointAssessment&) { return false; }
};

/** Makes a fresh topology for each solve that pardel::solve makes (the attempts, the coarse solve
 *  of the error estimate). */
using TopologyFactory = std::function<std::unique_ptr<Topology>()>;

/** The method of options.method over `topology`: the Jacobi methods as they are, the Newton
 *  methods over its unknowns, hybrid from its Newton; null with `message` where there is none. */
std::unique_ptr<Method_> make_method(const Options& options, int dim, Topology& topology, std::string* message);

/** pardel::solve on the CPU cores over the topologies that `make` makes: the requested method
 *  (with the automatic method's second attempt), the point assessment and the error estimate. */
Summary solve_over(const Problem& problem, const Options& requested, Trajectory& trajectory,
                   const TopologyFactory& make);

/** The topology of a solve in one process: every node here. */
class OneProcess final : public Topology {
 public:
  // Partition
  void update_times(Context& ctx, Positions positions) override;
  void check_next(const Context& ctx, const StepOutcome& outcome, int* node, double* qmax) override;
  double action(Context& ctx) override;
  // Topology
  Context& context() override { return ctx_; }
  std::unique_ptr<Method_> make_newton(const Options& options, int dim) override;
  std::unique_ptr<Method_> make_stationary_newton(const Options& options, int dim) override;
  void reserve(int N) override { ctx_.reserve_N = N; }
  bool set_up(const Problem& problem, int N, int threads, const Trajectory& from, std::string* message) override;
  bool set_up_resumed(const Problem& problem, const SolverState& st, int threads, std::string* message) override;
  bool lagrangian_regular(const Problem& problem, std::string* message) override;
  void gather(bool everywhere, Trajectory& out) override;
  void refine(const Options& options, Summary& summary) override;
  void assess(const Options& options, PointAssessment& out) override;
  void interior_inertia(Inertia& out) override;
  bool assess_extended(PointAssessment& out) override;

 private:
  Context ctx_;
};

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_TOPOLOGY_HPP
