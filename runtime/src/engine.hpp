/**
 * @file engine.hpp
 * Internals shared by every solver method: the solve context (grid, node times, free components,
 * preallocated interval arrays), kernel evaluation over all intervals, the DEL residual, the
 * discrete action, node-time updates by the model's clock, and the interface a method implements.
 *
 * Array layout: nodes 0..N, node k at q[k*dim]; interval k = [k, k+1], k = 0..N-1, with its
 * derivatives at D1[k*dim], D11[k*dim*dim] (row-major, as in kernel_abi.h).
 */
#ifndef PARDEL_RUNTIME_ENGINE_HPP
#define PARDEL_RUNTIME_ENGINE_HPP

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <type_traits>
#include <string>
#include <vector>

#include "pardel/pardel.hpp"
#include "constants.hpp"

namespace pardel::detail {


/** Which kernel filled the interval arrays. */
enum class Evaluated { nothing, sweep, grad, full };

/** v.assign(n, value) in storage for at least `capacity` elements (allocated only when v has less),
 *  so that a later assign up to `capacity` reuses it. */
template <class V, class T>
void assign_within(V& v, std::size_t n, std::size_t capacity, const T& value) {
  if (v.capacity() < std::max(n, capacity)) {
    V fresh;
    fresh.reserve(std::max(n, capacity));
    v.swap(fresh);
  }
  v.assign(n, value);
}

/**
 * The grid of one level and what the problem fixes on it (Pinocchio's Model): the model and
 * discretization, sizes, params, node times and steps, and which components are unknowns. Built
 * by setup_grid (from a problem and N) and then apply_constraints; the solve reads it. Only the
 * node times change afterwards, and only under a clock (update_times, retiming).
 */
struct Grid {
  const pardel_model* model = nullptr;
  const pardel_discretization* disc = nullptr;
  int dim = 0, ncoords = 0, order = 1, N = 0;
  int threads = 1;
  /** The finest N this context will be set up for (nested iteration), 0 if none: its arrays, and
   *  the methods', are allocated for that size at once (see capacity()), so that each finer level
   *  reuses the memory, and the pages, of the coarser ones instead of allocating anew. */
  int reserve_N = 0;
  /** Capacity for an array of n elements at this N: n itself, or (reserve_N > N) at least the
   *  same array's size at reserve_N. */
  std::size_t capacity(std::size_t n) const {
    if (reserve_N <= N) return n;
    return (n / static_cast<std::size_t>(std::max(N - 1, 1)) + 1) * static_cast<std::size_t>(reserve_N + 1);
  }
  std::vector<double> params;
  ClockMode clock = ClockMode::none;
  double t0 = 0, T = 1;
  std::vector<double> t;   ///< N+1 node times
  std::vector<double> hk;  ///< N steps passed to the kernels (T/N, or t_{k+1}-t_k under fixed_total_time)
  std::vector<double> t_kept, hk_kept;  ///< t and hk before a clock update that checks convergence
  std::vector<unsigned char> is_free;  ///< (N+1)*dim: 1 where the component is an unknown
  std::vector<int> free_count;         ///< N+1: free components of each node
  long free_total = 0;

  bool parallel(int n) const { return threads > 1 && n >= kParallelMin; }
  double h(int k) const { return hk[static_cast<std::size_t>(k)]; }
  const double* p() const { return params.empty() ? nullptr : params.data(); }
};

/**
 * What a solve computes on a grid (Pinocchio's Data): the iterate, the interval arrays at it, the
 * DEL residual with its round-off level and per-component sizes, the action, and scratch. Sized
 * for its grid by setup_workspace; the interval arrays by the first evaluation that needs them.
 */
struct Workspace {
  std::vector<double> q;       ///< current iterate, (N+1)*dim
  std::vector<double> q_next;  ///< next iterate written by a method
  std::vector<double> q_old;   ///< the iterate before a re-placement of the nodes (fixed_total_time)

  // Interval arrays at q (which kernel filled them: `evaluated`).
  std::vector<double> Ld, D1, D2, D11, D12, D22;
  Evaluated evaluated = Evaluated::nothing;

