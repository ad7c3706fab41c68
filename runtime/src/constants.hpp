/**
 * @file constants.hpp
 * Internal: the runtime's algorithmic constants in one place, each with its reason. A value a user
 * may need to change for a problem (tolerances, budgets, damping, the grid sequence's levels) is a
 * field of pardel::Options instead; what stays here is a choice of the algorithms themselves. The
 * adaptive grids' constants are with their monitor (adaptive.cpp), which explains them together.
 */
#ifndef PARDEL_RUNTIME_CONSTANTS_HPP
#define PARDEL_RUNTIME_CONSTANTS_HPP

namespace pardel::detail {

// --- Parallel loops ------------------------------------------------------------------------------

/** Below this many nodes (or blocks) a loop runs on one thread: a parallel region costs more. */
constexpr int kParallelMin = 512;

// --- Stopping rules of a level (iteration.cpp) ---------------------------------------------------

/** Checks of the clock's times at the tolerance, in a row, each after a step and none lowering the
 *  residual there by 1 %, and iterations since it last did (the window of the other stall rules),
 *  before the times count as unsettled. */
constexpr int kMaxPlacements = 20;
constexpr long kUnsettledIterations = 200;
/** A converged message warns where the round-off level sets the target above this many rtol. */
constexpr double kRoundOffDominates = 100;
/// Newton's stall message names the coordinates' scales, and a minimum's round-off bound says it
/// is one over all coordinates in one norm, where the Hessian's diagonal spans more than this
/// factor over the free components (engine.hpp, diagonal_spread).
constexpr double kStallSpread = 1e8;
/** An iterate whose largest |q| passes this has exploded (`diverged`): far above any coordinate a
 *  model of physical units reaches, and far enough below overflow (1e308) that the DEL terms of
 *  the iterate, products of a few powers of q, are still finite when the test runs. */
constexpr double kExplodedIterate = 1e150;

// --- Grid sequencing of the automatic method (levels.cpp) -----------------------------------------

/** The coarsest grid of the automatic method's grid sequencing, and the ratio of successive grids.
 *  Each level takes one Newton step from the extrapolated coarser solution on well-posed problems,
 *  so the levels below N cost 1/(kAutoRatio - 1) of the finest one: a third at ratio 4, against as
 *  much as the finest level at ratio 2 (docs/benchmarks.md has the measurements). */
constexpr int kAutoCoarseN = 200;
constexpr int kAutoRatio = 4;

// --- Jacobi and Jacobi–Newton (jacobi.cpp) ----------------------------------------------------------

/** A node's block M = D22 + D11 counts as singular (the sweep reports it) when the reciprocal
 *  condition number in the 1-norm of its Jacobi-scaled form S M S (S = diag |M_aa|^-1/2) is at
 *  most this: about 100 unit roundoffs, below which the node's update carries no correct digit. */
constexpr double kJacobiMinRcond = 1e-14;

// --- Trust-region Newton (trust_region.hpp) -------------------------------------------------------

/** A step is accepted when the actual decrease of the merit is at least this fraction of the
 *  predicted one (eta in Nocedal and Wright's Algorithm 4.1: any small positive value; a larger
 *  one refuses useful steps on curved valleys). */
constexpr double kAcceptRatio = 1e-4;
/** A Newton step the ratio test refuses is still accepted when it lowers the residual to this
 *  fraction of the best residual so far (the DEL equations are what must hold; near a solution the
 *  merit's decrease is lost in round-off first). */
constexpr double kResidualAccept = 0.9;
/** The radius shrinks to half the step below this ratio of actual to predicted decrease, and grows
 *  to twice the step above kExpandRatio when the step reached kBoundaryShare of the radius: the
 *  classical values (Nocedal and Wright, Algorithm 4.1). */
constexpr double kShrinkRatio = 0.25;
constexpr double kExpandRatio = 0.75;
constexpr double kBoundaryShare = 0.9;
/** How often in one level the method refuses to stop at a saddle before it reports it. */
constexpr int kMaxEscapes = 5;
/** Newton steps the watchdog takes past a refused one before it returns to the reference point. */
constexpr int kWatchdogSteps = 4;
/** The watchdog arms only near a solution: residual below this fraction of the DEL terms' scale.
 *  Armed far from a solution, it led a coarse level to another minimum (docs/benchmarks.md,
 *  "Where the remaining gaps come from"). */
constexpr double kWatchdogResidual = 1e-3;

// --- Stationary Newton (stationary.cpp) ----------------------------------------------------------

/** Armijo's fraction of the predicted decrease of the merit |residual|^2. */
constexpr double kArmijo = 1e-4;
/** Backtracking halves the step this many times (to 2^-40 of the Newton step, about 1e-12)
 *  before the iteration reports a stall. */
constexpr int kMaxHalvings = 40;

// --- Iterative refinement (iterative_refinement.cpp) -----------------------------------------------

/** At most this many corrections. */
constexpr int kMaxRefinementSteps = 6;
/** Refinement::automatic applies the corrections only when the first is above this many eps max|q|. */
constexpr double kRefinementThreshold = 1000;

// --- Certificate and point assessment (certificate.cpp, assessment.cpp) ----------------------------

/** The interval Hessians' eigenvalues (the seed's hypotheses, item 1 of the certificate) are
 *  compared with this fraction of the largest |eigenvalue| of H^Ld_k. The inertia of H (item 2)
 *  has the zero rule of inertia.hpp instead. */
constexpr double kCertificateRelTol = 1e-10;
/** The budget of Lanczos steps for each of the two smallest eigenvalues at a minimum. */
constexpr int kLanczosSteps = 24;
/** Lanczos on H^-1 stops when the residual bound puts the largest Ritz value within this relative
 *  distance of an eigenvalue: lambda_min to 1e-4 (its Rayleigh-quotient refinement squares the
 *  error), lambda_next only to 3e-3, as it decides no more than whether a minimum is nearly
 *  degenerate (lambda_min far below lambda_next). */
constexpr double kSettleSmallest = 1e-4;
constexpr double kSettleNext = 3e-3;
/** The degeneracy test's D12 (equilibrated) counts as singular when its smallest singular value is
 *  at most this fraction of its largest: the zero rule's 1e-12 (inertia.hpp), for one block. */
constexpr double kSingularD12 = 1e-12;

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_CONSTANTS_HPP
