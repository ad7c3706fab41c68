/**
 * @file distributed_newton.hpp
 * Newton over MPI ranks (distributed_newton.cpp): the trust-region Newton of trust_region.hpp on
 * a rank's unknowns with the Schur-complement split of schur_solver.hpp, and the point assessment
 * over the ranks from the same split.
 */
#ifndef PARDEL_RUNTIME_MPI_DISTRIBUTED_NEWTON_HPP
#define PARDEL_RUNTIME_MPI_DISTRIBUTED_NEWTON_HPP

#include <memory>

#include "rank_context.hpp"

namespace pardel::mpi::detail {

/** The trust-region Newton over the unknowns of `local` (a rank's share), with its state in the
 *  one-process layout (checkpoints move between one process and the ranks). */
std::unique_ptr<pardel::detail::Method_> make_distributed_newton(const Options& options, int dim, Local& local);

/** What the returned point is, over the ranks: the kind and inertia of the Hessian and, at a
 *  minimum, its smallest eigenvalues by the one-process assessment's Lanczos iterations
 *  (assessment.hpp) with the distributed solve. Collective. */
void assess_distributed(const Options& options, Local& local, PointAssessment& out);

}  // namespace pardel::mpi::detail

#endif  // PARDEL_RUNTIME_MPI_DISTRIBUTED_NEWTON_HPP