  // Node residual r_k = D2(k-1) + D1(k) on free components (0 elsewhere), (N+1)*dim.
  std::vector<double> res;
  std::vector<double> node_scratch;  ///< N+1 scratch (the action's terms in a fixed-order sum, old node times)
  double residual = 0;             ///< infinity-norm of res
  /** Round-off level of the residual: 16 eps max_k (|D2(k-1)| + |D1(k)|), plus, when the Hessian
   *  blocks are at hand, 2 eps max_k |H_k| |q| (the rounding of the nodes seen through the Hessian,
   *  which dominates at small steps); a residual near it cannot be reduced in double precision. */
  double residual_floor = 0;
  /** Size of the terms that cancel in the residual, max_k (|D2(k-1)| + |D1(k)|) (relative tolerance). */
  double residual_scale = 0;
  /** Per component i (dim values each), over the nodes: the largest |r_{k,i}| (comp_residual), the
   *  size of its cancelling terms |D2_i(k-1)| + |D1_i(k)| (comp_scale) and its row of |H_k| |q|
   *  (comp_hq, full evaluations only). The relative test holds every component to its own scale,
   *  so that a coordinate whose terms are orders of magnitude smaller than another's is solved too. */
  std::vector<double> comp_residual, comp_scale, comp_hq;
  /** Per component, the round-off level of its residual as measured where Newton stalled (the
   *  largest change of the component's residual when the iterate moves by a few units in its last
   *  place; measured_round_off, trust_region.hpp), a lower bound of component_floor and
   *  residual_floor from then on; empty before. Evaluations that amplify rounding (the elimination
   *  of high-order Galerkin interior values) lie far above the level estimated from the terms. */
  std::vector<double> comp_floor_measured;
  double action = 0;
  bool action_known = false;     ///< whether `action` belongs to q
  /** Options::keep_going of the solve, polled by the point assessment (empty: never stopped). */
  std::function<bool()> keep_going;
};

/** A level's solve context: its grid and its workspace, which every method and kernel pass reads
 *  and writes together; functions that need only one of them take that part. */
struct Context : Grid, Workspace {
  double* node(std::vector<double>& v, int k) const { return v.data() + static_cast<std::size_t>(k) * dim; }
  const double* node(const std::vector<double>& v, int k) const {
    return v.data() + static_cast<std::size_t>(k) * dim;
  }
};

/** The grid of `problem` at N intervals: sizes, params, uniform node times (or Problem::times at
 *  its own N), every component free (apply_constraints fixes the constrained ones). */
void setup_grid(const Problem& problem, int N, int threads, Grid& grid);
/** The workspace sized for `grid`: iterate and residual arrays zero, interval arrays left for the
 *  first evaluation (kept allocated when a finer level, grid.reserve_N, will reuse them). */
void setup_workspace(const Grid& grid, Workspace& work);

/** Builds the context for `problem` at N intervals: setup_grid, then setup_workspace. */
void setup_context(const Problem& problem, int N, int threads, Context& ctx);
/** The interior node of knot `a` on a grid of N intervals, or -1 (with `message` naming the knot
 *  and the nearest nodes) when the knot's time is not on one. */
int knot_node(const Problem& problem, std::size_t a, int N, std::string* message);
/** The iteration of the history record after `iteration`: every `every` iterations while fewer
 *  than 1000 are recorded, then geometrically spaced (1 %) so that long runs keep a bounded history. */
inline long next_history_record(long iteration, long every, std::size_t recorded) {
  if (recorded < 1000) return (iteration / every + 1) * every;
  return std::max(iteration + every, static_cast<long>(std::ceil(iteration * 1.01)));
}
/** Marks knots and boundaries; `message` is set and false returned for a knot off the grid. */
bool apply_constraints(const Problem& problem, Context& ctx, std::string* message);
/** The constraints of the problem on the nodes lo..hi of its grid of N intervals (all of it in one
 *  process, a rank's nodes over MPI): in `free` (node layout from node lo, ctx.dim values a node,
 *  all 1 on entry) 0 on the fixed components, the end points and the knots' nodes (all of a node
 *  at order 1, its coordinates at order >= 2), and the knots' coordinates written into `q` (the
 *  same layout); false with `message` for a knot off the grid. */
bool constrain_nodes(const Problem& problem, const Grid& grid, int N, int lo, int hi, unsigned char* free, double* q,
                     std::string* message);
/** The problem's end points q0 and qN into `q`, the values of the nodes lo..hi of its grid of N
 *  intervals in node layout, `dim` values a node (where those nodes include node 0 or node N). */
void place_end_points(const Problem& problem, int N, int lo, int hi, int dim, double* q);
/** grid.free_count and grid.free_total from grid.is_free. */
void count_free(Grid& grid);
/** The steps grid.hk from the node times grid.t (a given grid, or the times of fixed_total_time's clock). */
void steps_from_times(Grid& grid);
/** The node times of `trajectory` into the grid where it has them for it, with the steps from
 *  them under fixed_total_time; whether it had them. */
bool take_times(const Problem& problem, const Trajectory& trajectory, Grid& grid);
/** A context for the problem at a given trajectory on its grid (its node times under a clock, or
 *  times from the clock when the trajectory has none); false with `error` for an invalid pair. */
bool context_at(const Problem& problem, const Trajectory& trajectory, int threads, Context& ctx, std::string* error);

/** Sizes the interval arrays that a kernel of `kind` fills (sweep: D1, D2, D11, D22; grad: Ld, D1, D2;
 *  full: all) for ctx.N; setup_context leaves them empty, so methods that never store interval
 *  derivatives (the fused Jacobi sweeps) do not pay for them. */
void ensure_interval_arrays(Context& ctx, Evaluated kind);
/** Evaluates a kernel on every interval at `q` into the context's arrays (parallel over k). */
void eval_sweep(Context& ctx, const std::vector<double>& q);
void eval_full(Context& ctx, const std::vector<double>& q);
void eval_grad(Context& ctx, const std::vector<double>& q);

/** Residual from the D1, D2 arrays evaluated at the iterate q (ctx.q or ctx.q_next): fills res, sets
 *  ctx.residual, its round-off level (with the Hessian term |H| |q| after a full evaluation) and
 *  the per-component maxima, and returns the first node whose residual is not finite (or -1). */
int compute_residual(Context& ctx, const std::vector<double>& q);
inline int compute_residual(Context& ctx) { return compute_residual(ctx, ctx.q); }
/** Fixed-order sum of the Ld array (filled by full or grad). */
double sum_action(const Context& ctx);
/** Discrete action at q through the action kernel (parallel evaluation, fixed-order sum). */
double action_at(Context& ctx, const std::vector<double>& q);

/** Whether the positions move with the node times when a clock places the nodes anew. */
enum class Positions {
  stay,          ///< each node keeps its values and takes the new time (the trajectory is given as is)
  follow_times,  ///< fixed_total_time: the trajectory in time is kept, interpolated at the new times
};

/** Recomputes node times (and kernel steps) from ctx.q with the model's clock; no-op without a
 *  clock. Under fixed_total_time with Positions::follow_times the interior nodes are moved to the
 *  new times (retime_nodes), so that a re-placement of the nodes changes the discretization of the
 *  trajectory and not the trajectory itself; under free_final_time a node is a point of the path
 *  parameter and keeps its values. */
void update_times(Context& ctx, Positions positions);

/** Whether free_time_step finds each interval's end time as a fixed point t1 = t0 + travel(t0, t1)
 *  (the discretization has a travel kernel and L or the clock depends on t), which may not exist
 *  or not be reached on a grid where the clock is positive. */
inline bool end_times_are_fixed_points(const Grid& ctx) {
  return ctx.disc && ctx.disc->travel && ctx.model->time_dependent;
}

/** The time that an interval from node values q0 to q1 takes under the free_final_time clock, with
 *  the parameter step hs, starting at time t0: the discretization's travel kernel
 *  (the clock integrated with its own interpolant and quadrature) where it has one, solved for the
 *  interval's end time by fixed-point iteration where L or the clock depends on t (with secant
 *  steps), started from `guess` (the interval's previous duration) where that is positive, else
 *  from the left rule (NaN where it does not settle in kTravelIterations); else the model's clock
 *  by the seed's left rule (first order). */
double free_time_step(const Grid& ctx, double t0, const double* q0, const double* q1, double hs, double guess);

/** Under the free_final_time clock: the largest change of a node time when the interior nodes move
 *  by `delta` (nodes 1..N-1, dim each: the solve's Newton correction), the times summed from t0 as
 *  update_times sums them; 0 under another clock mode or none. */
double time_shift(const Context& ctx, const std::vector<double>& delta);

/** Whether ctx's discrete problem is one of fixed node times: no clock, or the free_final_time
 *  clock of a model whose L and clock do not depend on t, where the node times only report the
 *  travel time (the kernels' step is the parameter's, whatever the times). Iterative refinement
 *  and the assessment in extended precision need it. */
inline bool times_outside_the_problem(const Context& ctx) {
  return ctx.clock == ClockMode::none || (ctx.clock == ClockMode::free_final_time && !ctx.model->time_dependent);
}

/** Old nodes j_first..j_last (global numbering on a grid of N intervals) of a trajectory: times
 *  t[j - j_first], values q[(j - j_first) * dim ...]. */
struct RetimeGrid {
  const double* t;
  const double* q;
  int j_first, j_last, N, dim, ncoords;
};

/** The trajectory through the old nodes at the times t_new[0 .. k_last - k_first] of new nodes
 *  k_first..k_last, written to q_new: cubic Hermite in time, with the stored first derivatives as
 *  slopes when the state holds them (order >= 2; the derivatives are the interpolant's derivative)
 *  and central differences of the old nodes otherwise. Each new time lies between the old ones of
 *  nodes j_first and j_last, and the old nodes given reach one node beyond the intervals used on
 *  each side (for the differences) unless at 0 or N. The same nodes give the same bits on any rank. */
void retime_nodes(const RetimeGrid& old, const double* t_new, int k_first, int k_last, double* q_new);

/** First node (0..N) with a non-finite value in q, or -1. */
int first_non_finite_node(const Context& ctx, const std::vector<double>& q);

/** What one iteration of a method reports. */
struct StepOutcome {
  Termination failure = Termination::converged;  ///< `converged` here means "no failure"
  std::string message;
  /** The context already holds the evaluation at q_next: the interval arrays, the residual (res,
   *  ctx.residual, its round-off level and per-component maxima, over all processes) and
   *  ctx.action, as evaluate() would set them; the driver does not evaluate the next iterate again. */
  bool next_evaluated = false;
  /** The method checked q_next itself (in the pass that wrote it): the driver takes these two
   *  instead of scanning q_next again. */
  bool next_checked = false;
  int next_non_finite_node = -1;  ///< first node of q_next with a non-finite value, or -1
  double next_max_abs = 0;        ///< max |q_next|
  bool ok() const { return failure == Termination::converged; }
};

/**
 * A solver method. The driver owns the loop: it calls evaluate() at the current iterate ctx.q
 * (which must leave ctx.residual and ctx.residual_floor set), decides convergence, then calls
 * iterate(), which writes the next iterate into ctx.q_next from ctx.q.
 */
class Method_ {
 public:
  virtual ~Method_() = default;
  /** Called whenever the context is (re)built (new N). */
  virtual void reset(Context& ctx) = 0;
  /** Called after the node times were recomputed from the clock: the action and the residual are
   *  those of a changed problem, so values remembered from before do not compare. */
  virtual void times_changed() {}
  /** Evaluates at ctx.q; returns the first node with a non-finite residual or -1. */
  virtual int evaluate(Context& ctx) = 0;
  virtual StepOutcome iterate(Context& ctx, long iteration) = 0;
  /** Called when the residual has reached the tolerance: false refuses to stop there (Newton at a
   *  saddle of the action, which it then leaves along negative curvature); true by default.
   *  `final_level` is false on a coarse level of nested iteration, whose answer only starts the
   *  next level: a method may then spare checks that the final level repeats. */
  virtual bool accept_stop(Context& ctx, bool final_level) {
    (void)ctx;
    (void)final_level;
    return true;
  }
  /** The assessment of ctx.q from a factorization the method already holds there (Newton's, made
   *  when it accepted to stop at a minimum); false, leaving `out` alone, when it holds none. */
  virtual bool assess(Context& ctx, PointAssessment& out) {
    (void)ctx;
    (void)out;
    return false;
  }
  /** Into delta (the unknowns of nodes 1..N-1, node after node), the Newton correction -H^-1 r at
   *  ctx.q from a factorization of the unshifted Hessian that the method holds there (Newton's,
   *  made when it accepted to stop at a minimum); false where it holds none. */
  virtual bool newton_correction(Context& ctx, std::vector<double>& delta) {
    (void)ctx;
    (void)delta;
    return false;
  }
  /** Seconds the method spent on its coarse levels preparing the point assessment (Newton's
   *  eigenvector estimates, LevelEigenvectors); counted in Summary::assessment_seconds. */
  virtual double level_assessment_seconds() const { return 0; }
  /** Whether the unshifted Hessian of the action at the full evaluation in ctx is positive
   *  definite, by the method's own factorization (the trust-region Newton of trust_region.hpp
   *  answers it, for the hybrid's switch); false for a method without one. */
  virtual bool hessian_positive_definite(const Context& ctx) {
    (void)ctx;
    return false;
  }
  /** The method's own state between two iterations (checkpoint and resume); none by default. */
  virtual std::vector<double> save_state() const { return {}; }
  /** Restores what save_state() returned, after reset(); false if it does not fit this method. */
  virtual bool load_state(const std::vector<double>& state) { return state.empty(); }
};

/** The methods, each in its own file; dim selects the fixed-size block specialization. */
std::unique_ptr<Method_> make_jacobi(const Options& options, int dim);
std::unique_ptr<Method_> make_jacobi_newton(const Options& options, int dim);
std::unique_ptr<Method_> make_newton(const Options& options, int dim);
/** Newton's method for one block size D of dispatch_dim; each size is its own translation unit
 *  (runtime/src/newton_block_size.cpp.in), so that the sizes compile in parallel. */
template <int D>
std::unique_ptr<Method_> make_newton_sized(const Options& options);
class Partition;
/** Jacobi-Newton sweeps, then `newton` (a whole-system Newton, which answers
 *  hessian_positive_definite) once the Hessian is positive definite; `partition` reduces the
 *  residual of its check over the processes (iteration.hpp). */
std::unique_ptr<Method_> make_hybrid(const Options& options, int dim, Partition& partition,
                                     std::unique_ptr<Method_> newton);
std::unique_ptr<Method_> make_stationary_newton(const Options& options, int dim);

/** A DEL residual at most this many times its round-off level (Context::residual_floor,
 *  Summary::residual_floor) is at round-off: no iteration in double precision makes it smaller. */
constexpr double kRoundOffResidual = 10;
inline bool at_round_off(double residual, double residual_floor) {
  return residual <= kRoundOffResidual * residual_floor;
}

/** The residual that counts as converged at the context's iterate: Options::tol when set, else
 *  max(rtol x residual_scale, 10 x residual_floor). */
inline double target_residual(const Options& options, const Context& ctx) {
  if (options.tol > 0) return options.tol;
  return std::max(options.rtol * ctx.residual_scale, kRoundOffResidual * ctx.residual_floor);
}

/** Component i's name for messages: its coordinate, with a prime per derivative (order > 1). */
inline std::string component_name(const Context& ctx, int i) {
  const int nc = ctx.ncoords > 0 ? ctx.ncoords : std::max(ctx.dim, 1);
  const int c = i % nc, derivative = i / nc;
  std::string name = ctx.model && ctx.model->coords && c < ctx.model->ncoords ? std::string(ctx.model->coords[c])
                                                                               : std::to_string(i);
  return name + std::string(static_cast<std::size_t>(derivative), '\'');
}

/** Component i's round-off level: 16 eps of its terms plus 2 eps of its row of |H| |q|. */
inline double component_floor(const Context& ctx, int i) {
  const std::size_t ii = static_cast<std::size_t>(i);
  const double eps = std::numeric_limits<double>::epsilon();
  const double estimated = 16 * eps * ctx.comp_scale[ii] + 2 * eps * ctx.comp_hq[ii];
  return ctx.comp_floor_measured.empty() ? estimated : std::max(estimated, ctx.comp_floor_measured[ii]);
}

/** The name of the first component whose residual lies far above its own round-off level while the
 *  whole residual is at the largest terms' (at_round_off, not residual_at_round_off); empty where
 *  there is none. */
inline std::string unsolved_component(const Context& ctx) {
  if (!at_round_off(ctx.residual, ctx.residual_floor)) return {};
  const std::size_t d = static_cast<std::size_t>(ctx.dim);
  if (ctx.comp_residual.size() != d || ctx.comp_scale.size() != d || ctx.comp_hq.size() != d) return {};
  for (std::size_t i = 0; i < d; ++i)
    if (!(ctx.comp_residual[i] <= kRoundOffResidual * component_floor(ctx, static_cast<int>(i))))
      return component_name(ctx, static_cast<int>(i));
  return {};
}

/** The end of a stall's message where `component` (unsolved_component) is unsolved below the
 *  largest terms' rounding: why the method could not see its steps (`measure`: what it judges them
 *  by) and what may reach it. */
inline std::string unsolved_component_note(const std::string& component, const char* measure) {
  return "far above that of component " + component + ", whose terms are too small against the others' for " +
         measure + " to show its steps: Jacobi-Newton (solver.method = \"jacobi-newton\"), whose node steps are in "
         "each coordinate's own units, or coordinates in comparable units may reach the solution";
}

/** Whether the residual is at the round-off level in every component (component_floor), not only
 *  against the largest terms (at_round_off): a coordinate whose terms are 1e-14 of another's has an
 *  unsolved residual far below the other's rounding. The overall test alone where the
 *  per-component sizes are not known. */
inline bool residual_at_round_off(const Context& ctx) {
  return at_round_off(ctx.residual, ctx.residual_floor) && unsolved_component(ctx).empty();
}

/**
 * The residual that counts as resolved for component i at the context's iterate: Options::tol when
 * set; else max(rtol x the component's own scale, 10 x its round-off level, 10 x the round-off level
 * of its terms at the solve's start (`start_scale`, the size of the component's terms at the first
 * iterate: a component whose terms vanish at the solution, a coordinate at rest, has no scale of its
 * own there; its residual is then resolved once it is below the rounding of what it was). The
 * caller passes start_scale = 0 where that last term does not apply (Iteration: unless the
 * component's residual has stopped falling).
 */
inline double component_target(const Options& options, const Context& ctx, int i, double start_scale) {
  if (options.tol > 0) return options.tol;
  const double eps = std::numeric_limits<double>::epsilon();
  return std::max({options.rtol * ctx.comp_scale[static_cast<std::size_t>(i)], 10 * component_floor(ctx, i),
                   160 * eps * start_scale});
}

/** The largest over the smallest |diagonal entry| of the Hessian over the free components at ctx's
 *  full evaluation (1 where there is none, or a zero): how far apart the coordinates' units are. */
double diagonal_spread(const Context& ctx);

/** Number of threads to use for Options::threads (0: all cores). */
int resolve_threads(int requested);

/** Calls f with an integral constant D in {1,2,4,6} equal to dim (the sizes of the bundled models),
 *  or Eigen::Dynamic (-1) for other sizes; each fixed size is one more instantiation to compile.
 *  runtime/CMakeLists.txt lists the same sizes for Newton's per-size sources. */
template <class F>
auto dispatch_dim(int dim, F&& f) {
  switch (dim) {
    case 1: return f(std::integral_constant<int, 1>{});
    case 2: return f(std::integral_constant<int, 2>{});
    case 4: return f(std::integral_constant<int, 4>{});
    case 6: return f(std::integral_constant<int, 6>{});
    default: return f(std::integral_constant<int, -1>{});
  }
}

/** dispatch_dim for code that runs once per solve or on request, not per iteration (the assessment
 *  of a point that no Newton factorization serves): calls f with Eigen::Dynamic (-1) for every dim,
 *  one instantiation to compile instead of five. Blocks of a dynamic size cost more per block
 *  operation than fixed ones, so a solver's iteration keeps dispatch_dim (docs/benchmarks.md,
 *  "A fast first build"). */
template <class F>
auto dispatch_dim_cold(int /*dim*/, F&& f) {
  return f(std::integral_constant<int, -1>{});
}

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_ENGINE_HPP
