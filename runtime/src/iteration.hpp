/**
 * @file iteration.hpp
 * Internal: the iteration at one grid, written once for a solve in one process and for one over
 * MPI ranks. A Partition says where the unknowns live (the reductions, the agreement on failures
 * and the halo exchange of a topology, topology.hpp); Iteration runs a Method_ on it and ends it
 * by named stopping rules, each setting the summary's status and message.
 */
#ifndef PARDEL_RUNTIME_ITERATION_HPP
#define PARDEL_RUNTIME_ITERATION_HPP

#include <chrono>
#include <limits>
#include <string>
#include <vector>

#include "engine.hpp"

namespace pardel::detail {

/** What the iteration needs from where the unknowns live. The defaults are those of one process. */
class Partition {
 public:
  virtual ~Partition() = default;
  /** Recomputes the node times of ctx from the clock at ctx.q (engine.hpp update_times). */
  virtual void update_times(Context& ctx, Positions positions) = 0;
  /** From this process's first node with a non-finite residual (-1: none) after an evaluation:
   *  the lowest over all processes, with ctx.residual made the global one. */
  virtual int agree_on_residual(Context& ctx, int local_bad) {
    (void)ctx;
    return local_bad;
  }
  /** Whether every process's step succeeded; if not, `outcome` becomes the failure of the lowest
   *  failing one. */
  virtual bool agree_on_outcome(StepOutcome& outcome) { return outcome.ok(); }
  /** The first node with a non-finite value in ctx.q_next over all processes (-1: none) and the
   *  largest |value| there. */
  virtual void check_next(const Context& ctx, const StepOutcome& outcome, int* node, double* qmax) = 0;
  /** After ctx.q became the next iterate (the MPI partition exchanges halos). */
  virtual void iterate_changed(Context& ctx) { (void)ctx; }
  /** The discrete action at ctx.q over all processes. */
  virtual double action(Context& ctx) = 0;
  /** Whether every process answers yes. */
  virtual bool all(bool yes) { return yes; }
  /** The number of intervals of the whole grid (ctx.N is this process's). */
  virtual int global_N(const Context& ctx) const { return ctx.N; }
  /** t_N, the time of the grid's last node (the same on every process). */
  virtual double final_time(const Context& ctx) { return ctx.t.back(); }
  /** Iterative refinement of ctx.q (iterative_refinement.hpp) where the unknowns' placement has
   *  it, filling the summary's refinement fields; none by default. */
  virtual void refine(const Options& options, Summary& summary) {
    (void)options;
    (void)summary;
  }
};

/** The counters of one grid level (members so that an interruption can capture them). */
struct LevelCounters {
  long level_it = 0, since_clock = 0;
  double r_level0 = 0, r_checkpoint = std::numeric_limits<double>::infinity();
};

/**
 * Runs a method on one grid level until a stopping rule ends it. The counters are protected
 * members: the drivers that derive from it set up levels, resume, capture and write results.
 */
class Iteration {
 public:
  Iteration(const Options& options, Method_& method, Partition& partition, Context& ctx, Summary& summary)
      : options_(options), method_(method), partition_(partition), ctx_(ctx), s_(summary),
        start_(std::chrono::steady_clock::now()) {}
  virtual ~Iteration() = default;

  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

  /** Iterates at the current level. Returns true when an intermediate level has settled; on the
   *  last level (or on any failure) fills the summary's termination and returns false. */
  bool run_level(bool last);

  Context& context() { return ctx_; }
  long iterations() const { return iteration_; }
  /** Whether the current iterate is the one refined_at_round_off refined (no step since). */
  bool refined() const { return refinements_ > 0 && refined_iteration_ == iteration_; }
  /** What refined_at_round_off did ("" where it did not run or kept no correction), for the
   *  summary's refinement note once the solve has ended. */
  const std::string& refined_note() const { return refined_note_; }

  // An interrupted solve's state: its counters,
  // history and wall time into `st`; back from it to resume the level (every counter) or for a
  // warm start (the iteration count, the history and the wall time).
  void capture_counters(SolverState& st) const;
  /** The summary's numbers at the current iterate (the same on every process) and the history's
   *  record of it, then the wall time; the drivers add the trajectory. */
  void summarize();
  void resume_counters(const SolverState& st);
  void continue_count(const SolverState& st);

