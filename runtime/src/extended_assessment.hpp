/**
 * @file extended_assessment.hpp
 * Internal: the point assessment of one process redone with the Hessian in extended precision,
 * where the double one cannot tell the point's kind (models of order >= 2 on fine grids, whose
 * Hessian has a condition number of about N^(2 order)); docs/solvers.md, "Point assessment".
 */
#ifndef PARDEL_RUNTIME_EXTENDED_ASSESSMENT_HPP
#define PARDEL_RUNTIME_EXTENDED_ASSESSMENT_HPP

#include "engine.hpp"
#include "pardel/pardel.hpp"

namespace pardel::detail {

/** Whether a point assessment made in double precision may be wrong for want of precision: a point
 *  it did not find a minimum (round-off in the pivots of an ill-conditioned Hessian makes negative
 *  or zero ones), or a minimum whose condition number times 1e-16 exceeds 1e-3 (its smallest
 *  eigenvalues are then not resolved: notes_round_off_bound). Not for a point that was not
 *  assessed. */
bool beyond_double(const PointAssessment& point);

/** The assessment of ctx.q with the Hessian from the discretization's full_extended kernel,
 *  factored and counted in extended precision (extended_node_system.hpp), the smallest eigenvalues
 *  of a minimum by the same Lanczos iteration through the extended solve, into `out`; true. False,
 *  with `out` unchanged, where there is no such kernel, the node times move with q
 *  (times_outside_the_problem false), or a value is not finite or a pivot singular in extended
 *  precision. */
bool assess_extended(Context& ctx, PointAssessment& out);

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_EXTENDED_ASSESSMENT_HPP
