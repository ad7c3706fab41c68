/**
 * @file assessment.hpp
 * Internal: the assessment of a returned point (inertia and smallest eigenvalues of the Hessian of
 * the discrete action) and the regularity check of a Lagrangian, both over a solve context.
 */
#ifndef PARDEL_RUNTIME_ASSESSMENT_HPP
#define PARDEL_RUNTIME_ASSESSMENT_HPP

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "block_tridiagonal.hpp"
#include "engine.hpp"

namespace pardel::detail {

class LevelEigenvectors;

/** Assesses ctx.q (evaluating the full kernel there if needed) into `out`. */
void assess(Context& ctx, PointAssessment& out);

/** Into delta (the unknowns of nodes 1..N-1, node after node), the Newton correction -H^-1 r at
 *  ctx.q: r the DEL residual evaluated there (ctx.res and the residual fields rewritten), H the
 *  unshifted Hessian there (evaluating the full kernel if needed) factored by block LDL^T, or where
 *  that fails by the indefinite factorization; false where neither can (a singular H, a
 *  non-finite second derivative or residual). */
bool newton_correction(Context& ctx, std::vector<double>& delta);

/** Whether a solve that ended with `termination` has its point assessed: only a converged one.
 *  Any other iterate is no solution of the DEL equations, and what its Hessian is says nothing
 *  about an answer (an interrupted solve also stops sooner without it). */
inline bool point_assessed(Termination termination) { return termination == Termination::converged; }

/** The point of a solve that is not assessed: kind unknown, and a note that says why. */
inline PointAssessment not_assessed(Termination termination) {
  PointAssessment out;
  out.note = std::string("not assessed: the solve ended ") + to_string(termination) +
             ", and its iterate is no solution of the DEL equations";
  return out;
}

/** Assesses ctx.q given the unshifted Hessian there, positive definite, through lambda_max (its
 *  Gershgorin bound) and solve (x = H^-1 b): a minimum, with its smallest eigenvalues. `work` as
 *  LanczosOperator::work (optional); `from`: the previous level's eigenvectors (optional), which
 *  start the Lanczos runs. */
void assess_minimum(Context& ctx, double lambda_max, const std::function<void(const double* b, double* x)>& solve,
                    PointAssessment& out, double* const* work = nullptr, const LevelEigenvectors* from = nullptr);

/** Fixed components are identity rows of the assembled Hessian: +1 eigenvalues that are not the
 *  action's, taken out of the counts. */
long fixed_components(const Grid& grid);

/** From the inertia in out.positive, negative and zero: a saddle or a degenerate point gets its
 *  kind and note (true); a positive definite Hessian is left to the caller (false). */
bool classify_indefinite(PointAssessment& out);

/**
 * The assessment of ctx.q from H, the unshifted Hessian there as assembled; `factored`: already
 * factored by factor_ldlt() (Newton's last factorization, or the caller's). A minimum where the
 * factorization's pivots are positive definite under the zero rule of inertia.hpp; otherwise the
 * inertia by the elimination of every count (H.inertia()), so that a point's counts are those of
 * the certificate. Inline, so that it is compiled with the caller's block size (the one-process
 * Newton's, in newton.cpp) and assessment.cpp needs no instantiation per block size. `work` as
 * LanczosOperator::work (optional).
 */
template <int D>
void assess_hessian(Context& ctx, BlockTridiagonal<D>& H, bool factored, PointAssessment& out,
                    double* const* work = nullptr, const LevelEigenvectors* from = nullptr) {
  const auto solve = [&H](const double* b, double* x) { H.solve_ldlt(b, x); };
  double lambda_max = 0;  // Gershgorin's bound, from the rule's pass
  if ((factored || H.factor_ldlt()) && H.ldlt_definite_by_rule(&lambda_max)) {
    assess_minimum(ctx, lambda_max, solve, out, work, from);
    return;
  }
  const Inertia in = H.inertia();
  out = PointAssessment{};
  out.lambda_max = H.gershgorin_bound();
  out.positive = in.positive - fixed_components(ctx);
  out.negative = in.negative;
  out.zero = in.zero;
  if (classify_indefinite(out)) return;
  // Positive definite under the rule, though a pivot's Cholesky factor did not show it at once.
  if (H.factor_ldlt()) {
    assess_minimum(ctx, out.lambda_max, solve, out, work, from);
    return;
  }
  out.kind = PointKind::degenerate;
  out.note = "degenerate to working precision: the factorization of the Hessian failed";
}

/** assess_hessian given H already factored by block LDL^T at ctx.q (Newton's factorization). */
template <int D>
void assess_positive_definite(Context& ctx, BlockTridiagonal<D>& H, PointAssessment& out,
                              double* const* work = nullptr, const LevelEigenvectors* from = nullptr) {
  assess_hessian(ctx, H, true, out, work, from);
}

/** A positive definite Hessian's inverse, as the Lanczos iteration of smallest_eigenvalues sees it:
 *  n unknowns (this rank's, over ranks) of dim components per node, unknown 0 at node first_node
 *  of N intervals, free[i] false on fixed components (identity rows). */
struct LanczosOperator {
  std::size_t n = 0;
  int dim = 1, first_node = 1, N = 2;
  const unsigned char* free = nullptr;
  /** x = H^-1 b (collective over ranks). */
  std::function<void(const double* b, double* x)> solve;
  /** Sums `count` values over the ranks, in place (nothing in one process). */
  std::function<void(double* values, int count)> reduce;
  /** Scratch of four vectors of n that smallest_eigenvalues may overwrite (a method's vectors, free
   *  once it has stopped); where any is null, it allocates its own. */
  double* work[4] = {nullptr, nullptr, nullptr, nullptr};
  /** Where set: writes the start of run `which` (0: lambda_1's, 1: lambda_2's) into v (n values,
   *  zero on fixed components) and returns true, a vector close to that eigenvector (a coarser
   *  level's, LevelEigenvectors), from which a run settles as soon as its residual alone bounds
   *  the error; false: the built-in start. */
  std::function<bool(int which, double* v)> start;
  /** Where not null (n values each): smallest_eigenvalues writes its estimates of the two
   *  eigenvectors there (SmallestEigenvalues::kept), for a finer level's start. */
  double* keep[2] = {nullptr, nullptr};
};

/** The two smallest eigenvalues of H (Ritz values: upper bounds, the second up to the error of
 *  the first one's eigenvector) and whether they settled; where the two are nearly equal, the
 *  third as well (0 where not computed). */
struct SmallestEigenvalues {
  double lambda[3] = {0, 0, 0};
  bool settled = false;           ///< lambda[0] and lambda[1] settled
  bool settled_third = false;     ///< lambda[2] computed and settled
  bool kept[2] = {false, false};  ///< LanczosOperator::keep[i] written
};

/**
 * The eigenvectors of the two smallest eigenvalues of the Hessian at a settled coarse level of
 * nested iteration (node layout over its interior nodes, zero on fixed components), which start
 * the next level's Lanczos runs: the lowest modes of a first-order model are smooth in time, so
 * that the coarse ones resampled to the finer grid are its eigenvectors to O(h^2), and a run from
 * them settles in one step (one block solve) where a run from the built-in start takes 3 to 6.
 */
class LevelEigenvectors {
 public:
  /** This level's estimates at ctx.q by smallest_eigenvalues through `solve` (x = H^-1 b for the
   *  Hessian at ctx.q or at an iterate next to it), started from the held ones; they replace them
   *  (nothing is held where a run fails). `work`: four vectors of the level's n. */
  void settle_level(const Context& ctx, const std::function<void(const double* b, double* x)>& solve,
                    double* const* work);
  /** Vector `which` resampled onto ctx's grid into v (its n values): per component, linear in the
   *  node times between the held level's nodes and extrapolated linearly past its first and last
   *  interior nodes; zero on fixed components. False where none is held. */
  bool start(const Context& ctx, int which, double* v) const;
  /** Whether vector 0 is held. */
  bool held() const { return valid_[0]; }

