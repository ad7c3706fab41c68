/**
 * @file assessment.hpp
 * Internal: the assessment of a returned point (inertia and smallest eigenvalues of the Hessian of
 * the discrete action) and the regularity check of a Lagrangian, both over a solve context.
 */
#ifndef PARDEL_RUNTIME_ASSESSMENT_HPP
#define PARDEL_RUNTIME_ASSESSMENT_HPP

#include <string>

#include "block_tridiagonal.hpp"
#include "engine.hpp"

namespace pardel::detail {

/** Assesses ctx.q (evaluating the full kernel there if needed) into `out`. */
void assess(Context& ctx, PointAssessment& out);

/** Assesses ctx.q given H, the unshifted Hessian there, already factored by block LDL^T (positive
 *  definite): a minimum, with its smallest eigenvalues. Instantiated for the block sizes of
 *  dispatch_dim. */
template <int D>
void assess_positive_definite(Context& ctx, BlockTridiagonal<D>& H, PointAssessment& out);

/** From the inertia in out.positive, negative and zero: a saddle or a degenerate point gets its
 *  kind and note (true); a positive definite Hessian is left to the caller (false). */
bool classify_indefinite(PointAssessment& out);

/** False (with `message` naming the model and why) when D12 Ld is singular on every sampled
 *  interval of ctx.q: a degenerate Lagrangian whose DEL equations do not determine the motion. */
bool lagrangian_regular(const Context& ctx, std::string* message);

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_ASSESSMENT_HPP
