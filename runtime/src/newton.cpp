/**
 * @file newton.cpp
 * Newton's method on the whole DEL system in one process: the trust-region Newton of
 * trust_region.hpp over the LocalSpace of local_space.hpp, which holds the whole block-tridiagonal
 * Hessian (block LDL^T with Cholesky pivots, or block cyclic reduction) and the kinetic or identity
 * metric.
 */
#include "local_space.hpp"
#include "trust_region.hpp"

namespace pardel::detail {

std::unique_ptr<Method_> make_newton(const Options& options, int dim) {
  return dispatch_dim(dim, [&](auto D) -> std::unique_ptr<Method_> {
    return std::make_unique<TrustRegionNewton<LocalSpace<decltype(D)::value>>>(options);
  });
}

}  // namespace pardel::detail
