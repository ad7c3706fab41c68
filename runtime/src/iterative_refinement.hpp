/**
 * @file iterative_refinement.hpp
 * Internal: iterative refinement of a converged solution in one process. The DEL residual
 * r_k = D2 Ld(q_{k-1}, q_k) + D1 Ld(q_k, q_{k+1}) is a sum of terms of size about |q| h^(1-2 order)
 * that cancel; in double its rounding error is eps |q| h^(1-2 order), which the inverse Hessian
 * maps to an error in q that grows like eps N^(2 order). Refinement evaluates r with the
 * discretization's extended-precision kernel (grad_extended: D1 and D2 as double-double pairs,
 * summed per node in double-double and rounded once), solves H delta = -r with the Hessian at the
 * solution (factored once) and adds delta, while the corrections decrease.
 */
#ifndef PARDEL_RUNTIME_ITERATIVE_REFINEMENT_HPP
#define PARDEL_RUNTIME_ITERATIVE_REFINEMENT_HPP

#include <vector>

#include "engine.hpp"

namespace pardel::detail {


/** Where iterative refinement runs by default (a model of order >= 2, no clock, a discretization
 *  with an extended kernel): ctx.res replaced by the DEL residual at ctx.q from the extended kernel
 *  (extended_residual), so that a Newton correction from it measures the solve's own error and not
 *  the rounding of the double residual; true. Elsewhere, or where a value is not finite, ctx.res
 *  unchanged; false. */
bool extend_residual(Context& ctx);

/** The DEL residual at q from the extended kernel into res ((N+1) dim; 0 on fixed components and
 *  at the ends), each node's two terms summed in double-double and rounded once; `pairs` is
 *  scratch. Returns the first node with a non-finite value, or -1. The same bits for any thread
 *  count. Needs ctx.disc->grad_extended. */
int extended_residual(const Context& ctx, const std::vector<double>& q, std::vector<double>& pairs,
                      std::vector<double>& res);

/** Refines ctx.q (a converged solution) as Options::iterative_refinement says, re-evaluates the
 *  context there (full kernel and residual) when it changed, and fills the summary's refinement_*
 *  fields. */
void refine_solution(Context& ctx, const Options& options, Summary& summary);

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_ITERATIVE_REFINEMENT_HPP
