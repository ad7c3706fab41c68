/**
 * @file pardel.hpp
 * The public C++ API of the pardel runtime: problems, options, solvers, summaries and the
 * convergence certificate for the discrete Euler-Lagrange boundary-value problem
 *   D2 Ld(q_{k-1}, q_k) + D1 Ld(q_k, q_{k+1}) = 0,  k = 1..N-1,  q_0 and q_N fixed,
 * where each q_k is a point of T^(order-1)Q and Ld is a generated kernel (kernel_abi.h).
 */
#ifndef PARDEL_PARDEL_HPP
#define PARDEL_PARDEL_HPP

#include <functional>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "pardel/kernel_abi.h"

namespace pardel {

// ---------------------------------------------------------------------------------------------
// Models

/** Every model linked into this binary through the bundled registry (empty if none linked). */
const std::vector<const pardel_model*>& bundled_models();
/** Their names, in the same order. */
std::vector<std::string> bundled_model_names();
/** The bundled model of that name, or nullptr. */
const pardel_model* find_model(std::string_view name);
/**
 * The discretization of that name ("trapezoid", "trapezoid(alpha=1)", "hermite_gauss(s=3)", ...),
 * or nullptr. Names are compared in canonical form, so any spelling pardel-gen accepts in a .lag
 * finds the discretization it generated: spaces do not matter, a parameter may be written as a
 * decimal or a fraction ("trapezoid(alpha=0.7)" finds "trapezoid(alpha=7/10)"), and a bare
 * name finds the discretization whose pardel_discretization::bare_name it is (its family's
 * default parameter for the model's order, as the .lag reader gives a bare name).
 */
const pardel_discretization* find_discretization(const pardel_model& model, std::string_view name);

// ---------------------------------------------------------------------------------------------
// Problems

/** How node times are obtained. */
enum class ClockMode {
  none,              ///< t_k = t0 + k*T/N (h = T/N)
  free_final_time,   ///< h = T/N is the step of the path parameter s; t_{k+1} = t_k + clock_k; the
                     ///< travel time t_N is an output (Zermelo with time-varying wind)
  fixed_total_time,  ///< Sundman adaptive step: t_{k+1} - t_k proportional to clock_k, summing to T
};
const char* to_string(ClockMode mode);
/** Parses "none", "free_final_time", "fixed_total_time"; false if unknown. */
bool parse_clock_mode(std::string_view text, ClockMode* mode);
/** Every clock mode's name, in the order of the enum. */
std::vector<std::string> clock_mode_names();

/** An interpolation constraint (knot): q(t) = q at a grid node; only derivatives move there. */
struct Knot {
  double t = 0;
  std::vector<double> q;  ///< ncoords values
};

/** One boundary-value problem. */
struct Problem {
  const pardel_model* model = nullptr;
  const pardel_discretization* discretization = nullptr;
  std::vector<double> params;  ///< nparams values (model defaults when empty)
  double t0 = 0;
  double T = 1;                ///< final time minus t0 (or the span of s under free_final_time)
  int N = 100;                 ///< number of intervals; nodes 0..N
  std::vector<double> q0;      ///< dim values: coords, then derivatives up to order-1
  std::vector<double> qN;      ///< dim values
  std::vector<Knot> knots;
  ClockMode clock = ClockMode::none;
  /** The node times of a non-uniform grid: N+1 strictly increasing values from t0 to t0 + T (the
   *  step of interval k is times[k+1] - times[k]); empty: the uniform grid t_k = t0 + k T/N. Only
   *  without a clock; knots must lie on nodes; the solve then uses that one grid (no grid levels).
   *  Options::accuracy chooses such grids. */
  std::vector<double> times;
};

/** The index of the model's param of that name (declaration order, as Problem::params), or -1. */
int find_param(const pardel_model& model, std::string_view name);
/**
 * Params by name: the model's defaults in declaration order, with those named in `values`
 * replaced, written to *params (for Problem::params). A name the model does not declare is an
 * error: returns false, *params untouched and *error (when given) naming it and the model's params.
 */
bool params_by_name(const pardel_model& model, const std::map<std::string, double>& values,
                    std::vector<double>* params, std::string* error = nullptr);

/** A discrete trajectory: node times and points of T^(order-1)Q, row-major (N+1) x dim. */
struct Trajectory {
  int N = 0;
  int dim = 0;
  std::vector<double> t;  ///< N+1 node times
  std::vector<double> q;  ///< (N+1)*dim values
  double* node(int k) { return q.data() + static_cast<std::size_t>(k) * dim; }
  const double* node(int k) const { return q.data() + static_cast<std::size_t>(k) * dim; }
};

/** The straight line from q0 to qN (derivative components interpolated too). */
Trajectory linear_guess(const Problem& problem);
/** A polyline through the given coordinate points (ncoords each), first and last replaced by
 *  the boundary; derivatives consistent with the polyline's parametrization by node index. */
Trajectory polyline_guess(const Problem& problem, const std::vector<std::vector<double>>& points);
/** A trajectory resampled onto N intervals by interpolation (coarse-to-fine refinement). */
Trajectory resample(const Problem& problem, const Trajectory& from, int N);

// ---------------------------------------------------------------------------------------------
// Solving

enum class Method {
  automatic,      ///< "auto", the default: newton, with grid sequencing (nested iteration) for large N
  jacobi,         ///< nonlinear block Jacobi (seed eq. pDEL), each block by Newton to a tolerance
  jacobi_newton,  ///< the seed's m-step block Jacobi-Newton (eq. NewtonRaphson)
  newton,         ///< globalized Newton on the whole DEL system, block-tridiagonal solves
  hybrid,         ///< Jacobi-Newton until the certificate holds, then Newton
  stationary_newton,  ///< Newton globalized on the DEL residual: converges to saddles of the action too
};
const char* to_string(Method method);
/** Parses "auto", "jacobi", "jacobi-newton", "newton", "hybrid", "stationary-newton"; false if unknown. */
bool parse_method(std::string_view text, Method* method);
/** Every method's name, in the order of the enum. */
std::vector<std::string> method_names();

/** How Newton-type methods solve the block-tridiagonal systems. */
enum class LinearSolver {
  block_ldlt,        ///< block LDL^T (block Thomas), O(N) sequential
  cyclic_reduction,  ///< block cyclic reduction, O(N) work, O(log N) parallel depth
};
const char* to_string(LinearSolver solver);
/** Parses "ldlt", "cyclic-reduction"; false if unknown. */
bool parse_linear_solver(std::string_view text, LinearSolver* solver);
/** Every linear solver's name, in the order of the enum. */
std::vector<std::string> linear_solver_names();

/** Where solve() and solve_batch() run (Options::device). */
enum class Device {
  cpu,   ///< the host's cores (OpenMP)
  cuda,  ///< an NVIDIA GPU: solve_batch_cuda (pardel/cuda.hpp), in a program that linked pardel::cuda
         ///< and called enable_cuda(); jacobi, jacobi-newton, newton and auto (newton) on one grid (docs/gpu.md)
};
const char* to_string(Device device);
/** Parses "cpu", "cuda"; false if unknown. */
bool parse_device(std::string_view text, Device* device);
/** Every device's name, in the order of the enum. */
std::vector<std::string> device_names();

/** The metric M of Newton's trust region |s|_M <= Delta (and of the shift H + lambda M). */
enum class NewtonShift {
  identity,    ///< M = I
  difference,  ///< M = tridiag(-1, 2, -1) per component (the default): the shape of the kinetic part
               ///< of these Hessians, |s|_M^2 = sum_k |s_{k+1} - s_k|^2, so every wavelength is
               ///< treated alike and the iteration count does not grow with N
};
const char* to_string(NewtonShift shift);
/** Parses "identity", "difference"; false if unknown. */
bool parse_newton_shift(std::string_view text, NewtonShift* shift);
/** Every trust-region metric's name, in the order of the enum. */
std::vector<std::string> newton_shift_names();

/** Iterative refinement of a converged solution with the DEL residual evaluated in extended
 *  precision (Options::iterative_refinement; docs/solvers.md, "Iterative refinement"). */
enum class Refinement {
  automatic,  ///< "auto": for models of order >= 2 whose discretization has the extended kernel,
              ///< computes the first correction and refines only when it is above the rounding of
              ///< the nodes (1000 eps max|q|): round-off of the double residual matters
  on,         ///< refine wherever the extended kernel exists, whatever the first correction
  off         ///< never
};
const char* to_string(Refinement refinement);
/** Parses "auto", "on", "off"; false if unknown. */
bool parse_refinement(std::string_view text, Refinement* refinement);
/** Every refinement mode's name, in the order of the enum. */
std::vector<std::string> refinement_names();

enum class Termination {
  converged,
  max_iterations,
  diverged,
  non_finite,
  invalid_input,
  interrupted,
  stalled,  ///< no further progress with the residual at the round-off level of the problem (tol unattainable)
};
const char* to_string(Termination termination);

/** One record of the convergence history. */
struct IterationRecord {
  long iteration = 0;
  int N = 0;
  double residual = 0;  ///< infinity-norm of the DEL residual
  double action = 0;    ///< discrete action
  double seconds = 0;   ///< wall time since the start of the solve
};

/**
 * Where a solve stood when it was interrupted: everything needed to continue it with the same
 * iterates (checkpoint and resume). Summary::state holds it after a solve that ended
 * `interrupted`; Options::resume_from passes it back, with the same problem and options, to a
 * solve that then continues as if it had never stopped (bit for bit: same iterates, same
 * decisions, the history continued).
 */
struct SolverState {
  static constexpr int kFormatVersion = 1;  ///< of this layout (checkpoint files record it)
  bool valid = false;          ///< false: nothing captured
  Method method = Method::jacobi_newton;
  int level = 0;               ///< index of the coarse-to-fine level (0 without refinement)
  int N = 0;                   ///< grid size of that level
  long iteration = 0;          ///< iterations done in all; `trajectory` is this iterate
  long level_iteration = 0;    ///< iterations done at this level
  long since_clock_update = 0; ///< iterations since the node times were last updated
  long next_record = 0;        ///< iteration of the next history record
  long best_iteration = 0;     ///< when best_residual was reached (stall detection)
  bool have_initial_residual = false;
  double initial_residual = 0;          ///< of the first iterate (divergence detection)
  double last_good_residual = 0;
  double best_residual = 0;             ///< smallest residual so far (by 1% steps)
  double level_initial_residual = 0;    ///< first residual at this level
  double level_checkpoint_residual = 0; ///< residual at the last 50-iteration stagnation check
  double seconds = 0;                   ///< wall time used before the interruption
  Trajectory trajectory;       ///< the iterate at N with its node times
  std::vector<double> method_state;     ///< the method's own (newton: its trust region; hybrid: its
                                        ///< phase and Newton's state); jacobi methods none
  std::vector<IterationRecord> history; ///< the history recorded so far
  /** Per component, the size of its terms at the solve's first iterate (the convergence test's
   *  reference for a component at rest; empty: taken from the resumed iterate). */
  std::vector<double> component_start_scale;
  /** Per component, the residual at the iterate the last step started from (empty: no step on this
   *  level yet), which tells the convergence test whether a component's residual still falls. */
  std::vector<double> component_previous_residual;
  /** newton with refinement: the solution of the level before `level` (N = 0: none), which with
   *  this level's solution extrapolates the start of the next level. */
  Trajectory previous_level;
};

struct Options {
  Method method = Method::automatic;
  /** Convergence: the infinity-norm of the DEL residual at most max(rtol * scale, 10 * floor), with
   *  scale = max_k (|D2 Ld(k-1)| + |D1 Ld(k)|) the size of the terms that cancel in it and floor its
   *  round-off level (Summary::residual_floor); or, when tol > 0, at most the absolute tol. */
  double rtol = 1e-10;
  double tol = 0;                ///< absolute tolerance (0: the relative test above)
  long max_iterations = 1000000;
  double damping = 0;            ///< epsilon: q <- q + (1 - epsilon)(qbar - q)
  int newton_substeps = 1;       ///< m of the m-step Jacobi-Newton
  int threads = 0;               ///< 0: all cores
  int refine_start_N = 0;        ///< coarse-to-fine: start at this N (0: off; auto keeps its own levels)
  double refine_factor = 1.2;    ///< growth of N per refinement
  int clock_update_every = 100;  ///< iterations between node-time updates under a clock
  long history_every = 1;        ///< record the history every this many iterations
  LinearSolver linear_solver = LinearSolver::block_ldlt;  ///< newton and hybrid
  Device device = Device::cpu;  ///< where the solve runs (Device::cuda: see Device)
  NewtonShift newton_shift = NewtonShift::difference;     ///< newton and hybrid: trust-region metric
  double refine_settle = 1e-3;   ///< a coarse level is settled when its residual fell by this factor
  double divergence_factor = 1e8;  ///< diverged when the residual exceeds this times the initial one
  /** Called after each recorded iteration; returning false interrupts the solve. */
  std::function<bool(const IterationRecord&)> on_iteration;
  /** Polled between the block solves of a converged solve's point assessment (in one process),
   *  which records no iteration: returning false stops it at once, and the point is reported not
   *  assessed (an interruption that arrives after convergence). */
  std::function<bool()> keep_going;
  /** Continue an interrupted solve from this state (Summary::state of that solve) instead of from
   *  the trajectory passed to solve(); problem and options must be those of the interrupted solve. */
  const SolverState* resume_from = nullptr;
  /** With resume_from: a warm start instead. The solve starts from the state's iterate (resampled
   *  to the first level of these options at or above its N) with these options, whatever their
   *  method; the iteration count and the history continue, the method's own state and the
   *  stopping rules' memory start afresh (not bit for bit), and Summary::message says so. */
  bool warm_start = false;
  /** After a converged solve: estimate the discretization error at the nodes by Richardson's rule
   *  from a second solve on the grid of every other node, or from a coarser nested grid level the
   *  solve already has (Summary::error_estimate; docs/solvers.md, "Error estimate"). */
  bool error_estimate = true;
  /** With error_estimate, and where it was estimated: return the Richardson-extrapolated node values
   *  (the discrete solution plus the estimated error) instead of the discrete solution; the summary's
   *  residual, action and point still describe the discrete solution. */
  bool extrapolate = false;
  /** Adaptive grid: when > 0, the requested bound on the estimated error of the coordinates at the
   *  nodes (Summary::error_estimate). The solve starts on problem's grid, then places nodes to
   *  equidistribute the local error indicated by the coarse grid's residual at the solution, and
   *  chooses N from the estimate and the discretization's order, until the estimate is at or below
   *  `accuracy` or N would exceed accuracy_max_N (docs/solvers.md, "Adaptive grids"). 0: the
   *  problem's grid only. One process only (not over MPI ranks), no clock. */
  double accuracy = 0;
  int accuracy_max_N = 1 << 20;  ///< the largest N an adaptive solve may use
  /** After a converged solve in one process: iterative refinement with the DEL residual evaluated
   *  by the discretization's extended-precision kernel (pardel_discretization::grad_extended) and
   *  the Hessian at the solution, which removes the round-off error that grows like eps N^(2 order);
   *  where that double Hessian is too ill-conditioned, Newton corrections with the Hessian in
   *  quadruple precision (pardel_discretization::full_extended, models of order >= 2)
   *  (Summary::refinement_note says whether it ran and what it changed). Not over MPI ranks. */
  Refinement iterative_refinement = Refinement::automatic;
  /** Checks the options against their bounds (option_bound); on failure writes a message naming
   *  the option, its value and the rule it breaks. */
  bool is_valid(std::string* error) const;
};

/**
 * The valid range of one numeric member of Options, stated once: Options::is_valid checks each
 * member against it, and front ends (the scene reader, the command line) check their keys against
 * the same bound and report the same rule. A value is valid when it lies between `low` and `high`
 * (each end included or not, as the flags say; NaN never), or is 0 where `zero_allowed`.
 */
struct OptionBound {
  const char* name;     ///< the member of Options, e.g. "refine_factor"
  double low;           ///< lower end (-infinity: none)
  bool low_included;
  double high;          ///< upper end (+infinity: none)
  bool high_included;
  bool zero_allowed;    ///< 0 is valid too, outside [low, high] (refine_start_N: 0 is off)
  const char* rule;     ///< the bound in words, as a predicate: "must be in (1, 16]"
  bool accepts(double value) const;
};
/** The bound of the numeric member of Options of that name ("tol", "threads", ...); nullptr for
 *  any other name (the enumerations method, linear_solver and newton_shift have none). */
const OptionBound* option_bound(std::string_view name);

/** Verdicts of the seed's convergence theory at one trajectory. */
struct IntervalViolation {
  int k = 0;                   ///< interval [k, k+1]
  bool hessian_psd = true;     ///< H^{Ld}_k positive semi-definite
  bool A_pd = true;            ///< A_k = D11 positive definite
  bool B_pd = true;            ///< B_k = D22 positive definite
  double min_eig_hessian = 0, min_eig_A = 0, min_eig_B = 0;
};

struct Certificate {
  // The seed's sufficient condition for a positive definite Hessian, interval by interval
  bool all_intervals_psd = false;
  bool all_A_pd = false;
  bool all_B_pd = false;
  bool theorem_holds = false;  ///< all psd and (all A pd or all B pd)
  std::vector<IntervalViolation> violations;
  // Inertia of the full block-tridiagonal Hessian (block LDL^T, Sylvester's law)
  long inertia_positive = 0, inertia_negative = 0, inertia_zero = 0;
  bool hessian_positive_definite = false;
  // Jacobi iteration matrix J = -D^{-1} C
  double jacobi_spectral_radius = 0;
  /** 1 - rho, computed directly (the smallest eigenvalue of D^{-1/2} H D^{-1/2}, by inverse
   *  iteration) where H + 2^-12 D is positive definite, not as 1 - jacobi_spectral_radius, whose
   *  digits cancel when rho is near 1; elsewhere 1 - rho from the Lanczos or power estimate */
  double jacobi_one_minus_rho = 0;
  /** round-off level of jacobi_one_minus_rho (0 where it was not computed directly) */
  double jacobi_one_minus_rho_roundoff = 0;
  /** false when |1 - rho| is at or below its round-off level: rho is 1 to within double precision,
   *  and expected_iterations is then a lower bound */
  bool spectral_radius_resolved = false;
  double expected_iterations = 0;  ///< sweeps to reduce the residual by tol/initial residual
  bool spectral_radius_converged = false;  ///< the estimate settled (else a lower bound on rho)
  long intervals_violating = 0;    ///< violations holds at most the first 100 of them
  double residual = 0;             ///< DEL residual at the trajectory
  double tol = 1e-10;              ///< the target residual used for expected_iterations
  long free_components = 0;        ///< size of the (restricted) Hessian
  std::string error;               ///< non-empty when the problem or trajectory was invalid
  std::string report() const;      ///< human-readable
};

/** What a stationary point of the discrete action is, by the inertia of its Hessian. */
enum class PointKind {
  unknown,     ///< not assessed (the solve failed before a point existed, or the trajectory is invalid)
  minimum,     ///< Hessian positive definite: a strict local minimum
  saddle,      ///< Hessian with negative eigenvalues (their number is the index): a saddle
  degenerate,  ///< no negative eigenvalue but a zero one (numerically): not an isolated solution
};
const char* to_string(PointKind kind);

/**
 * The inertia of the Hessian of the discrete action at a trajectory, from its block LDL^T (O(N)),
 * and, at a minimum, its two smallest eigenvalues by Lanczos on its inverse (a few more O(N)
 * solves; where the two are nearly equal, the third as well) against Gershgorin's bound on the
 * largest. It says what a returned point is; at a residual above the tolerance it describes the
 * point, not a solution.
 */
struct PointAssessment {
  PointKind kind = PointKind::unknown;
  long positive = 0, negative = 0, zero = 0;  ///< inertia (negative = the saddle's index)
  double lambda_min = 0;    ///< smallest eigenvalue (minimum only; 0 otherwise)
  double lambda_next = 0;   ///< the next one, from above up to the error of lambda_min's eigenvector (0 with one row or at a non-minimum)
  double lambda_max = 0;    ///< Gershgorin's upper bound on the largest |eigenvalue|
  /** lambda_min and lambda_next settled in the Lanczos iterations (to within 1e-4 and 3e-3); false:
   *  they are the Ritz values where its iteration budget ended, upper bounds on the two smallest
   *  eigenvalues (the note says so) */
  bool lambda_settled = false;
  /** A minimum whose smallest eigenvalue is below 1e-4 of the next: the action is determined to
   *  round-off, the trajectory only up to a motion along the eigenvector of lambda_min; or whose
   *  two smallest are nearly equal (lambda_next < 2 lambda_min: a two-fold lowest mode) and
   *  lambda_next is below 1e-4 of the third (computed for this, given in the note): a motion in the
   *  two-dimensional subspace of their eigenvectors. */
  bool nearly_degenerate = false;
  /** For a nearly degenerate minimum: the Euclidean size, over all unknowns, of a motion along that
   *  eigenvector (in that subspace) that changes the action by its round-off,
   *  sqrt(2 * 1e-16 |action| / lambda_min). */
  double soft_motion = 0;
  std::string note;         ///< one sentence: what was found and what it means
};

struct Summary {
  Termination termination = Termination::invalid_input;
  std::string message;
  Method method = Method::jacobi_newton;
  long iterations = 0;
  int N = 0;
  int threads = 1;
  // What a solve computes is NaN until it does: a refused problem (invalid_input) reports no
  // residual, action or time rather than zeros that read as a perfect answer.
  double residual = std::numeric_limits<double>::quiet_NaN();
  double action = std::numeric_limits<double>::quiet_NaN();
  double final_time = std::numeric_limits<double>::quiet_NaN();  ///< t_N (the travel time under free_final_time)
  double wall_seconds = 0;
  /** Wall time of the point assessment at the end of the solve (the factorization it needed, where
   *  the method held none, and its Lanczos runs, with the eigenvector estimates on the nested
   *  levels that start them), included in wall_seconds; 0 where nothing was assessed. */
  double assessment_seconds = 0;
  double residual_floor = std::numeric_limits<double>::quiet_NaN();  ///< round-off level of the residual at the returned iterate
  /** The residual at the returned iterate lies at the round-off level in every component (each
   *  against its own terms), not only against the largest terms (residual_floor). */
  bool residual_at_round_off = false;
  double tolerance = std::numeric_limits<double>::quiet_NaN();       ///< the residual that counted as converged (Options::rtol or tol)
  PointAssessment point;      ///< what the returned trajectory is (minimum, saddle, degenerate)
  /** The estimated error of the coordinates at the nodes (Options::error_estimate): Richardson's
   *  estimate of the discretization error, max over the common nodes of the two grids and over the
   *  coordinates of |x_N - x_coarse| / (r^p - 1), r the ratio of the grids and p the
   *  discretization's consistency_order (the observed order where error_reliable is false because
   *  it fell short), plus solve_error where that was computed; NaN when not estimated (error_note
   *  says why). */
  double error_estimate = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> error_by_coordinate;  ///< the same per coordinate (ncoords values; empty when not estimated)
  /** The solve's own error (Options::error_estimate, one process): max over the interior nodes and
   *  the coordinates of |delta|, delta = -H^-1 r the Newton correction at the returned iterate (H
   *  the Hessian of the discrete action, r the DEL residual there): how far, to first order, the
   *  tolerance or round-off left the iterate from the discrete solution. NaN where not computed (a
   *  solve that did not converge, over MPI ranks, a singular Hessian). */
  double solve_error = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> solve_error_by_coordinate;  ///< the same per coordinate (empty where not computed)
  /** Under the free_final_time clock with a discretization that integrates the clock by its own
   *  quadrature (pardel_discretization::travel): the same rule's estimate of the node times' error,
   *  max over the common nodes of |t_N - t_(N/r)| / (r^p - 1) with the order error_estimate used
   *  (at least the times' round-off, 8 eps max|t|), plus solve_time_error where that was computed;
   *  NaN elsewhere (the seed's left rule, of order one, is not estimated). */
  double error_time_estimate = std::numeric_limits<double>::quiet_NaN();
  /** Under the free_final_time clock, where solve_error was computed: the largest change of a node
   *  time that the Newton correction at the returned iterate makes (the solve's own error in the
   *  times); NaN elsewhere. */
  double solve_time_error = std::numeric_limits<double>::quiet_NaN();
  int error_coarse_N = 0;       ///< the coarse grid it was estimated against (0: not estimated)
  double error_seconds = 0;     ///< time the estimate took (its coarse solve), included in wall_seconds
  bool extrapolated = false;    ///< the returned trajectory holds the extrapolated values (Options::extrapolate)
  std::string error_note;       ///< one line: how the estimate was made, or "not estimated: " and why
  /** The order at which the error was observed to fall over three nested grid levels (N, N/r and
   *  a third, coarser one; docs/solvers.md, "Error estimate"); NaN where it was not measured (no
   *  third level, or the solutions agree to round-off). */
  double error_observed_order = std::numeric_limits<double>::quiet_NaN();
  /** Whether a third grid level confirmed the estimate: the observed order is high enough for the
   *  estimate to be within a factor 3 of the error, or the solutions agree to round-off. False when
   *  not estimated, not checked (no third level; error_note says why), or when the observed order
   *  falls short (then error_estimate uses the observed order, and error_note says "estimate
   *  unreliable"). An adaptive solve accepts only a grid whose estimate is confirmed. */
  bool error_reliable = false;
  /** The grid levels' solutions agree to within 100 times round-off (no order observed): the two
   *  finer ones, and where L or the clock depends on t all three. Confirmed (error_reliable) only
   *  where neither depends on t: a jump or kink of the data in t that every grid's quadrature
   *  points miss alike gives the same agreement (docs/solvers.md, "Error estimate"). */
  bool error_at_round_off = false;
  /** An adaptive solve (Options::accuracy): the N of every grid it solved, in order (the last is
   *  the returned one), and one line on the outcome ("accuracy 1e-08 reached on N = 96 after 3
   *  grids", or why not); both empty otherwise. The returned trajectory carries the grid's times. */
  std::vector<int> grid_sizes;
  std::string grid_note;
  /** Iterative refinement (Options::iterative_refinement): corrections applied (0: none), the
   *  largest change of a node value they made in all, and one line on what happened ("2
   *  corrections, largest node change 3.1e-07 (the first 3.0e-07; DEL residual in extended
   *  precision 2.0e-03 at the solve's point)", with how many used the Hessian in extended
   *  precision, or why it did not run); the note is empty where refinement was off. */
  int refinement_steps = 0;
  double refinement_change = 0;
  std::string refinement_note;
  std::vector<IterationRecord> history;
  SolverState state;  ///< filled (state.valid) when the solve ended `interrupted`
  bool converged() const { return termination == Termination::converged; }
  std::string brief_report() const;
};

/**
 * Solves the problem starting from `trajectory`, which holds the initial guess on entry and the
 * last finite iterate on return (resampled to problem.N when refinement was used).
 */
Summary solve(const Problem& problem, const Options& options, Trajectory& trajectory);

/** The infinity-norm of the DEL residual and the discrete action at a trajectory, on the grid that
 *  certify() uses: the problem's node times (the trajectory's own under a clock); NaN for a
 *  trajectory that does not fit the problem (validate(), another N, a knot off the grid). */
double residual_norm(const Problem& problem, const Trajectory& trajectory);
double discrete_action(const Problem& problem, const Trajectory& trajectory);
/** The node times of the problem's grid at N intervals (problem.times, or uniform from t0 over T);
 *  empty under a clock (which places the nodes during the solve) or for an invalid problem. */
std::vector<double> grid_times(const Problem& problem, int N);

/** The discrete momenta at the two ends of a trajectory (the discrete Legendre transforms). */
struct BoundaryMomenta {
  std::vector<double> p0;  ///< -D1 Ld(q_0, q_1): dim values (empty when the input was invalid)
  std::vector<double> pN;  ///< D2 Ld(q_{N-1}, q_N): dim values
};
/** The boundary momenta of a trajectory on the problem's grid (its node times as given, the
 *  step of each interval as the solvers take it); both empty for an invalid problem or trajectory. */
BoundaryMomenta boundary_momenta(const Problem& problem, const Trajectory& trajectory);

/** The convergence certificate at a trajectory. */
Certificate certify(const Problem& problem, const Trajectory& trajectory, int threads = 0, double tol = 1e-10);

/** What a trajectory (on the problem's grid) is as a stationary point of the discrete action
 *  (kind unknown, with the reason in note, for an invalid problem or trajectory). */
PointAssessment assess_point(const Problem& problem, const Trajectory& trajectory, int threads = 0);

/** Checks a problem and a trajectory for it; on failure writes a message naming the field. */
bool validate(const Problem& problem, const Trajectory& trajectory, std::string* error);

// ---------------------------------------------------------------------------------------------
// Batches: many independent problems at once

/** One problem of a batch: what differs from solve_batch's base problem (an empty member: the base's). */
struct BatchProblem {
  std::vector<double> q0;      ///< dim values (empty: the base problem's)
  std::vector<double> qN;      ///< dim values (empty: the base problem's)
  std::vector<double> params;  ///< nparams values (empty: the base problem's)
  Trajectory guess;            ///< the initial guess, as solve() takes it (N = 0: linear_guess of the problem)
};

/** What solve() returned for one problem of a batch. */
struct BatchEntry {
  Summary summary;
  Trajectory trajectory;  ///< solve()'s trajectory (N = 0 where the problem was never started)
};

struct BatchSummary {
  std::vector<BatchEntry> entries;  ///< one per problem, in the order given (none when refused)
  /** Non-empty when the whole batch was refused before anything was allocated or solved (its
   *  estimated memory does not fit the machine, or options solve_batch does not take); `entries`
   *  is then empty. */
  std::string refusal;
  int threads = 1;          ///< problems solved at once
  double wall_seconds = 0;
  long converged = 0;       ///< entries that converged
};

/**
 * Solves many independent problems that differ from `base` in their boundary values, params or
 * initial guesses, each by solve() with `options` but one thread, Options::threads of them at once
 * (0: all cores; OpenMP, dynamic schedule over the problems). Every entry is what solve() returns
 * for that problem with Options::threads = 1, bit for bit, whatever the number of threads. A
 * problem with bad input ends invalid_input alone; the others are solved. Before anything is
 * allocated the batch's memory (the peak of the solves running at once, estimate_solve_memory, and
 * the trajectories returned) is checked against the machine (memory_refusal). Options::keep_going
 * is the batch's stop: it is polled from every thread (it must be safe to call concurrently) after
 * each recorded iteration of each solve and before each problem; once it returns false the running
 * solves end interrupted and the problems not started end interrupted with N = 0.
 * Options::on_iteration is not called, and resume_from is refused.
 */
BatchSummary solve_batch(const Problem& base, const Options& options, const std::vector<BatchProblem>& problems);

}  // namespace pardel

#endif  // PARDEL_PARDEL_HPP
