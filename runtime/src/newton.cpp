/**
 * @file newton.cpp
 * Newton's method on the whole DEL system in one process: the trust-region Newton of
 * trust_region.hpp over the LocalSpace of local_space.hpp, which holds the whole block-tridiagonal
 * Hessian (block LDL^T with Cholesky pivots, or block cyclic reduction) and the kinetic or identity
 * metric. This file picks the block size; each size's solver is compiled from
 * newton_block_size.cpp.in in a translation unit of its own.
 */
#include "engine.hpp"

namespace pardel::detail {

std::unique_ptr<Method_> make_newton(const Options& options, int dim) {
  return dispatch_dim(dim, [&](auto D) { return make_newton_sized<decltype(D)::value>(options); });
}

}  // namespace pardel::detail