 private:
  int N_ = 0, dim_ = 0;
  std::vector<double> t_;                  ///< the held level's N + 1 node times
  std::vector<double> v_[2], next_[2];     ///< the held vectors, and those being computed
  bool valid_[2] = {false, false};
};

/** The smallest eigenvalue by Lanczos on H^-1 over the free components (refined, where `positive`
 *  >= 2, by one inverse iteration from its Ritz vector) and the next one by Lanczos on H^-1 with
 *  that vector deflated (a repeated smallest eigenvalue is found twice, and a converged first one
 *  does not return as a copy). At most 24 steps each, stopping when the residual bound puts them
 *  within 1e-4 and 3e-3 (relative). With `third`, where `positive` >= 3 and the two are nearly
 *  equal (the second below twice the first: a repeated lowest mode), the third one as well, by
 *  Lanczos on H^-1 with both refined vectors deflated (stopping within 3e-3), which tells whether
 *  a two-fold lowest mode lies far below the rest. Four vectors of n (op.work or its own), and a
 *  fifth for the third run (op.keep[1] or its own); collective over ranks through op. */
SmallestEigenvalues smallest_eigenvalues(const LanczosOperator& op, long positive, bool third = true);

/** Whether a minimum's note bounds how far round-off in the DEL residual can move the solution:
 *  by up to the condition number lambda_max / lambda_min times 1e-16 (relative), said where that
 *  exceeds 1e-3 (high orders at large N: the condition grows like N^(2 order)). */
bool notes_round_off_bound(double lambda_min, double lambda_max);

/** A positive definite Hessian's assessment from its smallest eigenvalues, out.positive and
 *  out.lambda_max: kind, eigenvalues, nearly degenerate or not, and the note; `diagonal_spread`
 *  (engine.hpp's, 1 where not known) qualifies the note's round-off bound. */
void describe_minimum(const SmallestEigenvalues& e, double action, PointAssessment& out, double diagonal_spread = 1);

/** The inertia of the interior blocks d2S/dz2 of the intervals first .. first + count - 1 of ctx at
 *  ctx.q (pardel_discretization::interior_hessian: Galerkin discretizations with interior values;
 *  zero counts for any other), each block under the zero rule of inertia.hpp in its own Jacobi
 *  scaling; a block that is not finite counts all its eigenvalues as zero. */
Inertia interior_inertia(const Context& ctx, int first, int count);

/** The assessment of the node Hessian `out` (the condensed action's) made that of the action over
 *  nodes and interior values: by Haynsworth's inertia additivity its inertia is the node Hessian's
 *  plus `interior` (all intervals'), so that interior blocks with negative or zero eigenvalues make
 *  a minimum of the condensed action a saddle (or a degenerate point) of the whole one. */
void add_interior_inertia(const Inertia& interior, PointAssessment& out);

/** Adds to a converged point's note what its residual says about it: a saddle where round-off in
 *  the DEL terms (`floor`) is as large as their `scale` (its negative eigenvalues are not
 *  resolved); a degenerate point whose `residual` is far above `floor` (the tolerance, relative to
 *  terms that may have grown along the zero direction, leaves the trajectory undetermined there). */
void note_residual_caveats(double residual, double floor, double scale, PointAssessment& out);

/** False (with `message` naming the model and why) when D12 Ld is singular on every sampled
 *  interval of ctx.q: a degenerate Lagrangian whose DEL equations do not determine the motion. */
bool lagrangian_regular(const Context& ctx, std::string* message);

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_ASSESSMENT_HPP
