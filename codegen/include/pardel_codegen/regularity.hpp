/**
 * @file regularity.hpp
 * The regularity check pardel-gen runs on every model before generating code.
 *
 * For a model of order γ, W = ∂²L/∂q^(γ)∂q^(γ) is the n×n Hessian of L in the highest
 * derivatives. The DEL equations are regular (they determine the motion) only where W is
 * invertible, and Newton's and Jacobi's iterations need it. The check evaluates W exactly
 * differentiated, numerically at pseudo-random points (fixed seed, so the verdict and the messages
 * do not change from run to run) in 50-digit arithmetic and decides:
 *  - W singular at every sample point (rank < n everywhere): the model is refused, naming the
 *    null direction ("L does not depend on y''", "W annihilates the direction (1, -1) in (x'', y'')");
 *  - det W takes both signs at the sample points and a bisection between two of them ends at a
 *    point where det W is zero (not at a pole or a jump): a warning naming that point;
 *  - otherwise nothing is said.
 * A discretization that is not regular for any L (trapezoid(alpha=0)) is refused at its name.
 * `# pardel: allow-singular` on a line of its own in the .lag, or allow_singular = true
 * (pardel-gen --allow-singular), turns both refusals into warnings. The exact procedure is
 * documented in docs/discretizations.md ("Regularity").
 */
#ifndef PARDEL_CODEGEN_REGULARITY_HPP
#define PARDEL_CODEGEN_REGULARITY_HPP

#include <string>
#include <vector>

#include "pardel_codegen/lag_model.hpp"

namespace pardel_codegen {

/** What the sampling found about W = ∂²L/∂q^(γ)∂q^(γ). */
struct RegularityFindings {
  int ncoords = 0;
  int points = 0;            ///< sample points at which every entry of W is a finite real number
  int points_at_defaults = 0;  ///< those of them with every param at its default
  int tried = 0;             ///< sample points drawn
  int rank = 0;              ///< the largest rank of W over the sample points
  int rank_at_defaults = 0;  ///< the same over the points with every param at its default
  /** When rank < ncoords: one sentence per null direction ("L does not depend on y''", ...). */
  std::vector<std::string> null_directions;
  /** When det W was shown to vanish: where, e.g. "y = 1" (the variables det W depends on). */
  bool zero_found = false;
  int pairs_bisected = 0;    ///< pairs of sample points with opposite signs of det W that were bisected
  std::string zero_point;
  std::string det_text;      ///< det W as GiNaC prints it, when short (at most 3 coordinates)
};

/** Samples W; never throws for a model that parsed (points where L cannot be evaluated are skipped). */
RegularityFindings analyze_regularity(const LagModel& model);

/** True when the .lag text has a line `# pardel: allow-singular` (leading blanks allowed). */
bool declares_allow_singular(const LagModel& model);

/**
 * Runs the check. Returns the warnings to print (each a full `FILE:LINE:COL: warning: …` text with
 * the source line and a caret). @throws LagError when W is singular everywhere or a discretization
 * is not regular, unless `allow_singular` or the .lag's `# pardel: allow-singular` permits it (then
 * the refusal comes back as a warning).
 */
std::vector<std::string> check_regularity(const LagModel& model, bool allow_singular);

}  // namespace pardel_codegen

#endif  // PARDEL_CODEGEN_REGULARITY_HPP