 protected:
  // The stopping rules, in the order they are tried; each returns true when it ends the level
  // (having set the summary or, on an intermediate level, settled it).
  bool converged_at_tolerance(bool last, double r, double target, bool* settled);
  bool intermediate_level_settled(bool last, double r, double target, bool* settled);
  bool answer_at_tolerance(bool last, double r, double target, bool* settled);
  bool stalled_at_round_off(double r, double target);
  bool refined_at_round_off(double r, double target);
  /** Iterative refinement once where Newton's step `outcome` stalled at the round-off level. */
  bool refined_after_stall(const StepOutcome& outcome);
  /** Iterative refinement from the current iterate during the solve (`where`: why, for the note);
   *  false where it made no correction. */
  bool refine_during(const std::string& where);
  bool times_unsettled(int unsettled, long since_best);
  bool times_stop_increasing();
  bool reached_max_iterations(double r, double target);
  bool diverged(double r);
  /** Ends the level on a method's failed step or a non-finite or exploding next iterate. */
  bool step_failed(const StepOutcome& outcome, bool last, double r, double target, bool* settled);
  bool non_finite_residual(int node);

  /** The residual that counts as converged at the current iterate (Options::rtol or tol). */
  double target_residual() const { return detail::target_residual(options_, ctx_); }
  /** The first component whose equations do not hold yet against its own target
   *  (detail::component_target), or -1 when every one holds. */
  int unresolved_component() const;
  /** Whether the DEL equations hold at the current iterate: the residual at most `target` and every
   *  component at most its own target. */
  bool at_target(double r, double target) const { return r <= target && unresolved_component() < 0; }
  /** Whether the relative test is met only because the iterate's terms grew: the residual is more
   *  than kGrowthFactor times the solve's first one and this level's first (and above round-off). Iterates that slide off
   *  along a direction where the action falls without bound (just past a conjugate point) grow
   *  faster than their residual; such a point is not called converged. */
  bool met_by_growth(double r) const;
  /** How far the iterate is from the test, max(r / target, max_i r_i / target_i): at most 1 when
   *  the equations hold; the stall rules watch it for progress. */
  double distance_to_target(double r, double target) const;
  /** ", component NAME's equations are resolved to X > its target Y" for an unresolved component. */
  std::string unresolved_note() const;
  /** Component i's target (detail::component_target) with its scale at the solve's start. */
  double component_target(int i) const;
  std::string converged_message(double r, double target) const;
  /** "; the round-off level was measured …" where a stall measured it (Context::comp_floor_measured). */
  std::string measured_note() const;
  bool should_record();
  bool record();
  void finish(Termination termination, std::string message);

  const Options& options_;
  Method_& method_;
  Partition& partition_;
  Context& ctx_;
  Summary& s_;
  std::chrono::steady_clock::time_point start_;
  LevelCounters level_;
  bool resumed_level_ = false;
  bool times_pending_ = false;  ///< under a clock: the times at the tolerance were unsettled, no step since
  long iteration_ = 0, next_record_ = 0;
  /** Per component: the size of its terms at the solve's first iterate (detail::component_target). */
  std::vector<double> start_scale_;
  /** Per component: the residual at the iterate the last step on this level started from (empty
   *  before the level's first step), which tells whether a component's residual still falls. */
  std::vector<double> previous_comp_residual_;
  double r_initial_ = 0, last_good_residual_ = 0;
  double best_residual_ = std::numeric_limits<double>::infinity();
  long best_iteration_ = 0;
  bool have_initial_ = false;
  /** refine_during's runs on this level, at most kMaxRefinements (a second one after Newton
   *  stalled again gained nothing on an order-3 model under galerkin_gauss(s=4) at N = 1000). */
  static constexpr int kMaxRefinements = 1;
  int refinements_ = 0;
  long refined_iteration_ = -1;  ///< the iteration count when it did
  std::string refined_note_;
};

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_ITERATION_HPP
